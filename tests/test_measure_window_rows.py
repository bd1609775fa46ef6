"""scripts/measure_window_rows.py: windows wholly above the heads or below the feet of the people in
their columns, on synthetic windows."""
from __future__ import annotations

import numpy as np

from scripts.measure_window_rows import frame_off_rows, labelled_windows, off_rows_by_part, part_table, summary, window_off_rows


def test_a_window_off_the_rows_of_everyone_in_its_columns_is_counted_with_its_gap():
    people = np.array([[100.0, 120.0, 80.0, 200.0],   # near: head at row 80
                       [110.0, 125.0, 60.0, 150.0],   # farther, overlapping it: head at row 60
                       [200.0, 220.0, 70.0, 160.0],
                       [np.nan] * 4])                  # behind the camera
    windows = np.array([[101.0, 119.0, 82.0, 198.0],   # on the near person
                        [101.0, 105.0, 65.0, 70.0],    # above the near one's head, not over the farther one's columns
                        [112.0, 118.0, 50.0, 55.0],    # above both heads (the farther one's at 60)
                        [202.0, 218.0, 165.0, 170.0],  # below the third one's feet
                        [300.0, 310.0, 10.0, 20.0]])   # over nobody
    none, above, below = frame_off_rows(people, windows)
    assert none == 1
    assert above == [10.0, 5.0]
    assert below == [5.0]
    line = summary(5, none, above, below)
    assert "wholly above every overlapping person's head: 2 (40.000 %)" in line and "max 10.0 px" in line
    assert "wholly below every one's feet: 1" in line


def test_a_window_over_a_persons_rows_is_not_counted():
    none, above, below = frame_off_rows(np.array([[0.0, 10.0, 50.0, 150.0]]), np.array([[2.0, 8.0, 40.0, 52.0]]))
    assert (none, above, below) == (0, [], [])


def test_each_window_is_classed_with_its_gap():
    people = np.array([[100.0, 120.0, 80.0, 200.0], [np.nan] * 4])
    assert window_off_rows(people, np.array([300.0, 310.0, 10.0, 20.0])) == ("none", 0.0)
    assert window_off_rows(people, np.array([101.0, 105.0, 65.0, 70.0])) == ("above", 10.0)
    assert window_off_rows(people, np.array([101.0, 105.0, 203.0, 210.0])) == ("below", 3.0)
    assert window_off_rows(people, np.array([101.0, 105.0, 75.0, 90.0])) == (None, 0.0)


# a 320x240 camera looking along +y from 1.5 m up (focal length 400 px)
P_ALONG_Y = np.array([[400.0, 0.0, 160.0, 0.0], [0.0, 400.0, 120.0, 0.0], [0.0, 0.0, 1.0, 0.0]]) @ np.array(
    [[1.0, 0, 0, 0], [0, 0, -1.0, 1.5], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])


def _recording(windows: list[tuple[float, str, int, list[float]]], people: list[tuple[float, str, float, float]]):
    """A stand-in recording: one oblique camera, boxes ``windows`` (t, camera, track, edges),
    people (t, id, x, y)."""
    from types import SimpleNamespace

    import pandas as pd
    cams = {"obl_a": SimpleNamespace(P=P_ALONG_Y)}
    boxes = pd.DataFrame([{"t": t, "camera": c, "track": k, "u_left": e[0], "u_right": e[1], "v_top": e[2], "v_bottom": e[3]}
                          for t, c, k, e in windows])
    truth = pd.DataFrame([{"t": t, "person_id": p, "x": x, "y": y} for t, p, x, y in people])
    return SimpleNamespace(truth=SimpleNamespace(people=truth), observations={"boxes": boxes},
                           calibration=SimpleNamespace(cameras_of_kind=lambda kind: cams if kind == "oblique" else {}))


def test_windows_are_counted_by_the_part_of_the_model_that_drew_them():
    from trackroom.estimators import tp_geometry as geo
    from scripts.measure_window_rows import HEIGHT, RADIUS
    rec = _recording([], [(0.0, "a", 0.0, 4.0)])
    P = rec.calibration.cameras_of_kind("oblique")["obl_a"].P
    body = geo.cylinder_window(np.asarray(P, float), np.array([[0.0, 4.0]]), HEIGHT, RADIUS)[0]
    on = list(body)
    above = [body[0], body[1], body[2] - 30.0, body[2] - 20.0]
    aside = [body[1] + 50.0, body[1] + 60.0, body[2], body[3]]
    rec = _recording([(0.0, "obl_a", 0, on), (0.0, "obl_a", 1, above), (0.0, "obl_a", 2, aside), (0.0, "obl_a", 3, on)],
                     [(0.0, "a", 0.0, 4.0)])
    counts = off_rows_by_part(rec, {("obl_a", 1): "false", ("obl_a", 2): "false", ("obl_a", 3): "fragment", ("obl_b", 0): "false"})
    assert counts["person", "all"] == 1 and counts["person", "above"] == counts["person", "none"] == 0
    assert (counts["false", "all"], counts["false", "above"], counts["false", "none"]) == (2, 1, 1)
    assert counts["fragment", "all"] == 1 and counts["fragment", "above"] == 0
    table = part_table(counts)
    assert "| false | 2 | 1 (50.00 %) | 1 (50.00 %) | 0 (0.00 %) |" in table


def test_labelling_leaves_the_recording_and_the_model_as_they_were():
    """The labels cover the model's drawn parts; the recording is the same bit for bit, and the
    model's methods are restored."""
    import trackroom.sim.analytic_detectors as detectors
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate
    scene = load_scene("occlusion_lab")
    before = {name: getattr(detectors.WindowIds, name) for name in ("fragments", "partials", "clutter")}
    plain = simulate(scene, seed=7, duration=6.0, sensing="analytic")
    with labelled_windows() as labels:
        rec = simulate(scene, seed=7, duration=6.0, sensing="analytic")
    assert {name: getattr(detectors.WindowIds, name) for name in before} == before
    assert detectors.windows is not None and detectors.windows.__name__ == "windows" and detectors.windows.__module__ == detectors.__name__
    lab_boxes = rec.observations["boxes"]
    assert plain.observations["boxes"].equals(lab_boxes)
    assert labels and set(labels.values()) <= {"fragment", "partial", "false"}
    ids = {(c, int(k)) for c, k in zip(lab_boxes.camera, lab_boxes.track)}
    assert sum(key in ids for key in labels) > 0  # labelled ids are the recording's (a few clipped away at the border)
    counts = off_rows_by_part(rec, labels)
    assert sum(counts[p, "all"] for p in ("person", "fragment", "partial", "false")) == sum(
        len(g) for _, g in lab_boxes[lab_boxes.camera.isin(list(rec.calibration.cameras_of_kind("oblique")))].groupby("camera"))
