"""fusion_smoother: the QP smoother with the carrier's phone (issue 13)."""
from __future__ import annotations

import os
import tomllib
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd
import pytest

from trackroom.estimators import get
from trackroom.estimators.phone_motion import PhoneMotion
from trackroom.recording import Observations
from trackroom.scenes.loader import parse_scene, resolve_scene_path
from trackroom.sim.simulate import simulate

# no noise and ideal phones (the phone errors, on by default, switched off)
NOISELESS = {"bearing_sigma_px": 0.0, "accel_sigma": 0.0, "gyro_sigma": 0.0, "mag_sigma": 0.0, "perception": "ideal",
             "mag_disturbance_deg": 0.0, "accel_bias": 0.0, "pocket_yaw_deg": 0.0, "pocket_tilt_deg": 0.0,
             "swing_per_min": 0.0}


def hall_scene(people: list[dict], sensors: dict | None = None, **walkers):
    """bearing_hall with the given walkers (``[[walkers.people]]`` tables) and sensor settings."""
    raw = tomllib.loads(resolve_scene_path("bearing_hall").read_text())
    raw["walkers"] = {"count": len(people), "people": people, **walkers}
    raw["sensors"].update(sensors or {})
    return parse_scene(raw, "test")


def truth_grid(rec, person: str, dt: float) -> pd.DataFrame:
    p = rec.truth.people
    p = p[p.person_id == person]
    k = np.rint(p.t.to_numpy() / dt)
    on = np.abs(p.t.to_numpy() - k * dt) < 1e-6
    return p[on].set_index(k[on].astype(int))


def errors(tracks: pd.DataFrame, truth: pd.DataFrame, dt: float) -> np.ndarray:
    k = np.rint(tracks.t.to_numpy() / dt).astype(int)
    tr = truth.reindex(k)
    return np.hypot(tracks.x.to_numpy() - tr.x.to_numpy(), tracks.y.to_numpy() - tr.y.to_numpy())


def only_camera(obs: Observations, camera: str) -> Observations:
    b = obs["bearings"]
    return Observations({**obs.tables, "bearings": b[b.camera == camera].reset_index(drop=True)}, obs.duration)


def rotate_phone(obs: Observations, offset: float) -> Observations:
    """The phone turned by ``offset`` (rad) about its vertical axis in the pocket: every reading
    in the phone frame rotated by -offset."""
    imu = obs["imu"].copy()
    c, s = np.cos(-offset), np.sin(-offset)
    for x, y in (("ax", "ay"), ("gx", "gy"), ("mx", "my")):
        vx, vy = imu[x].to_numpy(), imu[y].to_numpy()
        imu[x], imu[y] = c * vx - s * vy, s * vx + c * vy
    return Observations({**obs.tables, "imu": imu}, obs.duration)


STRAIGHT = {"name": "walker", "motion": "waypoints", "waypoints": [[0.9, 0.75], [3.6, 6.5]], "speed": [1.0, 1.0],
            "vary": False, "color": "red"}


def perfect_phone(truth: pd.DataFrame, T: int, dt: float, step_length: float) -> PhoneMotion:
    """The cues of a perfect phone: true walking state and direction of travel, and a cadence
    that times ``step_length`` gives the true speed."""
    tr = truth.reindex(np.arange(T))
    speed = np.hypot(tr.vx, tr.vy).to_numpy()
    walking = speed > 0.1
    cadence = np.where(walking, speed / step_length, np.nan)
    heading = np.arctan2(tr.vy, tr.vx).to_numpy()
    return PhoneMotion("phone0", np.arange(T) * dt, walking, heading, cadence, np.diff(heading), np.zeros(0))


def test_one_camera_straight_walk_with_a_perfect_phone(monkeypatch):
    """Rahimi Fig. 1a: one camera and a known speed fix the depth. A straight walk at constant
    velocity (0.85 m/s), noiseless bearings of one camera (it sees the second half), a perfect
    phone (exact walking direction, and a cadence that times the known step length gives the
    speed): the walk is recovered to 5 cm; without the phone it is not."""
    from tests.qp_fixtures import bearings_of, hall_calibration, observations, straight_walk

    cal = hall_calibration()
    dt, T = 0.25, 28
    xy = straight_walk(T, dt, p0=(4.6, 4.6), v=(-0.6, -0.6))
    one = {"cam_south": cal.cameras["cam_south"]}
    from trackroom.recording import Calibration

    cal1 = Calibration(cameras=one, floorplan=cal.floorplan, noise=cal.noise)
    obs = observations(bearings_of(cal1, {"red": xy}, dt), T * dt)
    assert 8 <= len(obs["bearings"]) < T
    v = np.tile([-0.6, -0.6], (T, 1))
    truth = pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "vx": v[:, 0], "vy": v[:, 1]})
    est = get("fusion_smoother")(step_length=0.65, cadence_zero=0.0, step_length_sigma=1e-3)
    monkeypatch.setattr(est, "phone_motions", lambda *a: {"phone0": perfect_phone(truth, T, dt, 0.65)})
    tracks = est.estimate(obs, cal1)
    assert tracks.phone_id.unique().tolist() == ["phone0"]
    e = errors(tracks, truth, dt)
    plain = errors(get("qp_smoother")().estimate(obs, cal1), truth, dt)
    assert np.sqrt(np.mean(e**2)) < 0.05, (np.sqrt(np.mean(e**2)), e.max())
    assert np.sqrt(np.mean(plain**2)) > 1.0  # without the phone one camera cannot fix depth


def test_heading_offset_estimated():
    """A phone turned 40 degrees in the pocket, on a noiseless walk to and fro across the hall
    past two cameras (40 s): the offset is found to 2 degrees (the issue's target; measured 1.1),
    and 40 degrees more than with the phone straight to 0.2 degrees. The phone's heading itself
    is exact here; what error is left is the estimated path's own heading, bent at the walk's
    start and its turns, where the cadence's speed lags the walker's (2.2 degrees before the
    speed rows were widened by the phone's horizontal acceleration)."""
    walk = {**STRAIGHT, "waypoints": [[1.0, 1.0], [9.0, 9.0]], "loop": True, "speed": [1.1, 1.1]}
    rec = simulate(hall_scene([walk], NOISELESS), 0, 40.0)
    found = []
    for offset in (40.0, 0.0):
        # a scripted walk of straight legs at one speed: the stiffer velocity prior of a walker
        # that does not wander (with the default q_vel = 0.5 the path's heading is 3 deg off here)
        est = get("fusion_smoother")(sigma_px=1.0, q_vel=0.05)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            est.estimate(rotate_phone(rec.observations, np.radians(offset)), rec.calibration)
        d = est.diagnostics_["red"]
        assert d["phone_id"] == "phone0"
        found.append(d["heading_offset_deg"])
    assert abs(found[0] - found[1] - 40.0) < 0.2, found
    assert abs(found[0] - 40.0) < 2.0, found
    assert abs(found[1]) < 2.0, found


def bend_heading(obs: Observations, offset_of_t) -> Observations:
    """A heading bias that changes along the path (an indoor magnetic disturbance): the
    magnetometer's horizontal reading rotated by -offset(t) (rad), the other sensors untouched."""
    imu = obs["imu"].copy()
    a = -offset_of_t(imu["t"].to_numpy())
    c, s = np.cos(a), np.sin(a)
    vx, vy = imu["mx"].to_numpy(), imu["my"].to_numpy()
    imu["mx"], imu["my"] = c * vx - s * vy, s * vx + c * vy
    return Observations({**obs.tables, "imu": imu}, obs.duration)


def test_offset_knots_follow_a_heading_bias_that_ramps_along_the_path():
    """A magnetometer bias that ramps from 0 to 15 degrees over a noiseless 40 s walk to and fro
    past two cameras: with the offset as knots 5 s apart (``offset_knot_s``) every knot after
    the first is within 4 degrees of the bias (measured at most 3.5; the first, where the walker
    starts from rest, 7.9) and the path's RMSE is at most 0.6 of the constant offset's (measured
    0.083 m against 0.174 m, whose one offset is 3.8 degrees off at the median)."""
    walk = {**STRAIGHT, "waypoints": [[1.0, 1.0], [9.0, 9.0]], "loop": True, "speed": [1.1, 1.1]}
    rec = simulate(hall_scene([walk], NOISELESS), 0, 40.0)
    ramp = lambda t: np.radians(15.0) * np.clip(t / 40.0, 0.0, 1.0)  # noqa: E731
    obs = bend_heading(rec.observations, ramp)
    dt = 0.25
    truth = truth_grid(rec, "walker", dt)
    rmse = {}
    for knot_s in (0.0, 5.0):
        # the magnetometer heading alone: the gyro-aided one would follow a bias this slow (tau 30 s)
        # only in part (it is what a gyro drift looks like)
        est = get("fusion_smoother")(sigma_px=1.0, q_vel=0.05, offset_knot_s=knot_s, heading_gyro_tau_s=0.0)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            tracks = est.estimate(obs, rec.calibration)
        d = est.diagnostics_["red"]
        assert d["phone_id"] == "phone0"
        rmse[knot_s] = float(np.sqrt(np.mean(errors(tracks, truth, dt) ** 2)))
        knots = np.array(d["heading_offset_knots_deg"])
        if knot_s:
            t_knot = np.arange(len(knots)) * est.knot_steps(dt) * dt + dt / 2
            assert len(knots) == 9
            err = np.abs(knots - np.degrees(ramp(t_knot)))
            assert np.all(err[1:] < 4.0), err
        else:
            assert len(knots) == 1
    assert rmse[5.0] < 0.6 * rmse[0.0], rmse


def test_phoneless_person_falls_back_to_qp_smoother():
    """No IMU at all: exactly qp_smoother's answer with the same prior and settings."""
    scene = hall_scene([{**STRAIGHT, "phone": False, "waypoints": [[1.0, 2.5], [8.5, 8.5]]}])
    rec = simulate(scene, 1, 20.0)
    assert not rec.observations.has("imu")
    fused = get("fusion_smoother")().estimate(rec.observations, rec.calibration)
    plain = get("qp_smoother")(q_pos=1e-4, q_vel=0.5, discretisation="paper").estimate(rec.observations, rec.calibration)
    assert (fused.phone_id == "").all()
    np.testing.assert_allclose(fused[["t", "x", "y", "vx", "vy"]].to_numpy(), plain[["t", "x", "y", "vx", "vy"]].to_numpy(),
                               rtol=0, atol=1e-9)


def test_robust_residual_is_the_loss():
    """0.5 r~^2 = rho(r) for each loss, and the row weight is rho'(r) / r~."""
    from trackroom.estimators.fusion_model import robust_residual

    r = np.array([-50.0, -3.0, -0.5, 0.0, 0.7, 2.5, 400.0])
    c = 2.0
    rt, w = robust_residual(r, c, "huber")
    rho = np.where(np.abs(r) <= c, 0.5 * r**2, c * np.abs(r) - 0.5 * c * c)
    np.testing.assert_allclose(0.5 * rt**2, rho)
    drho = np.clip(r, -c, c)
    nz = rt != 0
    np.testing.assert_allclose(w[nz] * rt[nz], drho[nz])
    rt, w = robust_residual(r, c, "cauchy")
    np.testing.assert_allclose(0.5 * rt**2, 0.5 * c * c * np.log1p((r / c) ** 2))
    np.testing.assert_allclose(w[nz] * rt[nz], r[nz] / (1 + (r[nz] / c) ** 2))
    with pytest.raises(ValueError, match="loss must be one of"):
        robust_residual(r, c, "tukey")


def test_scale_free_rows_keep_a_path_scaled_with_the_step_length():
    """One camera cannot tell a path from the same path scaled about the camera (x -> c + a (x - c),
    v -> a v) with the step length (l -> a l): with ``scale_free`` neither can the prior's
    transition rows nor any phone row, so only the step length's own prior holds the scale; with
    the plain prior the scaled-down path is cheaper (what shrank the one-camera paths)."""
    from trackroom.estimators.fusion_model import IL, PhoneFactors, PhoneFactorSettings, ScaledPrior
    from trackroom.estimators.qp_model import NS, Prior
    from trackroom.scenes.spec import GaussMarkovParams

    rng = np.random.default_rng(3)
    T, dt = 40, 0.25
    prior = Prior.build(T, dt, GaussMarkovParams(1e-4, 0.5), discretisation="paper").with_parameters(
        [0.7, 0.0], [0.1, np.pi], [0.1, 0.1])
    walking = np.ones(T, bool)
    walking[[5, 6, 30]] = False
    kw, ks = np.flatnonzero(walking), np.flatnonzero(~walking)
    f = rng.uniform(1.3, 2.0, len(kw))
    f[[2, 9]] = np.nan  # walking without a cadence
    fac = PhoneFactors(T=T, kw=kw, psi=rng.uniform(-np.pi, np.pi, len(kw)), f=f, ks=ks, kg=np.zeros(0, int),
                       dpsi=np.zeros(0), psi_g=np.zeros(0), l_prior=0.7, s=PhoneFactorSettings(),
                       omega=rng.uniform(0, 1, len(kw)), accel=rng.uniform(0, 0.5, len(kw)))
    X = rng.normal(size=prior.n)
    X[NS * T + IL] = 0.74
    c, a = np.array([5.0, 0.06]), 0.6

    def scaled(X):
        Y = X.copy()
        Y[0:NS * T:NS] = c[0] + a * (X[0:NS * T:NS] - c[0])
        Y[2:NS * T:NS] = c[1] + a * (X[2:NS * T:NS] - c[1])
        Y[1:NS * T:NS], Y[3:NS * T:NS] = a * X[1:NS * T:NS], a * X[3:NS * T:NS]
        Y[NS * T + IL] = a * X[NS * T + IL]
        return Y

    sp_ = ScaledPrior(prior, 0.7)
    np.testing.assert_allclose(sp_.residual(scaled(X))[NS:NS * T], sp_.residual(X)[NS:NS * T], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fac.raw_residual(scaled(X)), fac.raw_residual(X), rtol=1e-9, atol=1e-9)
    plain = prior.residual(scaled(X))[NS:NS * T]
    assert plain @ plain < 0.5 * (prior.residual(X)[NS:NS * T] @ prior.residual(X)[NS:NS * T])
    # the prior's Jacobian, which solve_map re-evaluates at every iterate, is the derivative of its residual
    e = np.zeros(prior.n)
    e[NS * T + IL] = 1e-6
    num = (sp_.residual(X + e) - sp_.residual(X - e)) / 2e-6
    np.testing.assert_allclose(sp_.jacobian(X)[:, NS * T + IL].toarray().ravel(), num, rtol=1e-5, atol=1e-6)


def test_irls_rows_majorise_the_robust_loss():
    """The robust rows Gauss-Newton sees (sqrt(w) r, w = rho'(r) / r at the iterate) give a
    quadratic 0.5 sum w r^2 that touches sum rho(r) at the iterate with the same slope and lies
    above it elsewhere (up to that constant), so a full step descends."""
    from trackroom.estimators.fusion_model import irls_weight, robust_residual

    r0 = np.array([-30.0, -4.0, -1.0, 0.3, 2.5, 12.0])
    c = 2.0
    for loss in ("huber", "cauchy", "geman_mcclure"):
        rho = lambda r: 0.5 * robust_residual(r, c, loss)[0] ** 2  # noqa: E731
        w = irls_weight(r0, c, loss)
        for d in np.linspace(-20, 20, 81):
            r = r0 + d
            assert np.all(rho(r) - rho(r0) <= 0.5 * w * (r**2 - r0**2) + 1e-9), (loss, d)
        h = 1e-6
        np.testing.assert_allclose((rho(r0 + h) - rho(r0 - h)) / (2 * h), w * r0, rtol=1e-5, atol=1e-8)


def _central_differences(residual, X: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """The Jacobian of ``residual`` at X by central differences (step h), column by column."""
    cols = []
    for i in range(len(X)):
        e = np.zeros(len(X))
        e[i] = h
        cols.append((residual(X + e) - residual(X - e)) / (2 * h))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("bounded", [False, True])
def test_offset_knot_rows_jacobian_and_weights(bounded):
    """The phone rows with the heading offset as knots: step k's offset is (1 - w) delta_j +
    w delta_{j+1} (by hand: knots 4 steps apart, step 6 between knots 1 and 2 at w = 0.5), the
    Jacobian is the residual's derivative (central differences, every column), and with every
    knot equal the rows are those of the constant offset."""
    from trackroom.estimators.fusion_model import (ID, IL, PhoneFactors, PhoneFactorSettings, knot_weights, n_knots,
                                                   offset_knot_prior)
    from trackroom.estimators.qp_model import NS

    assert n_knots(13, 4) == 4 and n_knots(14, 4) == 5 and n_knots(14, 0) == 1
    j, w = knot_weights(np.array([0, 3, 6, 12]), 13, 4)
    np.testing.assert_array_equal(j, [0, 0, 1, 2])
    np.testing.assert_allclose(w, [0.0, 0.75, 0.5, 1.0])
    # 1 m per step: 4 m between knots 0-1 and 1-2, 4 m between 2-3
    np.testing.assert_allclose(offset_knot_prior(np.ones(13), 4, 13, 0.1, 0.25), [0.2, 0.2, 0.2])
    rng = np.random.default_rng(5)
    T = 30
    walking = np.ones(T, bool)
    walking[[5, 6]] = False
    kw, ks = np.flatnonzero(walking), np.flatnonzero(~walking)
    f = rng.uniform(1.3, 2.0, len(kw))
    f[3] = np.nan
    kwargs = dict(T=T, kw=kw, psi=rng.uniform(-np.pi, np.pi, len(kw)), f=f, ks=ks, kg=np.zeros(0, int),
                  dpsi=np.zeros(0), psi_g=np.zeros(0), l_prior=0.7, s=PhoneFactorSettings(),
                  omega=rng.uniform(0, 1, len(kw)), accel=rng.uniform(0, 0.5, len(kw)))
    fac = PhoneFactors(**kwargs, knot_steps=8, bounded=bounded)
    assert fac.n_knots == 5 and fac.n_par == 6 + bounded
    n = NS * T + fac.n_par
    X = rng.normal(size=n)
    X[NS * T + IL] = 0.74
    np.testing.assert_allclose(fac.raw_jacobian(X, n).toarray(), _central_differences(fac.raw_residual, X), rtol=1e-5,
                               atol=1e-6)
    const = PhoneFactors(**kwargs)
    Xc = X[:NS * T + 2].copy()
    Y = X.copy()
    if bounded:
        Y[NS * T + ID + 1:] = 0.0  # no deviation from delta_c
    else:
        Y[NS * T + ID:] = Xc[NS * T + ID]
    np.testing.assert_allclose(fac.raw_residual(Y), const.raw_residual(Xc), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("bounded", [False, True])
def test_gyro_rows_read_the_turn_not_the_change_of_speed(bounded):
    """The gyro rows (``gyro=true``): a walker who speeds up from 0.4 to 1.2 m/s while turning at
    a known rate, carrying a phone turned 30 degrees in the pocket. At the true path, step length
    and offset every row is 0 (with the phone's own heading as the normal, as before, they read
    sin(30 deg) of each change of speed: here 0.5 x 0.1 m/s per frame over a sigma of 0.042 m/s,
    1.2 sigma per row), unchanged when the path is scaled about a point with the step length
    (scale-free, like every other phone row), and the Jacobian is the residual's derivative."""
    from trackroom.estimators.fusion_model import ID, IL, PhoneFactors, PhoneFactorSettings
    from trackroom.estimators.qp_model import NS

    T, dt, delta = 9, 0.25, np.radians(30.0)
    speed = np.linspace(0.4, 1.2, T)
    heading = 0.3 + 0.2 * np.arange(T)  # walking direction, turning at 0.8 rad/s
    kw = np.arange(T)
    kg = np.arange(T - 1)
    psi = heading + delta  # the phone's yaw
    fac = PhoneFactors(T=T, kw=kw, psi=psi, f=np.full(T, np.nan), ks=np.zeros(0, int), kg=kg,
                       dpsi=np.diff(heading), psi_g=psi[kg + 1], l_prior=0.7, s=PhoneFactorSettings(gyro=True),
                       knot_steps=4 if bounded else 0, bounded=bounded)
    n = NS * T + fac.n_par
    X = np.zeros(n)
    X[1:NS * T:NS], X[3:NS * T:NS] = speed * np.cos(heading), speed * np.sin(heading)
    X[0:NS * T:NS] = np.concatenate([[0.0], np.cumsum(dt * X[1:NS * T:NS])[:-1]])
    X[2:NS * T:NS] = np.concatenate([[0.0], np.cumsum(dt * X[3:NS * T:NS])[:-1]])
    X[NS * T + IL] = 0.7
    if bounded:
        X[NS * T + ID] = delta  # delta_c, every deviation 0
    else:
        X[NS * T + ID:] = delta
    gyro = fac.raw_residual(X)[-len(kg):]
    np.testing.assert_allclose(gyro, 0.0, atol=1e-12)
    # scaled about (2, -1) with the step length: the same rows (at a perturbed point, where they are not 0)
    a, c0 = 0.6, np.array([2.0, -1.0])

    def scaled(X):
        Y = X.copy()
        Y[0:NS * T:NS], Y[2:NS * T:NS] = c0[0] + a * (X[0:NS * T:NS] - c0[0]), c0[1] + a * (X[2:NS * T:NS] - c0[1])
        Y[1:NS * T:NS], Y[3:NS * T:NS], Y[NS * T + IL] = a * X[1:NS * T:NS], a * X[3:NS * T:NS], a * X[NS * T + IL]
        return Y

    Z = X + np.random.default_rng(2).normal(0, 0.05, n)
    np.testing.assert_allclose(fac.raw_residual(scaled(Z))[-len(kg):], fac.raw_residual(Z)[-len(kg):], rtol=1e-9,
                               atol=1e-9)
    assert np.abs(fac.raw_residual(Z)[-len(kg):]).max() > 0.1
    np.testing.assert_allclose(fac.raw_jacobian(Z, n).toarray(), _central_differences(fac.raw_residual, Z), rtol=1e-5,
                               atol=1e-6)
    # the old row: across the phone's own heading, a change of speed read as a turn
    n_phone = np.stack([-np.sin(psi[kg + 1]), np.cos(psi[kg + 1])], axis=1)
    v = np.stack([X[1:NS * T:NS], X[3:NS * T:NS]], axis=1)
    c, s = np.cos(np.diff(heading)), np.sin(np.diff(heading))
    rv0 = np.stack([c * v[:-1, 0] - s * v[:-1, 1], s * v[:-1, 0] + c * v[:-1, 1]], axis=1)
    old = np.einsum("ij,ij->i", n_phone, v[1:] - rv0) / fac.sig_g
    np.testing.assert_allclose(np.abs(old), 0.5 * 0.1 / fac.sig_g, rtol=1e-9)


def test_speed_rows_widen_by_the_cadence_standard_error():
    """sigma_a^2 gains (l_prior f_0 / (f_0 - f_1) sigma_f)^2: with l_prior 0.7 m, f_0 1.8 Hz, f_1
    1.0 Hz and sigma_f 0.1 Hz, 0.1575^2 (m/s)^2 (by hand); no standard error (None or NaN) adds
    nothing."""
    from trackroom.estimators.fusion_model import PhoneFactors, PhoneFactorSettings

    kw = np.arange(4)
    base = dict(T=5, kw=kw, psi=np.zeros(4), f=np.array([1.5, 1.8, np.nan, 2.0]), ks=np.zeros(0, int),
                kg=np.zeros(0, int), dpsi=np.zeros(0), psi_g=np.zeros(0), l_prior=0.7, s=PhoneFactorSettings())
    plain = PhoneFactors(**base)
    wide = PhoneFactors(**base, f_se=np.array([0.1, np.nan, 0.2, 0.0]))
    np.testing.assert_allclose(wide.sig_a**2 - plain.sig_a**2, [0.1575**2, 0.0, 0.315**2, 0.0], rtol=1e-12, atol=1e-15)
