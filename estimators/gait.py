"""Phone-side features for the HMM matcher (Teixeira et al., "Wearable inertial sensors").

Walking / stopped from the accelerometer's vertical bobbing
-----------------------------------------------------------
The phone's accelerometer reads specific force f = a - g (m/s^2, phone frame). Its vertical
component is taken along the low-passed specific force (the gravity direction, u = mean(f) /
|mean(f)| over the window), so the feature does not depend on how the phone is held. The bobbing
feature is the standard deviation of that vertical component over a causal window of ``window_s``
seconds ending at the camera frame time:

    g_k = std{ f(t) . u  :  t_k - W < t <= t_k }                      (m/s^2)

As in the paper, the two classes are fitted from a training recording (``trackroom train-gait``):

    p(g | walking) = N(g; mu_w, sigma_w^2)         (Gaussian)
    p(g | stopped) = lambda exp(-lambda g)          (exponential, scale 1 / lambda)

and the motion state is read from their likelihood ratio. The same fit stores the heading noise
of the magnetometer against the true walking direction (von Mises concentration ``heading_kappa``,
after each phone's constant yaw offset in the pocket is taken out: the matcher estimates that
offset itself) and the walking-speed distribution N(speed_mu, speed_sigma^2) (m/s) the camera
side uses.

Heading, tilt-compensated
-------------------------
A phone in a pocket is tilted, so its yaw is read from the magnetometer in the horizontal plane
of the gravity direction the accelerometer gives (``tilt_compensated_yaw``); the fusion smoother's
phone cues (``phone_motion``) use the same function.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage, stats

DEFAULT_MODEL_PATH = Path(__file__).with_name("gait_default.json")
GRAVITY_WINDOW_S = 2.0  # s, centred window of the gravity estimate (several strides)


@dataclass(frozen=True)
class GaitModel:
    """Fitted class-conditional models of the phone features (see module docstring)."""

    window_s: float = 0.8  # bobbing window W, s (one step cycle at the slowest gait)
    walk_mu: float = 1.5  # m/s^2
    walk_sigma: float = 0.6  # m/s^2
    stop_scale: float = 0.05  # 1 / lambda, m/s^2
    heading_kappa: float = 50.0  # von Mises concentration of magnetometer heading - walking direction
    speed_mu: float = 1.0  # walking speed mean, m/s
    speed_sigma: float = 0.35  # walking speed std, m/s
    source: str = ""  # how the model was fitted (command line, recordings)
    stats: dict = field(default_factory=dict)  # sample counts of the fit

    def loglik(self, g: np.ndarray) -> np.ndarray:
        """log p(g | stopped), log p(g | walking) stacked on a last axis of size 2 (index 0 = stopped)."""
        g = np.maximum(np.asarray(g, float), 0.0)
        stop = stats.expon.logpdf(g, scale=self.stop_scale)
        walk = stats.norm.logpdf(g, loc=self.walk_mu, scale=self.walk_sigma)
        return np.stack([stop, walk], axis=-1)

    def walking(self, g: np.ndarray) -> np.ndarray:
        """Likelihood-ratio test: True where p(g | walking) > p(g | stopped)."""
        ll = self.loglik(g)
        return ll[..., 1] > ll[..., 0]

    def to_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(asdict(self), indent=2, sort_keys=True) + "\n")

    @staticmethod
    def from_json(path: str | Path) -> "GaitModel":
        path = Path(path)
        try:
            d = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ValueError(f"gait model {path}: not a JSON file ({e})") from None
        known = set(GaitModel.__dataclass_fields__)
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"gait model {path}: unknown fields {unknown}")
        return GaitModel(**d)


def load_default() -> GaitModel:
    """The bundled model (fitted by ``trackroom train-gait``; see docs/hmm_matcher.md)."""
    if not DEFAULT_MODEL_PATH.exists():
        raise FileNotFoundError(
            f"bundled gait model {DEFAULT_MODEL_PATH} is missing (install with package data, or pass "
            "gait_model=PATH from `trackroom train-gait`)"
        )
    return GaitModel.from_json(DEFAULT_MODEL_PATH)


def _window_sums(t: np.ndarray, values: np.ndarray, t_query: np.ndarray, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Sums of ``values`` (N, ...) over samples with t_q - W < t <= t_q, and the sample counts."""
    c = np.concatenate([np.zeros((1,) + values.shape[1:]), np.cumsum(values, axis=0)])
    hi = np.searchsorted(t, t_query + 1e-9, side="right")
    lo = np.searchsorted(t, t_query - window_s + 1e-9, side="right")
    return c[hi] - c[lo], (hi - lo)


def bobbing_feature(t: np.ndarray, acc: np.ndarray, t_query: np.ndarray, window_s: float) -> np.ndarray:
    """g_k: std of the vertical specific force over (t_k - W, t_k] (m/s^2), for each query time.

    ``t`` (N,) sorted sample times (s); ``acc`` (N, 3) specific force in the phone frame.
    Vertical = along the window's mean specific force (gravity direction). Windows with fewer
    than 2 samples give 0.
    """
    t = np.asarray(t, float)
    acc = np.asarray(acc, float)
    t_query = np.asarray(t_query, float)
    # Sums of f, f f^T over each window give mean and covariance of f; the vertical variance is
    # u^T Cov(f) u with u the unit mean (gravity) direction: no per-window Python loop.
    outer = (acc[:, :, None] * acc[:, None, :]).reshape(len(acc), 9)
    s1, n = _window_sums(t, acc, t_query, window_s)
    s2, _ = _window_sums(t, outer, t_query, window_s)
    n = np.maximum(n, 1)[:, None]
    mean = s1 / n
    cov = (s2 / n).reshape(-1, 3, 3) - mean[:, :, None] * mean[:, None, :]
    norm = np.linalg.norm(mean, axis=1, keepdims=True)
    u = mean / np.maximum(norm, 1e-9)
    var = np.einsum("ki,kij,kj->k", u, cov, u)
    g = np.sqrt(np.maximum(var, 0.0))
    return np.where(n[:, 0] >= 2, g, 0.0)


def tilt_compensated_yaw(acc: np.ndarray, mag: np.ndarray, field_world, n_gravity: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample phone yaw psi (rad, world frame) and unit up vector u (N, 3), tilt-compensated.

    Gravity (the phone's "up" in its own frame) is u = mean(f) / |mean(f)| of the specific force f
    over a centred window of ``n_gravity`` samples (walking accelerations average out; a pocket
    tilt does not). The field's horizontal part m_h = m - (m . u) u and the phone's x axis
    projected on the horizontal plane, x_h = e_x - u_x u, give the angle from x_h to m_h about u,
    theta = atan2(u . (x_h x m_h), x_h . m_h), and the phone's yaw psi = atan2(H_y, H_x) - theta
    (H the world field). For an upright phone (u = e_z) this is atan2(H_y, H_x) - atan2(m_y, m_x).
    """
    hx, hy = float(field_world[0]), float(field_world[1])
    if np.hypot(hx, hy) < 1e-9:
        raise ValueError("magnetic field has no horizontal component: heading is undefined")
    acc = np.asarray(acc, float)
    mag = np.asarray(mag, float)
    g = ndimage.uniform_filter1d(acc, size=max(1, int(n_gravity)), axis=0, mode="nearest")
    u = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
    mh = mag - np.einsum("ij,ij->i", mag, u)[:, None] * u
    xh = np.zeros_like(u)
    xh[:, 0] = 1.0
    xh = xh - u[:, [0]] * u
    theta = np.arctan2(np.einsum("ij,ij->i", u, np.cross(xh, mh)), np.einsum("ij,ij->i", xh, mh))
    return np.arctan2(hy, hx) - theta, u


def phone_heading(t: np.ndarray, acc: np.ndarray, mag: np.ndarray, t_query: np.ndarray, window_s: float, field_world,
                  gravity_window_s: float = GRAVITY_WINDOW_S) -> np.ndarray:
    """Phone yaw psi_m (rad, world frame) at each query time: the tilt-compensated yaw
    (``tilt_compensated_yaw``, gravity over a centred ``gravity_window_s``) averaged on the unit
    circle over (t_k - W, t_k]. ``acc`` (N, 3) specific force and ``mag`` (N, 3) field, phone frame."""
    t = np.asarray(t, float)
    t_query = np.asarray(t_query, float)
    rate = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    psi, _ = tilt_compensated_yaw(acc, mag, field_world, int(round(gravity_window_s * rate)))
    unit = np.stack([np.cos(psi), np.sin(psi)], axis=1)
    s, n = _window_sums(t, unit, t_query, window_s)
    # an empty window falls back to the nearest earlier sample
    empty = n == 0
    if empty.any():
        j = np.clip(np.searchsorted(t, t_query[empty], side="right") - 1, 0, len(psi) - 1)
        s[empty] = unit[j]
    return np.arctan2(s[:, 1], s[:, 0])


def fit_gait(features: np.ndarray, walking: np.ndarray, headings_err: np.ndarray, speeds: np.ndarray,
             window_s: float, source: str = "") -> GaitModel:
    """Fit the class models from labelled samples (truth walking labels of a training recording).

    features: bobbing feature g (m/s^2); walking: bool labels; headings_err: magnetometer heading
    minus true walking direction (rad) while walking; speeds: true speeds while walking (m/s).
    """
    features = np.asarray(features, float)
    walking = np.asarray(walking, bool)
    gw, gs = features[walking], features[~walking]
    if len(gw) < 10 or len(gs) < 10:
        raise ValueError(
            f"training data needs both walking and stopped samples (got {len(gw)} walking, {len(gs)} stopped)"
        )
    mu, sigma = stats.norm.fit(gw)
    _, scale = stats.expon.fit(gs, floc=0.0)
    err = np.angle(np.exp(1j * np.asarray(headings_err, float)))
    kappa, _, _ = stats.vonmises.fit(err, floc=0.0, fscale=1.0) if len(err) >= 10 else (GaitModel.heading_kappa, 0, 1)
    smu, ssd = stats.norm.fit(np.asarray(speeds, float)) if len(speeds) >= 10 else (1.0, 0.35)
    return GaitModel(
        window_s=float(window_s), walk_mu=float(mu), walk_sigma=float(max(sigma, 1e-3)),
        stop_scale=float(max(scale, 1e-4)), heading_kappa=float(min(kappa, 1e4)),
        speed_mu=float(smu), speed_sigma=float(max(ssd, 0.05)), source=source,
        stats={"walking_samples": int(len(gw)), "stopped_samples": int(len(gs)), "heading_samples": int(len(err))},
    )
