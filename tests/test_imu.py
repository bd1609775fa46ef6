"""Phone IMU from MuJoCo's sensors: the accelerometer and gyro match the analytic kinematics."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd

from trackroom.scenes.loader import load_scene
from trackroom.sim import imu
from trackroom.sim.walkers import plan_trajectories
from trackroom.sim.world import build_world

G = np.array([0.0, 0.0, -9.81])


def _rz(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_accelerometer_is_second_derivative_plus_gravity():
    """acc = R(yaw)^T (p'' - g) to 1e-6, with p'' the path's analytic second derivative; and p''
    is the second derivative of the sampled positions (central differences, O(dt^2))."""
    scene = load_scene("overhead_lab", ["walkers.count=2", "walkers.pause_probability=0.0"])
    traj = plan_trajectories(scene, 20.0, np.random.default_rng(11))
    world = build_world(scene)
    assert traj.walking[0].mean() > 0.5  # a walking person
    dt = 1.0 / traj.rate
    for k in range(5, traj.n_steps - 5, 37):
        world.set_step(traj, k)
        for i in range(traj.n_people):
            acc, gyro, _ = world.phone_reading(i)
            R = _rz(traj.yaw[i, k])
            np.testing.assert_allclose(acc, R.T @ (traj.acc[i, k] - G), atol=1e-6)
            np.testing.assert_allclose(gyro, [0.0, 0.0, traj.yaw_rate[i, k]], atol=1e-6)
    # consistency: vel and acc are the derivatives of pos (gait bob included)
    p = traj.pos
    fd_acc = (p[:, 2:] - 2 * p[:, 1:-1] + p[:, :-2]) / dt**2
    fd_vel = (p[:, 2:] - p[:, :-2]) / (2 * dt)
    assert np.abs(fd_acc - traj.acc[:, 1:-1]).max() < 0.02
    assert np.abs(fd_vel - traj.vel[:, 1:-1]).max() < 1e-3
    # the accelerometer sees the gait bob: vertical specific force oscillates while walking
    az = traj.acc[0, traj.walking[0], 2]
    assert az.std() > 0.3


def test_imu_table_noise_and_phoneless():
    scene = load_scene("overhead_lab", ["walkers.count=3", "walkers.phoneless=1"])
    traj = plan_trajectories(scene, 3.0, np.random.default_rng(0))
    world = build_world(scene)
    steps = imu.imu_steps(traj, scene.sensors.imu_rate)
    readings = imu.read_phones(world, traj, steps)
    assert np.isnan(readings[2]).all() and np.isfinite(readings[:2]).all()
    table = imu.imu_table(readings, traj.t[steps], ["phone0", "phone1", ""], scene, np.random.default_rng(1))
    assert list(table.columns) == imu.IMU_COLUMNS
    assert sorted(table.phone_id.unique()) == ["phone0", "phone1"]
    assert len(table) == 2 * len(steps)
    p0 = table[table.phone_id == "phone0"]
    resid = p0[["ax", "ay", "az"]].to_numpy() - readings[0, :, 0:3]
    assert abs(resid.std() - scene.sensors.accel_sigma) < 0.2 * scene.sensors.accel_sigma
    resid_m = p0[["mx", "my", "mz"]].to_numpy() - readings[0, :, 6:9]
    assert abs(resid_m.std() - scene.sensors.mag_sigma) < 0.2 * scene.sensors.mag_sigma
    assert (np.diff(table.t.to_numpy()) >= 0).all()


def test_readings_are_mj_inverse_bit_for_bit():
    """read_phones (and World.sense) run only the stages of mj_inverse the sensors need: the
    sensor data and the geometry poses the rays use equal mj_inverse's exactly."""
    import mujoco

    scene = load_scene("overhead_lab", ["walkers.count=3"])
    traj = plan_trajectories(scene, 4.0, np.random.default_rng(5))
    world = build_world(scene)
    steps = imu.imu_steps(traj, scene.sensors.imu_rate)
    fast = imu.read_phones(world, traj, steps)
    m, d = world.model, mujoco.MjData(world.model)
    Q, V, A = world.packed(traj)
    ref = np.empty((len(steps), m.nsensordata))
    for j, k in enumerate(steps):
        d.qpos[:], d.qvel[:], d.qacc[:] = Q[k], V[k], A[k]
        mujoco.mj_inverse(m, d)
        ref[j] = d.sensordata
        if j % 50 == 0:
            world.set_step(traj, k)
            np.testing.assert_array_equal(world.data.sensordata, d.sensordata)
            np.testing.assert_array_equal(world.data.geom_xpos, d.geom_xpos)
            np.testing.assert_array_equal(world.data.geom_xmat, d.geom_xmat)
    for i, adr in enumerate(world.phone_sensors):
        cols = np.concatenate([np.arange(a, a + 3) for a in adr])
        np.testing.assert_array_equal(fast[i], ref[:, cols])
    assert np.abs(ref).max() > 1.0  # real readings (gravity at least), not zeros on both sides


def test_batched_phone_world_reads_what_the_scene_world_reads(monkeypatch):
    """The phone world (copies of the phone walkers only, many samples per pass) gives the scene
    world's sensor readings bit for bit: a scene with scripted, standing and phoneless walkers, a
    sample count that leaves the last pass partial, and states packed in one chunk or several."""
    import mujoco

    scene = load_scene("occlusion_lab", ["walkers.people.2.phone=false"])  # waypoints, standing, one without a phone
    traj = plan_trajectories(scene, 3.0, np.random.default_rng(2))
    world = build_world(scene)
    phones = [i for i, s in enumerate(world.phone_sensors) if s is not None]
    steps = imu.imu_steps(traj, scene.sensors.imu_rate)[:-3]
    assert phones and len(steps) % max(1, imu.BATCH_BODIES // len(phones))  # a partial last pass
    fast = imu.read_phones(world, traj, steps)
    m, d = world.model, mujoco.MjData(world.model)
    Q, V, A = world.packed(traj)
    for j, k in enumerate(steps):
        d.qpos[:], d.qvel[:], d.qacc[:] = Q[k], V[k], A[k]
        mujoco.mj_inverse(m, d)
        for i in range(world.n_people):
            if world.phone_sensors[i] is None:
                assert np.isnan(fast[i, j]).all()
            else:
                cols = np.concatenate([np.arange(a, a + 3) for a in world.phone_sensors[i]])
                np.testing.assert_array_equal(fast[i, j], d.sensordata[cols])
    monkeypatch.setattr(imu, "CHUNK_SAMPLES", 60)  # several chunks of passes, each with its own packing
    np.testing.assert_array_equal(imu.read_phones(world, traj, steps), fast)
    pw = imu.phone_world(scene, 3)
    assert pw.copies == 3 and pw.model.nbody == 1 + 3 * len(phones)  # the phone walkers only
