"""Gauss-Newton with one sparse QP per step (Rahimi et al. eqs. 8-10), solved by osqp.

Problem: minimise eps(X) = 0.5 ||r(X)||^2, r = [G X - g; (u(X) - y) / sigma]  s.t.  C X >= l.

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
    system of its active set; active_set_rounds: primal active-set rounds tried from the previous
    step's active set before osqp (whose result osqp then certifies). pos_scale, vel_scale: variable scaling S (m, m/s).
    """

    max_iter: int = 50
    tol_step: float = 1e-5
    tol_cost: float = 1e-10
    eps_abs: float = 1e-6
    eps_rel: float = 1e-6
    osqp_max_iter: int = 4000
    pos_scale: float = 1.0
    vel_scale: float = 0.1
    line_search: bool = True
    refine: bool = True
    active_set_rounds: int = 20
    keep_iterates: bool = False


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
            "seconds": float(self.seconds),
        }


def cost(prior: Prior, obs: Bearings, X: np.ndarray) -> float:
    """eps(X) = 0.5 ||r(X)||^2 (eq. 8)."""
    rp = prior.residual(X)
    ro = obs.residual(X) if len(obs) else np.zeros(0)
    return 0.5 * (float(rp @ rp) + float(ro @ ro))


ConstraintFn = "Callable[[np.ndarray], tuple[sp.csc_matrix, np.ndarray]]"


def refine_active_set(H, JTr, GS, rp, Cs, b, active, max_rounds=12):
    """Exact solution of the step QP for a guessed active set, corrected by active-set rounds.

    Solves the KKT system of  min 0.5 dY^T H dY + JTr^T dY + 0.5 ||z||^2  s.t.  GS dY - z = -rp,
    C_a dY = b_a  (z = lambda eliminated):

        [ H    GS^T  C_a^T ] [dY    ]   [-JTr]
        [ GS   -I    0     ] [lambda] = [-rp ]
        [ C_a  0     0     ] [nu    ]   [ b_a]

    with a sparse LU. The multipliers of C dY >= b are mu = -nu >= 0. Constraints with mu < 0 leave
    the set one at a time, violated ones join it, until the KKT conditions hold. Returns (dY, y, active) with y
    the multipliers in osqp's convention ([lambda; nu], nu = 0 off the active set), or None.
    """
    n = H.shape[0]
    m_in = len(b)
    active = np.array(active, bool)
    tol = 1e-9 * max(1.0, float(np.max(np.abs(b))) if m_in else 1.0)
    for _ in range(max_rounds):
        ia = np.nonzero(active)[0]
        Ca = Cs[ia]
        na = len(ia)
        K = sp.bmat(
            [[H, GS.T, Ca.T], [GS, -sp.identity(n), None], [Ca, None, sp.csc_matrix((na, na))]], format="csc"
        )
        rhs = np.concatenate([-JTr, -rp, b[ia]])
        try:
            sol = spla.splu(K, permc_spec="COLAMD").solve(rhs)
        except RuntimeError:  # singular: dependent active rows
            return None
        if not np.all(np.isfinite(sol)):
            return None
        dY = sol[:n]
        nu = sol[2 * n :]
        slack = Cs @ dY - b if m_in else np.zeros(0)
        mu = np.zeros(m_in)
        mu[ia] = -nu
        neg = active & (mu < -1e-9 * max(1.0, float(np.max(np.abs(nu))) if na else 1.0))
        viol = (~active) & (slack < -tol)
        if not neg.any() and not viol.any():
            y_in = np.zeros(m_in)
            y_in[ia] = nu
            return dY, np.concatenate([sol[n : 2 * n], y_in]), active
        # add every violated row, drop only the most negative multiplier (avoids cycling)
        active = active | viol
        if neg.any():
            active[np.argmin(np.where(neg, mu, np.inf))] = False
    return None


def qp_step(P_obs, JTr, GS, rp, Cs, b, active_guess, s: SolverSettings):
    """One Gauss-Newton step: the lifted QP (module docstring) solved by osqp, made exact.

    The exact solution for the previous step's active set (``refine_active_set``) warm-starts
    osqp; osqp then certifies it or moves to the right active set, whose exact solution is the
    step. Returns (dY, status, osqp iterations, refined, active set).
    """
    n = GS.shape[1]
    m_in = Cs.shape[0]
    I_n = sp.identity(n, format="csc")
    P = sp.block_diag([P_obs, I_n], format="csc")
    q = np.concatenate([JTr, np.zeros(n)])
    A = sp.vstack(
        [sp.hstack([GS, -I_n]), sp.hstack([Cs, sp.csc_matrix((m_in, n))])], format="csc"
    )
    lo = np.concatenate([-rp, b])
    hi = np.concatenate([-rp, np.full(m_in, np.inf)])
    solver = osqp.OSQP()
    solver.setup(
        sp.triu(P, format="csc"), q, A, lo, hi, verbose=False, eps_abs=s.eps_abs, eps_rel=s.eps_rel,
        eps_prim_inf=1e-10, eps_dual_inf=1e-10, max_iter=s.osqp_max_iter, polishing=False, warm_starting=True,
    )
    guess = None
    if s.refine:
        if active_guess is None or len(active_guess) != m_in:
            active_guess = np.zeros(m_in, bool)
        guess = refine_active_set(P_obs, JTr, GS, rp, Cs, b, active_guess, max_rounds=s.active_set_rounds)
        if guess is not None:
            dY0, y0, _ = guess
            solver.warm_start(x=np.concatenate([dY0, GS @ dY0 + rp]), y=y0)
    out = solver.solve(raise_error=False)
    status = str(out.info.status)
    iters = int(out.info.iter)
    usable = out.x is not None and np.all(np.isfinite(out.x)) and status in (
        SOLVED, "solved inaccurate", "maximum iterations reached",
    )
    if not usable:
        return None, status, iters, False, None
    dY = out.x[:n]
    active = np.zeros(m_in, bool)
    if s.refine:
        y_in = out.y[n:]
        slack = Cs @ dY - b if m_in else np.zeros(0)
        active = (y_in < 0) & (slack < 1e-3) if m_in else active
        if guess is not None and np.array_equal(active, guess[2]):
            return guess[0], status, iters, True, active
        exact = refine_active_set(P_obs, JTr, GS, rp, Cs, b, active)
        if exact is not None:
            return exact[0], status, iters, True, exact[2]
    return dY, status, iters, False, active


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
    extra_constraints: optional function X -> (C_x, l_x) of rows re-decided at every iterate
    (walls and obstacles, whose relevant side depends on where the iterate is).
    """
    s = settings or SolverSettings()
    t_start = time.perf_counter()
    n = NS * prior.T
    X = np.asarray(X0, float).copy()
    if X.shape != (n,):
        raise ValueError(f"initial trajectory has shape {X.shape}, expected ({n},)")
    if C is None:
        C, lower = sp.csc_matrix((0, n)), np.zeros(0)
    scale = np.tile([s.pos_scale, s.vel_scale, s.pos_scale, s.vel_scale], prior.T)
    S = sp.diags(scale)
    GS = (prior.G @ S).tocsc()
    res = SolveResult(X=X, converged=False, reason="", iterations=0)
    eps_now = cost(prior, obs, X)
    res.cost.append(eps_now)
    if s.keep_iterates:
        res.iterates.append(X.copy())
    active = None
    for it in range(s.max_iter):
        Jo = obs.jacobian(X, n) if len(obs) else sp.csc_matrix((0, n))
        ro = obs.residual(X) if len(obs) else np.zeros(0)
        JoS = (Jo @ S).tocsc()
        Cx, lx = C, lower
        if extra_constraints is not None:
            Ce, le = extra_constraints(X)
            if Ce.shape[0]:
                Cx, lx = sp.vstack([C, Ce], format="csc"), np.concatenate([lower, le])
        rp = prior.residual(X)
        dY, status, iters, refined, active = qp_step(
            (JoS.T @ JoS).tocsc(), JoS.T @ ro, GS, rp, (Cx @ S).tocsc(), lx - Cx @ X,
            active if extra_constraints is None else None, s,
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
        step_pos = float(np.max(np.abs(alpha * dX[np.r_[0:n:NS, 2:n:NS]]))) if n else 0.0
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
        Ce, le = extra_constraints(X)
        if Ce.shape[0]:
            viol = max(viol, float(np.max(np.maximum(le - Ce @ X, 0.0))))
    res.violation = viol
    res.seconds = time.perf_counter() - t_start
    return res
