"""Fixed-lag RTS smoothing of the target-plane output (``smooth_output``, ``estimators/tp_smooth``)."""
import numpy as np
from filterpy.kalman import rts_smoother

from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_smooth import fixed_lag_smooth, smooth_chains
from trackroom.recording import Observations

from tests.test_target_planes import calib, four_cameras, line_path, synth_boxes


def cv_filter(n: int, seed: int = 0, dt: float = 0.1, q: float = 0.5, r: float = 0.05):
    """A constant-velocity walker in 2-D with noisy positions, Kalman-filtered: the filtered
    means and covariances, the priors, the transitions and process noises, and the truth."""
    rng = np.random.default_rng(seed)
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    Q = np.kron(q**2 * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), np.eye(2))
    H = np.eye(2, 4)
    R = r**2 * np.eye(2)
    x = np.array([1.0, 2.0, 0.8, -0.3])
    s, S = np.r_[x[:2] + rng.normal(0, r, 2), 0.0, 0.0], np.diag([r**2, r**2, 1.0, 1.0])
    truth, xs, Ss, pri, Pri = [], [], [], [], []
    for k in range(n):
        if k:
            x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
            s, S = F @ s, F @ S @ F.T + Q
        pri.append(s.copy())
        Pri.append(S.copy())
        if k:
            z = H @ x + rng.normal(0, r, 2)
            K = S @ H.T @ np.linalg.inv(H @ S @ H.T + R)
            s, S = s + K @ (z - H @ s), (np.eye(4) - K @ H) @ S
        truth.append(x.copy())
        xs.append(s.copy())
        Ss.append(S.copy())
    Fs = np.array([F] * n)
    return np.array(xs), np.array(Ss), np.array(pri), np.array(Pri), Fs, np.array([Q] * n), np.array(truth)


def fixed_lag_means(s, S, pri, Pri, Fs, lag):
    return fixed_lag_smooth(s, S, pri, Pri, Fs, lag)[0]


def test_the_whole_lag_is_filterpys_rts_smoother():
    s, S, pri, Pri, Fs, Qs, _ = cv_filter(60)
    ref, Pref, _, _ = rts_smoother(s, S, Fs, Qs)
    for lag in (59, 1000):
        m, P = fixed_lag_smooth(s, S, pri, Pri, Fs, lag)
        np.testing.assert_allclose(m, ref, atol=1e-10)
        np.testing.assert_allclose(P, Pref, atol=1e-12)


def test_a_fixed_lag_uses_the_frames_up_to_the_lag_and_no_further():
    """Frame k's mean is the RTS smoother's over frames 0 .. k + lag (the rest not read)."""
    s, S, pri, Pri, Fs, Qs, _ = cv_filter(40, seed=3)
    lag = 7
    got, cov = fixed_lag_smooth(s, S, pri, Pri, Fs, lag)
    for k in range(40):
        end = min(k + lag, 39) + 1
        ref, Pref, _, _ = rts_smoother(s[:end], S[:end], Fs[:end], Qs[:end])
        np.testing.assert_allclose(got[k], ref[k], atol=1e-10)
        np.testing.assert_allclose(cov[k], Pref[k], atol=1e-12)
    # smoothing only narrows: each frame's smoothed covariance is at most its filtered one
    assert all(np.linalg.eigvalsh(S[k] - cov[k]).min() > -1e-12 for k in range(40))
    np.testing.assert_array_equal(fixed_lag_means(s, S, pri, Pri, Fs, 0), s)


def test_smoothing_brings_the_walker_closer():
    errs = []
    for seed in range(5):
        s, S, pri, Pri, Fs, _, truth = cv_filter(80, seed=seed)
        sm = fixed_lag_means(s, S, pri, Pri, Fs, lag=10)
        errs.append((np.linalg.norm(s[:, :2] - truth[:, :2], axis=1).mean(),
                     np.linalg.norm(sm[:, :2] - truth[:, :2], axis=1).mean()))
    filt, smooth = np.array(errs).T
    assert (smooth < filt).all()
    assert smooth.mean() < 0.8 * filt.mean()


def test_a_chain_is_cut_where_the_state_changed_outside_the_prediction():
    """Two tracks interleaved: track 1 is moved after its fourth frame's updates, so its frames
    are smoothed in two pieces; a capped prior cuts too (track 2's last frame). A track's first
    frame, without a prior, starts its chain."""
    s, S, pri, Pri, Fs, _, _ = cv_filter(6, seed=1)
    recs = []
    for k in range(6):
        recs.append((1, s[k], S[k], (pri[k], Pri[k]) if k else None, Fs[k], k == 3))
        recs.append((2, s[k], S[k], (pri[k], Pri[k]) if k else None, Fs[k], k == 5))
    out = smooth_chains(recs, lag=10)
    first, second = fixed_lag_smooth(s[:3], S[:3], pri[:3], Pri[:3], Fs[:3], 10), fixed_lag_smooth(s[3:], S[3:], pri[3:], Pri[3:], Fs[3:], 10)
    np.testing.assert_allclose(np.array([m for m, _ in out[0::2]]), np.r_[first[0], second[0]])
    np.testing.assert_allclose(np.array([P for _, P in out[0::2]]), np.r_[first[1], second[1]])
    alone = fixed_lag_smooth(s[:5], S[:5], pri[:5], Pri[:5], Fs[:5], 10)
    np.testing.assert_allclose(np.array([m for m, _ in out[1::2]]), np.r_[alone[0], s[5:]])
    np.testing.assert_allclose(np.array([P for _, P in out[1::2]]), np.r_[alone[1], S[5:]])
    assert smooth_chains([None, recs[0]], 3)[0] is None


def _noisy_walker(duration: float):
    cams = four_cameras()
    times = np.round(np.arange(0, 8.0, 0.1), 6)
    path = line_path([1.5, 3.0], [6.5, 4.0], times)
    boxes = synth_boxes(cams, {"target": path}, times, sigma=2.0, seed=4)
    boxes = boxes[boxes["t"] <= duration + 1e-9].reset_index(drop=True)
    return Observations({"boxes": boxes}, duration=duration), calib(cams), times, path


def test_the_smoothed_output_is_closer_and_final_the_output_lag_after_each_frame():
    obs, cal, times, path = _noisy_walker(8.0)
    res_off = TargetPlanes(initial_xy=[1.5, 3.0], smooth_output=False).run(obs, cal)
    res_on = TargetPlanes(initial_xy=[1.5, 3.0], smooth_output=True).run(obs, cal)
    off, on = res_off.tracks, res_on.tracks
    # the internal rows' covariances are the smoothed estimate's: narrower, the last frame's the filter's
    cov = {k: r.internal[r.internal["track_id"] == 0][["cxx", "cyy"]].to_numpy() for k, r in (("off", res_off), ("on", res_on))}
    assert (cov["on"] <= cov["off"] + 1e-12).all() and cov["on"].sum() < 0.8 * cov["off"].sum()
    np.testing.assert_allclose(cov["on"][-1], cov["off"][-1])
    assert len(on) == len(off) == len(times)
    np.testing.assert_array_equal(on[["t", "track_id", "n_cameras"]], off[["t", "track_id", "n_cameras"]])
    err = {k: np.hypot(tr.x - path[:, 0], tr.y - path[:, 1]) for k, tr in (("off", off), ("on", on))}
    assert np.sqrt(np.mean(err["on"] ** 2)) < 0.85 * np.sqrt(np.mean(err["off"] ** 2))
    # the frames output_lag_s (3.5 s) before the recording's end do not change when it goes on
    obs5, cal5, _, _ = _noisy_walker(5.0)
    short = TargetPlanes(initial_xy=[1.5, 3.0], smooth_output=True).run(obs5, cal5).tracks
    early = short["t"] <= 5.0 - 3.5 + 1e-9
    np.testing.assert_allclose(short.loc[early, ["x", "y", "vx", "vy"]], on.loc[early.to_numpy().nonzero()[0], ["x", "y", "vx", "vy"]], atol=1e-12)
    assert not np.allclose(short[["x", "y"]].iloc[-1], on[["x", "y"]].iloc[len(short) - 1])
