"""scripts/measure_encounters.py: the movers' closest approach, on synthetic truth tables."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from scripts.measure_encounters import encounters, main


def _walker(name, t, x, y):
    return pd.DataFrame({"t": t, "person_id": name, "x": x, "y": np.full_like(t, y) if np.isscalar(y) else y})


def test_a_head_on_crossing_on_one_lane_overlaps_and_an_offset_one_does_not():
    t = np.round(np.arange(0.0, 10.0, 0.1), 1)
    radii = {"target": 0.2, "distractor": 0.2, "standing1": 0.2}
    same_lane = pd.concat([_walker("target", t, t, 1.0), _walker("distractor", t, 10.0 - t, 1.0),
                           _walker("standing1", t, np.full_like(t, 5.0), 0.0)], ignore_index=True)
    e = encounters(same_lane, radii)
    assert list(zip(e.a, e.b)) == [("target", "distractor")]  # standing people are not movers by default
    assert e.d_min[0] == pytest.approx(0.0) and e.t_min[0] == pytest.approx(5.0)
    # closing at 2 m/s: centres nearer than 0.4 m for |10 - 2t| < 0.4, t in (4.8, 5.2): 3 samples
    # of 0.1 s
    assert e.overlap_s[0] == pytest.approx(0.3)
    # and nearer than 0.5 m (0.4 + the planner's 0.1 m personal space): |10 - 2t| < 0.5, 5 samples
    assert e.inside_space_s[0] == pytest.approx(0.5)
    offset = pd.concat([_walker("target", t, t, 1.0), _walker("distractor", t, 10.0 - t, 1.6)], ignore_index=True)
    e = encounters(offset, radii)
    assert e.d_min[0] == pytest.approx(0.6) and e.overlap_s[0] == 0 and e.inside_space_s[0] == 0
    # the pair of the two walkers named, in that order; a name not in the table is left out
    e = encounters(same_lane, radii, names=("target", "standing1", "nobody"))
    assert list(zip(e.a, e.b)) == [("target", "standing1")]
    assert e.d_min[0] == pytest.approx(1.0)


def test_no_input_is_a_clear_usage_error(capsys):
    with pytest.raises(SystemExit):
        main([])
    assert "give recording folders or --seeds" in capsys.readouterr().err
