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

BATCH_BODIES = 100  # phone bodies in the phone world (copies x phones): fewer calls vs a longer compile
CHUNK_SAMPLES = 2000  # samples whose states are packed at once (and progress reported)
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
    (``World.set_pose``: positions only); ``progress(n)`` every CHUNK_SAMPLES samples (or so)
    with the number done since its last call.
    """
    P, n = world.n_people, len(steps)
    out = np.empty((P, n, 9))
    phones = [i for i in range(P) if world.phone_sensors[i] is not None]
    out[[i for i in range(P) if i not in phones]] = np.nan
    if phones and n:
        pw = phone_world(world.scene, max(1, min(n, BATCH_BODIES // len(phones))))
        K, m, d = pw.copies, pw.model, pw.data
        kinematics, com_pos, com_vel = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel
        sensor_pos, sensor_vel, rne_post, sensor_acc = mujoco.mj_sensorPos, mujoco.mj_sensorVel, mujoco.mj_rnePostConstraint, mujoco.mj_sensorAcc
        qpos, qvel, qacc, sensordata = d.qpos, d.qvel, d.qacc, d.sensordata  # views, fetched once
        # qpos, qvel, qacc and readings of CHUNK passes at a time, (pass, copy, phone, [x, y, z, yaw])
        # in the model's order: small buffers, reused (a 10-minute run's whole state would be ~60 MB)
        chunk = max(1, CHUNK_SAMPLES // K)
        Q, V, A = (np.empty((chunk * K, len(phones), 4)) for _ in range(3))
        S = np.empty((chunk, m.nsensordata))
        for j0 in range(0, n, chunk * K):
            j1 = min(n, j0 + chunk * K)
            part = steps[j0:j1]
            for j, i in enumerate(phones):
                for full, xyz, yaw in ((Q, traj.pos, traj.yaw), (V, traj.vel, traj.yaw_rate), (A, traj.acc, traj.yaw_acc)):
                    full[: j1 - j0, j, :3] = xyz[i, part]
                    full[: j1 - j0, j, 3] = yaw[i, part]
            for x in (Q, V, A):
                x[j1 - j0 :] = x[j1 - j0 - 1]  # a last, partial pass: padded with its last sample
            Qb, Vb, Ab = (x.reshape(chunk, -1) for x in (Q, V, A))
            for b in range(-(-(j1 - j0) // K)):
                # World.sense's stages (the ones of mj_inverse the sensors read), unrolled
                qpos[:] = Qb[b]
                qvel[:] = Vb[b]
                qacc[:] = Ab[b]
                kinematics(m, d)
                com_pos(m, d)
                com_vel(m, d)
                sensor_pos(m, d)
                sensor_vel(m, d)
                rne_post(m, d)
                sensor_acc(m, d)
                S[b] = sensordata
            out[phones, j0:j1] = S.reshape(chunk * K, len(phones), 9)[: j1 - j0].transpose(1, 0, 2)
            if progress is not None:
                progress(j1 - j0)
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
    n, m = readings.shape[1], len(phones)
    col = {pid: c for c, (pid, _) in enumerate(phones)}
    # one contiguous run per table column, rows in table order (built in place: no stacked copies)
    values = np.empty((9, n, m))
    for i, pid in enumerate(phone_ids):  # noise drawn per phone in scene order (the draws do not depend on the sort)
        if pid:
            r = readings[i]
            for k, x in enumerate(noise.imu(rng, r[:, 0:3], r[:, 3:6], r[:, 6:9], scene.sensors)):
                values[3 * k : 3 * k + 3, :, col[pid]] = x.T
    data = {"t": np.repeat(t, m), "phone_id": str_column([p for p, _ in phones], np.tile(np.arange(m), n))}
    data.update({c: values[j].reshape(n * m) for j, c in enumerate(IMU_COLUMNS[2:])})
    return pd.DataFrame(data, copy=False)
