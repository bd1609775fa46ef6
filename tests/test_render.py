"""Rendering: the rendered image agrees with the Camera model; backgrounds, segmentation, video."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
import pytest

from trackroom.scenes.camera import Camera
from trackroom.sim.render import SceneRenderer, VideoSink, read_video


class TinyWorld:
    """A minimal MjSpec world for tests: a floor, cameras from ``Camera`` objects and mocap people
    (a capsule of radius r from the floor to height h, in the person's colour)."""

    def __init__(self, cameras: list[Camera], colors, radius=0.2, height=1.75, size=10.0):
        spec = mujoco.MjSpec()
        spec.visual.headlight.ambient = [0.4, 0.4, 0.4]
        w = spec.worldbody
        w.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[size, size, 0.1], pos=[size / 2, size / 2, 0],
                   rgba=[0.6, 0.6, 0.55, 1])
        w.add_light(pos=[size / 2, size / 2, 4.0], dir=[0, 0, -1], castshadow=False)
        for c in cameras:
            cam = w.add_camera(name=c.name, pos=list(c.position), fovy=float(np.degrees(c.fovy)))
            cam.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
            cam.alt.xyaxes = list(c.mujoco_xyaxes())
        self.bodies = []
        for i, col in enumerate(colors):
            b = w.add_body(name=f"p{i}", mocap=True, pos=[100.0 + i, 0, 0])
            b.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[radius, 0, 0],
                       fromto=[0, 0, radius, 0, 0, height - radius], rgba=[*col, 1])
            self.bodies.append(f"p{i}")
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        self.radius, self.height = radius, height
        self.camera_ids = {c.name: mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, c.name) for c in cameras}
        self.person_geoms = [np.flatnonzero(self.model.geom_bodyid == self.model.body(n).id) for n in self.bodies]
        self.person_of_geom = np.full(self.model.ngeom, -1, np.int16)
        for i, g in enumerate(self.person_geoms):
            self.person_of_geom[g] = i

    def place(self, xy):
        for i, p in enumerate(np.asarray(xy, float)):
            self.data.mocap_pos[self.model.body(self.bodies[i]).mocapid[0]] = [p[0], p[1], 0.0]
        mujoco.mj_forward(self.model, self.data)


def horizontal_cam(**kw) -> Camera:
    base = dict(name="h", kind="horizontal", position=np.array([5.0, 0.06, 1.5]), yaw=np.pi / 2, pitch=0.0,
                fovy=np.radians(30), width=320, height=240, fps=4.0)
    base.update(kw)
    return Camera(**base)


def overhead_cam(**kw) -> Camera:
    base = dict(name="o", kind="overhead", position=np.array([5.0, 5.0, 2.95]), yaw=0.0, pitch=-np.pi / 2,
                fovy=np.radians(120), width=320, height=240, fps=20.0, region=(0.0, 0.0, 10.0, 10.0))
    base.update(kw)
    return Camera(**base)


@pytest.fixture(scope="module")
def world():
    cams = [horizontal_cam(), overhead_cam()]
    return TinyWorld(cams, [(0.85, 0.1, 0.1), (0.1, 0.25, 0.9)]), cams


def test_rendered_person_centre_matches_camera_model(world):
    w, (hc, oc) = world
    w.place([[4.2, 5.0], [100, 100]])
    with SceneRenderer(w.model, w.person_of_geom) as r:
        seg = r.segment(w.data, w.camera_ids["h"], hc.width, hc.height)
    cols = np.nonzero(seg == 0)[1]
    u_seg = cols.mean() + 0.5  # pixel centres
    assert len(cols) > 500
    assert abs(u_seg - hc.bearing_u([4.2, 5.0])) < 0.5


def test_background_hides_people_and_restores_model(world):
    w, (hc, oc) = world
    w.place([[5.0, 5.0], [6.0, 5.0]])
    before = w.model.geom_rgba.copy()
    with SceneRenderer(w.model, w.person_of_geom) as r:
        bg = r.background(w.data, w.camera_ids["o"], oc.width, oc.height, np.concatenate(w.person_geoms))
        rgb, seg = r.rgb_and_segment(w.data, w.camera_ids["o"], oc.width, oc.height)
        w.place([[100, 100], [101, 100]])
        empty = r.rgb(w.data, w.camera_ids["o"], oc.width, oc.height)
    np.testing.assert_array_equal(w.model.geom_rgba, before)
    np.testing.assert_array_equal(bg, empty)
    changed = np.abs(rgb.astype(int) - bg.astype(int)).max(axis=2) > 0
    assert set(np.unique(seg)) == {-1, 0, 1}
    # the people are exactly where the image differs from the background
    assert (changed == (seg >= 0)).mean() > 0.995


def test_shadows_flag(world):
    w, _ = world
    r = SceneRenderer(w.model, w.person_of_geom, shadows=True)
    assert r.renderer(160, 120).scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW]
    r.close()
    r = SceneRenderer(w.model, w.person_of_geom)
    assert not r.renderer(160, 120).scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW]
    r.close()


def test_renderer_grows_offscreen_buffer(world):
    w, _ = world
    with SceneRenderer(w.model, w.person_of_geom) as r:
        img = r.rgb(w.data, w.camera_ids["h"], 800, 600)
    assert img.shape == (600, 800, 3)


def test_video_round_trip(tmp_path, world):
    w, (hc, _) = world
    sink = VideoSink(tmp_path)
    frames = []
    with SceneRenderer(w.model, w.person_of_geom) as r:
        for x in (3.0, 4.0, 5.0):
            w.place([[x, 5.0], [100, 100]])
            frames.append(r.rgb(w.data, w.camera_ids["h"], 160, 120).copy())
            sink.write("h", frames[-1], 4.0)
    sink.close()
    back = read_video(sink.path("h"))
    assert len(back) == 3
    # lossy codec: close, not equal
    assert np.abs(back[1].astype(int) - frames[1].astype(int)).mean() < 6
    assert len(read_video(sink.path("h"), frames=[2])) == 1


def test_fast_segmentation_equals_mujoco_segmentation(world):
    """``SceneRenderer.segment`` (no-multisampling context, one id lookup) gives exactly the
    person indices of MuJoCo's own segmentation render on the multisampled RGB renderer."""
    w, (hc, oc) = world
    with SceneRenderer(w.model, w.person_of_geom) as r:
        for xy in ([[4.2, 5.0], [5.0, 4.6]], [[5.0, 5.0], [5.3, 5.1]], [[2.0, 8.0], [7.5, 6.0]]):
            w.place(xy)
            for cam in (hc, oc):
                fast = r.segment(w.data, w.camera_ids[cam.name], cam.width, cam.height)
                ref = r.renderer(cam.width, cam.height)
                ref.update_scene(w.data, camera=w.camera_ids[cam.name])
                ref.enable_segmentation_rendering()
                try:
                    ids = ref.render()
                finally:
                    ref.disable_segmentation_rendering()
                assert fast.dtype == np.int16
                np.testing.assert_array_equal(fast, r.person_index(ids))
        assert w.model.vis.quality.offsamples == 4  # the model's setting is restored


def test_tables_do_not_depend_on_the_worker_count():
    """Perception, labels and video in 0 (the rendering thread), 1 or 3 worker threads give the
    same tables, bit for bit (privacy cameras: each camera's stateful motion gate must see its
    frames in order while the cameras run side by side)."""
    import pandas as pd

    from trackroom.scenes.loader import load_scene
    from trackroom.sim.rendered import observe
    from trackroom.sim.walkers import plan_trajectories
    from trackroom.sim.world import build_world

    scene = load_scene("overhead_lab", ["cameras.*.privacy=true"])
    traj = plan_trajectories(scene, 1.0, np.random.default_rng(3))
    world = build_world(scene)
    ticks = []
    a = observe(world, scene, traj, workers=1, progress=ticks.append)
    assert len(a[0]["floor_detections"]) > 0 and len(a[1]["labels"]) > 0
    assert ticks == [1] * 4 * 20  # one tick per camera frame: 4 cameras at 20 Hz for 1 s
    for workers in (0, 3):
        b = observe(world, scene, traj, workers=workers)
        for ta, tb in zip(a, b):
            for k in ta:
                pd.testing.assert_frame_equal(ta[k], tb[k], check_exact=True)


def test_rendered_recording_with_one_and_two_workers_is_identical():
    """A short rendered recording of the oblique-camera scene (flow tracker, bearings, labels,
    IMUs) has the same tables, bit for bit, with one worker thread and with two."""
    import pandas as pd

    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    scene = load_scene("occlusion_lab")
    a, b = (simulate(scene, seed=2, duration=1.5, sensing="rendered", render_workers=n) for n in (1, 2))
    assert len(a.observations.tables["boxes"]) > 0 and len(a.observations.tables["bearings"]) > 0
    for ta, tb in ((a.observations.tables, b.observations.tables), (a.truth.tables, b.truth.tables)):
        assert ta.keys() == tb.keys()
        for k in ta:
            pd.testing.assert_frame_equal(ta[k], tb[k], check_exact=True)
