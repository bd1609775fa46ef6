"""Realistic phone errors, applied to the noise-free IMU readings (``sim.imu.read_phones``).

The readings come in the walker's body frame (z up, x along the body's yaw). Per phone, drawn
from the recording's own stream (same scene and seed, same errors):

- **Indoor magnetic disturbance** (``mag_disturbance_deg``): steel in walls and furniture bends
  the field. The field read at floor point p is turned about the vertical by
      d(p) = D w(p) xi(p),   w(p) = exp(-c(p) / ``mag_disturbance_range_m``),
  c(p) the clearance to the nearest wall or obstacle (m), so the deviation is largest next to
  them, and xi a smooth random field in [-1, 1] (a sum of ``N_WAVES`` plane waves of wavelength
  1.5-4 m, random directions and phases, normalised), one field per recording (the building's).
  Along a walker's path it is evaluated every ``FIELD_STRIDE`` samples and interpolated between
  them (it changes over metres, a walker covers centimetres in between).
- **Accelerometer bias** (``accel_bias``): a constant N(0, b^2) per axis and phone (m/s^2).
- **Pocket orientation**: the phone sits in the pocket turned by a yaw offset
  U(-``pocket_yaw_deg``, +``pocket_yaw_deg``) and tilted by U(0, ``pocket_tilt_deg``) about a
  random horizontal axis: every reading is rotated into that phone frame.
- **Phone in the hand** (``swing_per_min``): episodes (Poisson, that many per minute, 4-10 s
  long) in which the phone swings in the hand about the vertical by
  ``swing_deg`` sin(2 pi f t) (f = 0.9 Hz, an arm swing per stride): the readings turn with it,
  and the gyro reads the swing's rate.

Every setting 0 (the default) leaves the readings as they are.
"""
from __future__ import annotations

import numpy as np

N_WAVES = 6
FIELD_STRIDE = 10  # samples between evaluations of the disturbance field along a path
SWING_HZ = 0.9
SWING_S = (4.0, 10.0)


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _turn(v: np.ndarray, angle: np.ndarray) -> None:
    """Rotate the rows of ``v`` (n, 3) about z by ``angle`` (n,) rad, in place."""
    c, s = np.cos(angle), np.sin(angle)
    x = v[:, 0].copy()
    v[:, 0] = c * x - s * v[:, 1]
    v[:, 1] = s * x + c * v[:, 1]


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def disturbance_field(rng: np.random.Generator, floorplan, strength_deg: float, range_m: float):
    """p (N, 2) -> deviation of the field's direction (rad) at p (module docstring)."""
    k = rng.uniform(2 * np.pi / 4.0, 2 * np.pi / 1.5, N_WAVES)
    th = rng.uniform(0, 2 * np.pi, N_WAVES)
    ph = rng.uniform(0, 2 * np.pi, N_WAVES)
    dirs = np.stack([np.cos(th), np.sin(th)], axis=1) * k[:, None]
    D = np.radians(strength_deg)

    def field(p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, float).reshape(-1, 2)
        xi = np.sin(p @ dirs.T + ph).sum(axis=1) / np.sqrt(N_WAVES / 2.0)
        xi = np.tanh(xi)  # in (-1, 1)
        w = np.exp(-np.maximum(floorplan.clearance(p), 0.0) / max(range_m, 1e-6))
        return D * w * xi

    return field


def apply(readings: np.ndarray, pos: np.ndarray, t: np.ndarray, floorplan, s, rng: np.random.Generator) -> np.ndarray:
    """Readings (P, n, 9) [acc, gyro, mag] with the errors of ``s`` (a ``SensorSpec``); ``pos``
    (P, n, 2) the walkers' floor positions at the samples, ``t`` (n,) their times (s). Rows of
    walkers without a phone (NaN) stay NaN. Draws: the field first, then per walker in order."""
    out = readings.copy()
    field = disturbance_field(rng, floorplan, s.mag_disturbance_deg, s.mag_disturbance_range_m)
    P = readings.shape[0]
    for i, r in enumerate(rng.spawn(P)):
        bias = r.normal(0.0, s.accel_bias, 3)
        yaw = r.uniform(-1.0, 1.0) * np.radians(s.pocket_yaw_deg)
        tilt = r.uniform(0.0, 1.0) * np.radians(s.pocket_tilt_deg)
        axis_th = r.uniform(0, 2 * np.pi)
        n_sw = r.poisson(s.swing_per_min * (t[-1] - t[0]) / 60.0) if len(t) > 1 and s.swing_per_min > 0 else 0
        starts = r.uniform(t[0], t[-1], n_sw) if n_sw else np.zeros(0)
        lengths = r.uniform(*SWING_S, n_sw) if n_sw else np.zeros(0)
        if not np.all(np.isfinite(readings[i])):
            continue
        acc, gyro, mag = (out[i, :, j:j + 3] for j in (0, 3, 6))
        if s.mag_disturbance_deg > 0:
            # the field varies over metres: evaluated every FIELD_STRIDE samples along the path
            # (0.1 s at 100 Hz, at most ~0.15 m walked) and interpolated in time between them
            k = np.r_[np.arange(0, len(t), FIELD_STRIDE), len(t) - 1]
            _turn(mag, np.interp(np.arange(len(t)), k, field(pos[i, k])))
        if n_sw:
            a = np.zeros(len(t))
            for t0, L in zip(starts, lengths):
                m = (t >= t0) & (t < t0 + L)
                a[m] = np.radians(s.swing_deg) * np.sin(2 * np.pi * SWING_HZ * (t[m] - t0)) * np.sin(np.pi * (t[m] - t0) / L)
            m = a != 0  # the phone turned by a: readings turned by -a (only where it swings)
            for v in (acc, gyro, mag):
                w = v[m]
                _turn(w, -a[m])
                v[m] = w
            gyro[:, 2] += np.gradient(a, t)
        R = _rot_z(yaw) @ _axis_angle([np.cos(axis_th), np.sin(axis_th), 0.0], tilt)  # phone in body frame
        for v in (acc, gyro, mag):
            v[:] = v @ R  # R^T v per row
        acc += bias
    return out
