"""scripts/measure_tp_handover.py: each scored hand-over labelled from the truth."""
import pandas as pd

from scripts.measure_tp_handover import label

# two people at t = 0 and t = 2: A walks east from (1, 1) to (3, 1), B west from (3, 1.4) to (1, 1.4)
PEOPLE = pd.DataFrame({"t": [0.0, 0.0, 2.0, 2.0], "person_id": ["A", "B", "A", "B"],
                       "x": [1.0, 3.0, 3.0, 1.0], "y": [1.0, 1.4, 1.0, 1.4]})


def row(survivor_pre, gone_pre, survivor_xy, new_xy):
    (spx, spy), (gpx, gpy), (sx, sy), (nx, ny) = survivor_pre, gone_pre, survivor_xy, new_xy
    return pd.Series({"t": 2.0, "t_pre": 0.0, "survivor_pre_x": spx, "survivor_pre_y": spy, "gone_pre_x": gpx,
                      "gone_pre_y": gpy, "survivor_xy_x": sx, "survivor_xy_y": sy, "new_xy_x": nx, "new_xy_y": ny})


def test_labels():
    # the survivor started on A and ended on B, the new track is on A: an exchange was due
    assert label(row((1, 1), (3, 1.4), (1, 1.4), (3, 1)), PEOPLE) == "exchanged"
    # the survivor stayed on A
    assert label(row((1, 1), (3, 1.4), (3, 1), (1, 1.4)), PEOPLE) == "kept"
    # both tracks started on A: one person seen twice
    assert label(row((1, 1), (1.1, 1), (3, 1), (1, 1.4)), PEOPLE) == "same"
    # the survivor went to B, the new track is on B too: neither
    assert label(row((1, 1), (3, 1.4), (1, 1.4), (1.1, 1.4)), PEOPLE) == "other"
