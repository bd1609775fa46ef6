"""Analytic sensing: occlusion by ray casts, field of view, privacy cameras, determinism."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd
import pytest

from trackroom.scenes.loader import load_scene, parse_scene
from trackroom.recording import OBSERVATION_COLUMNS, TRUTH_COLUMNS, check_table
from trackroom.sim.simulate import simulate

# A 10 m x 6 m room: a horizontal camera on the west wall looking east, a wall segment in the
# middle hiding "hidden" (behind it), "open" in plain view, and "shadowed" behind "open".
# These tests check the geometry, so the detectors are ideal (every visible person, exact labels);
# the fitted perception model is tested in test_perception_model.py.
OCCLUSION = {
    "scene": {"name": "occlusion_test"},
    "sensors": {"perception": "ideal"},
    "room": {"outline": [[0, 0], [10, 0], [10, 6], [0, 6]]},
    "walls": [{"start": [5.0, 3.5], "end": [5.0, 5.5]}],
    "cameras": [
        {"name": "west", "kind": "horizontal", "position": [0.1, 4.0, 1.5], "yaw_deg": 0, "fovy_deg": 50, "resolution": [320, 240], "fps": 10},
        {"name": "tilted", "kind": "oblique", "position": [0.1, 4.0, 2.5], "look_at": [8.0, 4.0, 0.9], "fovy_deg": 50, "resolution": [320, 240], "fps": 10},
        {"name": "top", "kind": "overhead", "position": [7.5, 3.0, 2.5], "fovy_deg": 120, "resolution": [160, 120], "fps": 10},
    ],
    "walkers": {
        "count": 3,
        "vary": False,  # the standing spots exactly as written (the geometry above depends on them)
        "people": [
            {"name": "hidden", "motion": "standing", "start": [8.0, 4.5]},
            {"name": "open", "motion": "standing", "start": [3.0, 3.3]},
            {"name": "shadowed", "motion": "standing", "start": [6.0, 2.5759]},
        ],
    },
}


def test_occluded_people_produce_no_observation():
    scene = parse_scene(OCCLUSION)
    rec = simulate(scene, seed=1, duration=2.0)
    vis = rec.truth.visibility
    by = vis.groupby(["camera", "person_id"])[["in_fov", "visible"]].all()
    # all three stand in both side cameras' fields of view
    for cam in ("west", "tilted"):
        assert by.loc[(cam, "hidden"), "in_fov"] and by.loc[(cam, "open"), "in_fov"]
    # the wall hides "hidden" from both; "open" is seen
    assert not vis[(vis.person_id == "hidden") & vis.camera.isin(["west", "tilted"])].visible.any()
    assert by.loc[("west", "open"), "visible"] and by.loc[("tilted", "open"), "visible"]
    # "shadowed" stands straight behind "open" as seen from the horizontal camera (same bearing)
    assert not vis[(vis.person_id == "shadowed") & (vis.camera == "west")].visible.any()
    bearings = rec.observations["bearings"]
    labels = dict(zip([w.name for w in scene.walkers], [w.color_name for w in scene.walkers]))
    assert labels["hidden"] not in set(bearings.label)
    west = bearings[bearings.camera == "west"]
    assert set(west.label) == {labels["open"]}
    assert len(west) == 20  # every frame of 2 s at 10 Hz
    # the overhead camera sees "hidden" from above (the wall is in the way of neither ray)
    assert vis[(vis.person_id == "hidden") & (vis.camera == "top")].visible.all()
    # people standing still give the optical-flow tracker no window (sensors.flow_min_px_s)
    assert len(rec.observations["boxes"]) == 0


def test_bearing_is_projection_of_body_centre():
    scene = parse_scene(OCCLUSION, overrides={"sensors.bearing_sigma_px": 0.0})
    rec = simulate(scene, seed=0, duration=1.0)
    cam = scene.camera("west")
    u = cam.bearing_u(np.array([3.0, 3.3]))
    west = rec.observations["bearings"].query("camera == 'west'")
    np.testing.assert_allclose(west.u.to_numpy(), u, atol=1e-9)


def test_privacy_camera_misses_still_people_and_quantises():
    raw = {**OCCLUSION, "cameras": [{**OCCLUSION["cameras"][2], "privacy": True, "position": [5.0, 3.0, 2.9]}]}
    raw["walkers"] = {
        "count": 2,
        "people": [
            {"name": "still", "motion": "standing", "start": [3.0, 2.0]},
            {"name": "mover", "motion": "waypoints", "waypoints": [[2.0, 4.0], [8.0, 1.5]], "loop": True, "speed": [1.0, 1.0]},
        ],
    }
    scene = parse_scene(raw)
    rec = simulate(scene, seed=3, duration=10.0)
    det = rec.observations["floor_detections"]
    q = scene.cameras[0].quantum
    assert q == pytest.approx(0.15)
    np.testing.assert_allclose(det.x / q, np.round(det.x / q), atol=1e-9)
    # no detection near the person standing still, though they are visible
    assert rec.truth.visibility.query("person_id == 'still'").visible.all()
    assert (np.hypot(det.x - 3.0, det.y - 2.0) > 0.8).all()
    assert len(det) > 0


def test_region_filters_by_measured_position():
    raw = {**OCCLUSION, "cameras": [{**OCCLUSION["cameras"][2], "position": [5.0, 3.0, 2.9], "region": [0, 0, 5, 6]}]}
    scene = parse_scene(raw)
    rec = simulate(scene, seed=2, duration=3.0)
    det = rec.observations["floor_detections"]
    assert len(det) and (det.x < 5).all()


def test_same_scene_and_seed_give_identical_tables():
    scene = parse_scene(OCCLUSION, overrides={"walkers.people.1.motion": "random_waypoint"})
    a = simulate(scene, seed=7, duration=5.0)
    b = simulate(scene, seed=7, duration=5.0)
    c = simulate(scene, seed=8, duration=5.0)
    for kind, df in a.observations.tables.items():
        pd.testing.assert_frame_equal(df, b.observations.tables[kind], check_exact=True)
        assert list(df.columns) == OBSERVATION_COLUMNS[kind]
        check_table(kind, df)
    for kind, df in a.truth.tables.items():
        pd.testing.assert_frame_equal(df, b.truth.tables[kind], check_exact=True)
        assert list(df.columns) == TRUTH_COLUMNS[kind]
    assert not a.observations["imu"].equals(c.observations["imu"])
    assert a.meta["walkers"][1]["motion"] == "random_waypoint" and a.meta["seed"] == 7
    assert a.calibration.noise["floor_sigma_m"] == scene.sensors.floor_sigma_m
    # the walker seen by the oblique camera gets windows; a track id stays while it stays visible
    boxes = a.observations["boxes"]
    assert len(boxes) > 0
    frames = np.round(boxes.t.to_numpy() * 10).astype(int)
    for _, g in boxes.assign(f=frames).groupby("track"):
        assert (np.diff(np.sort(g.f.to_numpy())) == 1).all()


def test_look_alikes_given_one_colour_share_the_label():
    """Two walkers the scene gives the same ``color`` are one appearance class: the loader accepts
    it (a walker without a colour takes one nobody has), analytic bearings label both alike, and
    rendered perception knows the colour once (its labels are ``Appearance.names``)."""
    from trackroom.sim.perception import Appearance

    raw = {**OCCLUSION, "walkers": {"count": 3, "vary": False, "people": [
        {"name": "open", "motion": "standing", "start": [3.0, 3.3], "color": "blue"},
        {"name": "twin", "motion": "standing", "start": [3.0, 4.7], "color": "blue"},
        {"name": "other", "motion": "standing", "start": [8.0, 1.0]},
    ]}}
    scene = parse_scene(raw)
    assert [w.color_name for w in scene.walkers] == ["blue", "blue", "red"]
    assert Appearance.from_scene(scene).names == ("blue", "red")
    west = simulate(scene, seed=0, duration=1.0).observations["bearings"].query("camera == 'west'")
    per_frame = west.groupby("t")["label"].apply(sorted)
    assert len(per_frame) == 10 and all(v[:2] == ["blue", "blue"] for v in per_frame)


def test_a_person_beside_a_wall_camera_is_not_seen_in_its_image():
    """Someone walking along the wall a horizontal camera hangs on, a few centimetres in front of
    its image plane and metres to its side, projects far outside the image. Ring points of their
    cylinder behind the camera must not mirror into the image (they made the person span the
    whole image and be reported in its middle, u = 160 px, in 3-16 % of bearing_hall's bearings)."""
    from types import SimpleNamespace

    from trackroom.sim.analytic import project_people

    scene = load_scene("bearing_hall")
    cam = next(c for c in scene.cameras if c.kind == "horizontal")
    yaw = cam.yaw
    ahead, side = np.array([np.cos(yaw), np.sin(yaw)]), np.array([np.sin(yaw), -np.cos(yaw)])
    at = np.asarray(cam.position[:2], float)
    beside = at + 0.06 * ahead + 3.0 * side  # 6 cm in front of the image plane, 3 m to the side
    in_view = at + 3.0 * ahead  # and someone straight ahead, for contrast
    pos = np.array([[[*beside, 0.9]], [[*in_view, 0.9]]])
    g = project_people(cam, SimpleNamespace(pos=pos), np.array([1.7, 1.7]), np.array([0.2, 0.2]), np.array([0]))
    assert not g.near[0, 0] and g.span[0, 0, 0] > cam.width  # wholly right of the image
    assert g.near[0, 1] and 0 < g.span[0, 1, 0] < cam.width / 2 < g.span[0, 1, 1] < cam.width


@pytest.mark.parametrize("obstacle_height, head_seen", [(1.80, 1.0), (2.10, 0.0)])
def test_the_head_ray_sees_a_head_over_an_obstacle_that_hides_the_axis(obstacle_height, head_seen):
    """An oblique camera at 2 m looks along y = 3 at a person 1.75 m tall standing at (6, 3), behind
    a 10 cm thick obstacle across the line of sight at x = 4. The axis rays (to 0.5, 0.75 and 0.95
    of the height) pass x = 4 at 1.78 m or lower, the ray to the top of the head at 1.83 m: a 1.80 m
    obstacle hides the axis and leaves the head seen (``Occlusion.head`` 1), a 2.10 m one hides
    both; ``fraction`` is 0 in both."""
    from trackroom.sim import analytic
    from trackroom.sim.walkers import plan_trajectories
    from trackroom.sim.world import build_world

    raw = {
        **OCCLUSION,
        "walls": [],
        "obstacles": [{"name": "shelf", "center": [4.0, 3.0], "size": [0.1, 1.0, obstacle_height]}],
        "cameras": [{**OCCLUSION["cameras"][1], "position": [0.1, 3.0, 2.0], "look_at": [8.0, 3.0, 0.9]}],
        "walkers": {"count": 1, "vary": False, "people": [{"name": "target", "motion": "standing", "start": [6.0, 3.0], "height": 1.75}]},
    }
    scene = parse_scene(raw)
    traj = plan_trajectories(scene, 1.0, np.random.default_rng(0))
    geometry = analytic.camera_geometry(scene, traj)
    occ = analytic.Occlusion(build_world(scene), scene, traj, geometry, head_ray=True)
    occ.finish()
    assert geometry["tilted"].in_fov.all()
    np.testing.assert_array_equal(occ.fraction["tilted"], 0.0)
    np.testing.assert_array_equal(occ.head["tilted"], head_seen)
