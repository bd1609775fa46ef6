"""The Bayesian Cramér-Rao bound of a whole trajectory seen by bearing cameras, and RMSE / sqrt(CRB).

Model (Rahimi et al. eqs. 1-4; state s_k = [x, vx, y, vy], k = 0..T-1):

    s_{k+1} = A s_k + nu_k,  nu_k ~ N(0, Q),   s_0 ~ N(m_0, P_0)
    y_j = u(x_{k_j}) + w_j,  w_j ~ N(0, sigma^2)       (one row j per observed (k, camera))

For the observation pattern of a recording, the information of the trajectory X (4T) is

    J_X = G^T G + sum_j H_j^T H_j / sigma^2,        H_j = d u / d s_{k_j} at the *true* state,

with G the whitened prior factor (block tridiagonal G^T G). The bound on any estimator's error is
E[(X^ - X)(X^ - X)^T] >= J_X^{-1}; we need only its 4x4 diagonal blocks, which a Kalman filter
and Rauch-Tung-Striebel smoother with the linearised measurements compute in O(T) (the
covariance recursions do not depend on the measured values), never forming a dense 4T x 4T inverse:

    filter:   P_k|k = (P_k|k-1^{-1} + sum_{j: k_j = k} H_j^T H_j / sigma^2)^{-1}  (as scalar Joseph
              updates),  P_k+1|k = A P_k|k A^T + Q
    smoother: C_k = P_k|k A^T P_k+1|k^{-1},  P_k|T = P_k|k + C_k (P_k+1|T - P_k+1|k) C_k^T

The trajectory bound reported is CRB = (1/T) sum_k (P_k|T[x,x] + P_k|T[y,y])  [m^2], the bound on
the mean squared position error, so RMSE / sqrt(CRB) >= ~1 for any estimator (= 1 for an efficient
one). ``rmse_over_crb`` is that ratio.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from trackroom.scenes.camera import Camera
from trackroom.scenes.spec import GaussMarkovParams

POS = (0, 2)  # x and y in the state [x, vx, y, vy]


def bearing_jacobians(cameras: dict[str, Camera], cam_names, xy, z_h: float = 0.9) -> np.ndarray:
    """d u / d s (J, 4) of the horizontal image coordinate u (px) at floor points xy (J, 2).

    u = (P_0 . [x, y, z_h, 1]) / (P_2 . [x, y, z_h, 1]) for each observation's camera; for a
    horizontal camera this is Rahimi eq. 4. Velocity columns are zero.
    """
    xy = np.asarray(xy, float).reshape(-1, 2)
    names = np.asarray(cam_names, object)
    H = np.zeros((len(xy), 4))
    for name in set(names.tolist()):
        if name not in cameras:
            raise KeyError(f"observation from camera {name!r} that is not in the calibration")
        P = np.asarray(cameras[name].P, float)
        m = names == name
        hom = np.column_stack([xy[m], np.full(m.sum(), z_h), np.ones(m.sum())])
        num, den = hom @ P[0], hom @ P[2]
        grad = (P[0, :2][None, :] * den[:, None] - num[:, None] * P[2, :2][None, :]) / (den**2)[:, None]
        H[np.ix_(m, POS)] = grad
    return H


def _obs_information(T: int, k, H, sigma: float) -> np.ndarray:
    """Per-step observation information sum_j H_j^T H_j / sigma^2, (T, 4, 4)."""
    info = np.zeros((T, 4, 4))
    k = np.asarray(k, int)
    if len(k):
        np.add.at(info, k, np.einsum("ji,jk->jik", H, H) / sigma**2)
    return info


def smoothed_covariances(A, Q, P0, T: int, k, H, sigma: float) -> np.ndarray:
    """The 4x4 diagonal blocks of J_X^{-1} (T, 4, 4) by Kalman filter + RTS recursions.

    Covariance form throughout (the paper's prior makes the predicted covariances nearly singular,
    ~1e10 condition, so the information-form update 1/(1/P + H^T H) loses digits): each scalar
    measurement updates P by the Joseph form P <- (I - K h) P (I - K h)^T + sigma^2 K K^T,
    K = P h^T / (h P h^T + sigma^2), and the smoother gain is a linear solve, not an inverse.
    """
    H = np.asarray(H, float).reshape(-1, np.asarray(A).shape[0])
    return smoothed_covariances_rows(A, Q, P0, T, k, H / sigma)


def smoothed_covariances_rows(A, Q, P0, T: int, k, H) -> np.ndarray:
    """``smoothed_covariances`` for whitened rows h (unit noise) of any state size n, and a process
    noise Q that is one (n, n) matrix or one per transition ((T - 1, n, n)). Returns (T, n, n)."""
    A, Q, P0 = (np.asarray(M, float) for M in (A, Q, P0))
    n = A.shape[0]
    k = np.asarray(k, int)
    H = np.asarray(H, float).reshape(-1, n)
    Qk = np.broadcast_to(Q, (max(T - 1, 0), n, n)) if Q.ndim == 2 else Q
    order = np.argsort(k, kind="stable")
    k, H = k[order], H[order]
    starts = np.searchsorted(k, np.arange(T + 1))
    eye = np.eye(n)
    Pf = np.empty((T, n, n))
    Pp = np.empty((T, n, n))
    Pp[0] = P0
    for t in range(T):
        P = Pp[t]
        for h in H[starts[t] : starts[t + 1]]:
            Ph = P @ h
            K = Ph / (h @ Ph + 1.0)
            IKH = eye - np.outer(K, h)
            P = IKH @ P @ IKH.T + np.outer(K, K)
        Pf[t] = P
        if t + 1 < T:
            Pp[t + 1] = A @ P @ A.T + Qk[t]
    Ps = Pf.copy()
    for t in range(T - 2, -1, -1):
        Ck = np.linalg.solve(Pp[t + 1], A @ Pf[t]).T  # P_t|t A^T P_t+1|t^{-1} (both symmetric)
        Ps[t] = Pf[t] + Ck @ (Ps[t + 1] - Pp[t + 1]) @ Ck.T
        Ps[t] = 0.5 * (Ps[t] + Ps[t].T)
    return Ps


def information_matrix(A, Q, P0, T: int, k, H, sigma: float) -> sp.csc_matrix:
    """The sparse trajectory information J_X = G^T G + sum_j H_j^T H_j / sigma^2, (4T, 4T)."""
    A, Q, P0 = (np.asarray(M, float) for M in (A, Q, P0))
    W = np.linalg.cholesky(np.linalg.inv(Q)).T  # W^T W = Q^{-1}
    W0 = np.linalg.cholesky(np.linalg.inv(P0)).T
    rows = [sp.hstack([sp.csc_matrix(W0), sp.csc_matrix((4, 4 * (T - 1)))])] if T > 1 else [sp.csc_matrix(W0)]
    for t in range(1, T):
        r = sp.lil_matrix((4, 4 * T))
        r[:, 4 * (t - 1) : 4 * t] = W @ A
        r[:, 4 * t : 4 * t + 4] = -W
        rows.append(r.tocsc())
    G = sp.vstack(rows, format="csc")
    info = _obs_information(T, k, H, sigma)
    return (G.T @ G + sp.block_diag(list(info), format="csc")).tocsc()


@dataclass(frozen=True)
class TrajectoryCRB:
    """cov: smoothed bound covariances (T, 4, 4); pos_var: x + y variance bound per step (m^2);
    crb: their mean (m^2), the bound on the mean squared position error."""

    cov: np.ndarray
    pos_var: np.ndarray
    crb: float

    @property
    def sqrt_crb(self) -> float:
        return float(np.sqrt(self.crb))


def trajectory_crb(
    xy_true,
    k,
    cam_names,
    cameras: dict[str, Camera],
    sigma_px: float,
    dt: float,
    q_pos: float,
    q_vel: float,
    first_sigma=(100.0, 10.0, 100.0, 10.0),
    z_h: float = 0.9,
    discretisation: str = "exact",
) -> TrajectoryCRB:
    """The bound for a true path xy_true (T, 2) on a grid of step dt (s), observed at steps k by
    cameras cam_names (one entry per observation), with the Gauss-Markov prior (q_pos, q_vel per
    second; discretisation "paper": Q = diag(q_pos dt, q_vel dt) per axis, "exact": the
    continuous-time model's [[q_pos dt + q_vel dt^3/3, q_vel dt^2/2], [q_vel dt^2/2, q_vel dt]])
    and the weak first-state prior N(m_0, diag(first_sigma)^2) the estimator uses."""
    xy_true = np.asarray(xy_true, float)
    T = len(xy_true)
    k = np.asarray(k, int)
    if len(k) and (k.min() < 0 or k.max() >= T):
        raise ValueError(f"observation steps outside 0..{T - 1}")
    A = np.kron(np.eye(2), np.array([[1.0, dt], [0.0, 1.0]]))
    Q = _gm_Q(q_pos, q_vel, dt, discretisation)
    P0 = np.diag(np.asarray(first_sigma, float) ** 2)
    H = bearing_jacobians(cameras, cam_names, xy_true[k], z_h) if len(k) else np.zeros((0, 4))
    cov = smoothed_covariances(A, Q, P0, T, k, H, sigma_px)
    pos_var = cov[:, 0, 0] + cov[:, 2, 2]
    return TrajectoryCRB(cov=cov, pos_var=pos_var, crb=float(np.mean(pos_var)))


def rmse(xy_est, xy_true) -> float:
    """Root mean squared position error (m) over matched steps."""
    e = np.asarray(xy_est, float) - np.asarray(xy_true, float)
    return float(np.sqrt(np.mean(np.sum(e**2, axis=-1))))


def rmse_over_crb(xy_est, xy_true, bound: TrajectoryCRB) -> float:
    """RMSE / sqrt(CRB): 1 for an efficient estimator, larger for one that falls short of the bound."""
    return rmse(xy_est, xy_true) / bound.sqrt_crb


# --- the bound with the phone (issue 13) -----------------------------------------------------
@dataclass(frozen=True)
class PhoneRows:
    """The phone's factors as the fusion smoother models them (``estimators/fusion_model.py``), per
    grid step k: ``walking`` (T,) bool; ``cadence`` f_k (T,) Hz, NaN where none; noise of the speed
    row ``sigma_a`` and of the heading row ``sigma_c`` (T,) m/s; ``sigma_stop`` m/s; the step-length
    law's derivative ``dspeed_dl`` = ds_k / dl (T,) 1/s (None: the cadence, speed = f l) and the
    priors of the step length l and heading offset delta (``sigma_l`` m, ``sigma_delta`` rad);
    ``loose``: (T - 1,) transitions whose velocity noise is ``q_vel_phone`` (where the phone
    measures the velocity)."""

    walking: np.ndarray
    cadence: np.ndarray
    sigma_a: np.ndarray
    sigma_c: np.ndarray
    sigma_stop: float
    sigma_l: float
    sigma_delta: float
    loose: np.ndarray
    q_vel_phone: float
    dspeed_dl: np.ndarray | None = None


def _gm_Q(q_pos: float, q_vel: float, dt: float, discretisation: str) -> np.ndarray:
    """One step's process covariance: the walkers' and the smoothers' own (``GaussMarkovParams.Sigma``)."""
    return GaussMarkovParams(q_pos=q_pos, q_vel=q_vel).Sigma(dt, discretisation)


def trajectory_crb_phone(
    xy_true,
    vxy_true,
    k,
    cam_names,
    cameras: dict[str, Camera],
    sigma_px: float,
    dt: float,
    q_pos: float,
    q_vel: float,
    phone: PhoneRows | None,
    first_sigma=(100.0, 10.0, 100.0, 10.0),
    z_h: float = 0.9,
    discretisation: str = "paper",
) -> TrajectoryCRB:
    """The trajectory bound with the phone's factors (``phone``; None: bearings alone, the same
    prior). State [x, vx, y, vy, l, delta] with l, delta constant; at the true state (true
    velocity v_k, direction e_k = v_k / |v_k|, normal n_k, true offset 0) the phone rows are

        speed    h = [0, e_x, 0, e_y, -ds_k/dl, -(n_k . v_k)] / sigma_a,k     (walking, cadence f_k)
        heading  h = [0, n_x, 0, n_y, 0, e_k . v_k] / sigma_c,k             (walking)
        stopped  h = [0, 1, 0, 0, 0, 0] / sigma_stop and [0, 0, 0, 1, 0, 0] / sigma_stop

    (the robust losses are left out: a Gaussian bound). Returns the position bound as
    ``trajectory_crb`` does."""
    xy_true = np.asarray(xy_true, float)
    vxy = np.asarray(vxy_true, float)
    T = len(xy_true)
    k = np.asarray(k, int)
    n = 6
    A = np.eye(n)
    A[:4, :4] = np.kron(np.eye(2), np.array([[1.0, dt], [0.0, 1.0]]))
    Q0 = np.zeros((n, n))
    Q0[:4, :4] = _gm_Q(q_pos, q_vel, dt, discretisation)
    Qk = np.broadcast_to(Q0, (max(T - 1, 0), n, n)).copy()
    P0 = np.zeros((n, n))
    P0[:4, :4] = np.diag(np.asarray(first_sigma, float) ** 2)
    P0[4, 4], P0[5, 5] = 1.0, 1.0  # unused without the phone (no row touches l, delta)
    Hb = np.zeros((len(k), n))
    if len(k):
        Hb[:, :4] = bearing_jacobians(cameras, cam_names, xy_true[k], z_h) / sigma_px
    rows_k, rows_H = [k], [Hb]
    if phone is not None:
        P0[4, 4], P0[5, 5] = phone.sigma_l**2, phone.sigma_delta**2
        if T > 1 and np.any(phone.loose):
            Qk[np.asarray(phone.loose, bool), :4, :4] = _gm_Q(q_pos, phone.q_vel_phone, dt, discretisation)
        speed = np.hypot(vxy[:, 0], vxy[:, 1])
        e = vxy / np.maximum(speed, 1e-9)[:, None]
        nrm = np.stack([-e[:, 1], e[:, 0]], axis=1)
        walk = np.asarray(phone.walking, bool)
        kw = np.flatnonzero(walk)
        has = kw[np.isfinite(phone.cadence[kw])]
        Ha = np.zeros((len(has), n))
        dsdl = phone.cadence if phone.dspeed_dl is None else np.asarray(phone.dspeed_dl, float)
        Ha[:, 1], Ha[:, 3], Ha[:, 4] = e[has, 0], e[has, 1], -dsdl[has]
        Ha[:, 5] = -np.einsum("ij,ij->i", nrm[has], vxy[has])
        Ha /= phone.sigma_a[has][:, None]
        Hc = np.zeros((len(kw), n))
        Hc[:, 1], Hc[:, 3], Hc[:, 5] = nrm[kw, 0], nrm[kw, 1], speed[kw]
        Hc /= phone.sigma_c[kw][:, None]
        ks = np.flatnonzero(~walk)
        Hs = np.zeros((2 * len(ks), n))
        Hs[: len(ks), 1] = Hs[len(ks):, 3] = 1.0 / phone.sigma_stop
        rows_k += [has, kw, np.concatenate([ks, ks])]
        rows_H += [Ha, Hc, Hs]
    cov = smoothed_covariances_rows(A, Qk, P0, T, np.concatenate(rows_k), np.concatenate(rows_H))
    pos_var = cov[:, 0, 0] + cov[:, 2, 2]
    return TrajectoryCRB(cov=cov, pos_var=pos_var, crb=float(np.mean(pos_var)))
