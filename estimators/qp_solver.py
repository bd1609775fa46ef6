"""Gauss-Newton with one sparse QP per step (Rahimi et al. eqs. 8-10), solved by osqp.

Problem: minimise eps(X) = 0.5 ||r(X)||^2, r = [G X - g; (u(X) - y) / sigma]  s.t.  C X >= l.
X is the trajectory, optionally followed by extra parameters with a prior of their own
(``Prior.with_parameters``); the observation model ``obs`` is anything with ``residual(X)``,
``jacobian(X, n)`` and ``len`` (``qp_model.Bearings``, or a stack of residual blocks such as
``fusion_model.Residuals``).

Each step linearises the bearing residuals about the iterate X0 (eq. 10) and solves, for the
step dX, the constrained least-squares problem in the *lifted* form (the prior residual
z = G (X0 + dX) - g becomes a variable, so the stiff prior, precision ~1e10 on positions with the
paper's Sigma_nu, enters only as equality rows that osqp equilibrates instead of as a
badly-conditioned Hessian G^T G):

    minimise_{dY, z}  0.5 ||r_o + J_o S dY||^2 + 0.5 ||z||^2
    subject to        G S dY - z = -(G X0 - g)              (equalities)
                      C S dY >= l - C X0 (- extra rows)     (field of view, walls)

with dX = S dY, S a diagonal variable scaling (positions and velocities in units of their
typical step). Hessian P = blockdiag(S J_o^T J_o S, I), linear term q = [S J_o^T r_o; 0].
Tight tolerances and osqp's polishing make the step exact to ~1e-9 m; the previous step's
primal/dual solution warm-starts the next. A backtracking line search on eps keeps the
iterates feasible (C X >= l is convex and both ends of the segment are feasible).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import osqp
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .qp_model import NS, Bearings, Prior

SOLVED = "solved"


@dataclass
class SolverSettings:
    """Gauss-Newton and osqp settings.

    max_iter: Gauss-Newton iterations. tol_step: stop when the largest position change of a
    step is below this (m). tol_cost: or when the relative decrease of eps is below this.
    eps_abs, eps_rel: osqp tolerances. refine: make each osqp step exact by solving the KKT
    system of its active set; guess_rounds: active-set rounds tried from the previous step's
    active set before osqp (a poor guess is left to osqp, which then certifies or corrects it);
    active_set_rounds: rounds from osqp's active set. eps_find: osqp's tolerance when it only has to
    find the active set (the step is then the exact KKT solution, certified at eps_abs/eps_rel).
    pos_scale, vel_scale: variable scaling S (m, m/s). trust_kkt: a step whose active set passes
    the KKT test (``refine_active_set``: feasible, multipliers of the right sign, so the QP's unique
    solution) is taken without osqp's certification (which, when osqp's own iterate is poor, can
    take thousands of ADMM iterations to agree); off by default (qp_smoother's steps as before).
    """

    max_iter: int = 50
    tol_step: float = 1e-4
    tol_cost: float = 1e-10
    eps_abs: float = 1e-6
    eps_rel: float = 1e-6
    osqp_max_iter: int = 4000
    pos_scale: float = 1.0
    vel_scale: float = 0.1
    line_search: bool = True
    refine: bool = True
    guess_rounds: int = 10
    eps_find: float = 1e-3
    active_set_rounds: int = 100
    keep_iterates: bool = False
    trust_kkt: bool = False


@dataclass
class SolveResult:
    """The MAP trajectory and every diagnostic of how it was reached.

    converged: a stopping test was met (not the iteration cap, not a failed QP).
    reason: why it stopped. qp_status: osqp's status of every step ("solved", "solved inaccurate",
    "primal infeasible", ...). violation: the largest constraint violation of X (m, >= 0).
    """

    X: np.ndarray
    converged: bool
    reason: str
    iterations: int
    cost: list[float] = field(default_factory=list)
    qp_status: list[str] = field(default_factory=list)
    qp_iterations: list[int] = field(default_factory=list)
    qp_refined: list[bool] = field(default_factory=list)
    step_sizes: list[float] = field(default_factory=list)
    violation: float = 0.0
    seconds: float = 0.0
    iterates: list[np.ndarray] = field(default_factory=list)
    osqp_setups: int = 0

    def summary(self) -> dict:
        statuses = sorted(set(self.qp_status))
        return {
            "converged": bool(self.converged),
            "reason": self.reason,
            "iterations": int(self.iterations),
            "final_cost": float(self.cost[-1]) if self.cost else float("nan"),
            "qp_status": statuses,
            "qp_not_solved": int(sum(s != SOLVED for s in self.qp_status)),
            "qp_iterations": int(sum(self.qp_iterations)),
            "qp_refined": int(sum(self.qp_refined)),
            "violation_m": float(self.violation),
            "osqp_setups": int(self.osqp_setups),
            "seconds": float(self.seconds),
        }


def cost(prior: Prior, obs: Bearings, X: np.ndarray) -> float:
    """eps(X) = 0.5 ||r(X)||^2 (eq. 8); an observation model with ``loss(X)`` (robust rows whose
    ``residual`` is only the iterate's weighted model, ``fusion_model.Robust``) gives its own term."""
    rp = prior.residual(X)
    if hasattr(obs, "loss"):
        return 0.5 * float(rp @ rp) + float(obs.loss(X))
    ro = obs.residual(X) if len(obs) else np.zeros(0)
    return 0.5 * (float(rp @ rp) + float(ro @ ro))


ConstraintFn = "Callable[[np.ndarray], tuple[sp.csc_matrix, np.ndarray]]"


def sparse_lu(K: sp.spmatrix):
    """A factorisation of the sparse square matrix ``K`` with ``solve(rhs)`` (a vector or columns).

    Plain ``splu`` (COLAMD ordering) unless K has a few dense columns (extra parameters that every
    phone row touches: ``fusion_smoother``'s step length and pocket offset), which fill a sparse LU
    in whatever column order (T = 960: 9 of 12.6 s in factorisations). Those are split off as a
    border (``BorderedLU``): the rest keeps the trajectory's band structure. Without dense columns
    (``qp_smoother``) the factorisation is exactly as before. Where more than ``DENSE_MAX`` columns
    pass the test (the heading offset's knots, ``offset_knot_s``: each touches the phone rows of a few
    seconds, ~90 non-zeros, banded like the trajectory), only the ``DENSE_MAX`` fullest go to the
    border; the rest stay in the sparse LU (before: no border at all, and the step length's full
    column filled the LU in: T = 3840 took 140 s instead of 10)."""
    K = K.tocsc()
    nnz = np.diff(K.indptr)
    dense = np.nonzero(nnz > max(DENSE_NNZ, 20 * float(np.median(nnz)) if len(nnz) else 0))[0]
    if len(dense) == 0:
        return spla.splu(K, permc_spec="COLAMD")
    if len(dense) > DENSE_MAX:
        dense = np.sort(dense[np.argsort(-nnz[dense], kind="stable")[:DENSE_MAX]])
    return BorderedLU(K, dense)


#: a column with more non-zeros than this (and 20x the median) is dense; at most DENSE_MAX of them
DENSE_NNZ, DENSE_MAX = 64, 8


class BorderedLU:
    """LU of [[A, B], [C, D]] (D: the few dense rows and columns, permuted to the border) by the
    Schur complement: x_d = S^-1 (r_d - C A^-1 r_k), S = D - C A^-1 B, x_k = A^-1 (r_k - B x_d),
    with one sparse LU of A and a small dense S. Raises RuntimeError where A or S is singular, as
    ``splu`` does."""

    def __init__(self, K: sp.csc_matrix, dense: np.ndarray):
        n = K.shape[0]
        self.d = np.asarray(dense, int)
        keep = np.ones(n, bool)
        keep[self.d] = False
        self.k = np.nonzero(keep)[0]
        Kr = K.tocsr()
        rows_k, rows_d = Kr[self.k], Kr[self.d]
        self.lu = spla.splu(rows_k[:, self.k].tocsc(), permc_spec="COLAMD")
        B = rows_k[:, self.d].toarray()
        self.C = rows_d[:, self.k].tocsr()
        self.AiB = self.lu.solve(B)
        self.S = rows_d[:, self.d].toarray() - self.C @ self.AiB
        if not np.all(np.isfinite(self.S)) or np.linalg.cond(self.S) > 1e14:
            raise RuntimeError("singular border of the KKT system")

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        rhs = np.asarray(rhs, float)
        R = rhs.reshape(rhs.shape[0], -1)
        y = self.lu.solve(np.ascontiguousarray(R[self.k]))
        y = y.reshape(len(self.k), -1)
        xd = np.linalg.solve(self.S, R[self.d] - self.C @ y)
        out = np.empty_like(R)
        out[self.k] = y - self.AiB @ xd
        out[self.d] = xd
        return out.reshape(rhs.shape)


class StepKKT:
    """The equality-constrained part of the step QP, factorised once per Gauss-Newton step.

    Without inequality rows the step solves the KKT system of
    min 0.5 dY^T H dY + JTr^T dY + 0.5 ||z||^2  s.t.  GS dY - z = -rp  (z = lambda eliminated):

        K0 w = h,   K0 = [[H, GS^T], [GS, -I]],   w = [dY; lambda],   h = [-JTr; -rp].

    K0 (2n x 2n, symmetric quasi-definite) gets one sparse LU per step. With an active set C_a
    (rows E = [C_a, 0] on w) the KKT system [[K0, E^T], [E, 0]] [w; nu] = [h; b_a] is solved by
    the Schur complement on the few active rows:

        S nu = E w0 - b_a,   S = E K0^{-1} E^T = C_a (H + GS^T GS)^{-1} C_a^T  (positive definite),
        w = w0 - K0^{-1} E^T nu,   w0 = K0^{-1} h,

    so an active-set round costs |a| triangular solves (cached per row), not a new factorisation.
    """

    #: above this many active rows one sparse LU of the whole KKT system beats the dense Schur
    #: complement (and avoids multi-threaded dense LAPACK on a busy machine)
    SCHUR_MAX = 24
    #: -REG I on the active rows' block: dependent active rows (more than two at one step, or a
    #: wall row repeating a field-of-view row) keep the system solvable; the step moves by
    #: O(REG |nu|), far below the tolerances
    REG = 1e-10

    def __init__(self, H, JTr, GS, rp, Cs, b):
        self.n = H.shape[0]
        self.H, self.GS, self.JTr, self.rp = H, GS, JTr, rp
        self.Cs, self.b = Cs.tocsr(), np.asarray(b, float)
        K0 = sp.bmat([[H, GS.T], [GS, -sp.identity(self.n)]], format="csc")
        self.lu = sparse_lu(K0)
        self.w0 = self.lu.solve(np.concatenate([-JTr, -rp]))
        self.m_in = len(self.b)
        self.slack0 = self.Cs @ self.w0[: self.n] - self.b if self.m_in else np.zeros(0)
        # time step of each inequality row (its first non-zero column // 4)
        self.step_of = (self.Cs.indices[self.Cs.indptr[:-1]] // NS) if self.m_in else np.zeros(0, int)
        self._V: dict[int, np.ndarray] = {}  # row index -> K0^{-1} E_row^T (first n entries)
        self.factorisations = 1

    def _columns(self, rows: np.ndarray) -> np.ndarray:
        """(n, |rows|) top blocks of K0^{-1} E^T for the given inequality rows (cached)."""
        todo = [int(r) for r in rows if int(r) not in self._V]
        if todo:
            rhs = np.zeros((2 * self.n, len(todo)))
            rhs[: self.n] = self.Cs[todo].toarray().T
            sol = self.lu.solve(rhs)
            for j, r in enumerate(todo):
                self._V[r] = sol[: self.n, j]
        return np.stack([self._V[int(r)] for r in rows], axis=1)

    def _full(self, ia: np.ndarray):
        """The whole KKT system [[H, GS^T, C_a^T], [GS, -I, 0], [C_a, 0, 0]] by one sparse LU."""
        n, na = self.n, len(ia)
        Ca = self.Cs[ia].tocsc()
        K = sp.bmat([[self.H, self.GS.T, Ca.T], [self.GS, -sp.identity(n), None], [Ca, None, -self.REG * sp.identity(na)]],
                    format="csc")
        self.factorisations += 1
        sol = sparse_lu(K).solve(np.concatenate([-self.JTr, -self.rp, self.b[ia]]))
        return sol[:n], sol[2 * n:]

    def solve(self, active: np.ndarray):
        """Exact step for active set ``active``: (dY, nu on the active rows, slack of every row)."""
        ia = np.nonzero(active)[0]
        dY0 = self.w0[: self.n]
        if not len(ia):
            return dY0, np.zeros(0), self.slack0
        if len(ia) > self.SCHUR_MAX:
            try:
                dY, nu = self._full(ia)
            except RuntimeError:  # singular: dependent active rows
                return np.full(self.n, np.nan), np.zeros(len(ia)), self.slack0
            return dY, nu, self.Cs @ dY - self.b
        V = self._columns(ia)
        S = np.asarray(self.Cs[ia] @ V) + self.REG * np.eye(len(ia))
        r = self.slack0[ia]  # E w0 - b_a
        try:
            nu = np.linalg.solve(S, r)
        except np.linalg.LinAlgError:
            nu = np.linalg.lstsq(S, r, rcond=None)[0]
        dY = dY0 - V @ nu
        return dY, nu, self.Cs @ dY - self.b


def _most_violated_per_step(viol: np.ndarray, slack: np.ndarray, step_of: np.ndarray) -> np.ndarray:
    """The most violated of the violated rows at each time step (rows on one step compete for
    its two degrees of freedom; adding them all at once makes the active rows dependent)."""
    iv = np.nonzero(viol)[0]
    order = iv[np.lexsort((slack[iv], step_of[iv]))]
    _, first = np.unique(step_of[order], return_index=True)
    out = np.zeros_like(viol)
    out[order[first]] = True
    return out


def refine_active_set(kkt: StepKKT, active, max_rounds=100, bulk_rounds=8):
    """Exact solution of the step QP for a guessed active set, corrected by active-set rounds.

    For the active set a, ``kkt.solve`` gives the exact KKT solution; the multipliers of
    C dY >= b are mu = -nu >= 0. The first ``bulk_rounds`` rounds are primal-dual active-set
    updates (the most violated row of every step joins, every row with mu < 0 leaves: few rounds
    from a poor guess); after that violated rows join and only the most negative quarter of the
    negative multipliers leaves per round (no cycling in practice; the round cap ends it anyway). It stops when the KKT conditions hold: then the step is the QP's unique
    solution (the QP is strictly convex in dY). Returns (dY, y, active) with y the multipliers in
    osqp's convention (nu on the inequality rows, 0 off the active set), or None when the rounds
    run out.
    """
    m_in, b = kkt.m_in, kkt.b
    active = np.array(active, bool)
    tol = 1e-9 * max(1.0, float(np.max(np.abs(b))) if m_in else 1.0)
    for rnd in range(max_rounds):
        ia = np.nonzero(active)[0]
        dY, nu, slack = kkt.solve(active)
        if not (np.all(np.isfinite(dY)) and np.all(np.isfinite(nu))):
            return None
        mu = np.zeros(m_in)
        mu[ia] = -nu
        neg = active & (mu < -1e-9 * max(1.0, float(np.max(np.abs(nu))) if len(ia) else 1.0))
        viol = (~active) & (slack < -tol)
        if not neg.any() and not viol.any():
            y_in = np.zeros(m_in)
            y_in[ia] = nu
            return dY, y_in, active
        if viol.any():
            active = active | _most_violated_per_step(viol, slack, kkt.step_of)
        if rnd < bulk_rounds:
            active &= ~neg
        elif neg.any():
            # the most negative quarter of them (at least one): far from the answer this still
            # takes few rounds; near it, one at a time
            n_drop = max(1, int(neg.sum()) // 4)
            active[np.argsort(np.where(neg, mu, np.inf))[:n_drop]] = False
    return None


def _osqp_P(P_obs, n: int) -> sp.csc_matrix:
    """Upper triangle of P = blockdiag(P_obs, I) in canonical CSC form."""
    P = sp.triu(sp.block_diag([P_obs, sp.identity(n, format="csc")], format="csc"), format="csc")
    P.sort_indices()
    return P


def _osqp_A(GS, Cs) -> sp.csc_matrix:
    """A = [[GS, -I], [C S, 0]]: prior equalities, then the inequality rows."""
    n, m_in = GS.shape[1], Cs.shape[0]
    I_n = sp.identity(n, format="csc")
    A = sp.vstack([sp.hstack([GS, -I_n]), sp.hstack([Cs, sp.csc_matrix((m_in, n))])], format="csc")
    A.sort_indices()
    return A


class StepQP:
    """osqp for the lifted step QP (module docstring), set up once and updated while the sparsity
    pattern of P and A is unchanged (the Jacobian and constraint patterns are fixed across
    Gauss-Newton steps unless the wall rows change)."""

    def __init__(self, s: "SolverSettings"):
        self.s = s
        self.solver = None
        self.pattern = None
        self.setups = 0
        self._A_key, self._A = None, None  # A only changes with the inequality rows (and a nonlinear prior)

    def solve(self, P_obs, JTr, GS, rp, Cs, b, warm, eps: float | None = None):
        """osqp on the step QP; eps (optional) replaces the tolerances for this solve only."""
        n, m_in = GS.shape[1], Cs.shape[0]
        Cs = Cs.tocsc()
        # GS too: a prior linearised at every iterate (``solve_map``) changes it
        key = (Cs.shape, Cs.indptr.tobytes(), Cs.indices.tobytes(), Cs.data.tobytes(), GS.indptr.tobytes(),
               GS.indices.tobytes(), GS.data.tobytes())
        same_A = key == self._A_key
        if not same_A:
            self._A_key, self._A = key, _osqp_A(GS, Cs)
        P, A = _osqp_P(P_obs, n), self._A
        q = np.concatenate([JTr, np.zeros(n)])
        lo = np.concatenate([-rp, b])
        hi = np.concatenate([-rp, np.full(m_in, np.inf)])
        pattern = (P.shape, P.indptr.tobytes(), P.indices.tobytes(), A.shape, A.indptr.tobytes(), A.indices.tobytes())
        s = self.s
        if self.solver is not None and pattern == self.pattern:
            if same_A:
                self.solver.update(q=q, l=lo, u=hi, Px=P.data)
            else:
                self.solver.update(q=q, l=lo, u=hi, Px=P.data, Ax=A.data)
        else:
            self.solver = osqp.OSQP()
            self.solver.setup(
                P, q, A, lo, hi, verbose=False, eps_abs=s.eps_abs, eps_rel=s.eps_rel, eps_prim_inf=1e-10,
                eps_dual_inf=1e-10, max_iter=s.osqp_max_iter, polishing=False, warm_starting=True,
            )
            self.pattern = pattern
            self.setups += 1
        if warm is not None:
            self.solver.warm_start(x=warm[0], y=warm[1])
        if eps is None:
            return self.solver.solve(raise_error=False)
        self.solver.update_settings(eps_abs=eps, eps_rel=eps)
        try:
            return self.solver.solve(raise_error=False)
        finally:
            self.solver.update_settings(eps_abs=s.eps_abs, eps_rel=s.eps_rel)


def qp_step(P_obs, JTr, GS, rp, Cs, b, active_guess, s: SolverSettings, qp: StepQP | None = None):
    """One Gauss-Newton step: the lifted QP (module docstring) solved by osqp, made exact.

    1. The exact solution for the previous step's active set, corrected by a few active-set
       rounds (``refine_active_set``). 2. When that fails (first step, or the set changed a lot):
       osqp at the loose tolerance ``s.eps_find`` finds the active set, and its exact solution
       is computed. 3. osqp at the tight tolerance, warm-started from that exact solution,
       certifies it (25 ADMM iterations when it is right) or moves to the right active set,
       whose exact solution is the step. Returns (dY, status, osqp iterations, refined, active).
    """
    n = GS.shape[1]
    m_in = Cs.shape[0]
    qp = qp or StepQP(s)
    guess, kkt, warm, iters = None, None, None, 0
    if s.refine:
        try:
            kkt = StepKKT(P_obs, JTr, GS, rp, Cs, b)
        except RuntimeError:  # singular K0 (cannot happen with the weak first-state prior)
            kkt = None
    if kkt is not None:
        rounds = s.guess_rounds
        if active_guess is None or len(active_guess) != m_in:
            # no previous set: try only whether the unconstrained step is feasible
            active_guess, rounds = np.zeros(m_in, bool), 1
        guess = refine_active_set(kkt, active_guess, max_rounds=rounds)
        if guess is None and m_in:
            rough = qp.solve(P_obs, JTr, GS, rp, Cs, b, None, eps=s.eps_find)
            iters += int(rough.info.iter)
            if rough.x is not None and np.all(np.isfinite(rough.x)):
                guess = refine_active_set(kkt, _active_of(rough, Cs, b, n), max_rounds=s.active_set_rounds)
        if guess is not None and s.trust_kkt:
            return guess[0], SOLVED, iters, True, guess[2]
        if guess is not None:
            dY0, y_in, _ = guess
            z0 = GS @ dY0 + rp
            # lambda = z at the optimum (stationarity in z)
            warm = (np.concatenate([dY0, z0]), np.concatenate([z0, y_in]))
    out = qp.solve(P_obs, JTr, GS, rp, Cs, b, warm)
    status = str(out.info.status)
    iters += int(out.info.iter)
    usable = out.x is not None and np.all(np.isfinite(out.x)) and status in (
        SOLVED, "solved inaccurate", "maximum iterations reached",
    )
    if not usable:
        return None, status, iters, False, None
    dY = out.x[:n]
    active = _active_of(out, Cs, b, n)
    if kkt is not None:
        if guess is not None and np.array_equal(active, guess[2]):
            return guess[0], status, iters, True, active
        exact = refine_active_set(kkt, active, max_rounds=s.active_set_rounds)
        if exact is not None:
            return exact[0], status, iters, True, exact[2]
    return dY, status, iters, False, active


def _active_of(out, Cs, b, n: int) -> np.ndarray:
    """osqp's active inequality rows: a negative multiplier and (almost) no slack."""
    if not Cs.shape[0]:
        return np.zeros(0, bool)
    slack = Cs @ out.x[:n] - b
    return (out.y[n:] < 0) & (slack < 1e-3)


def _extra(fn, X):
    """(C_x, l_x, keys or None) from an iterate-dependent constraint function."""
    out = fn(X)
    return (out[0], out[1], np.asarray(out[2])) if len(out) == 3 else (out[0], out[1], None)


def solve_map(
    prior: Prior,
    obs: Bearings,
    X0: np.ndarray,
    C: sp.csc_matrix | None = None,
    lower: np.ndarray | None = None,
    extra_constraints=None,
    settings: SolverSettings | None = None,
) -> SolveResult:
    """Gauss-Newton / sequential QP from X0.

    C, lower: fixed linear constraints C X >= lower (the field-of-view rows; may be empty).
    extra_constraints: optional function X -> (C_x, l_x[, keys]) of rows re-decided at every iterate
    (walls and obstacles, whose relevant side depends on where the iterate is).
    prior: a ``qp_model.Prior`` (linear: G X - g), or anything with ``residual(X)``, ``jacobian(X)``
    (square, invertible), ``G``, ``n``, ``T``, ``par_scale``, linearised at every iterate.
    """
    s = settings or SolverSettings()
    t_start = time.perf_counter()
    n = prior.n  # trajectory (NS T) and any extra parameters (``Prior.with_parameters``)
    nx = NS * prior.T
    X = np.asarray(X0, float).copy()
    if X.shape != (n,):
        raise ValueError(f"initial trajectory has shape {X.shape}, expected ({n},)")
    if C is None:
        C, lower = sp.csc_matrix((0, n)), np.zeros(0)
    scale = np.concatenate([np.tile([s.pos_scale, s.vel_scale, s.pos_scale, s.vel_scale], prior.T), prior.par_scale])
    S = sp.diags(scale)
    GS = (prior.G @ S).tocsc()
    nonlinear_prior = hasattr(prior, "jacobian")
    res = SolveResult(X=X, converged=False, reason="", iterations=0)
    eps_now = cost(prior, obs, X)
    res.cost.append(eps_now)
    if s.keep_iterates:
        res.iterates.append(X.copy())
    active, keys_prev = None, None
    qp = StepQP(s)
    for it in range(s.max_iter):
        Jo = obs.jacobian(X, n) if len(obs) else sp.csc_matrix((0, n))
        ro = obs.residual(X) if len(obs) else np.zeros(0)
        JoS = (Jo @ S).tocsc()
        Cx, lx, guess = C, lower, active
        if extra_constraints is not None:
            Ce, le, keys = _extra(extra_constraints, X)
            if Ce.shape[0]:
                Cx, lx = sp.vstack([C, Ce], format="csc"), np.concatenate([lower, le])
            # carry the active set over to the re-decided rows that are the same as before
            guess = None
            if active is not None and keys is not None and keys_prev is not None:
                m0 = C.shape[0]
                was = set(keys_prev[active[m0:]].tolist())
                guess = np.concatenate([active[:m0], np.array([kk in was for kk in keys.tolist()], bool)])
            keys_prev = keys
        rp = prior.residual(X)
        if nonlinear_prior:  # a prior with a jacobian (fusion_model.ScaledPrior): linearised at X
            GS = (prior.jacobian(X) @ S).tocsc()
        dY, status, iters, refined, active = qp_step(
            (JoS.T @ JoS).tocsc(), JoS.T @ ro, GS, rp, (Cx @ S).tocsc(), lx - Cx @ X, guess, s, qp,
        )
        res.qp_status.append(status)
        res.qp_refined.append(refined)
        res.qp_iterations.append(iters)
        res.iterations = it + 1
        if dY is None:
            res.reason = f"QP step {it + 1} failed: osqp status {status!r}"
            break
        dX = scale * dY
        alpha, eps_new = 1.0, cost(prior, obs, X + dX)
        if s.line_search:
            while eps_new > eps_now and alpha > 1e-4:
                alpha *= 0.5
                eps_new = cost(prior, obs, X + alpha * dX)
        res.step_sizes.append(alpha)
        if eps_new > eps_now:
            # no descent: at a minimum to numerical precision when the step was exact
            res.converged = refined or status == SOLVED
            res.reason = f"no decrease along step {it + 1} (QP status {status!r})"
            break
        X = X + alpha * dX
        rel = (eps_now - eps_new) / max(eps_now, 1e-300)
        eps_now = eps_new
        res.cost.append(eps_now)
        if s.keep_iterates:
            res.iterates.append(X.copy())
        step_pos = float(np.max(np.abs(alpha * dX[np.r_[0:nx:NS, 2:nx:NS]]))) if nx else 0.0
        if step_pos < s.tol_step:
            res.converged, res.reason = True, f"step below {s.tol_step} m"
            break
        if rel < s.tol_cost and alpha == 1.0:
            res.converged, res.reason = True, f"relative cost decrease below {s.tol_cost}"
            break
    else:
        res.reason = f"iteration cap {s.max_iter} reached"
    res.X = X
    viol = 0.0
    if C.shape[0]:
        viol = max(viol, float(np.max(np.maximum(lower - C @ X, 0.0))))
    if extra_constraints is not None:
        Ce, le, _ = _extra(extra_constraints, X)
        if Ce.shape[0]:
            viol = max(viol, float(np.max(np.maximum(le - Ce @ X, 0.0))))
    res.violation = viol
    res.osqp_setups = qp.setups
    res.seconds = time.perf_counter() - t_start
    return res
