"""The model of the QP smoother (Rahimi, Dunagan, Darrell 2004): prior, bearings, constraints.

State per time step k (grid t_k = t_0 + k dt, k = 0..T-1): s_k = [u, u', v, v'] = [x, vx, y, vy]
(metres, m/s). The trajectory X = [s_0; ...; s_{T-1}] has n = 4T entries.

Prior (eqs. 1-3): s_{k+1} = A s_k + nu_k, nu_k ~ N(0, Sigma), with A(dt) from
``scenes.spec.GaussMarkovParams`` and Sigma(dt) from its per-second q_pos, q_vel
(``process_covariance``: the paper's A and Sigma_nu = 1e-6 diag(1e-4, 1, 1e-4, 1) at dt = 0.5 s
are the default q; the "exact" discretisation makes another frame rate mean the same prior).
With W = Sigma^{-1/2} (inverse Cholesky factor) the whitened prior residual is

    r_p(X) = G X - g,   rows k = 1..T-1:  W (A s_{k-1} - s_k)            (eq. 3)
                        first state:      W_0 (s_0 - m_0)    (a weak prior, N(m_0, W_0^{-2}))

so -log p(X) = 0.5 ||G X - g||^2 + const and the prior information is G^T G (block tridiagonal).

Bearings (eq. 4, written with the calibrated 3x4 projection P so that horizontal and oblique
cameras share one model): a person at floor point (x, y) and assumed height z_h projects to the
horizontal image coordinate

    u(x, y) = (P_0 . [x, y, z_h, 1]) / (P_2 . [x, y, z_h, 1]) = (a . x + c) / (b . x + d)   [px]

For a horizontal camera b = (cos yaw, sin yaw), d = -b . p (P_2 = [R_2 | t_2] as K_2 = [0 0 1]) and
this is exactly eq. 4: u = f R_y(x - p) / R_x(x - p) + c_x. The whitened residual of observation
j is r_j = (u(x_{k_j}) - u_j) / sigma_px; its gradient w.r.t. (x, y) is
(a (b . x + d) - (a . x + c) b) / (b . x + d)^2 / sigma_px.

Field-of-view constraint (eq. 9, Fig. 2): the observed point lies in front of the camera,

    n^T (x_k - p) >= margin,   n = b / |b|,   i.e. (b . x + d) / |b| >= margin   [m]

which is linear in X. For a horizontal camera n = (cos yaw, sin yaw) is the optical axis.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from trackroom.scenes.camera import Camera
from trackroom.scenes.spec import GaussMarkovParams

NS = 4  # state size per step
IX, IVX, IY, IVY = 0, 1, 2, 3


DISCRETISATIONS = ("exact", "paper")


def process_covariance(params: GaussMarkovParams, dt: float, kind: str = "exact") -> np.ndarray:
    """Sigma(dt) of one step of dt seconds, state [x, vx, y, vy].

    "paper": diag(q_pos dt, q_vel dt) per axis (``GaussMarkovParams.Sigma``; at dt = 0.5 s and the
    default q this is the paper's Sigma_nu = 1e-6 diag(1e-4, 1)). It does not compose: n steps of
    dt/n give a position variance that grows like q_vel dt^3 / 3, which this ignores, so a walker
    simulated at 100 Hz is far from this prior at 4 Hz.
    "exact": the covariance of the continuous-time model dx = v dt + sqrt(q_pos) dW_1,
    dv = sqrt(q_vel) dW_2 over dt, per axis [[q_pos dt + q_vel dt^3 / 3, q_vel dt^2 / 2],
    [q_vel dt^2 / 2, q_vel dt]]. It composes exactly over sub-steps, so it is the same prior at
    every frame rate (and the matched prior of a Gauss-Markov walker simulated at a finer rate).
    """
    if kind not in DISCRETISATIONS:
        raise ValueError(f"discretisation must be one of {DISCRETISATIONS}, got {kind!r}")
    return params.Sigma(dt, kind)


def pos_index(T: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices of x and y of every step in X."""
    k = np.arange(T) * NS
    return k + IX, k + IY


@dataclass(frozen=True)
class Prior:
    """The whitened linear prior r_p = G X - g (sparse G, (n, n), n = 4T + extra parameters).

    ``par_scale``: the solver's variable scale of each extra parameter after the 4T trajectory
    entries (``with_parameters``); empty for a trajectory alone.
    """

    G: sp.csc_matrix
    g: np.ndarray
    dt: float
    T: int
    par_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n(self) -> int:
        """Number of variables: 4T trajectory entries, then the extra parameters."""
        return self.G.shape[1]

    def with_parameters(self, mean, sigma, scale) -> "Prior":
        """This prior with extra parameters theta appended to X, each with an independent
        Gaussian prior N(mean, sigma^2): rows (theta - mean) / sigma below G (block diagonal, so
        G stays square as the lifted solver needs). ``scale``: their typical step (the solver's
        variable scaling), in their own units."""
        mean, sigma, scale = (np.asarray(a, float).ravel() for a in (mean, sigma, scale))
        if not (len(mean) == len(sigma) == len(scale)) or np.any(sigma <= 0) or np.any(scale <= 0):
            raise ValueError("extra parameters need one mean, positive sigma and positive scale each")
        return self.with_parameter_rows(sp.diags(1.0 / sigma), mean / sigma, scale)

    def with_parameter_rows(self, W, w, scale) -> "Prior":
        """This prior with extra parameters theta appended to X and the prior rows W theta - w
        below G (W square and invertible, e.g. a random walk's differences, so G stays square as
        the lifted solver needs). ``scale``: their typical step (the solver's variable scaling)."""
        W = sp.csc_matrix(W)
        w, scale = np.asarray(w, float).ravel(), np.asarray(scale, float).ravel()
        if W.shape[0] != W.shape[1] or not (W.shape[0] == len(w) == len(scale)) or np.any(scale <= 0):
            raise ValueError("extra parameters need a square W, one w and one positive scale each")
        G = sp.block_diag([self.G, W], format="csc")
        g = np.concatenate([self.g, w])
        return Prior(G=G, g=g, dt=self.dt, T=self.T, par_scale=np.concatenate([self.par_scale, scale]))

    @staticmethod
    def build(
        T: int,
        dt: float,
        params: GaussMarkovParams,
        first_mean=(0.0, 0.0, 0.0, 0.0),
        first_sigma=(100.0, 10.0, 100.0, 10.0),
        discretisation: str = "exact",
        alt: tuple[GaussMarkovParams, np.ndarray] | None = None,
    ) -> "Prior":
        """Build G (eq. 3) for T steps of dt seconds, plus the weak first-state prior.

        alt: (params', mask) -- transitions k-1 -> k with mask[k-1] True use the process noise
        params' instead (a prior that is looser where another sensor measures the velocity).
        first_sigma: standard deviations (m, m/s, m, m/s) of the first state about first_mean.
        discretisation: how Sigma(dt) follows from the per-second q (``process_covariance``).
        W = L^{-1} with Sigma = L L^T, so that W^T W = Sigma^{-1}.
        """
        if T < 1:
            raise ValueError(f"need at least one time step, got T={T}")
        if not dt > 0:
            raise ValueError(f"time step must be positive, got dt={dt}")
        A = params.A(dt)

        def whitener(par):
            Sig = process_covariance(par, dt, discretisation)
            if np.any(np.diag(Sig) <= 0) or par.q_vel <= 0:
                raise ValueError(f"process noise must be positive, got q_pos={par.q_pos}, q_vel={par.q_vel}")
            W = np.linalg.inv(np.linalg.cholesky(Sig))
            W[np.abs(W) < 1e-300] = 0.0
            return W

        W = whitener(params)
        W0 = np.diag(1.0 / np.asarray(first_sigma, float))
        nb = T - 1
        # block rows: first-state prior, then one per transition
        blocks_r, blocks_c, vals = [], [], []
        ii, jj = np.nonzero(W0)
        blocks_r.append(ii)
        blocks_c.append(jj)
        vals.append(W0[ii, jj])
        if nb:
            k = np.arange(1, T)
            # the whitener of each transition k-1 -> k (the alternative where ``alt`` says so)
            Wk = np.broadcast_to(W, (nb, NS, NS)).copy()
            if alt is not None:
                par_alt, mask = alt
                mask = np.asarray(mask, bool)
                if mask.shape != (nb,):
                    raise ValueError(f"alt mask needs one entry per transition ({nb}), got {mask.shape}")
                Wk[mask] = whitener(par_alt)
            mi, mj = np.nonzero(np.ones((NS, NS)))
            for M, col_off in ((Wk @ A, -1), (-Wk, 0)):
                r = (k[:, None] * NS + mi[None, :]).ravel()
                c = ((k + col_off)[:, None] * NS + mj[None, :]).ravel()
                v = M[:, mi, mj].ravel()
                nz = v != 0
                blocks_r.append(r[nz])
                blocks_c.append(c[nz])
                vals.append(v[nz])
        G = sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(blocks_r), np.concatenate(blocks_c))), shape=(NS * T, NS * T)
        )
        g = np.zeros(NS * T)
        g[:NS] = W0 @ np.asarray(first_mean, float)
        return Prior(G=G, g=g, dt=float(dt), T=int(T))

    def residual(self, X: np.ndarray) -> np.ndarray:
        return self.G @ X - self.g


@dataclass(frozen=True)
class Bearings:
    """Observed bearings of one person, as arrays over observations j.

    k: time-step index; u: observed horizontal image coordinate (px); a, b (J, 2) and c, d (J,):
    the rows of P restricted to the floor at height z_h (see module docstring); cam: camera index
    into ``names``; sigma: pixel noise (one sigma).
    """

    k: np.ndarray
    u: np.ndarray
    a: np.ndarray
    c: np.ndarray
    b: np.ndarray
    d: np.ndarray
    cam: np.ndarray
    names: tuple[str, ...]
    sigma: float

    @staticmethod
    def from_arrays(k, cam_names, u, cameras: dict[str, Camera], sigma: float, z_h: float = 0.9) -> "Bearings":
        """k: step index per observation; cam_names: camera name per observation; u: pixels."""
        k = np.asarray(k, int)
        u = np.asarray(u, float)
        cam_names = np.asarray(cam_names, object)
        names = tuple(sorted(set(cam_names.tolist())))
        missing = [n for n in names if n not in cameras]
        if missing:
            raise KeyError(f"bearings from camera(s) {missing} that are not in the calibration")
        rows = {}
        for n in names:
            P = np.asarray(cameras[n].P, float)
            rows[n] = (P[0, :2], P[0, 2] * z_h + P[0, 3], P[2, :2], P[2, 2] * z_h + P[2, 3])
        idx = np.array([names.index(n) for n in cam_names], int) if len(cam_names) else np.zeros(0, int)
        A_ = np.array([rows[n][0] for n in names]).reshape(-1, 2)
        C_ = np.array([rows[n][1] for n in names])
        B_ = np.array([rows[n][2] for n in names]).reshape(-1, 2)
        D_ = np.array([rows[n][3] for n in names])
        if len(names) and np.any(np.linalg.norm(B_, axis=1) < 1e-9):
            raise ValueError("a camera looks straight down: its bearing does not constrain the floor position")
        return Bearings(
            k=k, u=u, a=A_[idx] if len(idx) else np.zeros((0, 2)), c=C_[idx] if len(idx) else np.zeros(0),
            b=B_[idx] if len(idx) else np.zeros((0, 2)), d=D_[idx] if len(idx) else np.zeros(0),
            cam=idx, names=names, sigma=float(sigma),
        )

    def __len__(self) -> int:
        return len(self.k)

    def positions(self, X: np.ndarray) -> np.ndarray:
        """(J, 2) floor positions of the observed steps in trajectory X (extra parameters after
        the trajectory are ignored)."""
        return np.stack([X[self.k * NS + IX], X[self.k * NS + IY]], axis=1)

    def depth(self, X: np.ndarray) -> np.ndarray:
        """Signed distance in front of the camera, n^T (x - p) (m), per observation."""
        xy = self.positions(X)
        return (np.einsum("ij,ij->i", self.b, xy) + self.d) / np.linalg.norm(self.b, axis=1)

    def predict(self, X: np.ndarray) -> np.ndarray:
        xy = self.positions(X)
        return (np.einsum("ij,ij->i", self.a, xy) + self.c) / (np.einsum("ij,ij->i", self.b, xy) + self.d)

    def residual(self, X: np.ndarray) -> np.ndarray:
        """Whitened bearing residuals (u(x_k) - u) / sigma."""
        return (self.predict(X) - self.u) / self.sigma

    def jacobian(self, X: np.ndarray, n: int) -> sp.csc_matrix:
        """Sparse (J, n) Jacobian of the whitened residuals (two non-zeros per row)."""
        xy = self.positions(X)
        num = np.einsum("ij,ij->i", self.a, xy) + self.c
        den = np.einsum("ij,ij->i", self.b, xy) + self.d
        grad = (self.a * den[:, None] - num[:, None] * self.b) / (den**2)[:, None] / self.sigma
        rows = np.repeat(np.arange(len(self)), 2)
        cols = np.stack([self.k * NS + IX, self.k * NS + IY], axis=1).ravel()
        return sp.csc_matrix((grad.ravel(), (rows, cols)), shape=(len(self), n))

    def fov_constraints(self, n: int, margin: float) -> tuple[sp.csc_matrix, np.ndarray]:
        """Rows C and lower bounds l of C X >= l: one per observed (k, camera) pair (eq. 9)."""
        if len(self) == 0:
            return sp.csc_matrix((0, n)), np.zeros(0)
        key = self.k * (len(self.names) + 1) + self.cam
        _, first = np.unique(key, return_index=True)
        b = self.b[first]
        nb = np.linalg.norm(b, axis=1)
        k = self.k[first]
        rows = np.repeat(np.arange(len(first)), 2)
        cols = np.stack([k * NS + IX, k * NS + IY], axis=1).ravel()
        C = sp.csc_matrix(((b / nb[:, None]).ravel(), (rows, cols)), shape=(len(first), n))
        lower = margin - self.d[first] / nb
        return C, lower
