"""Synthetic bearing observations for the QP smoother tests (no simulator needed)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from trackroom.scenes.loader import load_scene
from trackroom.recording import Calibration, Observations


def hall_calibration(scene: str = "bearing_hall") -> Calibration:
    sc = load_scene(scene)
    return Calibration(cameras={c.name: c for c in sc.cameras}, floorplan=sc.floorplan, noise={"bearing_sigma_px": 1.0})


def bearings_of(calib: Calibration, paths: dict[str, np.ndarray], dt: float, sigma_px: float = 0.0, seed: int = 0):
    """Bearings table of people (label -> (T, 2) floor path on the grid k dt) seen by every
    horizontal camera whose field of view holds them; Gaussian pixel noise sigma_px."""
    rng = np.random.default_rng(seed)
    rows = []
    for label, xy in paths.items():
        t = np.arange(len(xy)) * dt
        for name, cam in calib.cameras.items():
            m = cam.in_horizontal_fov(xy)
            u = cam.bearing_u(xy[m]) + sigma_px * rng.normal(size=int(m.sum()))
            rows.append(pd.DataFrame({"t": t[m], "camera": name, "u": u, "label": label}))
    df = pd.concat(rows, ignore_index=True).sort_values(["t", "camera"], kind="stable").reset_index(drop=True)
    return df


def straight_walk(T: int = 240, dt: float = 0.25, p0=(1.5, 2.0), v=(0.12, 0.1)) -> np.ndarray:
    t = np.arange(T) * dt
    return np.asarray(p0, float) + t[:, None] * np.asarray(v, float)


def observations(df: pd.DataFrame, duration: float) -> Observations:
    return Observations(tables={"bearings": df}, duration=duration)
