"""Analytic windows for the target-plane tracker: like an optical-flow tracker, an oblique camera
reports a window only for a person whose image moves (``sensors.flow_min_px_s``). The geometry
tests use ideal perception (the fitted model's misses and false windows are tested in
test_perception_model.py)."""
from __future__ import annotations

import dataclasses

import numpy as np

from trackroom.scenes.loader import load_scene
from trackroom.scenes.spec import hidden_heights, occluding_boxes
from trackroom.sim.simulate import simulate

STANDING = "{motion='standing', start=[3.4, 4.0]}"
WALKER = "{motion='waypoints', waypoints=[[1.0, 4.0], [3.0, 6.3]], speed=[1.0, 1.0]}"


def test_people_standing_still_give_no_windows():
    scene = load_scene("occlusion_lab", ["walkers.count=2", f"walkers.people=[{STANDING}, {{motion='standing', start=[6.0, 4.2]}}]",
                                         "sensors.perception=ideal"])
    rec = simulate(scene, seed=0, duration=1.0)
    assert len(rec.observations["bearings"]) > 0  # they are seen ...
    assert "boxes" not in rec.observations.tables or len(rec.observations["boxes"]) == 0  # ... but no flow window


def test_windows_follow_only_the_walker():
    scene = load_scene("occlusion_lab", ["walkers.count=2", f"walkers.people=[{STANDING}, {WALKER}]", "sensors.perception=ideal"])
    rec = simulate(scene, seed=0, duration=2.0)
    boxes, people = rec.observations["boxes"], rec.truth.people
    walker = people[people.person_id == scene.walkers[1].name]
    assert len(boxes) > 20
    assert boxes.groupby(["t", "camera"]).size().max() == 1  # one window per camera frame: the walker's
    boxes_of_plan = occluding_boxes(scene.floorplan)
    cut = 0
    for _, b in boxes.iterrows():
        cam = rec.calibration.cameras[b.camera]
        w = walker.iloc[int(np.argmin(np.abs(walker.t.to_numpy() - b.t)))]
        (u, v), _ = cam.project(np.array([w.x, w.y, w.z]))
        (_, v_head), _ = cam.project(np.array([w.x, w.y, 2.0 * w.z]))
        assert b.u_left - 3 <= u <= b.u_right + 3 and b.v_top - 3 <= v_head <= b.v_bottom + 3
        if hidden_heights(boxes_of_plan, cam.position, [w.x, w.y]) < w.z:  # the body centre seen
            assert b.v_top - 3 <= v <= b.v_bottom + 3
        else:  # the shelf hides it from this camera: the window stops above it
            assert b.v_bottom < v
            cut += 1
    assert cut > 0  # the walk passes behind the shelf for some camera
    # region-averaged flow noise, not edge noise x fps: |flow| of a walker at ~1 m/s is tens of px/s
    assert rec.calibration.noise["flow_sigma_px_s"] < rec.calibration.noise["box_sigma_px"] * 10


def test_rendered_recordings_declare_the_flow_detectors_noise():
    """A rendered recording's calibration carries the flow detector's measured window noise
    (its own keys) and the fitted perception model's bearing noise, and the estimator picks it
    up; an analytic recording through the fitted model declares the same; with ideal perception
    an analytic recording falls back to the bearing noise. The eq. 8
    threshold is the estimator's own parameter in both (never a calibration entry), and the
    simulator's detector settings (``still_speed``, ``flow_min_px_s``) are not in the calibration."""
    from trackroom.estimators.target_planes import TargetPlanes
    from trackroom.sim.perception_flow import RENDERED_WINDOW_NOISE

    scene = load_scene("occlusion_lab")
    rec = simulate(scene, seed=0, duration=0.2, sensing="rendered")
    noise = rec.calibration.noise
    for key, value in RENDERED_WINDOW_NOISE.items():
        assert noise[key] == value
    from trackroom.sim.perception_model import load_model

    assert noise["bearing_sigma_px"] == load_model("fitted").noise_figures({"oblique"})["bearing_sigma_px"]
    assert simulate(scene, seed=0, duration=0.2).calibration.noise == noise  # analytic, fitted: the same
    cfg = TargetPlanes(multi_person=True).resolved_config(rec.calibration)
    assert (cfg.box_sigma_px, cfg.box_u_sigma_px, cfg.flow_sigma_px_s, cfg.width_ratio_threshold) == (
        RENDERED_WINDOW_NOISE["box_sigma_px"], RENDERED_WINDOW_NOISE["box_u_sigma_px"],
        RENDERED_WINDOW_NOISE["flow_sigma_px_s"], TargetPlanes.Config().width_ratio_threshold)
    for key in ("still_speed", "flow_min_px_s", "box_width_ratio_threshold"):
        assert key not in noise
    assert TargetPlanes(multi_person=True, width_ratio_threshold=0.8).resolved_config(rec.calibration).width_ratio_threshold == 0.8

    ideal = load_scene("occlusion_lab", ["sensors.perception=ideal"])
    analytic = simulate(ideal, seed=0, duration=0.2).calibration
    assert "box_u_sigma_px" not in analytic.noise
    assert analytic.noise["bearing_sigma_px"] == scene.sensors.bearing_sigma_px
    cfg = TargetPlanes(multi_person=True).resolved_config(analytic)
    assert cfg.box_u_sigma_px == analytic.noise["bearing_sigma_px"] and cfg.width_ratio_threshold == 0.5
    assert not {"still_speed", "flow_min_px_s"} & set(analytic.noise)
    # a calibration that still carries a threshold (an old recording) does not steer the estimator
    old = dataclasses.replace(analytic, noise={**analytic.noise, "box_width_ratio_threshold": 2.0})
    assert TargetPlanes(multi_person=True).resolved_config(old).width_ratio_threshold == 0.5


def test_a_window_edge_cut_by_the_image_border_stays_on_it():
    """The fitted model's edge errors move a window's edges, but not one the image border cuts:
    a rendered flow region cut by the border ends on it (``perception_flow.current_box``), and
    so must an analytic one (before, about half of them were drawn inside the image, where the
    tracker took them for the person's own edge). A walker along the south wall leaves obl_se's
    image by its left border and comes into obl_nw's by its right: in every frame where the
    walker's projected cylinder reaches past that border and a window covers the part inside,
    a window ends exactly on the border."""
    from trackroom.sim import analytic
    from trackroom.sim.walkers import plan_trajectories

    walker = "{motion='waypoints', waypoints=[[3.2, 1.2], [0.8, 1.2], [0.8, 3.0]], speed=[1.0, 1.0]}"
    scene = load_scene("occlusion_lab", ["walkers.count=1", f"walkers.people=[{walker}]"])  # fitted perception
    duration = 5.0
    cut = {"obl_se": [0, 0], "obl_nw": [0, 0]}  # frames cut, frames with a window on the border
    for seed in (0, 1, 2):  # three draws of the windows: a few frames cut in obl_nw each
        rec = simulate(scene, seed=seed, duration=duration)
        traj = plan_trajectories(scene, duration, np.random.default_rng(seed).spawn(4)[0])  # simulate's motion stream
        boxes = rec.observations["boxes"]
        for cam in scene.cameras:
            if cam.name not in cut:
                continue
            g = analytic.camera_geometry(dataclasses.replace(scene, cameras=[cam]), traj)[cam.name]
            mine = boxes[boxes.camera == cam.name]
            for k, t in enumerate(traj.t[g.steps]):
                lo, hi = g.span[k, 0]
                rows = mine[np.isclose(mine.t, t)]
                if lo <= 0.0 < hi and (rows.u_left < 0.5 * hi).any():
                    cut[cam.name][0] += 1
                    cut[cam.name][1] += int((rows.u_left == 0.0).any())
                if hi >= cam.width > lo and (rows.u_right > 0.5 * (lo + cam.width)).any():
                    cut[cam.name][0] += 1
                    cut[cam.name][1] += int((rows.u_right == cam.width).any())
    assert cut["obl_se"][0] >= 20 and cut["obl_nw"][0] >= 5, cut
    assert all(n == on for n, on in cut.values()), cut
