"""Phone factors on a trajectory's velocity, for the fusion smoother (``fusion_smoother``).

Variables: the trajectory X (state s_k = [x, vx, y, vy], ``qp_model``) followed by per-person
parameters theta = [l, delta_0, ..., delta_{K-1}]: l the step length at the reference cadence f_0
(m) and delta the phone's heading offset (rad; walking direction = phone yaw - delta): the yaw
offset in the pocket plus the indoor magnetic disturbance, which is smooth along the path. With
one knot (K = 1) delta is one constant; with knots every ``knot_steps`` grid steps it is linear
between them,

    delta(k) = (1 - w_k) delta_j + w_k delta_{j+1},   j = floor(k / knot_steps), w_k = k / knot_steps - j,

with a random-walk prior between consecutive knots (``offset_knot_prior``). Their priors are
extra rows of the prior factor (``Prior.with_parameter_rows``).

For grid step k with phone heading psi_k (``phone_motion``), unit walking direction
e_k = (cos(psi_k - delta(k)), sin(psi_k - delta(k))) and its left normal n_k:

- **speed from cadence** (walking, a cadence f_k): the speed is linear in cadence above a cadence
  f_1 at which it extrapolates to zero, and proportional to the step length l at f_0:
      s_k = l g(f_k),   g(f) = f_0 (f - f_1) / (f_0 - f_1)   (floored at ``G_MIN``)
  (f_1 a population constant; the step length at cadence f is s / f). Proportional to l, so a
  path scaled about a camera together with l keeps these rows exactly;
      r_a = (e_k . v_k - s_k) / sigma_a,k,
      sigma_a^2 = sigma_speed^2 + (rel_speed s~_k)^2 + (tau omega_k s~_k)^2 + (tau_a a_k)^2 + (l f_0 / (f_0 - f_1) sigma_f,k)^2
  (people slow down in turns faster than a cadence over half a second follows: tau and omega_k
  as below), and by tau_a a_k (a_k the phone's horizontal acceleration, ``phone_motion``): the
  cadence lags a change of speed by about its averaging window tau_a, and the first and last
  steps of a walk are short; and by the cadence's own standard error sigma_f,k (``phone_motion``:
  a weak bob at slow walking gives a ragged step phase) through the speed law's slope
- **heading** (walking): the velocity's component across the phone heading, a von Mises heading
  error of concentration kappa in its small-angle (Gaussian) form, sigma_psi = 1 / sqrt(kappa),
  widened in turns, where the body (and the phone with it) turns a little before or after the
  path: sigma_psi,k^2 = sigma_psi^2 + (tau omega_k)^2, omega_k the gyro's yaw rate, tau the lag:
      r_c = (n_k . v_k) / (s~_k sigma_psi,k)
  with s~_k the speed the priors predict (f_k L(f_k) at the prior l, or ``nominal_speed`` where
  no cadence was found), so that the weights stay fixed.
- **stopped** (the gait model says stopped): r_s = v_k / sigma_stop (two rows).
- **scale-free** (``scale_free``, the default): the heading rows without a cadence and the stopped
  rows have their sigma multiplied by l / l_prior as well, so that every phone row is unchanged when
  the path is scaled about a camera together with l (``ScaledPrior`` does the same for the prior):
  with one camera only the step length's prior then holds the scale.
- **gyro** (optional, walking at k and k+1): the heading change equals the integrated yaw rate
  dpsi_k, whatever the magnetic field:
      r_g = (n_{k+1} . (v_{k+1} - R(dpsi_k) v_k)) / (s~ sigma_gyro)
  with n_{k+1} the normal of the walking direction psi_{k+1} - delta(k+1) (with the phone's own
  heading instead, the row also read sin(delta) times the change of speed), and, with
  ``scale_free``, its sigma times l / l_prior like the other rows.

Robust loss (missed steps, a phone taken out of the pocket): every row r goes through Huber's
rho with threshold c (in sigmas); the bearings, whose detector reports clipped people at the
image border and the odd false detection, through a bounded one (``Robust``). Each Gauss-Newton
step stays one QP by iteratively reweighted least squares: rows sqrt(w) r, sqrt(w) J with
w = rho'(r) / r at the iterate, a majoriser of the loss; the line search sees sum rho(r)
(``Robust.loss``; 0.5 r~^2 with r~ = sign(r) sqrt(2 rho(r)), ``robust_residual``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .qp_model import IVX, IVY, NS

N_PAR = 2  # [l, delta] with one offset knot (the constant offset)
G_MIN = 0.15  # least speed per unit step length, 1/s (0.1 m/s at l = 0.7 m): cadences near f_1
IL, ID = 0, 1


@dataclass(frozen=True)
class PhoneFactorSettings:
    """Noise levels and the step-length law (module docstring); angles in radians."""

    f0: float = 1.8  # reference cadence of the step length l, Hz
    f1: float = 1.0  # cadence at which the speed extrapolates to zero, Hz
    sigma_speed: float = 0.05  # m/s
    rel_speed: float = 0.08  # relative speed error from cadence
    sigma_psi: float = 0.15  # rad
    sigma_stop: float = 0.05  # m/s
    sigma_gyro: float = 0.05  # rad per grid step
    nominal_speed: float = 0.8  # m/s, heading weight where no cadence was found
    huber: float = 2.0  # robust threshold, sigmas
    turn_lag: float = 0.3  # s, tau
    speed_lag: float = 0.5  # s, tau_a: the cadence's lag behind speed changes
    loss: str = "huber"
    gyro: bool = False
    scale_free: bool = True  # every row in units of the step length (sigma ~ l / l_prior); see ``_raw``


LOSSES = ("huber", "cauchy", "geman_mcclure", "l2")


def speed_per_step_length(f: np.ndarray, s: PhoneFactorSettings) -> np.ndarray:
    """g(f) = f_0 (f - f_1) / (f_0 - f_1), floored at ``G_MIN`` (1/s): speed = l g(f)."""
    return np.maximum(s.f0 * (np.asarray(f, float) - s.f1) / (s.f0 - s.f1), G_MIN)


def robust_residual(r: np.ndarray, c: float, loss: str = "huber") -> tuple[np.ndarray, np.ndarray]:
    """(r~, w): r~ = sign(r) sqrt(2 rho(r)) and the row weight w = rho'(r) / r~ (module docstring).

    huber: rho = r^2 / 2 for |r| <= c, c |r| - c^2 / 2 beyond (convex, bounded influence);
    cauchy: rho = c^2 / 2 log(1 + (r / c)^2) (redescending: a gross outlier loses its pull);
    geman_mcclure: rho = (c^2 / 2) r^2 / (c^2 + r^2) (bounded by c^2 / 2: a false detection costs
    the same wherever the path goes, so nothing is gained by bending the path to explain it);
    l2: rho = r^2 / 2.
    """
    r = np.asarray(r, float)
    if loss == "l2":
        return r, np.ones_like(r)
    a = np.abs(r)
    rt = r.copy()
    w = np.ones_like(r)
    if loss == "huber":
        big = a > c
        if big.any():
            rt[big] = np.sign(r[big]) * np.sqrt(2.0 * c * a[big] - c * c)
            w[big] = c * np.sign(r[big]) / rt[big]
        return rt, w
    if loss == "cauchy":
        nz = a > 1e-12 * c
        q = (r[nz] / c) ** 2
        rt[nz] = np.sign(r[nz]) * c * np.sqrt(np.log1p(q))
        w[nz] = (r[nz] / (1.0 + q)) / rt[nz]
        return rt, w
    if loss == "geman_mcclure":
        nz = a > 1e-12 * c
        d = c * c + r[nz] ** 2
        rt[nz] = np.sign(r[nz]) * c * a[nz] / np.sqrt(d)
        w[nz] = (c**4 * r[nz] / d**2) / rt[nz]
        return rt, w
    raise ValueError(f"loss must be one of {LOSSES}, got {loss!r}")


class Robust:
    """A residual block (``raw_residual(X)`` and ``raw_jacobian(X, n)``, or a ``qp_model.Bearings``)
    seen through a robust loss: ``loss(X)`` = sum rho(r / scale). ``scale`` (optional, per row)
    widens the noise of some rows (e.g. bearings at the image border).

    Gauss-Newton sees it by iteratively reweighted least squares: at the iterate X0 the rows are
    sqrt(w) r and sqrt(w) J with w = rho'(r0) / r0 (``irls_weight``), so each step minimises the
    quadratic 0.5 sum w r^2, which majorises sum rho(r) up to a constant for Huber, Cauchy and
    Geman-McClure (rho'(r) / r does not grow with |r|): a full step descends. The square-root
    form r~ = sign(r) sqrt(2 rho(r)) (``robust_residual``) was used first: beyond the threshold
    its Gauss-Newton curvature is about half the loss's (Huber: c / 2|r| against c / |r|), so
    its steps overshoot by about two, and at T = 3840 every step was halved by the line search
    until the 50-iteration cap."""

    def __init__(self, block, c: float, loss: str = "huber", scale: np.ndarray | None = None):
        if loss not in LOSSES:
            raise ValueError(f"loss must be one of {LOSSES}, got {loss!r}")
        self.block, self.c, self.loss_name = block, float(c), loss
        self.inv = None if scale is None else 1.0 / np.asarray(scale, float)

    def __len__(self) -> int:
        return len(self.block)

    def _r(self, X):
        r = self.block.raw_residual(X) if hasattr(self.block, "raw_residual") else self.block.residual(X)
        return r if self.inv is None else r * self.inv

    def loss(self, X: np.ndarray) -> float:
        """sum rho(r) (the cost these rows add)."""
        rt = robust_residual(self._r(X), self.c, self.loss_name)[0]
        return 0.5 * float(rt @ rt)

    def residual(self, X: np.ndarray) -> np.ndarray:
        r = self._r(X)
        return np.sqrt(irls_weight(r, self.c, self.loss_name)) * r

    def jacobian(self, X: np.ndarray, n: int) -> sp.csc_matrix:
        sw = np.sqrt(irls_weight(self._r(X), self.c, self.loss_name))
        J = self.block.raw_jacobian(X, n) if hasattr(self.block, "raw_jacobian") else self.block.jacobian(X, n)
        return (sp.diags(sw if self.inv is None else sw * self.inv) @ J).tocsc()


def irls_weight(r: np.ndarray, c: float, loss: str) -> np.ndarray:
    """w = rho'(r) / r (1 at r = 0): huber min(1, c / |r|); cauchy 1 / (1 + (r / c)^2);
    geman_mcclure c^4 / (c^2 + r^2)^2; l2 1."""
    r = np.abs(np.asarray(r, float))
    if loss == "huber":
        return np.minimum(1.0, c / np.maximum(r, 1e-300))
    if loss == "cauchy":
        return 1.0 / (1.0 + (r / c) ** 2)
    if loss == "geman_mcclure":
        return c**4 / (c * c + r * r) ** 2
    if loss == "l2":
        return np.ones_like(r)
    raise ValueError(f"loss must be one of {LOSSES}, got {loss!r}")


@dataclass
class PhoneFactors:
    """The phone rows of one person: walking steps ``kw`` with heading ``psi`` and cadence ``f``
    (NaN: none), stopped steps ``ks``, gyro pairs ``kg`` -> ``kg + 1`` with heading change ``dpsi``.
    ``T``: trajectory steps (the parameters sit at columns NS T (l) and NS T + 1 ... (the offset's
    knots, ``knot_steps`` apart; one knot if 0)). ``l_prior``: the prior mean of l, for the fixed
    weights."""

    T: int
    kw: np.ndarray
    psi: np.ndarray
    f: np.ndarray
    ks: np.ndarray
    kg: np.ndarray
    dpsi: np.ndarray
    psi_g: np.ndarray
    l_prior: float
    s: PhoneFactorSettings
    omega: np.ndarray | None = None  # yaw rate at the walking steps, rad/s (None: no widening)
    accel: np.ndarray | None = None  # horizontal acceleration at the walking steps, m/s^2 (None: no widening)
    f_se: np.ndarray | None = None  # the cadence's standard error at the walking steps, Hz (None or NaN: none)
    knot_steps: int = 0  # grid steps between heading-offset knots; 0: one constant offset
    bounded: bool = False  # knots as deviations b_j about a constant delta_c (``OffsetKnots``)

    def __post_init__(self):
        self.n_knots = n_knots(self.T, self.knot_steps)
        self.bounded = bool(self.bounded and self.n_knots > 1)
        self.n_par = 1 + self.n_knots + int(self.bounded)
        # each walking row's offset: knots j0, j0 + 1 with weights 1 - w, w (module docstring)
        self.kj, self.kwt = knot_weights(self.kw, self.T, self.knot_steps)
        f = self.f
        has = np.isfinite(f)
        self.has_f = has
        nominal = np.full(len(f), self.s.nominal_speed)
        self.g = speed_per_step_length(f[has], self.s)
        nominal[has] = self.l_prior * self.g
        self.s_nom = nominal
        turn = np.zeros(len(f)) if self.omega is None else self.s.turn_lag * self.omega
        lag = np.zeros(len(f)) if self.accel is None else self.s.speed_lag * self.accel
        # the cadence's own error through the speed law: ds/df = l f_0 / (f_0 - f_1), at the prior's l
        cad = np.zeros(len(f)) if self.f_se is None else np.nan_to_num(np.asarray(self.f_se, float), nan=0.0)
        cad = cad * self.l_prior * self.s.f0 / (self.s.f0 - self.s.f1)
        self.sig_a = np.sqrt(self.s.sigma_speed**2 + (self.s.rel_speed * nominal) ** 2 + (turn * nominal) ** 2 + lag**2
                             + cad**2)
        sig_psi = self.s.sigma_psi
        if self.omega is not None:
            sig_psi = np.sqrt(sig_psi**2 + (self.s.turn_lag * self.omega) ** 2)
        self.sig_c = np.maximum(nominal, 0.2) * sig_psi
        self.ia = np.flatnonzero(has)  # along-track rows exist only with a cadence
        self.sig_g = np.maximum(self.s.nominal_speed, 0.2) * self.s.sigma_gyro

    @property
    def n_rows(self) -> int:
        return len(self.ia) + len(self.kw) + 2 * len(self.ks) + (len(self.kg) if self.s.gyro else 0)

    def __len__(self) -> int:
        return self.n_rows

    # raw (non-robust) rows ------------------------------------------------------------------
    def _raw(self, X: np.ndarray):
        """Raw whitened residuals and their Jacobian as (rows, cols, vals) triplets."""
        s, T = self.s, self.T
        l = X[NS * T + IL]
        cl, cd = NS * T + IL, NS * T + ID
        cb = cd + int(self.bounded)  # the first knot's column
        knots = X[cb:cb + self.n_knots]
        j0, w1 = self.kj, self.kwt
        j1 = np.minimum(j0 + 1, self.n_knots - 1)
        delta_w = (1.0 - w1) * knots[j0] + w1 * knots[j1]  # the offset at each walking row
        if self.bounded:
            delta_w = delta_w + X[cd]
        res, R, C, V = [], [], [], []
        row0 = 0
        # along-track speed and cross-track heading. With a cadence both are read relative to
        # the speed the step length implies, s_k(l) (their sigmas scale with s_k(l) / s~_k): a
        # path shrunk towards a camera together with l then costs the phone rows nothing, so
        # only the step length's prior, not the rows' noise model, decides the scale
        ka, fa = self.kw[self.ia], self.f[self.ia]
        th = self.psi[self.ia] - delta_w[self.ia]
        e = np.stack([np.cos(th), np.sin(th)], axis=1)
        nrm = np.stack([-e[:, 1], e[:, 0]], axis=1)
        v = np.stack([X[ka * NS + IVX], X[ka * NS + IVY]], axis=1)
        ev, nv = np.einsum("ij,ij->i", e, v), np.einsum("ij,ij->i", nrm, v)
        ga = self.g
        speed = l * ga
        ratio = speed / self.s_nom[self.ia]  # s_k(l) / s~_k
        sa = self.sig_a[self.ia] * ratio
        res.append((ev - speed) / sa)
        # r = (e.v - s) / (c s), c = sig_a / s~:  dr/ds = -(e.v) / (c s^2), ds/dl = g
        rows = row0 + np.arange(len(ka))
        ia, dd = self.ia, -nv / sa  # dr/d delta(k), shared by its two knots
        R += [rows, rows, rows, rows, rows]
        C += [ka * NS + IVX, ka * NS + IVY, np.full(len(ka), cl), cb + j0[ia], cb + j1[ia]]
        V += [e[:, 0] / sa, e[:, 1] / sa, -(ev / speed) * ga / sa, (1.0 - w1[ia]) * dd, w1[ia] * dd]
        if self.bounded:
            R, C, V = R + [rows], C + [np.full(len(ka), cd)], V + [dd]
        row0 += len(ka)
        # cross-track heading (rows with a cadence relative to s_k(l); the others to s~_k)
        kw = self.kw
        th = self.psi - delta_w
        e = np.stack([np.cos(th), np.sin(th)], axis=1)
        nrm = np.stack([-e[:, 1], e[:, 0]], axis=1)
        v = np.stack([X[kw * NS + IVX], X[kw * NS + IVY]], axis=1)
        ev, nv = np.einsum("ij,ij->i", e, v), np.einsum("ij,ij->i", nrm, v)
        sc = self.sig_c.copy()
        dl = np.zeros(len(kw))
        sc[self.ia] *= ratio
        dl[self.ia] = -(nv[self.ia] / speed) * ga / sc[self.ia]
        q = l / self.l_prior if s.scale_free else 1.0  # the scale of the path relative to the prior's
        if s.scale_free:
            # rows without a cadence (and the stopped rows below) in units of the step length too:
            # sigma ~ l, so a path scaled with l keeps them; dr/dl = -r / l
            nc = np.ones(len(kw), bool)
            nc[self.ia] = False
            sc[nc] *= q
            dl[nc] = -(nv[nc] / sc[nc]) / l
        res.append(nv / sc)
        rows = row0 + np.arange(len(kw))
        R += [rows, rows, rows, rows, rows]
        C += [kw * NS + IVX, kw * NS + IVY, cb + j0, cb + j1, np.full(len(kw), cl)]
        V += [nrm[:, 0] / sc, nrm[:, 1] / sc, (1.0 - w1) * ev / sc, w1 * ev / sc, dl]
        if self.bounded:
            R, C, V = R + [rows], C + [np.full(len(kw), cd)], V + [ev / sc]
        row0 += len(kw)
        # stopped
        ks = self.ks
        ss = s.sigma_stop * q
        for iv in (IVX, IVY):
            r = X[ks * NS + iv] / ss
            res.append(r)
            rows = row0 + np.arange(len(ks))
            R += [rows, rows] if s.scale_free else [rows]
            C += [ks * NS + iv, np.full(len(ks), cl)] if s.scale_free else [ks * NS + iv]
            V += [np.full(len(ks), 1.0 / ss), -r / l] if s.scale_free else [np.full(len(ks), 1.0 / ss)]
            row0 += len(ks)
        # gyro: heading change between consecutive walking steps, across the walking direction
        # at k0 + 1 (phone heading minus the offset there: across the phone's own heading the
        # row would also read sin(delta) of the change of speed), in units of the step length
        if s.gyro and len(self.kg):
            k0 = self.kg
            gj0, gw1 = knot_weights(k0 + 1, T, self.knot_steps)
            gj1 = np.minimum(gj0 + 1, self.n_knots - 1)
            d1 = (1.0 - gw1) * knots[gj0] + gw1 * knots[gj1] + (X[cd] if self.bounded else 0.0)
            th1 = self.psi_g - d1
            e1 = np.stack([np.cos(th1), np.sin(th1)], axis=1)
            n1 = np.stack([-e1[:, 1], e1[:, 0]], axis=1)  # normal at k0 + 1
            c, sn = np.cos(self.dpsi), np.sin(self.dpsi)
            v0 = np.stack([X[k0 * NS + IVX], X[k0 * NS + IVY]], axis=1)
            v1 = np.stack([X[(k0 + 1) * NS + IVX], X[(k0 + 1) * NS + IVY]], axis=1)
            dv = v1 - np.stack([c * v0[:, 0] - sn * v0[:, 1], sn * v0[:, 0] + c * v0[:, 1]], axis=1)  # v1 - R v0
            # n1 . (v1 - R v0):  d/dv0 = -R^T n1
            a_x = -(n1[:, 0] * c + n1[:, 1] * sn)
            a_y = -(-n1[:, 0] * sn + n1[:, 1] * c)
            sg = np.full(len(k0), self.sig_g * (q if s.scale_free else 1.0))
            r = np.einsum("ij,ij->i", n1, dv) / sg
            res.append(r)
            rows = row0 + np.arange(len(k0))
            dd = np.einsum("ij,ij->i", e1, dv) / sg  # dn1/d delta = e1
            R += [rows] * 6
            C += [(k0 + 1) * NS + IVX, (k0 + 1) * NS + IVY, k0 * NS + IVX, k0 * NS + IVY, cb + gj0, cb + gj1]
            V += [n1[:, 0] / sg, n1[:, 1] / sg, a_x / sg, a_y / sg, (1.0 - gw1) * dd, gw1 * dd]
            if self.bounded:
                R, C, V = R + [rows], C + [np.full(len(k0), cd)], V + [dd]
            if s.scale_free:
                R, C, V = R + [rows], C + [np.full(len(k0), cl)], V + [-r / l]
            row0 += len(k0)
        return np.concatenate(res), np.concatenate(R), np.concatenate(C), np.concatenate(V), row0

    def offsets(self, X: np.ndarray) -> np.ndarray:
        """The heading offset at each knot (rad): delta_j, or delta_c + b_j when ``bounded``."""
        cd = NS * self.T + ID
        cb = cd + int(self.bounded)
        return X[cb:cb + self.n_knots] + (X[cd] if self.bounded else 0.0)

    def raw_residual(self, X: np.ndarray) -> np.ndarray:
        return self._raw(X)[0]

    def raw_jacobian(self, X: np.ndarray, n: int) -> sp.csc_matrix:
        _, R, C, V, m = self._raw(X)
        return sp.csc_matrix((V, (R, C)), shape=(m, n))

    def robust(self) -> Robust:
        """These rows through Huber's loss (threshold ``huber`` sigmas)."""
        return Robust(self, self.s.huber, self.s.loss)


def n_knots(T: int, knot_steps: int) -> int:
    """Number of heading-offset knots for T grid steps, ``knot_steps`` apart (1 if 0: a constant)."""
    if knot_steps <= 0 or T < 2:
        return 1
    return int(np.ceil((T - 1) / knot_steps)) + 1


def knot_weights(k: np.ndarray, T: int, knot_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """(j, w): step k's offset is (1 - w) delta_j + w delta_{j+1} (j = 0, w = 0 with one knot)."""
    k = np.asarray(k, int)
    K = n_knots(T, knot_steps)
    if K == 1:
        return np.zeros(len(k), int), np.zeros(len(k))
    j = np.minimum(k // knot_steps, K - 2)
    return j, (k - j * knot_steps) / knot_steps


def offset_knot_prior(step_length: np.ndarray, knot_steps: int, T: int, rate: float, floor: float) -> np.ndarray:
    """Std (rad) of delta_j - delta_{j-1} for j = 1 .. K-1: a random walk along the path,

        sigma_j^2 = rate^2 max(d_j, floor),   d_j = sum over the steps between the knots of the
                                             distance the phone says was walked (m),

    ``step_length`` (T,) the metres walked in each grid step at the prior's step length (0 stopped),
    ``rate`` rad / sqrt(m); ``floor`` m keeps a knot free where the walker stood (the phone may
    still be turned in the pocket)."""
    K = n_knots(T, knot_steps)
    if K == 1:
        return np.zeros(0)
    d = np.add.reduceat(np.asarray(step_length, float), np.arange(0, T, knot_steps))[:K - 1]
    return rate * np.sqrt(np.maximum(d, floor))


def offset_bounded_prior(step_length: np.ndarray, knot_steps: int, T: int, sigma: float, length: float,
                         floor: float) -> tuple[np.ndarray, np.ndarray]:
    """(rho_j, sigma_j) of the bounded model's knots b_j (``PhoneFactors.bounded``): a stationary
    Gauss-Markov (Ornstein-Uhlenbeck) process along the path about the constant offset,

        b_0 ~ N(0, sigma^2),   b_j - rho_j b_{j-1} ~ N(0, sigma^2 (1 - rho_j^2)),   rho_j = exp(-d_j / length),

    d_j the metres walked between the knots (at least ``floor``), as ``offset_knot_prior``: a
    disturbance of std ``sigma`` (rad) that changes over ``length`` m, and is no wider after a long
    walk (a random walk's would grow without bound)."""
    K = n_knots(T, knot_steps)
    if K == 1:
        return np.zeros(0), np.zeros(0)
    d = np.add.reduceat(np.asarray(step_length, float), np.arange(0, T, knot_steps))[:K - 1]
    rho = np.exp(-np.maximum(d, floor) / length)
    return rho, sigma * np.sqrt(1.0 - rho**2)


class ScaledPrior:
    """A ``qp_model.Prior`` (with the parameters appended) whose transition rows are in units of
    the step length (scale-free):

        r_t = (l_ref / l) (G_t X - g_t),   the first state's and the parameters' rows as they are,

    l the step length (column ``NS T + IL``) and l_ref its prior mean. A path scaled about a camera
    together with l (x -> a x, v -> a v, l -> a l) keeps these rows, as it keeps that camera's
    bearings and the phone rows: with one camera the data cannot tell the scale, and a prior on
    absolute accelerations (cost ~ a^2) would decide it instead of the step length's own prior,
    always towards a smaller path (docs/fusion_smoother.md). Not linear: ``jacobian(X)`` is
    G with the transition rows scaled by l_ref / l and -r_t / l in the l column, which
    ``qp_solver.solve_map`` re-evaluates at every iterate (still square and invertible: with l
    ordered first it is block triangular), so the stiff prior stays in the lifted QP's equality
    rows."""

    def __init__(self, prior, l_ref: float):
        self.base = prior
        self.G, self.g, self.dt, self.T, self.par_scale = prior.G, prior.g, prior.dt, prior.T, prior.par_scale
        self.l_ref = float(l_ref)
        self.col = NS * prior.T + IL
        self.trans = np.zeros(prior.n, bool)
        self.trans[NS:NS * prior.T] = True

    @property
    def n(self) -> int:
        return self.G.shape[1]

    def _q(self, X) -> tuple[float, float]:
        l = max(float(X[self.col]), 1e-3)
        return l, self.l_ref / l

    def residual(self, X: np.ndarray) -> np.ndarray:
        _, q = self._q(X)
        r = self.G @ X - self.g
        r[self.trans] *= q
        return r

    def jacobian(self, X: np.ndarray) -> sp.csc_matrix:
        l, q = self._q(X)
        w = np.where(self.trans, q, 1.0)
        r = self.residual(X)
        rows = np.flatnonzero(self.trans)
        Jl = sp.csc_matrix((-r[rows] / l, (rows, np.full(len(rows), self.col))), shape=self.G.shape)
        return (sp.diags(w) @ self.G + Jl).tocsc()


class Residuals:
    """A stack of residual blocks seen by ``qp_solver.solve_map`` as one observation model."""

    def __init__(self, *blocks):
        self.blocks = [b for b in blocks if b is not None]

    def __len__(self) -> int:
        return int(sum(len(b) for b in self.blocks))

    def residual(self, X: np.ndarray) -> np.ndarray:
        parts = [b.residual(X) for b in self.blocks if len(b)]
        return np.concatenate(parts) if parts else np.zeros(0)

    def loss(self, X: np.ndarray) -> float:
        """The cost of the rows: each robust block's ``loss``, 0.5 ||r||^2 for the others."""
        out = 0.0
        for b in self.blocks:
            if not len(b):
                continue
            if hasattr(b, "loss"):
                out += b.loss(X)
            else:
                r = b.residual(X)
                out += 0.5 * float(r @ r)
        return out

    def jacobian(self, X: np.ndarray, n: int) -> sp.csc_matrix:
        parts = [b.jacobian(X, n) for b in self.blocks if len(b)]
        return sp.vstack(parts, format="csc") if parts else sp.csc_matrix((0, n))
