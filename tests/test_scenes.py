"""Scene language: parsing, validation errors that name file/field/problem, overrides, geometry."""
from __future__ import annotations

import math
import tomllib
from importlib import resources

import numpy as np
import pytest

from trackroom.scenes import SceneError, bundled_scenes, load_scene, parse_scene
from trackroom.scenes.camera import Camera

MINIMAL = """
[scene]
name = "tiny"
[room]
outline = [[0, 0], [6, 0], [6, 4], [0, 4]]
[[walls]]
start = [3, 0]
end = [3, 2]
[[obstacles]]
center = [5, 3]
size = [0.6, 0.6, 1.0]
[[cameras]]
name = "c0"
kind = "horizontal"
position = [0.1, 2.0, 1.5]
yaw_deg = 0
fovy_deg = 40
resolution = [320, 240]
fps = 4
[walkers]
count = 1
[[walkers.people]]
start = [1.0, 1.0]
motion = "standing"
"""


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_bundled_scenes_load():
    assert set(bundled_scenes()) >= {"bearing_hall", "bearing_corridor", "office_floor", "overhead_lab", "occlusion_lab"}
    for name in bundled_scenes():
        s = load_scene(name)
        assert s.cameras and s.walkers


@pytest.mark.parametrize(
    "old,new,field,problem",
    [
        ('position = [0.1, 2.0, 1.5]', 'position = [9.0, 2.0, 1.5]', "cameras[0] (c0).position", "outside the room"),
        ('start = [1.0, 1.0]', 'start = [3.0, 1.0]', "walkers.people[0].start", "inside a wall or obstacle"),
        ('start = [1.0, 1.0]', 'start = [5.0, 3.0]', "walkers.people[0].start", "inside a wall or obstacle"),
        ('fps = 4', 'fps = 4\nzoom = 2', "cameras[0].zoom", "unknown key"),
        ('fps = 4', 'fps = -4', "cameras[0] (c0).fps", "must be positive"),
        ('[walkers]', '[sensors]\nimu_rate = -100\n[walkers]', "sensors.imu_rate", "must be positive"),
        ('kind = "horizontal"', 'kind = "fisheye"', "cameras[0] (c0).kind", "not one of"),
        ('yaw_deg = 0', 'yaw_deg = 0\npitch_deg = -20', "cameras[0] (c0).pitch_deg", "parallel to the floor"),
        ('name = "tiny"', 'name = "tiny"\ncolour = 1', "scene.colour", "unknown key"),
    ],
)
def test_bad_scene_errors_name_file_field_and_problem(tmp_path, old, new, field, problem):
    assert old in MINIMAL
    p = write(tmp_path, MINIMAL.replace(old, new, 1))
    with pytest.raises(SceneError) as e:
        load_scene(p)
    msg = str(e.value)
    assert str(p) in msg and field in msg and problem in msg, msg


def test_malformed_toml_and_missing_file(tmp_path):
    p = write(tmp_path, "[scene\nname=1")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(p)
    with pytest.raises(SceneError, match="no such scene file"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(SceneError, match="bundled"):
        load_scene("no_such_scene")


def test_a_folder_named_like_a_bundled_scene_does_not_hide_it(tmp_path, monkeypatch):
    """``trackroom generate overhead_lab --out overhead_lab`` leaves a folder of that name; the
    bundled scene must still load from there, and a folder that is no scene says so."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "overhead_lab").mkdir()
    (tmp_path / "a_folder").mkdir()
    scene = load_scene("overhead_lab")
    assert scene.name == "overhead_lab" and scene.source == "overhead_lab"
    with pytest.raises(SceneError, match="a folder, not a scene file"):
        load_scene("a_folder")


def test_overrides_set_any_field():
    s = load_scene("overhead_lab", ["walkers.count=10", "cameras.*.privacy=true", "walkers.phoneless=3"])
    assert len(s.walkers) == 10
    assert all(c.privacy and c.quantum == pytest.approx(0.15) for c in s.cameras)
    assert sum(w.phone for w in s.walkers) == 7
    with pytest.raises(SceneError, match="walkers.count"):
        load_scene("overhead_lab", ["walkers.count=99"])
    with pytest.raises(SceneError, match="expected key=value"):
        load_scene("overhead_lab", ["walkers.count"])


def test_projection_matrix_matches_projection():
    rng = np.random.default_rng(0)
    for name in bundled_scenes():
        for cam in load_scene(name).cameras:
            X = rng.uniform([0, 0, 0], [10, 10, 2], size=(50, 3))
            uv, z = cam.project(X)
            h = np.hstack([X, np.ones((50, 1))]) @ cam.P.T
            ok = np.abs(z) > 1e-3
            np.testing.assert_allclose(h[ok, :2] / h[ok, 2:], uv[ok], rtol=1e-9, atol=1e-6)
            np.testing.assert_allclose(cam.R @ cam.R.T, np.eye(3), atol=1e-12)
            if cam.kind == "horizontal":  # u does not depend on height for a level camera
                np.testing.assert_allclose(cam.bearing_u(X[ok, :2]), uv[ok, 0], rtol=1e-9, atol=1e-6)


def test_camera_looks_where_it_is_told():
    cam = Camera("c", "oblique", np.array([0.0, 0.0, 2.0]), yaw=math.radians(30), pitch=math.radians(-20),
                 fovy=math.radians(50), width=320, height=240, fps=10)
    ahead = cam.position + 5 * np.array([math.cos(math.radians(-20)) * math.cos(math.radians(30)),
                                         math.cos(math.radians(-20)) * math.sin(math.radians(30)), math.sin(math.radians(-20))])
    uv, z = cam.project(ahead)
    np.testing.assert_allclose(uv, [160, 120], atol=1e-9)
    assert z == pytest.approx(5)
    # back-projection inverts projection on a horizontal plane
    p = np.array([3.0, 2.0, 0.9])
    uv, _ = cam.project(p)
    np.testing.assert_allclose(cam.backproject_to_plane(uv, 0.9), p, atol=1e-9)


def _sees(cam, pts, walls):
    """Horizontal field of view with 2-D occlusion by wall centre lines."""
    ok = cam.in_horizontal_fov(pts)
    c = np.asarray(cam.position[:2])
    for w in walls:
        a, b = np.asarray(w.start), np.asarray(w.end)
        d1, d2 = pts - c, b - a
        den = d1[:, 0] * d2[1] - d1[:, 1] * d2[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((a[0] - c[0]) * d2[1] - (a[1] - c[1]) * d2[0]) / den
            r = ((a[0] - c[0]) * d1[:, 1] - (a[1] - c[1]) * d1[:, 0]) / den
        ok &= ~((s > 1e-6) & (s < 1 - 1e-6) & (r >= 0) & (r <= 1))
    return ok


@pytest.mark.parametrize("name", ["bearing_hall", "office_floor", "bearing_corridor"])
def test_bearing_cameras_do_not_overlap(name):
    s = load_scene(name)
    x0, y0, x1, y1 = s.floorplan.bounds()
    g = np.stack(np.meshgrid(np.linspace(x0 + 0.15, x1 - 0.15, 150), np.linspace(y0 + 0.15, y1 - 0.15, 150)), -1).reshape(-1, 2)
    g = g[s.floorplan.clearance(g) > 0.2]
    seen = np.stack([_sees(c, g, s.floorplan.walls) for c in s.cameras])
    assert seen.sum(axis=0).max() == 1, "two cameras see the same floor point"
    assert (seen.sum(axis=1) > 0).all(), "a camera sees no floor"


def test_scene_files_have_only_known_sections():
    for name in bundled_scenes():
        raw = tomllib.loads(resources.files("trackroom.scenes").joinpath(f"{name}.toml").read_text())
        parse_scene(raw, name)  # validates every key


def test_a_start_for_a_waypoints_walker_is_refused():
    raw = {"scene": {"name": "w"}, "room": {"outline": [[0, 0], [6, 0], [6, 6], [0, 6]]},
           "walkers": {"count": 1, "people": [{"motion": "waypoints", "waypoints": [[1, 1], [5, 5]], "start": [3, 1]}]}}
    with pytest.raises(SceneError, match="starts at its first waypoint"):
        parse_scene(raw)
