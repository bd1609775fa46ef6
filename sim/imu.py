"""Phone IMU streams from MuJoCo's sensors.

Each phone site's accelerometer, gyro and magnetometer (``sim.world``) read, at every IMU sample
(``sensors.imu_rate``, a divisor of the simulation rate), with the walker's qpos, qvel and qacc of
that trajectory step written and the stages of ``mj_inverse`` the sensors need run
(``World.sense``):

    acc = R^T (a - g)   (specific force, m/s^2; g = (0, 0, -9.81))
    gyro = R^T omega    (rad/s)
    mag = R^T m         (m = option.magnetic)

R the phone's world rotation (its walker's yaw). Noise is added by ``sim.noise.imu``.

Batching: the readings come from a *phone world* (``phone_world``) holding only the walkers with
a phone, BATCH_BODIES of them at once: copy c of every phone walker takes the state of sample
b * copies + c, so one pass of the sensor stages reads ``copies`` samples. Each walker is its own
kinematic tree, built by the same ``sim.world.add_walker`` with the same options, so MuJoCo does
the same arithmetic on it as in the scene's world: the readings equal ``mj_inverse``'s on the
scene's world bit for bit (tests/test_imu.py), at a tenth of the calls (60000 samples of 10 phones:
6000 passes instead of 60000).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pandas as pd

from . import noise
from .analytic import str_column
from .walkers import Trajectories
from .world import World, add_walker, new_spec

PROGRESS_EVERY = 100  # samples between progress reports
BATCH_BODIES = 100  # phone bodies in the phone world (copies x phones): fewer calls vs a longer compile
IMU_COLUMNS = ["t", "phone_id", "ax", "ay", "az", "gx", "gy", "gz", "mx", "my", "mz"]


def imu_steps(traj: Trajectories, imu_rate: float) -> np.ndarray:
    """Trajectory step indices of the IMU samples."""
    stride = int(round(traj.rate / imu_rate))
    return np.arange(0, traj.n_steps, stride)


@dataclass
class PhoneWorld:
    """``copies`` copies of a scene's phone walkers (``phones``: walker indices, scene order).

    Body ``c/<name>`` is copy c of a phone walker; its joints x, y, z, yaw take qpos (and qvel)
    addresses 4 b .. 4 b + 3 and its [acc, gyro, mag] sensordata 9 b .. 9 b + 8, b = c * len(phones)
    + j for the j-th phone (checked when built).
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    phones: list
    copies: int


def phone_world(scene, copies: int) -> PhoneWorld:
    """The phone walkers of ``scene``, ``copies`` times (bodies ``c/<walker name>``), in a world with
    the scene's options and nothing else (walls, cameras and phoneless walkers do not change what a
    phone reads)."""
    spec = new_spec(scene)
    phones = [i for i, w in enumerate(scene.walkers) if w.phone]
    names = [f"{c}/{scene.walkers[i].name}" for c in range(copies) for i in phones]
    for c in range(copies):
        for i in phones:
            add_walker(spec, scene.walkers[i], f"{c}/{scene.walkers[i].name}")
    m = spec.compile()
    qadr = [m.jnt_qposadr[m.joint(f"{n}_{j}").id] for n in names for j in ("x", "y", "z", "yaw")]
    dadr = [m.jnt_dofadr[m.joint(f"{n}_{j}").id] for n in names for j in ("x", "y", "z", "yaw")]
    sadr = [m.sensor_adr[m.sensor(f"{n}_{s}").id] + a for n in names for s in ("acc", "gyro", "mag") for a in range(3)]
    for adr, size in ((qadr, m.nq), (dadr, m.nv), (sadr, m.nsensordata)):
        if list(adr) != list(range(size)):
            raise RuntimeError("phone world: MuJoCo laid out the copies' joints or sensors out of order")
    return PhoneWorld(m, mujoco.MjData(m), phones, copies)


def read_phones(world: World, traj: Trajectories, steps: np.ndarray, on_step=None, progress=None) -> np.ndarray:
    """Noise-free readings (P, len(steps), 9) [acc, gyro, mag]; NaN for walkers without a phone.

    Read in batches from a ``phone_world`` of ``world.scene`` (module docstring).
    ``on_step(k)``, when given, is called for every sample k with ``world`` posed at it
    (``World.set_pose``: positions only); ``progress(n)`` every PROGRESS_EVERY samples (or so)
    with the number done since its last call.
    """
    P, n = world.n_people, len(steps)
    out = np.full((P, n, 9), np.nan)
    phones = [i for i in range(P) if world.phone_sensors[i] is not None]
    if phones and n:
        pw = phone_world(world.scene, max(1, min(n, BATCH_BODIES // len(phones))))
        K, m, d = pw.copies, pw.model, pw.data
        nb = -(-n // K)  # passes; the last one padded with the last sample
        # qpos, qvel, qacc of every pass: (pass, copy, phone, [x, y, z, yaw]) in the model's order
        Q, V, A = (np.empty((nb * K, len(phones), 4)) for _ in range(3))
        for j, i in enumerate(phones):
            for full, xyz, yaw in ((Q, traj.pos, traj.yaw), (V, traj.vel, traj.yaw_rate), (A, traj.acc, traj.yaw_acc)):
                full[:n, j, :3] = xyz[i, steps]
                full[:n, j, 3] = yaw[i, steps]
        for x in (Q, V, A):
            x[n:] = x[n - 1]
        Q, V, A = (x.reshape(nb, K * len(phones) * 4) for x in (Q, V, A))
        S = np.empty((nb, m.nsensordata))
        kinematics, com_pos, com_vel = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel
        sensor_pos, sensor_vel, rne_post, sensor_acc = mujoco.mj_sensorPos, mujoco.mj_sensorVel, mujoco.mj_rnePostConstraint, mujoco.mj_sensorAcc
        qpos, qvel, qacc, sensordata = d.qpos, d.qvel, d.qacc, d.sensordata  # views, fetched once
        reported = 0
        for b in range(nb):
            # World.sense's stages (the ones of mj_inverse the sensors read), unrolled
            qpos[:] = Q[b]
            qvel[:] = V[b]
            qacc[:] = A[b]
            kinematics(m, d)
            com_pos(m, d)
            com_vel(m, d)
            sensor_pos(m, d)
            sensor_vel(m, d)
            rne_post(m, d)
            sensor_acc(m, d)
            S[b] = sensordata
            if progress is not None and (b + 1) * K - reported >= PROGRESS_EVERY:
                progress(min((b + 1) * K, n) - reported)
                reported = min((b + 1) * K, n)
        if progress is not None and reported < n:
            progress(n - reported)
        out[phones] = S.reshape(nb * K, len(phones), 9)[:n].transpose(1, 0, 2)
    elif progress is not None and n:
        progress(n)
    if on_step is not None:
        for k in steps.tolist():
            world.set_pose(traj, k)
            on_step(k)
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
