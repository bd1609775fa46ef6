"""Every sensor noise of the simulator, in one place (one-sigma values from ``SensorSpec``).

Each function takes a seeded ``numpy.random.Generator`` (the caller's stream for that sensor)
and noise-free values, and returns the measured values. Models:

- IMU (phone frame): a = a_true + N(0, accel_sigma^2 I) (m/s^2), g = g_true + N(0, gyro_sigma^2 I)
  (rad/s), m = m_true + N(0, mag_sigma^2 I) (field units). White, independent per sample and
  axis (Teixeira sec. 7 simulates white accelerometer and magnetometer noise).
- Bearing: u = u_true + N(0, bearing_sigma_px^2) (pixels).
- Boxes (oblique cameras): each window edge u_left, u_right, v_top, v_bottom gets independent
  N(0, box_sigma_px^2); the centroid u gets N(0, bearing_sigma_px^2); the flow gets
  N(0, flow_sigma_px_s^2) per axis (px/s: the mean flow over the object region, whose error is
  far below an edge error differenced between frames, box_sigma_px * fps).
- Floor positions (overhead cameras): (x, y) + N(0, floor_sigma_m^2 I) (m). A privacy camera
  then quantises to its grid: x_q = quantum * round(x / quantum) (Teixeira: 15 cm cells).
"""
from __future__ import annotations

import numpy as np

from trackroom.scenes.spec import SensorSpec


def imu(rng: np.random.Generator, acc: np.ndarray, gyro: np.ndarray, mag: np.ndarray, s: SensorSpec):
    """Noisy (acc, gyro, mag), each (n, 3)."""
    return (
        acc + rng.normal(0.0, s.accel_sigma, acc.shape),
        gyro + rng.normal(0.0, s.gyro_sigma, gyro.shape),
        mag + rng.normal(0.0, s.mag_sigma, mag.shape),
    )


def bearing(rng: np.random.Generator, u: np.ndarray, s: SensorSpec) -> np.ndarray:
    """Noisy horizontal image coordinate (pixels)."""
    return u + rng.normal(0.0, s.bearing_sigma_px, np.shape(u))


def box(rng: np.random.Generator, edges: np.ndarray, u: np.ndarray, flow: np.ndarray, fps: float, s: SensorSpec):
    """Noisy window edges (n, 4) [u_left, u_right, v_top, v_bottom], centroid u (n,) and flow (n, 2)."""
    e = edges + rng.normal(0.0, s.box_sigma_px, edges.shape)
    # keep the window well formed after the noise
    e[:, [0, 1]] = np.sort(e[:, [0, 1]], axis=1)
    e[:, [2, 3]] = np.sort(e[:, [2, 3]], axis=1)
    return e, u + rng.normal(0.0, s.bearing_sigma_px, u.shape), flow + rng.normal(0.0, s.flow_sigma_px_s, flow.shape)


def floor_position(rng: np.random.Generator, xy: np.ndarray, s: SensorSpec, quantum: float = 0.0) -> np.ndarray:
    """Noisy floor positions (n, 2), quantised to ``quantum`` metres when positive."""
    out = xy + rng.normal(0.0, s.floor_sigma_m, np.shape(xy))
    if quantum > 0:
        out = quantum * np.round(out / quantum)
    return out
