"""scripts/measure_hidden_rows.py: how far below the floor plan's occluding edge the windows of a
person seen over a box reach, on a stand-in recording whose geometry is worked out by hand."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from scripts.measure_hidden_rows import hidden_rows, summary
from trackroom.estimators.tp_joint import Occluders

# a 320x240 camera at (0, 0) 1.5 m up looking along +y (focal length 400 px): v = 120 + 400 (1.5 - z) / y
P_ALONG_Y = np.array([[400.0, 0.0, 160.0, 0.0], [0.0, 400.0, 120.0, 0.0], [0.0, 0.0, 1.0, 0.0]]) @ np.array(
    [[1.0, 0, 0, 0], [0, 0, -1.0, 1.5], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])
# a box 1 m high from y = 1.9 to 2.1 hides a person at (0, 4) below 0.548 m (the ray over its far top
# edge: 1.5 + (z - 1.5) 2.1 / 4 = 1.0); of the 21 heights 0, 0.09, ... 1.8 m the lowest clear is 0.63
# m, so the seen part's bottom is taken at 0.54 m: row 120 + 400 (1.5 - 0.54) / 4 = 216
FLOORPLAN = SimpleNamespace(obstacles=[SimpleNamespace(center=(0.0, 2.0), size=(1.0, 0.2, 1.0), yaw=0.0)], walls=[])


def _recording(windows):
    cams = {"obl_a": SimpleNamespace(P=P_ALONG_Y)}
    boxes = pd.DataFrame([{"t": 0.0, "camera": "obl_a", "track": k, "u_left": e[0], "u_right": e[1], "v_top": e[2], "v_bottom": e[3]}
                          for k, e in enumerate(windows)])
    truth = pd.DataFrame([{"t": 0.0, "person_id": "target", "x": 0.0, "y": 4.0, "z": 0.9},
                          {"t": 0.0, "person_id": "standing1", "x": 1.5, "y": 6.0, "z": 0.9}])
    return SimpleNamespace(truth=SimpleNamespace(people=truth), observations={"boxes": boxes},
                           calibration=SimpleNamespace(floorplan=FLOORPLAN, cameras_of_kind=lambda kind: cams if kind == "oblique" else {}))


def test_the_box_hides_the_person_below_the_height_worked_out_by_hand():
    occ = Occluders(FLOORPLAN, {"obl_a": P_ALONG_Y}, 1.0)
    clear = occ.clear_heights("obl_a", np.array([[0.0, 4.0]]), np.array([0.0, 0.54, 0.56, 0.63, 1.8]))[0]
    assert clear.tolist() == [False, False, True, True, True]
    assert occ.clear_rays("obl_a", np.array([[0.0, 4.0]]), np.array([0.0, 0.54, 0.56, 0.63, 1.8]))[0] == 3


def test_a_lone_window_is_measured_from_the_seen_parts_bottom_and_a_shared_one_is_left_out():
    df = hidden_rows(_recording([[140.0, 180.0, 92.0, 268.0],    # the person's whole body: 52 px below the seen part
                                 [140.0, 180.0, 92.0, 214.0],    # stops at the box's edge: 2 px above it
                                 [150.0, 250.0, 92.0, 268.0],    # over the standing person's columns too: left out
                                 [20.0, 40.0, 92.0, 268.0]]),    # over no one
                     "stand-in")
    assert df.person.tolist() == ["target", "target"]
    assert df.seen_bottom.to_numpy() == pytest.approx([216.0, 216.0])
    assert df.below.to_numpy() == pytest.approx([52.0, -2.0])
    assert df.height_px.to_numpy() == pytest.approx([180.0, 180.0])  # head at row 90, feet at 270
    s = summary(df).iloc[0]
    assert s["windows"] == 2 and s["below >5 px"] == 0.5 and s["below >15 px"] == 0.5 and s["below >1/4 height"] == 0.5


def test_a_person_seen_at_the_feet_is_not_measured():
    rec = _recording([[140.0, 180.0, 92.0, 268.0]])
    rec.calibration.floorplan = SimpleNamespace(obstacles=[], walls=[])
    assert hidden_rows(rec).empty


def test_a_person_seen_beside_the_boxs_end_down_to_the_floor_is_not_measured():
    # the box ends at x = 0.05: the axis is hidden below 0.548 m, the line at the cylinder's edge
    # (x = 0.2 at y = 4, the tracker's radius) passes it at x = 0.095-0.105 and is seen down to the floor
    rec = _recording([[140.0, 180.0, 92.0, 268.0]])
    rec.calibration.floorplan = SimpleNamespace(obstacles=[SimpleNamespace(center=(-0.275, 2.0), size=(0.65, 0.2, 1.0), yaw=0.0)], walls=[])
    occ = Occluders(rec.calibration.floorplan, {"obl_a": P_ALONG_Y}, 1.0)
    assert not occ.clear_heights("obl_a", np.array([[0.0, 4.0]]), np.array([0.0]))[0, 0]
    assert hidden_rows(rec).empty
