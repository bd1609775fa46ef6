"""QP smoother (Rahimi et al.): recovery, constraints, walls, statuses, bad input."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackroom.estimators import get
from trackroom.estimators.base import EstimatorError
from trackroom.estimators.qp_model import Bearings, Prior, process_covariance
from trackroom.estimators.qp_smoother import QPSmoother
from trackroom.scenes.spec import GaussMarkovParams

from .qp_fixtures import bearings_of, hall_calibration, observations, straight_walk


@pytest.fixture(scope="module")
def cal():
    return hall_calibration()


def rmse(tracks, xy):
    e = np.c_[tracks.x.to_numpy(), tracks.y.to_numpy()] - xy
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))


def test_registered():
    assert get("qp_smoother") is QPSmoother


def test_noiseless_two_camera_straight_walk_to_1cm(cal):
    xy = straight_walk()
    df = bearings_of(cal, {"red": xy}, 0.25, sigma_px=0.0)
    assert df.camera.nunique() == 2
    tracks = QPSmoother().estimate(observations(df, 60.0), cal)
    assert len(tracks) == len(xy) and np.allclose(tracks.t, np.arange(len(xy)) * 0.25)
    err = np.hypot(tracks.x - xy[:, 0], tracks.y - xy[:, 1])
    assert err.max() < 0.01
    d = tracks.attrs["qp_smoother"]["red"]
    assert d["converged"] and d["qp_not_solved"] == 0 and d["violation_m"] < 1e-6


def test_prior_factor_matches_gauss_markov_density():
    """G^T G is the inverse covariance of the chain (eq. 2): check 0.5 |G X - g|^2 against a dense log-density."""
    T, dt, pm = 5, 0.25, GaussMarkovParams(1e-3, 1e-1)
    pr = Prior.build(T, dt, pm, first_mean=(1, 0, 2, 0), first_sigma=(3, 1, 3, 1))
    rng = np.random.default_rng(1)
    X = rng.normal(size=4 * T)
    A, Q = pm.A(dt), process_covariance(pm, dt, "exact")
    assert np.allclose(process_covariance(pm, dt, "paper"), pm.Sigma(dt))
    s = X.reshape(T, 4)
    e0 = s[0] - np.array([1, 0, 2, 0])
    q = e0 @ np.diag(1 / np.array([9, 1, 9, 1.0])) @ e0
    for k in range(1, T):
        d = s[k] - A @ s[k - 1]
        q += d @ np.linalg.solve(Q, d)
    r = pr.residual(X)
    assert np.isclose(r @ r, q, rtol=1e-10)


def test_bearing_jacobian_matches_finite_differences(cal):
    xy = np.array([[4.0, 3.0], [3.0, 6.0]])
    obs = Bearings.from_arrays([0, 1], ["cam_south", "cam_west"], [100.0, 200.0], cal.cameras, 2.0)
    X = np.zeros(8)
    X[[0, 2, 4, 6]] = xy.ravel()
    J = obs.jacobian(X, 8).toarray()
    h = 1e-6
    for i in range(8):
        dX = np.zeros(8)
        dX[i] = h
        fd = (obs.residual(X + dX) - obs.residual(X - dX)) / (2 * h)
        assert np.allclose(J[:, i], fd, atol=1e-5)
    # for a horizontal camera the P-based bearing is eq. 4 (Camera.bearing_u)
    assert np.allclose(obs.predict(X), [cal.cameras["cam_south"].bearing_u(xy[0]), cal.cameras["cam_west"].bearing_u(xy[1])])


def test_noisy_walk_within_10cm_and_constraints_hold(cal):
    xy = straight_walk()
    df = bearings_of(cal, {"red": xy}, 0.25, sigma_px=1.0, seed=3)
    est = QPSmoother()
    tracks = est.estimate(observations(df, 60.0), cal)
    assert rmse(tracks, xy) <= 0.10
    # every observed point in front of its camera by the margin (eq. 9)
    k = np.rint(df.t / 0.25).astype(int).to_numpy()
    for name in df.camera.unique():
        cam = cal.cameras[name]
        m = (df.camera == name).to_numpy()
        p = np.c_[tracks.x.to_numpy()[k[m]], tracks.y.to_numpy()[k[m]]] - cam.position[:2]
        assert np.all(p @ [np.cos(cam.yaw), np.sin(cam.yaw)] >= 0.2 - 1e-6)


def test_walls_keep_every_point_inside_the_room(cal):
    """One camera only: depth is poorly fixed and the unconstrained estimate may leave the room."""
    xy = straight_walk(T=120)
    df = bearings_of(cal, {"red": xy}, 0.25, sigma_px=1.0, seed=4)
    df = df[df.camera == "cam_south"].reset_index(drop=True)
    tracks = QPSmoother(walls=True, max_iter=30).estimate(observations(df, 30.0), cal)
    inside = cal.floorplan.inside(np.c_[tracks.x, tracks.y])
    assert inside.all()
    assert tracks.x.between(0.05, 9.95).all() and tracks.y.between(0.05, 9.95).all()


def test_empty_bearings_give_empty_tracks(cal):
    df = pd.DataFrame({"t": pd.Series(dtype=float), "camera": pd.Series(dtype=object), "u": pd.Series(dtype=float), "label": pd.Series(dtype=object)})
    tracks = QPSmoother().estimate(observations(df, 10.0), cal)
    assert len(tracks) == 0 and {"t", "track_id", "x", "y"} <= set(tracks.columns)


def test_camera_that_sees_nobody_is_harmless(cal):
    """Only one camera reports, the others never see anyone: a track, no crash, statuses reported."""
    xy = straight_walk(T=80)
    df = bearings_of(cal, {"red": xy}, 0.25, sigma_px=1.0)
    df = df[df.camera == "cam_south"].reset_index(drop=True)
    tracks = QPSmoother().estimate(observations(df, 20.0), cal)
    assert len(tracks) == 80 and np.isfinite(tracks[["x", "y"]].to_numpy()).all()
    assert "converged" in tracks.attrs["qp_smoother"]["red"]


def test_unknown_camera_is_a_clear_error(cal):
    df = pd.DataFrame({"t": [0.0], "camera": ["cam_nowhere"], "u": [100.0], "label": ["red"]})
    with pytest.raises(EstimatorError, match="cam_nowhere"):
        QPSmoother().estimate(observations(df, 1.0), cal)


def test_off_grid_times_and_bad_params_are_errors(cal):
    df = pd.DataFrame({"t": [0.1], "camera": ["cam_south"], "u": [100.0], "label": ["red"]})
    with pytest.raises(EstimatorError, match="frame grid"):
        QPSmoother().estimate(observations(df, 1.0), cal)
    with pytest.raises(EstimatorError, match="init"):
        QPSmoother(init="bogus").estimate(observations(df, 1.0), cal)


def test_two_labels_are_two_tracks_and_online_runs(cal):
    a = straight_walk(T=120)
    b = straight_walk(T=120, p0=(8.5, 8.0), v=(-0.1, -0.11))
    df = bearings_of(cal, {"red": a, "blue": b}, 0.25, sigma_px=0.5, seed=2)
    tracks = QPSmoother(window_s=15.0, lag_s=5.0, hop_s=2.5).estimate(observations(df, 30.0), cal)
    assert set(tracks.track_id) == {"red", "blue"}
    assert (tracks.groupby("track_id").size() == 120).all()
    assert tracks.attrs["qp_smoother"]["red"]["windows"] > 1


def test_ray_limit_stops_an_observed_point_at_the_first_wall():
    """cam1 (office_floor, at (5, 0.06) looking +y) sees a person straight ahead: the person lies
    on x = 5 between the camera and the corridor wall at y = 4 (thickness 0.1, margin 0.1), so
    the row is -y >= -(4 - 0.05 - 0.1) by hand."""
    from trackroom.estimators.qp_walls import ray_limits

    cal = hall_calibration("office_floor")
    cam = cal.cameras["cam1"]
    obs = Bearings.from_arrays([0], ["cam1"], [cam.bearing_u(np.array([[5.0, 2.0]]))[0]], cal.cameras, 1.0)
    C, lower, rays = ray_limits(obs, cal.floorplan, 1, margin=0.1, fov_margin=0.2)
    row = C.toarray()[0]
    assert np.allclose(row[[0, 2]], [0.0, -1.0], atol=1e-9)
    assert np.isclose(lower[0], -(4.0 - 0.05 - 0.1), atol=1e-6)
    # a point pushed beyond the wall is pulled back onto the visible segment for the wall rule
    ref = rays.reference(np.array([[5.0, 7.0]]))
    assert np.allclose(ref, [[5.0, 3.85]], atol=1e-6)


def test_office_walls_keep_observed_points_in_their_camera_room():
    """With walls, every point cam1 observed stays in room A (south of the corridor, west of x = 10)."""
    cal = hall_calibration("office_floor")
    t = np.arange(80) * 0.25
    xy = np.c_[4.0 + 0.1 * t, 2.5 + 0.025 * t]
    df = bearings_of(cal, {"red": xy}, 0.25, sigma_px=1.0, seed=5)
    df = df[df.camera == "cam1"].reset_index(drop=True)
    assert len(df) > 10
    tracks = QPSmoother(walls=True, q_pos=1e-4, q_vel=0.1).estimate(observations(df, 20.0), cal)
    k = np.unique(np.rint(df.t / 0.25).astype(int))
    est = np.c_[tracks.x.to_numpy()[k], tracks.y.to_numpy()[k]]
    assert np.all(est[:, 1] <= 4.0 - 0.05 - 0.1 + 1e-6) and np.all(est[:, 0] <= 10.0 - 0.05 + 1e-6)
    assert tracks.attrs["qp_smoother"]["red"]["violation_m"] < 1e-6


def test_bearing_corridor_alone_within_30cm_on_development_seeds():
    """Rahimi Fig. 1(b) (issue 13): on bearing_corridor (a nearly constant-speed walker past three
    non-overlapping cameras) the QP smoother with its defaults and nothing but bearings is within
    0.3 m RMSE over every frame: median over development seeds 100-102 (measured 0.23, 0.32,
    0.19 m; the evaluation seeds, docs/qp_smoother.md, are never used here). The camera that saw
    the walker most, alone, cannot fix the depth (Fig. 1a): metres off on the same runs."""
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate
    from trackroom.recording import Observations

    scene = load_scene("bearing_corridor")
    all_cams, one_cam = [], []
    for seed in (100, 101, 102):
        rec = simulate(scene, seed, 20.0)
        w = rec.meta["walkers"][0]
        p = rec.truth.people
        p = p[(p.person_id == w["name"]) & (np.abs(p.t * 4 - np.rint(p.t * 4)) < 1e-6)]
        xy = p[["x", "y"]].to_numpy()[:80]
        b = rec.observations["bearings"]
        assert b[b.label == w["color"]].camera.nunique() >= 2
        tr = QPSmoother().estimate(rec.observations, rec.calibration)
        all_cams.append(rmse(tr[tr.track_id == w["color"]], xy))
        most = b[b.label == w["color"]].camera.value_counts().idxmax()
        obs1 = Observations({**rec.observations.tables, "bearings": b[b.camera == most].reset_index(drop=True)}, 20.0)
        tr1 = QPSmoother().estimate(obs1, rec.calibration)
        one_cam.append(rmse(tr1[tr1.track_id == w["color"]], xy))
    assert np.median(all_cams) <= 0.3, all_cams
    assert min(one_cam) > 2.0, one_cam


def test_bordered_lu_equals_a_plain_lu_and_is_only_used_for_dense_columns():
    """``sparse_lu``: a banded KKT-like matrix with two dense rows and columns (the fusion smoother's
    step length and pocket offset) is solved through its border to the same answer as one sparse
    LU; a matrix without dense columns gets the plain LU (qp_smoother's factorisation unchanged)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from trackroom.estimators.qp_solver import BorderedLU, sparse_lu

    g = np.random.default_rng(3)
    n = 600
    band = sp.diags([g.normal(size=n - 2), g.normal(size=n - 1), 4.0 + g.random(n), g.normal(size=n - 1), g.normal(size=n - 2)],
                    [-2, -1, 0, 1, 2]).tolil()
    for d in (200, 201):  # two dense rows and columns in the middle, as the parameters sit
        band[:, d] = g.normal(size=(n, 1))
        band[d, :] = g.normal(size=(1, n))
        band[d, d] = 50.0
    K = band.tocsc()
    rhs = g.normal(size=(n, 3))
    lu = sparse_lu(K)
    assert isinstance(lu, BorderedLU) and sorted(lu.d.tolist()) == [200, 201]
    np.testing.assert_allclose(lu.solve(rhs), spla.splu(K).solve(rhs), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(lu.solve(rhs[:, 0]), spla.splu(K).solve(rhs[:, 0]), rtol=1e-9, atol=1e-9)
    plain = sparse_lu(sp.diags([np.ones(n - 1), 4.0 * np.ones(n), np.ones(n - 1)], [-1, 0, 1]).tocsc())
    assert not isinstance(plain, BorderedLU)
    # more columns pass the test than the border holds (the heading offset's knots, each filling a
    # stretch of rows): the DENSE_MAX fullest go to the border, the answer is the same
    many = band.copy()
    for d in range(20, 600, 50):
        lo = max(0, d - 125)
        many[lo:lo + 250, d] = g.normal(size=(min(250, n - lo), 1))
        many[d, lo:lo + 250] = g.normal(size=(1, min(250, n - lo)))
        many[d, d] = 50.0
    K = many.tocsc()
    lu = sparse_lu(K)
    assert isinstance(lu, BorderedLU) and {200, 201} <= set(lu.d.tolist()) and len(lu.d) == 8
    np.testing.assert_allclose(lu.solve(rhs), spla.splu(K).solve(rhs), rtol=1e-8, atol=1e-9)
