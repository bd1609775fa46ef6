"""Phone IMU streams from MuJoCo's sensors.

At every IMU sample (``sensors.imu_rate``, a divisor of the simulation rate) the world is put at
that trajectory step (``World.set_step``: qpos, qvel, qacc, then ``World.sense``: the stages of
``mj_inverse`` the sensors need) and the phone sites'
accelerometer, gyro and magnetometer are read from ``sensordata``:

    acc = R^T (a - g)   (specific force, m/s^2; g = (0, 0, -9.81))
    gyro = R^T omega    (rad/s)
    mag = R^T m         (m = option.magnetic)

R the phone's world rotation (its walker's yaw). Noise is added by ``sim.noise.imu``.
"""
from __future__ import annotations

import mujoco
import numpy as np
import pandas as pd

from . import noise
from .analytic import str_column
from .walkers import Trajectories
from .world import World

PROGRESS_EVERY = 100  # samples between progress reports
IMU_COLUMNS = ["t", "phone_id", "ax", "ay", "az", "gx", "gy", "gz", "mx", "my", "mz"]


def imu_steps(traj: Trajectories, imu_rate: float) -> np.ndarray:
    """Trajectory step indices of the IMU samples."""
    stride = int(round(traj.rate / imu_rate))
    return np.arange(0, traj.n_steps, stride)


def read_phones(world: World, traj: Trajectories, steps: np.ndarray, on_step=None, progress=None) -> np.ndarray:
    """Noise-free readings (P, len(steps), 9) [acc, gyro, mag]; NaN for walkers without a phone.

    ``on_step(k)`` is called after each step is set (the simulator casts its rays there);
    ``progress(n)`` every PROGRESS_EVERY samples with the number done since its last call.
    """
    P = world.n_people
    out = np.full((P, len(steps), 9), np.nan)
    phones = [i for i in range(P) if world.phone_sensors[i] is not None]
    adr = np.concatenate([np.concatenate([np.arange(a, a + 3) for a in world.phone_sensors[i]]) for i in phones]) if phones else np.zeros(0, int)
    m, d = world.model, world.data
    Q, V, A = world.packed(traj)
    S = np.empty((len(steps), m.nsensordata))
    # World.sense, unrolled: this loop runs once per IMU sample (60000 times for 10 phones x 10 min)
    kinematics, com_pos, com_vel = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel
    sensor_pos, sensor_vel, rne_post, sensor_acc = mujoco.mj_sensorPos, mujoco.mj_sensorVel, mujoco.mj_rnePostConstraint, mujoco.mj_sensorAcc
    qpos, qvel, qacc, sensordata = d.qpos, d.qvel, d.qacc, d.sensordata  # views, fetched once
    for j, k in enumerate(steps.tolist()):
        qpos[:] = Q[k]
        qvel[:] = V[k]
        qacc[:] = A[k]
        kinematics(m, d)
        com_pos(m, d)
        com_vel(m, d)
        sensor_pos(m, d)
        sensor_vel(m, d)
        rne_post(m, d)
        sensor_acc(m, d)
        S[j] = sensordata
        if on_step is not None:
            on_step(k)
        if progress is not None and j % PROGRESS_EVERY == PROGRESS_EVERY - 1:
            progress(PROGRESS_EVERY)
    if progress is not None and len(steps) % PROGRESS_EVERY:
        progress(len(steps) % PROGRESS_EVERY)
    if phones:
        out[phones] = S[:, adr].reshape(len(steps), len(phones), 9).transpose(1, 0, 2)
    return out


def imu_table(readings: np.ndarray, t: np.ndarray, phone_ids: list[str], scene, rng: np.random.Generator) -> pd.DataFrame:
    """The ``imu`` observation table from noise-free readings (P, n, 9), sorted by t then phone."""
    phones = sorted((pid, i) for i, pid in enumerate(phone_ids) if pid)  # table order: t, then phone_id
    if not phones:
        return pd.DataFrame({c: pd.Series(dtype=object if c == "phone_id" else float) for c in IMU_COLUMNS})
    # noise drawn per phone in scene order (the draws do not depend on the sort)
    noisy = {}
    for i, pid in enumerate(phone_ids):
        if pid:
            r = readings[i]
            noisy[pid] = np.concatenate(noise.imu(rng, r[:, 0:3], r[:, 3:6], r[:, 6:9], scene.sensors), axis=1)
    stacked = np.stack([noisy[pid] for pid, _ in phones], axis=1)  # (n, phones, 9), rows sorted
    n, m = stacked.shape[:2]
    flat = stacked.reshape(n * m, 9)
    data = {"t": np.repeat(t, m), "phone_id": str_column([p for p, _ in phones], np.tile(np.arange(m), n))}
    data.update({c: flat[:, j] for j, c in enumerate(IMU_COLUMNS[2:])})
    return pd.DataFrame(data)
