"""``qp_smoother``: MAP trajectories from bearing-only cameras (Rahimi, Dunagan, Darrell 2004).

One person per appearance label. For each label the trajectory X (state [x, vx, y, vy] on the
camera frame grid t_k = k dt, dt = 1 / camera fps) maximises p(X) p(Y | X) (eq. 6): the
Gauss-Markov prior (eqs. 1-3, ``qp_model.Prior``) times the Gaussian bearing likelihood (eq. 4,
``qp_model.Bearings``), subject to "every observed point lies in front of the camera that saw
it" (eq. 9), by Gauss-Newton with one osqp QP per step (``qp_solver.solve_map``).

Options beyond the paper (its section 8): walls and obstacles as constraints (``qp_walls``),
oblique cameras (the bearing is the horizontal image coordinate of the calibrated P at an
assumed body-centre height), and a time-lagged sliding-window (online) version.

Every run's convergence, iteration count and osqp statuses are in ``tracks.attrs["qp_smoother"]``
(per label) and ``self.diagnostics_``; a run that did not converge is reported there, never
dropped silently.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import scipy.sparse as sp

from trackroom.scenes.spec import GaussMarkovParams
from trackroom.recording import Calibration, Observations

from .base import Estimator, EstimatorError, check_tracks, param, register
from .qp_model import DISCRETISATIONS, IVX, IVY, IX, IY, NS, Bearings, Prior
from .qp_solver import SolveResult, SolverSettings, solve_map
from .qp_walls import is_convex, make_box_constraints, outline_halfplanes, ray_limits

INITS = ("paper", "ray")
SPANS = ("recording", "observed")


@register
class QPSmoother(Estimator):
    """Rahimi et al.'s iterated-QP MAP smoother for horizontal (and oblique) bearing cameras."""

    name = "qp_smoother"
    description = "MAP trajectory from bearings by Gauss-Newton with field-of-view-constrained QPs (Rahimi 2004)"
    requires = ("bearings",)

    @dataclasses.dataclass
    class Config:
        """Gauss-Markov prior (the defaults are the paper's Sigma_nu = 1e-6 diag(1e-4, 1) per 0.5 s
        step), bearing noise, constraints (eq. 9 field of view; walls with ``qp_walls``), the
        initial trajectory, and the online (sliding-window) version. Each field's doc says more."""

        q_pos: float = param(2e-10, "Gauss-Markov process noise of position per second, m^2/s")
        q_vel: float = param(2e-6, "Gauss-Markov process noise of velocity per second, m^2/s^3")
        discretisation: str = param("exact", '"exact" (continuous time: the same prior at any frame rate) or "paper" '
                                             "(diag(q_pos dt, q_vel dt)); see qp_model.process_covariance")
        sigma_px: float | None = param(None, "bearing noise, px; none: the calibration's bearing_sigma_px")
        constraints: bool = param(True, "field-of-view constraints (eq. 9): every observed point in front of its camera")
        margin: float = param(0.2, "field-of-view constraints: observed points at least this far in front of their "
                                   "camera, m")
        walls: bool = param(False, "floor-plan constraints: estimated points stay off walls and obstacles (qp_walls)")
        wall_margin: float = param(0.1, "with walls: clearance from the wall surface, m")
        wall_reach: float = param(1.0, "with walls: walls and obstacles within this distance of a point (at the current "
                                        "iterate) constrain it, m")
        see_walls: bool = param(True, "with walls: every observed point between its camera and the first wall along "
                                      "its bearing ray (qp_walls.ray_limits)")
        max_iter: int = param(50, "most Gauss-Newton iterations (one QP each)")
        init: str = param("paper", '"paper" (unobserved points at the origin, observed ones init_depth along the '
                                   'camera axis) or "ray" (observed points init_depth along their ray, rest interpolated)')
        init_depth: float = param(1.0, "depth of the initial points in front of the observing camera, m")
        person_height: float = param(0.9, "height of the point whose bearing is measured (oblique cameras only), m")
        first_pos_sigma: float = param(100.0, "weak prior on the first position about the room centre (std), m")
        first_vel_sigma: float = param(10.0, "weak prior on the first velocity (std), m/s")
        span: str = param("recording", '"recording" (every frame of the recording) or "observed" (first to last '
                                       "observation of the label)")
        window_s: float = param(0.0, "> 0: the online version, windows of this length, s; 0: the whole recording "
                                     "at once")
        lag_s: float = param(5.0, "online: each window reports its estimates this long before its end, s")
        hop_s: float = param(1.0, "online: a window every this many seconds, s")
        eps: float = param(1e-5, "osqp tolerance (absolute and relative)")

    # ------------------------------------------------------------------------------------------
    def _validate(self) -> None:
        c = self.config
        if c.init not in INITS:
            raise EstimatorError(f"qp_smoother: init must be one of {INITS}, got {c.init!r}")
        if c.discretisation not in DISCRETISATIONS:
            raise EstimatorError(f"qp_smoother: discretisation must be one of {DISCRETISATIONS}, got {c.discretisation!r}")
        if c.span not in SPANS:
            raise EstimatorError(f"qp_smoother: span must be one of {SPANS}, got {c.span!r}")
        for key in ("q_pos", "q_vel", "first_pos_sigma", "first_vel_sigma", "init_depth", "eps"):
            if not getattr(c, key) > 0:
                raise EstimatorError(f"qp_smoother: {key} must be positive, got {getattr(c, key)}")
        if c.sigma_px is not None and not c.sigma_px > 0:
            raise EstimatorError(f"qp_smoother: sigma_px must be positive, got {c.sigma_px}")
        if c.window_s < 0 or (c.window_s > 0 and not (0 <= c.lag_s < c.window_s and c.hop_s > 0)):
            raise EstimatorError("qp_smoother: need window_s >= 0, and 0 <= lag_s < window_s, hop_s > 0 when online")

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        self._validate()
        c = self.config
        self.diagnostics_: dict[str, dict] = {}
        grid = self.grid(observations, calibration)
        if grid is None:
            return _empty_tracks(self.diagnostics_)
        frames = []
        for label in grid.labels:
            k, cam_names, u = grid.of_label(label)
            k0, k1 = (0, grid.T) if c.span == "recording" else (int(k.min()), int(k.max()) + 1)
            X, diag = self._solve_label(k - k0, cam_names, u, k1 - k0, grid.dt, grid.cameras, grid.sigma, calibration)
            self.diagnostics_[label] = diag
            frames.append(track_frame(label, X, k0, k1, grid.dt))
            if not diag["converged"]:
                warnings.warn(f"qp_smoother: label {label!r} did not converge: {diag['reason']}", RuntimeWarning, stacklevel=2)
        tracks = check_tracks(pd.concat(frames, ignore_index=True), "qp_smoother")
        tracks.attrs["qp_smoother"] = self.diagnostics_
        return tracks

    def grid(self, observations: Observations, calibration: Calibration) -> "BearingGrid | None":
        """The bearings checked and put on the camera frame grid (None: no bearings at all)."""
        c = self.config
        bearings = observations["bearings"]
        if len(bearings) == 0:
            return None
        unknown = sorted(set(bearings["camera"]) - set(calibration.cameras))
        if unknown:
            raise EstimatorError(f"{self.name}: bearings from camera(s) {unknown} not in the calibration")
        cams = {n: calibration.cameras[n] for n in sorted(set(bearings["camera"]))}
        not_bearing = [n for n, cam in cams.items() if cam.kind == "overhead"]
        if not_bearing:
            raise EstimatorError(f"{self.name}: overhead camera(s) {not_bearing} cannot give bearings")
        fps = max(cam.fps for cam in cams.values())
        dt = 1.0 / fps
        t_obs = bearings["t"].to_numpy(float)
        k_all = np.rint(t_obs / dt).astype(int)
        off = np.abs(t_obs - k_all * dt)
        if np.any(off > 0.25 * dt):
            raise EstimatorError(
                f"{self.name}: bearing times are not on the {fps:g} Hz camera frame grid (off by up to {off.max():.3f} s)"
            )
        T_rec = max(int(np.rint(observations.duration / dt)), int(k_all.max()) + 1)
        sigma = c.sigma_px if c.sigma_px is not None else float(calibration.noise.get("bearing_sigma_px", 1.0))
        if not sigma > 0:
            raise EstimatorError(f"{self.name}: the calibration's bearing_sigma_px is {sigma}; give sigma_px (> 0), the "
                                 "noise the estimator assumes")
        # one trajectory per appearance label; a blob without a label ("": no colour votes, e.g. a
        # false detection) cannot be told apart and is left out
        labels = sorted(set(bearings["label"].astype(str)) - {""})
        if not labels:
            raise EstimatorError(f"{self.name}: every bearing is unlabelled (label \"\"); it needs appearance labels to tell people apart")
        return BearingGrid(bearings, cams, dt, T_rec, k_all, sigma, labels)

    # ------------------------------------------------------------------------------------------
    def problem(self, k, cam_names, u, T: int, dt: float, cameras, sigma: float, calibration: Calibration):
        """The pieces of one label's problem: prior, bearings, fixed rows (C, l), iterate rows."""
        c = self.config
        fp = calibration.floorplan
        prior = self.prior(T, dt, calibration)
        obs = Bearings.from_arrays(k, cam_names, u, cameras, sigma, z_h=c.person_height)
        n = NS * T
        rows = []
        if c.constraints:
            rows.append(obs.fov_constraints(n, c.margin))
        extra = None
        if c.walls:
            if fp is None:
                raise EstimatorError("qp_smoother: walls=true needs a floor plan in the calibration")
            if is_convex(fp.outline):
                rows.append(outline_halfplanes(fp, T, c.wall_margin))
            rays = None
            if c.see_walls:
                C_r, l_r, rays = ray_limits(obs, fp, T, c.wall_margin, c.margin if c.constraints else -np.inf)
                rows.append((C_r, l_r))
            if len(fp.walls) or len(fp.obstacles) or not is_convex(fp.outline):
                extra = make_box_constraints(fp, T, c.wall_margin, c.wall_reach, rays)
        C = sp.vstack([r[0] for r in rows], format="csc") if rows else sp.csc_matrix((0, n))
        lower = np.concatenate([r[1] for r in rows]) if rows else np.zeros(0)
        return prior, obs, C, lower, extra

    def prior(self, T: int, dt: float, calibration: Calibration, alt=None) -> Prior:
        """The Gauss-Markov prior with the weak first-state prior about the room centre
        (``alt``: looser process noise on some transitions, ``Prior.build``)."""
        c = self.config
        fp = calibration.floorplan
        centre = np.asarray(fp.outline, float).mean(axis=0) if fp is not None and len(fp.outline) else np.zeros(2)
        return Prior.build(
            T, dt, GaussMarkovParams(c.q_pos, c.q_vel), first_mean=(centre[0], 0.0, centre[1], 0.0),
            first_sigma=(c.first_pos_sigma, c.first_vel_sigma, c.first_pos_sigma, c.first_vel_sigma),
            discretisation=c.discretisation, alt=alt,
        )

    def initial_guess(self, obs: Bearings, T: int, cameras, origin=(0.0, 0.0)) -> np.ndarray:
        """The paper's initial iterate (sec. 6: unobserved points at the origin), or the "ray"
        variant. origin: where unobserved points start (with walls: ``feasible_origin``, the
        paper's origin moved just inside the room, so that the first iterate is feasible)."""
        c = self.config
        X = np.zeros(NS * T)
        X[IX::NS], X[IY::NS] = origin[0], origin[1]
        if len(obs) == 0:
            return X
        pos = np.zeros((len(obs), 2))
        for i, name in enumerate(obs.names):
            cam = cameras[name]
            m = obs.cam == i
            if c.init == "paper":
                axis = np.array([np.cos(cam.yaw), np.sin(cam.yaw)])
                pos[m] = np.asarray(cam.position, float)[:2] + c.init_depth * axis
            else:
                uv = np.column_stack([obs.u[m], np.full(m.sum(), cam.height / 2.0)])
                ray = np.column_stack([(uv[:, 0] - cam.width / 2.0) / cam.focal, np.zeros(m.sum()), np.ones(m.sum())]) @ cam.R
                ray = ray[:, :2] / np.linalg.norm(ray[:, :2], axis=1, keepdims=True)
                pos[m] = np.asarray(cam.position, float)[:2] + c.init_depth * ray
        # several cameras at one step: the mean of their points
        cnt = np.bincount(obs.k, minlength=T).astype(float)
        px = np.bincount(obs.k, pos[:, 0], minlength=T)
        py = np.bincount(obs.k, pos[:, 1], minlength=T)
        seen = cnt > 0
        x, y = np.full(T, float(origin[0])), np.full(T, float(origin[1]))
        x[seen], y[seen] = px[seen] / cnt[seen], py[seen] / cnt[seen]
        if c.init == "ray":
            ks = np.nonzero(seen)[0]
            x = np.interp(np.arange(T), ks, x[ks])
            y = np.interp(np.arange(T), ks, y[ks])
        X[IX::NS], X[IY::NS] = x, y
        return X

    def _settings(self, keep_iterates: bool = False) -> SolverSettings:
        c = self.config
        return SolverSettings(max_iter=c.max_iter, eps_abs=c.eps, eps_rel=c.eps, keep_iterates=keep_iterates)

    def solve(self, k, cam_names, u, T, dt, cameras, sigma, calibration, X0=None, keep_iterates=False) -> SolveResult:
        """Batch MAP over T steps (k: step of each observation); X0 overrides the initial guess."""
        prior, obs, C, lower, extra = self.problem(k, cam_names, u, T, dt, cameras, sigma, calibration)
        if X0 is None:
            origin = (0.0, 0.0)
            if self.config.walls and calibration.floorplan is not None:
                origin = feasible_origin(calibration.floorplan, self.config.wall_margin)
            X0 = self.initial_guess(obs, T, cameras, origin)
        return solve_map(prior, obs, X0, C, lower, extra, self._settings(keep_iterates))

    def _solve_label(self, k, cam_names, u, T, dt, cameras, sigma, calibration):
        c = self.config
        if c.window_s <= 0:
            res = self.solve(k, cam_names, u, T, dt, cameras, sigma, calibration)
            d = res.summary()
            d["windows"] = 1
            return res.X, d
        return self._solve_online(k, cam_names, u, T, dt, cameras, sigma, calibration)

    def _solve_online(self, k, cam_names, u, T, dt, cameras, sigma, calibration):
        """Time-lagged sliding window: the window ending at step e covers [e - W, e); it reports
        the steps in [e - L - H, e - L) (H = hop), i.e. each estimate uses lag_s seconds of
        future data. The next window starts from the previous estimate (shifted)."""
        c = self.config
        W = max(2, int(round(c.window_s / dt)))
        L = int(round(c.lag_s / dt))
        Hs = max(1, int(round(c.hop_s / dt)))
        X_out = np.zeros(NS * T)
        done = 0
        summaries = []
        X_prev, prev_start = None, 0
        e = min(T, max(W, L + Hs))
        while done < T:
            start = max(0, e - W)
            m = (k >= start) & (k < e)
            Tw = e - start
            X0 = None
            if X_prev is not None:
                # reuse the previous window's estimate where it overlaps; constant velocity after
                X0 = self.initial_guess(Bearings.from_arrays(k[m] - start, cam_names[m], u[m], cameras, sigma), Tw, cameras)
                ov = np.arange(start, min(e, prev_start + len(X_prev) // NS))
                X0[NS * (ov[0] - start): NS * (ov[-1] - start + 1)] = X_prev[NS * (ov[0] - prev_start): NS * (ov[-1] - prev_start + 1)]
            res = self.solve(k[m] - start, cam_names[m], u[m], Tw, dt, cameras, sigma, calibration, X0=X0)
            summaries.append(res.summary())
            last = T if e >= T else e - L
            X_out[NS * done: NS * last] = res.X[NS * (done - start): NS * (last - start)]
            done = last
            X_prev, prev_start = res.X, start
            e = min(T, e + Hs)
        d = {
            "converged": all(s["converged"] for s in summaries),
            "reason": "; ".join(sorted({s["reason"] for s in summaries})),
            "iterations": int(sum(s["iterations"] for s in summaries)),
            "qp_status": sorted({st for s in summaries for st in s["qp_status"]}),
            "qp_not_solved": int(sum(s["qp_not_solved"] for s in summaries)),
            "violation_m": float(max(s["violation_m"] for s in summaries)),
            "seconds": float(sum(s["seconds"] for s in summaries)),
            "windows": len(summaries),
        }
        return X_out, d


@dataclasses.dataclass(frozen=True)
class BearingGrid:
    """Bearings on the camera frame grid t_k = k dt, k = 0..T-1: ``k_all`` the step of every row
    of ``bearings``; ``labels`` the appearance labels (one person each); ``sigma`` the pixel noise."""

    bearings: pd.DataFrame
    cameras: dict
    dt: float
    T: int
    k_all: np.ndarray
    sigma: float
    labels: list[str]

    def of_label(self, label: str):
        """(k, camera names, u) of one label's bearings."""
        m = (self.bearings["label"].astype(str) == label).to_numpy()
        return self.k_all[m], self.bearings["camera"].to_numpy(object)[m], self.bearings["u"].to_numpy(float)[m]


def track_frame(label: str, X: np.ndarray, k0: int, k1: int, dt: float) -> pd.DataFrame:
    """One label's track rows from the trajectory X over steps k0..k1-1."""
    t = np.arange(k0, k1) * dt
    n = NS * (k1 - k0)
    return pd.DataFrame({"t": t, "track_id": label, "x": X[IX:n:NS], "y": X[IY:n:NS], "vx": X[IVX:n:NS], "vy": X[IVY:n:NS]})


def feasible_origin(fp, margin: float) -> tuple[float, float]:
    """The floor origin moved into the room: clipped to the outline's bounding box shrunk by the
    wall clearance (+1 cm), when that point is clear of every wall; else the outline's centroid."""
    p = np.asarray(fp.outline, float)
    if not len(p):
        return (0.0, 0.0)
    need = 0.5 * fp.wall_thickness + margin + 0.01
    o = np.clip(np.zeros(2), p.min(axis=0) + need, p.max(axis=0) - need)
    if bool(fp.inside(o[None])[0]) and float(fp.clearance(o[None])[0]) >= margin + 0.005:
        return (float(o[0]), float(o[1]))
    c = p.mean(axis=0)
    return (float(c[0]), float(c[1]))


def _empty_tracks(diag: dict) -> pd.DataFrame:
    df = pd.DataFrame({c: pd.Series(dtype=float) for c in ("t", "x", "y", "vx", "vy")})
    df.insert(1, "track_id", pd.Series(dtype=object))
    df.attrs["qp_smoother"] = diag
    return df
