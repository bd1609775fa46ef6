"""The trajectory Cramér-Rao bound: O(T) recursions equal a dense inverse of the information."""
from __future__ import annotations

import numpy as np
import pytest

from trackroom.metrics.crb import bearing_jacobians, information_matrix, rmse_over_crb, trajectory_crb
from trackroom.scenes.loader import load_scene


@pytest.fixture(scope="module")
def cams():
    return {c.name: c for c in load_scene("bearing_hall").cameras}


@pytest.mark.parametrize("q", [(1e-3, 1e-1), (2e-10, 2e-6)])  # a loose prior, and the paper's stiff one
def test_bound_equals_dense_inverse(cams, q):
    T, dt = 30, 0.25
    xy = np.c_[np.linspace(2, 8, T), np.linspace(3, 4, T)]
    k = np.r_[np.arange(0, 10), np.arange(20, 30), 25]
    names = ["cam_south"] * 10 + ["cam_north"] * 10 + ["cam_east"]
    fs = (100.0, 10.0, 100.0, 10.0)
    b = trajectory_crb(xy, k, names, cams, 1.5, dt, *q, first_sigma=fs, discretisation="paper")
    A = np.kron(np.eye(2), [[1.0, dt], [0.0, 1.0]])
    Q = np.diag([q[0] * dt, q[1] * dt] * 2)
    J = information_matrix(A, Q, np.diag(np.square(fs)), T, k, bearing_jacobians(cams, names, xy[k]), 1.5).toarray()
    s = 1 / np.sqrt(np.diag(J))  # equilibrate before the dense inverse (the stiff prior)
    D = np.linalg.inv(J * s[:, None] * s[None, :]) * s[:, None] * s[None, :]
    blocks = np.array([D[4 * t : 4 * t + 4, 4 * t : 4 * t + 4] for t in range(T)])
    assert np.allclose(b.cov, blocks, rtol=1e-6, atol=1e-9 * np.abs(blocks).max())
    assert np.isclose(b.crb, np.mean(blocks[:, 0, 0] + blocks[:, 2, 2]), rtol=1e-6)


def test_hand_case_one_step_two_orthogonal_cameras():
    """One step, no dynamics: the bound is the inverse of the two bearing informations."""
    from trackroom.scenes.camera import Camera

    cam_x = Camera("a", "horizontal", np.array([0.0, 0.0, 1.0]), 0.0, 0.0, np.radians(60), 320, 240, 4.0)
    cam_y = Camera("b", "horizontal", np.array([5.0, -5.0, 1.0]), np.pi / 2, 0.0, np.radians(60), 320, 240, 4.0)
    xy = np.array([[5.0, 0.0]])  # 5 m ahead of both
    b = trajectory_crb(xy, [0, 0], ["a", "b"], {"a": cam_x, "b": cam_y}, 1.0, 0.25, 1.0, 1.0, first_sigma=(1e6,) * 4)
    f = cam_x.focal
    # camera a measures y with du/dy = -f / 5 px/m; camera b measures x with du/dx = f / 5
    assert np.isclose(b.cov[0, 0, 0], (5 / f) ** 2, rtol=1e-6)
    assert np.isclose(b.cov[0, 2, 2], (5 / f) ** 2, rtol=1e-6)


def test_more_observations_tighten_the_bound(cams):
    T, dt = 40, 0.25
    xy = np.c_[np.linspace(2, 8, T), np.full(T, 3.0)]
    few = trajectory_crb(xy, [0, 1, 2], ["cam_south"] * 3, cams, 1.0, dt, 1e-4, 1e-2)
    many = trajectory_crb(xy, np.arange(10), ["cam_south"] * 10, cams, 1.0, dt, 1e-4, 1e-2)
    assert many.crb < few.crb
    assert np.isclose(rmse_over_crb(xy + [0.0, many.sqrt_crb], xy, many), 1.0)


def test_truth_linearised_smoother_is_exact_on_a_noiseless_constant_velocity_walk():
    """The oracle of scripts.crb_montecarlo (the yardstick splitting RMSE / sqrt(CRB)): a
    constant-velocity path has zero prior residual, so with noiseless bearings and a first-state
    prior centred on its start it is returned exactly; bearing noise moves it."""
    from trackroom.estimators.qp_model import Bearings, Prior
    from trackroom.scenes.spec import GaussMarkovParams
    from scripts.crb_montecarlo import oracle

    sc = load_scene("bearing_hall")
    cams = {c.name: c for c in sc.cameras}
    T, dt = 80, 0.25
    t = np.arange(T) * dt
    S = np.c_[2.0 + 0.3 * t, np.full(T, 0.3), 2.5 + 0.2 * t, np.full(T, 0.2)]
    k, names = [], []
    for name, cam in cams.items():
        kk = np.nonzero(cam.in_horizontal_fov(S[:, [0, 2]]))[0]
        k += kk.tolist()
        names += [name] * len(kk)
    k, names = np.array(k), np.array(names, object)
    assert len(k) >= 3
    u = np.array([cams[n].bearing_u(S[kk, [0, 2]]) for kk, n in zip(k, names)])
    prior = Prior.build(T, dt, GaussMarkovParams(1e-4, 0.1), first_mean=S[0], first_sigma=(100.0, 10.0, 100.0, 10.0))
    obs = Bearings.from_arrays(k, names, u, cams, 1.0)
    X = oracle(prior, obs, u, S)
    assert np.max(np.abs(X - S.ravel())) < 1e-6
    X2 = oracle(prior, obs, u + np.random.default_rng(0).standard_normal(len(u)), S)
    assert np.max(np.abs(X2 - S.ravel())) > 1e-4
