"""EKF baseline on small synthetic inputs: models, association, initiation, smoothing, errors."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackroom.estimators.base import EstimatorError
from trackroom.estimators.ekf import EKF, BearingModel, cv_model
from trackroom.scenes import load_scene
from trackroom.recording import Calibration, Observations


def overhead_input(paths: dict[str, np.ndarray], sigma=0.05, duration=4.0, seed=0):
    """Floor detections at 20 Hz for straight-line walkers: paths[name] = (x0, y0, vx, vy)."""
    sc = load_scene("overhead_lab")
    rng = np.random.default_rng(seed)
    t = np.arange(0, duration, 0.05)
    rows = []
    for k, tk in enumerate(t):
        for x0, y0, vx, vy in paths.values():
            rows.append((tk, "ceil_sw", x0 + vx * tk + rng.normal(0, sigma), y0 + vy * tk + rng.normal(0, sigma)))
    det = pd.DataFrame(rows, columns=["t", "camera", "x", "y"])
    cal = Calibration({c.name: c for c in sc.cameras}, sc.floorplan, {"floor_sigma_m": sigma})
    return Observations({"floor_detections": det}, duration), cal


def test_cv_model_by_hand():
    F, Q = cv_model(0.5, 2.0)
    np.testing.assert_allclose(F[0], [1, 0, 0.5, 0])
    assert Q[0, 0] == pytest.approx(2.0 * 0.5**3 / 3) and Q[0, 2] == pytest.approx(2.0 * 0.5**2 / 2)
    assert Q[2, 2] == pytest.approx(1.0)
    # predicting in two halves is the same as at once
    F1, Q1 = cv_model(0.25, 2.0)
    np.testing.assert_allclose(F1 @ Q1 @ F1.T + Q1, Q)
    np.testing.assert_allclose(F1 @ F1, F)


@pytest.mark.parametrize("scene", ["bearing_hall", "occlusion_lab"])
def test_bearing_model_and_jacobian(scene):
    cam = load_scene(scene).cameras[0]
    m = BearingModel(cam, 0.9)
    # a point 3 m in front of the camera, 0.5 m to its right
    fwd = np.array([np.cos(cam.yaw), np.sin(cam.yaw)])
    right = np.array([np.sin(cam.yaw), -np.cos(cam.yaw)])
    x = np.r_[np.asarray(cam.position[:2]) + 3 * fwd + 0.5 * right, 0.3, -0.2]
    uv, _ = cam.project(np.r_[x[:2], 0.9])
    assert m.h(x)[0] == pytest.approx(uv[0])
    J = m.jacobian(x)
    eps = 1e-6
    num = [(m.h(x + eps * np.eye(4)[i])[0] - m.h(x - eps * np.eye(4)[i])[0]) / (2 * eps) for i in range(4)]
    np.testing.assert_allclose(J[0], num, rtol=1e-5, atol=1e-6)
    # the ray of that u passes through the point
    p, e = m.ray(m.h(x)[0], np.array([5.0, 5.0]))
    assert m.h(np.r_[p + 1.7 * e, 0, 0])[0] == pytest.approx(m.h(x)[0], abs=1e-6)


@pytest.mark.parametrize("filt", ["ekf", "ukf"])
def test_tracks_two_walkers(filt):
    obs, cal = overhead_input({"a": (1.0, 1.0, 1.0, 0.0), "b": (1.0, 4.0, 0.0, -0.5)})
    tracks = EKF(filter=filt).estimate(obs, cal)
    assert tracks["track_id"].nunique() == 2
    last = tracks[tracks["t"] == tracks["t"].max()].sort_values("y")
    np.testing.assert_allclose(last[["x", "y"]].to_numpy(), [[1.0 + 3.95, 1.0], [1.0, 4.0 - 0.5 * 3.95]], atol=0.08)
    np.testing.assert_allclose(last[["vx", "vy"]].to_numpy(), [[1.0, 0.0], [0.0, -0.5]], atol=0.2)
    # confirmed after confirm_m = 3 hits: the first rows are at the third frame
    assert tracks["t"].min() == pytest.approx(0.10)


def test_smoothing_lowers_the_error_and_reports_the_start():
    obs, cal = overhead_input({"a": (1.0, 1.0, 1.0, 0.5)}, sigma=0.15, seed=1)
    truth = lambda t: np.stack([1.0 + t, 1.0 + 0.5 * t], axis=1)  # noqa: E731
    err = {}
    for smooth in (False, True):
        tr = EKF(smooth=smooth).estimate(obs, cal)
        err[smooth] = np.sqrt(np.mean(np.sum((tr[["x", "y"]].to_numpy() - truth(tr["t"].to_numpy())) ** 2, axis=1)))
        if smooth:
            assert tr["t"].min() == 0.0
    assert err[True] < 0.7 * err[False]


def test_deterministic_and_empty_frames_coast():
    obs, cal = overhead_input({"a": (1.0, 1.0, 0.5, 0.0)})
    det = obs.tables["floor_detections"]
    gap = det[(det["t"] < 1.0) | (det["t"] > 1.5)]  # half a second unseen: the track coasts
    obs2 = Observations({"floor_detections": gap}, obs.duration)
    a = EKF().estimate(obs2, cal)
    b = EKF().estimate(obs2, cal)
    pd.testing.assert_frame_equal(a, b)
    assert a["track_id"].nunique() == 1
    assert np.isclose(a["t"], 1.25).any()  # reported while coasting


def test_labelled_bearings_give_one_track_per_label():
    sc = load_scene("occlusion_lab")
    cams = {c.name: c for c in sc.cameras}
    pos = {"red": np.array([3.0, 3.0]), "blue": np.array([5.0, 2.5])}
    rows = []
    for t in np.arange(0, 3, 0.1):
        for name, c in cams.items():
            for lab, p in pos.items():
                m = BearingModel(c, 0.9)
                if m.covers(p):
                    rows.append((t, name, float(m.h(np.r_[p, 0, 0])[0]), lab))
    obs = Observations({"bearings": pd.DataFrame(rows, columns=["t", "camera", "u", "label"])}, 3.0)
    tr = EKF().estimate(obs, Calibration(cams, sc.floorplan, {"bearing_sigma_px": 1.0}))
    assert tr["track_id"].nunique() == 2
    last = tr[tr["t"] == tr["t"].max()].sort_values("x")
    np.testing.assert_allclose(last[["x", "y"]].to_numpy(), [pos["red"], pos["blue"]], atol=0.05)


def test_bad_config_and_input():
    obs, cal = overhead_input({"a": (1.0, 1.0, 0.5, 0.0)}, duration=1.0)
    for bad in ({"filter": "pf"}, {"accel_psd": 0.0}, {"confirm_m": 6}, {"measurements": "imu"}):
        with pytest.raises(EstimatorError):
            EKF(**bad).estimate(obs, cal)
    with pytest.raises(EstimatorError, match="unknown parameter"):
        EKF(nonsense=1)
    with pytest.raises(EstimatorError, match="no bearings measurements"):
        EKF(measurements="bearings").estimate(obs, cal)
    det = obs.tables["floor_detections"].assign(camera="nowhere")
    with pytest.raises(EstimatorError, match="not in the calibration"):
        EKF().estimate(Observations({"floor_detections": det}, 1.0), cal)
