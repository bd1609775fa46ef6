"""Analytic windows for the target-plane tracker: like an optical-flow tracker, an oblique camera
reports a window only for a person whose image moves (``sensors.flow_min_px_s``)."""
from __future__ import annotations

import numpy as np

from scenes.loader import load_scene
from sim.simulate import simulate

STANDING = "{motion='standing', start=[3.4, 4.0]}"
WALKER = "{motion='waypoints', waypoints=[[1.0, 4.0], [3.0, 6.3]], speed=[1.0, 1.0]}"


def test_people_standing_still_give_no_windows():
    scene = load_scene("occlusion_lab", ["walkers.count=2", f"walkers.people=[{STANDING}, {{motion='standing', start=[6.0, 4.2]}}]"])
    rec = simulate(scene, seed=0, duration=1.0)
    assert len(rec.observations["bearings"]) > 0  # they are seen ...
    assert "boxes" not in rec.observations.tables or len(rec.observations["boxes"]) == 0  # ... but no flow window


def test_windows_follow_only_the_walker():
    scene = load_scene("occlusion_lab", ["walkers.count=2", f"walkers.people=[{STANDING}, {WALKER}]"])
    rec = simulate(scene, seed=0, duration=2.0)
    boxes, people = rec.observations["boxes"], rec.truth.people
    walker = people[people.person_id == scene.walkers[1].name]
    assert len(boxes) > 20
    assert boxes.groupby(["t", "camera"]).size().max() == 1  # one window per camera frame: the walker's
    for _, b in boxes.iterrows():
        cam = rec.calibration.cameras[b.camera]
        w = walker.iloc[int(np.argmin(np.abs(walker.t.to_numpy() - b.t)))]
        (u, v), _ = cam.project(np.array([w.x, w.y, w.z]))
        assert b.u_left - 3 <= u <= b.u_right + 3 and b.v_top - 3 <= v <= b.v_bottom + 3
    # region-averaged flow noise, not edge noise x fps: |flow| of a walker at ~1 m/s is tens of px/s
    assert rec.calibration.noise["flow_sigma_px_s"] < rec.calibration.noise["box_sigma_px"] * 10
