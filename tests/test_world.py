"""The MuJoCo world: camera model vs MuJoCo's camprojection sensor, phone sensors, MJCF export."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
import pytest

from trackroom.scenes.loader import load_scene
from trackroom.sim.walkers import plan_trajectories
from trackroom.sim.world import build_world

SCENES_BY_KIND = {"horizontal": "bearing_hall", "overhead": "overhead_lab", "oblique": "occlusion_lab"}


@pytest.mark.parametrize("kind", sorted(SCENES_BY_KIND))
def test_camera_model_matches_mujoco_camprojection(kind):
    """P from the scene's camera model puts a walker's body centre within 0.5 px of MuJoCo's
    own camprojection sensor, for every camera of the scene, at several times."""
    scene = load_scene(SCENES_BY_KIND[kind])
    world = build_world(scene)
    name = scene.walkers[0].name
    site = world.spec.body(name).add_site()
    site.name = "centre_probe"
    for cam in scene.cameras:
        s = world.spec.add_sensor()
        s.name = f"proj_{cam.name}"
        s.type = mujoco.mjtSensor.mjSENS_CAMPROJECTION
        s.objtype = mujoco.mjtObj.mjOBJ_SITE
        s.objname = "centre_probe"
        s.reftype = mujoco.mjtObj.mjOBJ_CAMERA
        s.refname = cam.name
    model = world.spec.compile()
    data = mujoco.MjData(model)
    traj = plan_trajectories(scene, 5.0, np.random.default_rng(3))
    adr = model.jnt_qposadr[model.joint(f"{name}_x").id]
    checked = 0
    for k in (0, 120, 260, 499):
        data.qpos[adr : adr + 4] = [*traj.pos[0, k], traj.yaw[0, k]]
        mujoco.mj_forward(model, data)
        for cam in scene.cameras:
            uv, depth = cam.project(traj.pos[0, k])
            if depth <= 0.1:
                continue  # camprojection does not clip points behind the camera
            np.testing.assert_allclose(data.sensor(f"proj_{cam.name}").data, uv, atol=0.5)
            checked += 1
    assert checked >= 4


@pytest.mark.parametrize("kind", sorted(SCENES_BY_KIND))
def test_camera_model_matches_rendered_marker(kind):
    """A rendered check of the same: a 3 cm sphere 1 m away placed on the ray of a fractional pixel
    (u, v) of each camera shows up in MuJoCo's segmentation render with its pixel centroid within
    0.5 px of Camera.project (the compiled cameras are the calibrated ones, no syncing needed)."""
    from trackroom.sim.rendered import check_cameras

    scene = load_scene(SCENES_BY_KIND[kind])
    world = build_world(scene)
    check_cameras(world.model, scene, world.camera_ids)
    targets = []
    for j, cam in enumerate(scene.cameras):
        uv = np.array([0.62 * cam.width + 0.37, 0.41 * cam.height - 0.21])
        ray = cam.R.T @ np.linalg.solve(cam.K, [*uv, 1.0])
        p = np.asarray(cam.position, float) + 1.0 * ray / np.linalg.norm(ray)
        g = world.spec.worldbody.add_geom()
        g.name, g.type, g.size, g.pos = f"marker{j}", mujoco.mjtGeom.mjGEOM_SPHERE, [0.03, 0, 0], p.tolist()
        g.contype = g.conaffinity = 0
        targets.append((cam, p, g.name))
    model = world.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam0 = scene.cameras[0]
    with mujoco.Renderer(model, cam0.height, cam0.width) as renderer:
        renderer.enable_segmentation_rendering()
        for cam, p, gname in targets:
            assert (cam.width, cam.height) == (cam0.width, cam0.height)
            renderer.update_scene(data, camera=cam.name)
            seg = renderer.render()
            v, u = np.nonzero((seg[..., 0] == model.geom(gname).id) & (seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)))
            assert len(u) >= 5, f"marker not seen by {cam.name}"
            centroid = np.array([u.mean(), v.mean()]) + 0.5  # pixel centres
            np.testing.assert_allclose(centroid, cam.project(p[None])[0][0], atol=0.5)


def test_world_contents_and_export():
    scene = load_scene("occlusion_lab")
    world = build_world(scene)
    m = world.model
    assert m.ncam == len(scene.cameras)
    assert world.n_people == len(scene.walkers)
    # every person geom maps back to its walker; walls and floor map to -1
    assert [int(world.geom_person[g]) for g in world.person_geom] == list(range(len(scene.walkers)))
    assert world.geom_person[m.geom("floor").id] == -1
    assert m.vis.global_.offwidth >= max(c.width for c in scene.cameras)
    assert all(not bool(x) for x in m.light_castshadow)
    # capsules are human-sized, in the walkers' colours
    for w, g in zip(scene.walkers, world.person_geom):
        assert m.geom_size[g][0] == pytest.approx(w.radius)
        np.testing.assert_allclose(m.geom_rgba[g][:3], w.color, atol=1e-6)
    again = mujoco.MjModel.from_xml_string(world.to_xml())
    assert (again.nbody, again.nsensor, again.ncam, again.ngeom) == (m.nbody, m.nsensor, m.ncam, m.ngeom)


def test_magnetometer_gives_heading():
    """The phone's magnetometer reads R(yaw)^T m; the heading recovered from it is the yaw."""
    scene = load_scene("overhead_lab", ["walkers.count=3"])
    world = build_world(scene)
    traj = plan_trajectories(scene, 20.0, np.random.default_rng(5))
    m_world = np.asarray(scene.sensors.magnetic_field, float)
    for k in range(0, traj.n_steps, 97):
        world.set_step(traj, k)
        for i in range(traj.n_people):
            _, _, mag = world.phone_reading(i)
            heading = np.arctan2(m_world[1], m_world[0]) - np.arctan2(mag[1], mag[0])
            err = np.angle(np.exp(1j * (heading - traj.yaw[i, k])))
            assert abs(err) < 1e-9
            assert np.linalg.norm(mag) == pytest.approx(np.linalg.norm(m_world))


def test_export_xml_command(tmp_path):
    from trackroom.cli import main

    out = tmp_path / "hall.xml"
    assert main(["export-xml", "bearing_hall", "--out", str(out), "--set", "walkers.count=2"]) == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.ncam == 4 and m.nsensor == 6
    assert main(["export-xml", "no_such_scene"]) == 2
