"""scripts/measure_border_flow.py: windows of people cut by the image border against the labels'
motion."""
import numpy as np
import pandas as pd
import pytest

from scripts.measure_border_flow import border_windows, label_motion, summary


def labels_and_boxes():
    """One camera (320 px wide, 10 fps), three frames: a person cut by the left border whose
    inner (right) edge moves +20 px/s (its window's at 0.2 s 4 px further into the image), and a
    person seen whole moving -30 px/s."""
    t = np.array([0.0, 0.1, 0.2])
    labels = pd.DataFrame({
        "t": np.r_[t, t], "camera": "c", "person_id": ["a"] * 3 + ["b"] * 3, "pixels": 1000,
        "x0": np.r_[0.0, 0.0, 0.0, 200.0, 197.0, 194.0], "x1": np.r_[30.0, 32.0, 34.0, 240.0, 237.0, 234.0],
        "y0": 50.0, "y1": 150.0,
    })
    boxes = pd.DataFrame({
        "t": [0.1, 0.1, 0.2, 0.2], "camera": "c", "track": [0, 1, 0, 1],
        "u_left": [0.0, 198.0, 10.0, 195.0], "u_right": [32.0, 236.0, 38.0, 233.0],
        "flow_u": [18.0, -30.0, 5.0, -27.0],
    })
    return labels, boxes


def test_edges_move_with_the_labels_and_the_first_frame_has_no_motion():
    labels, _ = labels_and_boxes()
    m = label_motion(labels, {"c": 10.0})
    assert len(m) == 4  # each person's first label has no previous frame
    a = m[m["person_id"] == "a"]
    assert a["v_right"].to_numpy() == pytest.approx([20.0, 20.0])
    assert a["v_left"].to_numpy() == pytest.approx([0.0, 0.0])
    assert m[m["person_id"] == "b"]["v_centre"].to_numpy() == pytest.approx([-30.0, -30.0])


def test_a_cut_person_is_compared_with_its_inner_edge_and_split_by_reaching_the_border():
    labels, boxes = labels_and_boxes()
    w = border_windows(boxes, label_motion(labels, {"c": 10.0}), {"c": 320.0}).set_index(["t", "kind"])
    assert w.loc[(0.1, "left-cut"), "reach"] == "reaches"
    assert w.loc[(0.1, "left-cut"), "motion"] == pytest.approx(20.0)
    assert w.loc[(0.2, "left-cut"), "reach"] == "short"  # its left edge 10 px from the border
    assert w.loc[(0.2, "left-cut"), "gap"] == pytest.approx(10.0)
    assert w.loc[(0.1, "whole"), "motion"] == pytest.approx(-30.0)
    assert w.loc[(0.1, "left-cut"), "inner"] == pytest.approx(0.0)  # the inner edge: the window's right against the label's
    assert w.loc[(0.2, "left-cut"), "inner"] == pytest.approx(4.0)
    assert np.isnan(w.loc[(0.1, "whole"), "inner"])
    S = summary(w.reset_index()).set_index(["kind", "reach"])
    assert S.loc[("left-cut", "short"), "inner median px"] == pytest.approx(4.0)
    assert S.loc[("left-cut", "short"), "inner beyond 10 px"] == 0.0
    assert np.isnan(S.loc[("whole", "-"), "inner median px"])
    assert S.loc[("left-cut", "short"), "error median px/s"] == pytest.approx(-15.0)
    assert S.loc[("whole", "-"), "windows"] == 2
    assert S.loc[("whole", "-"), "error median px/s"] == pytest.approx(1.5)


def test_a_window_over_two_people_is_left_out():
    labels, boxes = labels_and_boxes()
    boxes = pd.concat([boxes, pd.DataFrame({"t": [0.1], "camera": "c", "track": [2], "u_left": [20.0], "u_right": [210.0],
                                            "flow_u": [0.0]})], ignore_index=True)
    w = border_windows(boxes, label_motion(labels, {"c": 10.0}), {"c": 320.0})
    assert len(w) == 4


def test_projected_labels_stand_in_for_segmentation_labels_on_an_analytic_recording(occlusion_lab_6s, capsys):
    """An analytic recording has no segmentation labels: the command says so, and with
    ``--projection`` it measures against the truth's cylinders, clipped to each image, only where
    the truth has the person visible."""
    from scripts.measure_border_flow import main, projected_labels
    from trackroom.dataset import read_recording

    with pytest.raises(SystemExit, match="no segmentation labels"):
        main([occlusion_lab_6s])
    rec = read_recording(occlusion_lab_6s)
    L = projected_labels(rec)
    widths = {c: float(rec.calibration.cameras[c].width) for c in rec.calibration.cameras}
    assert len(L) and (L["x0"] >= 0.0).all() and (L["x1"] <= L["camera"].map(widths)).all() and (L["x0"] < L["x1"]).all()
    vis = rec.truth.visibility
    seen = set(map(tuple, vis.loc[vis["visible"].astype(bool), ["camera", "person_id"]].astype(str).to_numpy()))
    assert set(map(tuple, L[["camera", "person_id"]].to_numpy())) <= seen
    assert main(["--projection", occlusion_lab_6s]) == 0
    assert "whole" in capsys.readouterr().out
