"""What a phone in a pocket says about its carrier's motion, on a camera frame grid.

From the phone's 100 Hz accelerometer f (specific force, m/s^2), gyro w (rad/s) and magnetometer
m (phone frame), for every grid time t_k:

- **Walking / stopped** (``gait.bobbing_feature`` and the fitted ``GaitModel``, as the HMM
  matcher uses them): g_k = std of the vertical specific force over a window; walking where
  p(g | walking) > p(g | stopped).
- **Gravity** (the phone's "up" in its own frame): u = mean(f) / |mean(f)| over a centred window
  of ``gravity_window_s`` (walking accelerations average out; the pocket tilt does not).
- **Heading, tilt-compensated** (``gait.tilt_compensated_yaw``): the field's horizontal part
  m_h = m - (m . u) u and the phone's x axis projected on the horizontal plane, x_h = e_x - u_x u;
  the angle from x_h to m_h about u, theta = atan2(u . (x_h x m_h), x_h . m_h), gives the phone's
  yaw in the world as psi = atan2(H_y, H_x) - theta (H the world field).
- **Gyro-aided heading** (``gyro_heading_tau_s`` > 0, the default): the indoor magnetic
  disturbance bends psi by up to ten degrees near walls, smoothly along the path, which the
  smoother's heading rows cannot tell from the walking direction; the gyro does not see it. The
  heading is the gyro's integrated yaw with its constant and slow drift taken from the
  magnetometer (``gyro_aided_heading``, a complementary filter of time constant
  ``gyro_heading_tau_s``). Either heading is averaged on the unit circle over a centred window of
  ``heading_window_s``. The walking direction is psi - delta, with delta the phone's yaw offset
  in the pocket (estimated by the smoother, not here).
- **Steps and cadence**: the vertical specific force a_v = f . u is band-passed
  (``scipy.signal`` Butterworth, zero phase, ``band_hz``); one gait bob per step, so the phase
  phi(t) of its analytic signal (``scipy.signal.hilbert``) advances 2 pi per step: the steps are
  where phi crosses a multiple of 2 pi, and the cadence is the step phase's rate,
  f = (dphi/dt) / 2 pi, averaged over ``cadence_window_s`` (Hz). It follows the cadence through
  starts and stops, where intervals between peaks lag by a step. Where the bob's envelope is
  below ``step_min_accel`` (slow shuffling, standing) there is no cadence. Its standard error is
  the scatter (std) of the instantaneous rate dphi/dt / 2 pi over the same window divided by the
  root of the independent samples in it, 2 f_hi W (f_hi the band's upper edge): a strong, clean
  bob has a steady phase rate, a weak one (slow walking, where the bob fades) a ragged one. On
  development seeds 100-119 (Gauss-Markov walker) the cadence's error against the simulator's
  step rate had an rms of 0.015 Hz where that scatter was below 0.02 Hz, 0.08 Hz at 0.05-0.1,
  0.19 Hz at 0.2-0.5 and 0.27 Hz above 0.5 (bobs weaker than 0.75 m/s^2: slow walking at
  0.3-0.4 m/s). A step the detector
  gets wrong gives one bad cadence (the smoother's robust loss absorbs it).
- **Horizontal acceleration**: |mean of f - (f . u) u| over ``cadence_window_s`` (m/s^2): how
  fast the carrier speeds up or slows down (and turns). A cadence averaged over half a second
  lags such changes, and the first and last steps of a walk are short, so the smoother widens
  the speed rows' noise by it (``fusion_model.PhoneFactors``).
- **Yaw rate**: the gyro about the phone's up, w . u_g (rad/s; tilt-compensated: the pocket tilt
  and a swing turn the phone's z axis off the vertical), integrated between grid times (the
  change of heading from one frame to the next, free of the magnetometer's disturbances and
  offset). u_g is the mean specific force over ``gyro_gravity_window_s`` (10 s), not the 2 s of
  the magnetometer's tilt compensation: in a turn the centripetal acceleration (v omega, 2 m/s^2
  at 1 m/s and 2 rad/s) leans a 2-s mean into the turn by up to 10 degrees, and w . u then
  under-reads every turn by 1 - cos of that lean (on development seeds 100-101, default walker,
  the 2-s up vector put the integrated yaw 2-5 degrees off the 60-s one by the end of a minute;
  the 10-s one 0.4-0.5).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import ndimage, signal

from .gait import GRAVITY_WINDOW_S, GaitModel, bobbing_feature, tilt_compensated_yaw


@dataclass(frozen=True)
class MotionSettings:
    """Feature windows and step-detector thresholds (see the module docstring)."""

    gravity_window_s: float = GRAVITY_WINDOW_S
    heading_window_s: float = 0.5
    band_hz: tuple[float, float] = (0.6, 4.0)
    cadence_window_s: float = 0.5
    step_min_accel: float = 0.5  # m/s^2, bob envelope below which no cadence is given
    gyro_gravity_window_s: float = 10.0  # s, centred window of the up vector the gyro is projected on (module docstring)
    gyro_heading_tau_s: float = 30.0  # s, time constant of the gyro-aided heading (``gyro_aided_heading``); 0: magnetometer only
    min_cadence_hz: float = 0.8  # walking cadences (a harmonic locked onto by a weak bob falls outside)
    max_cadence_hz: float = 2.2


@dataclass(frozen=True)
class PhoneMotion:
    """One phone's motion cues on the grid t (K,): walking (bool), heading psi (rad, world, phone
    yaw), cadence (Hz, NaN where none), dyaw (rad, gyro yaw change from t_k to t_{k+1}; K - 1),
    the detected step times (s), the horizontal acceleration (m/s^2, K; None: not known) and the
    cadence's standard error (Hz, K; NaN where no cadence; None: not known)."""

    phone_id: str
    t: np.ndarray
    walking: np.ndarray
    heading: np.ndarray
    cadence: np.ndarray
    dyaw: np.ndarray
    steps: np.ndarray
    accel_h: np.ndarray | None = None
    cadence_se: np.ndarray | None = None


def _centred_mean(x: np.ndarray, n: int) -> np.ndarray:
    return ndimage.uniform_filter1d(x, size=max(1, n), axis=0, mode="nearest")


def _window_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Mean of the rows of x over a centred window of n samples, over the samples there are at
    the ends (no padding: a start transient is not repeated into the window)."""
    h = max(1, n) // 2
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    i = np.arange(len(x))
    lo, hi = np.maximum(i - h, 0), np.minimum(i + h + 1, len(x))
    return (c[hi] - c[lo]) / (hi - lo).reshape((-1,) + (1,) * (x.ndim - 1))


def gyro_aided_heading(t: np.ndarray, psi_mag: np.ndarray, yaw_gyro: np.ndarray, tau: float) -> np.ndarray:
    """The phone's yaw (rad) from the gyro, its constant and slow drift from the magnetometer.

    The gyro's integral y(t) (rad, ``yaw_gyro``) is the phone's yaw up to a constant and a slow
    drift (bias); the tilt-compensated magnetometer ``psi_mag`` is absolute but bent by the
    indoor disturbance, which changes over metres walked (seconds). Their difference
    c(t) = psi_mag - y is the constant plus the drift plus the disturbance; its slow part is a
    local linear fit with exponential weights w = exp(-|t' - t| / tau) (the two-sided kernel of the
    steady-state smoother of a random walk in white noise; the linear term keeps a gyro drift
    followed at the ends of the recording, where a plain weighted mean lags it by its slope
    times tau):

        c~(t) = a_t,   (a_t, b_t) = argmin sum_t' w(t', t) (c(t') - a - b (t' - t))^2,   psi = y + c~:

    the magnetometer below about 1 / (2 pi tau) Hz, the gyro above (a complementary filter). The
    weighted sums run as one causal and one anti-causal first-order recursion each
    (``scipy.signal.lfilter``)."""
    t = np.asarray(t, float)
    c = np.unwrap(np.asarray(psi_mag, float) - np.asarray(yaw_gyro, float))
    if len(t) < 3:
        return np.asarray(yaw_gyro, float) + np.mean(c)
    dt = float(np.median(np.diff(t)))
    a = np.exp(-dt / tau)
    s = (t - t[0]) / tau  # time in units of tau (well scaled sums)

    def ksum(x):
        """sum over t' of exp(-|t' - t| / tau) x(t'), for every sample t."""
        fwd = signal.lfilter([1.0], [1.0, -a], x)
        bwd = signal.lfilter([1.0], [1.0, -a], x[::-1])[::-1]
        return fwd + bwd - x  # the sample itself counted once

    # moments about each sample's own time: sum w (s' - s)^j = sum w s'^j expanded
    m0, m1, m2 = ksum(np.ones_like(s)), ksum(s), ksum(s * s)
    c0, c1 = ksum(c), ksum(s * c)
    S1 = m1 - s * m0
    S2 = m2 - 2 * s * m1 + s * s * m0
    C1 = c1 - s * c0
    det = m0 * S2 - S1 * S1
    slow = np.where(det > 1e-12 * m0 * m0, (S2 * c0 - S1 * C1) / np.where(det > 0, det, 1.0), c0 / m0)
    return np.asarray(yaw_gyro, float) + slow


def step_phase(t: np.ndarray, acc: np.ndarray, u: np.ndarray, rate: float, s: MotionSettings):
    """(phi, envelope): unwrapped step phase (rad) and bob envelope (m/s^2) of the band-passed
    vertical specific force."""
    av = np.einsum("ij,ij->i", acc, u)
    if len(t) < 16:
        return np.zeros(len(t)), np.zeros(len(t))
    lo, hi = s.band_hz
    sos = signal.butter(2, [lo, min(hi, 0.45 * rate)], btype="bandpass", fs=rate, output="sos")
    padlen = min(len(av) - 1, 3 * int(rate / lo))
    z = signal.hilbert(signal.sosfiltfilt(sos, av - av.mean(), padlen=padlen))
    return np.unwrap(np.angle(z)), np.abs(z)


def phone_motion(imu: pd.DataFrame, phone_id: str, t_grid: np.ndarray, gait: GaitModel, field_world,
                 s: MotionSettings = MotionSettings()) -> PhoneMotion:
    """The motion cues of one phone (rows of ``imu`` with that phone_id) on the grid t_grid."""
    d = imu[imu["phone_id"].astype(str) == phone_id]
    # one sample per time (the first), in time order
    t, first = np.unique(d["t"].to_numpy(float), return_index=True)
    if len(t) < 2:
        raise ValueError(f"phone {phone_id!r} has fewer than 2 IMU samples at distinct times")
    rate = 1.0 / float(np.median(np.diff(t)))
    acc = d[["ax", "ay", "az"]].to_numpy(float)[first]
    gyro = d[["gx", "gy", "gz"]].to_numpy(float)[first]
    mag = d[["mx", "my", "mz"]].to_numpy(float)[first]
    psi, u = tilt_compensated_yaw(acc, mag, field_world, int(round(s.gravity_window_s * rate)))
    # gyro yaw rate about "up" (tilt-compensated: the pocket tilt and a swing turn the phone's z
    # axis off the vertical) and its integral, the phone's yaw up to a constant
    u_g = u
    if s.gyro_gravity_window_s != s.gravity_window_s:
        g = _window_mean(acc, int(round(s.gyro_gravity_window_s * rate)))
        u_g = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
    w_up = np.einsum("ij,ij->i", gyro, u_g)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (w_up[1:] + w_up[:-1]) * np.diff(t))])
    if s.gyro_heading_tau_s > 0:
        psi = gyro_aided_heading(t, psi, cum, s.gyro_heading_tau_s)
    # circular mean of the heading over a centred window, read at the grid times
    n_h = max(1, int(round(s.heading_window_s * rate)))
    c, sn = _centred_mean(np.cos(psi), n_h), _centred_mean(np.sin(psi), n_h)
    j = np.clip(np.searchsorted(t, t_grid), 0, len(t) - 1)
    heading = np.arctan2(sn[j], c[j])
    # walking from the gait model's bobbing feature, its window centred on t_k
    g = bobbing_feature(t, acc, t_grid + 0.5 * gait.window_s, gait.window_s)
    walking = gait.walking(g)
    phi, env = step_phase(t, acc, u, rate, s)
    n_c = max(1, int(round(s.cadence_window_s * rate)))
    f_inst = np.gradient(phi, t) / (2 * np.pi)
    f = _centred_mean(f_inst, n_c)
    # the cadence's standard error: the scatter of the instantaneous step rate over the window
    # over the root of the independent samples in it (the band-pass keeps fluctuations up to
    # band_hz[1], so 2 band_hz[1] of them a second; module docstring)
    sd = np.sqrt(np.maximum(_centred_mean(f_inst * f_inst, n_c) - f * f, 0.0))
    n_ind = max(1.0, 2.0 * min(s.band_hz[1], 0.45 * rate) * s.cadence_window_s)
    se = sd / np.sqrt(n_ind)
    ok = (_centred_mean(env, n_c) >= s.step_min_accel) & (f >= s.min_cadence_hz) & (f <= s.max_cadence_hz)
    cadence = np.where(ok[j], f[j], np.nan)
    cycles = np.floor(phi / (2 * np.pi))
    steps = t[1:][(np.diff(cycles) > 0) & ok[1:]]
    # the gyro's yaw, integrated from each grid time to the next
    yaw_int = np.interp(t_grid, t, cum)
    # horizontal specific force (gravity removed along u), its magnitude averaged like the cadence
    fh = acc - np.einsum("ij,ij->i", acc, u)[:, None] * u
    acc_h = np.linalg.norm(_centred_mean(fh, n_c), axis=1)[j]  # the mean first: a step's sway averages out
    return PhoneMotion(phone_id, np.asarray(t_grid, float), walking, heading, cadence, np.diff(yaw_int), steps, acc_h,
                       np.where(ok[j], se[j], np.nan))
