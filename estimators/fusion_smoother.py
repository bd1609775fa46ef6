"""``fusion_smoother``: the Rahimi MAP smoother with the phone each person carries.

Bearing-only tracking with sparse non-overlapping cameras leaves depth unobservable between
views (Rahimi et al. Fig. 1a: with the target's speed known, one camera fixes depth). Every
walker carries a phone, and a phone tells how its carrier moves: walking or stopped (the gait
model's bobbing feature), the walking direction (the gyro's integrated yaw with its constant and
drift from the tilt-compensated magnetometer, immune to the indoor magnetic disturbance; up to
the phone's yaw offset in the pocket), the speed (step cadence times the person's step length,
as noisy as the step phase is ragged) and the turn rate (gyro). This estimator adds those cues to the QP smoother's problem as residuals on
the trajectory's velocity (``fusion_model.PhoneFactors``), with the step length l and the heading
offset delta of each person estimated jointly (``Prior.with_parameters``), so that each
Gauss-Newton step is still one sparse QP (``qp_solver.solve_map``, the same prior, bearing model,
field-of-view and wall constraints as ``qp_smoother``, which this class extends).

Phones are matched to bearing tracks, not assumed. For every appearance label h the plain MAP
(no phone, the bearings through the same robust loss) has cost E(h); for every phone i the phone-only problem has cost E(i); the fused MAP
of (h, i) has cost E(h, i). The mismatch

    D(h, i) = E(h, i) - E(h) - E(i)   (>= 0 up to solver tolerance; ~ chi^2 / 2 for the right phone)

is how much the two explanations contradict each other. ``linear_sum_assignment`` minimises the
total D over labels and phones, with one "no phone" column per label at D = ``match_max`` times
the label's bearing count, so a person without a phone (or whose best phone contradicts the
cameras) keeps the plain prior: exactly the ``qp_smoother`` answer with the same parameters.
The claimed phone is the output's ``phone_id``.

The initial iterates of a fused solve are dead reckoning aligned to the bearings: for each
heading offset on a grid, the path p_k = p_0 + l A_k(delta) + B_k(delta) integrated from the phone
is linear in (p_0, l), and every bearing says that its point lies on a line n . x + h = 0
(``qp_model.Bearings``: (a - u b) . x + (c - u d) = 0), so (p_0, l) is a small least-squares fit;
the offset with the least residual and the best one in each other of ``starts`` sectors of the
circle each get ``start_iter`` Gauss-Newton steps, and the lowest cost goes on to convergence.

Scale: with ``scale_free`` the prior's transition rows (``fusion_model.ScaledPrior``) and every
phone row are in units of the step length, so a path scaled about a camera together with l costs
the same, and with one camera only l's prior sets the scale (docs/fusion_smoother.md).
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from trackroom.recording import Calibration, Observations

from .base import EstimatorError, check_tracks, param, register
from .fusion_model import (ID, IL, LOSSES, PhoneFactors, PhoneFactorSettings, Residuals, Robust, ScaledPrior,
                           offset_bounded_prior, offset_knot_prior, speed_per_step_length)
from .gait import GaitModel, load_default
from .phone_motion import MotionSettings, PhoneMotion, phone_motion
from trackroom.scenes.spec import GaussMarkovParams

from .qp_model import IVX, IVY, IX, IY, NS, Bearings, Prior
from .qp_smoother import QPSmoother, feasible_origin, track_frame
from .qp_solver import SolveResult, solve_map


EVIDENCE_OSQP = 400  # ADMM iterations of their osqp solves: only an active set for the exact KKT rounds
EVIDENCE_ITER = 6  # Gauss-Newton steps of the no-phone and phone-only solves (``_evidence_settings``)


@register
class FusionSmoother(QPSmoother):
    """QP smoother + phone factors (heading, cadence speed, walking/stopped, gyro), phones matched to labels."""

    name = "fusion_smoother"
    description = ("MAP trajectory from bearings and the carrier's phone (heading, step cadence, gait), phones matched "
                   "to bearing tracks (Rahimi 2004 + phone factors)")
    requires = ("bearings",)

    @dataclasses.dataclass
    class Config(QPSmoother.Config):
        """The QP smoother's parameters (a walker-like prior by default: the phone gives the
        velocity, the prior only its smoothness) and the phone factors' (``fusion_model``)."""

        q_pos: float = param(1e-4, "Gauss-Markov process noise of position per second, m^2/s")
        q_vel: float = param(0.5, "Gauss-Markov process noise of velocity per second, m^2/s^3 (a walker turning "
                                  "at 1 m/s; chosen on development seeds, docs/fusion_smoother.md)")
        see_walls: bool = param(False, "with walls: observed points between their camera and the first wall on their ray "
                                       "(qp_walls.ray_limits); off here: a false detection's ray would be a hard "
                                       "constraint that no robust loss can discount (office_floor: 6-10 m with it, "
                                       "0.2-0.4 m without)")
        discretisation: str = param("paper", '"paper" (default here: diag(q_pos dt, q_vel dt), positions tied to '
                                             'x + dt v whatever q_vel is) or "exact"; see qp_model.process_covariance')
        q_vel_phone: float = param(5.0, "process noise of velocity where the phone measures it (a cadence), "
                                        "m^2/s^3 (see phone_prior)")
        gait_model: str = param("", 'file: gait-model JSON (`trackroom train-gait`); "": the bundled one')
        step_length: float = param(0.7, "prior mean of the person's step length at the reference cadence, m")
        step_length_sigma: float = param(0.1, "prior std of the step length, m")
        step_length_min: float = param(0.3, "least step length (a constraint), m")
        cadence_ref: float = param(1.8, "reference cadence of step_length, Hz")
        cadence_zero: float = param(1.0, "cadence at which the walking speed extrapolates to zero, Hz: speed = step_length "
                                         "cadence_ref (f - cadence_zero) / (cadence_ref - cadence_zero) (population "
                                         "constant; fitted on development recordings, docs/fusion_smoother.md)")
        offset_sigma_deg: float = param(180.0, "prior std of the phone's yaw offset in the pocket, deg")
        offset_knot_s: float = param(0.0, "the heading offset as knots this far apart (s), linear between them, with a "
                                          "random walk along the path between knots (offset_rate_deg): the pocket "
                                          "offset plus the indoor magnetic disturbance; 0: one constant offset")
        offset_rate_deg: float = param(5.0, "random walk of the heading offset between knots, deg per sqrt(m) walked "
                                            "(indoor magnetic disturbance: about 10 deg changing over 2-4 m near walls, "
                                            "docs/fusion_smoother.md)")
        offset_disturbance_deg: float = param(0.0, "with knots: > 0 makes them deviations about one constant offset, "
                                                   "a bounded disturbance of this std (deg) changing over "
                                                   "offset_length_m (an Ornstein-Uhlenbeck prior, "
                                                   "fusion_model.offset_bounded_prior) instead of a random walk; 0: "
                                                   "the random walk (offset_rate_deg)")
        offset_length_m: float = param(2.0, "with offset_disturbance_deg: the distance over which the disturbance "
                                            "changes, m")
        offset_floor_m: float = param(0.25, "least distance counted between two knots for their random walk, m "
                                            "(a phone may turn in the pocket while its carrier stands)")
        heading_gyro_tau_s: float = param(30.0, "gyro-aided heading: the phone's yaw from the integrated (tilt-compensated) gyro, "
                                                "its constant and drift from the magnetometer smoothed over this time "
                                                "constant (phone_motion.gyro_aided_heading), s; 0: the magnetometer alone")
        gyro_gravity_window_s: float = param(10.0, "centred window of the accelerometer mean the gyro's yaw rate is projected "
                                                   "on (the phone's up), s: in a turn the centripetal acceleration tilts a "
                                                   "short mean and the projected rate under-reads the turn "
                                                   "(docs/fusion_smoother.md)")
        heading_sigma_deg: float = param(8.6, "walking-direction noise of the phone heading (1/sqrt(kappa)), deg")
        speed_sigma: float = param(0.05, "absolute speed noise of cadence x step length, m/s")
        speed_rel: float = param(0.08, "relative speed noise of cadence x step length")
        stop_sigma: float = param(0.05, "velocity noise while the gait model says stopped, m/s")
        nominal_speed: float = param(0.8, "walking speed assumed where no cadence was found, m/s")
        huber: float = param(2.0, "threshold of the phone rows' robust loss, in sigmas")
        phone_loss: str = param("huber", 'robust loss of the phone rows: "huber", "cauchy" or "l2"')
        bearing_loss: str = param("geman_mcclure", 'robust loss of the bearings with a phone: "geman_mcclure" (bounded: '
                                                   'a false detection costs the same wherever the path goes), '
                                                   '"cauchy", "huber" or "l2"')
        bearing_robust: float = param(3.0, "threshold of that loss, in bearing sigmas")
        border_px: float = param(60.0, "bearings this close to the image's left or right edge get wider noise, px")
        border_sigma_px: float = param(20.0, "the extra bearing noise at the edge itself (falling to 0 at border_px), px")
        cadence_noise: bool = param(True, "widen each speed row by the cadence's own standard error (the scatter of the "
                                          "step phase's rate over its window, phone_motion): a weak bob at slow walking "
                                          "gives a ragged, upward-biased cadence")
        speed_lag_s: float = param(0.5, "speed noise where the carrier speeds up or slows down: the cadence lags a "
                                        "change of speed by about this (sigma widened by the phone's horizontal "
                                        "acceleration times this), s")
        turn_lag_s: float = param(0.3, "heading noise in turns: the body turns this long before or after the path "
                                       "(sigma widened by the gyro's yaw rate times this), s")
        gyro: bool = param(False, "add the gyro's heading change between frames")
        gyro_sigma_deg: float = param(3.0, "gyro heading-change noise per camera frame, deg")
        scale_free: bool = param(True, "the prior's transition rows in units of the step length (fusion_model.ScaledPrior): "
                                       "only the step length's prior, not the prior on absolute accelerations, holds "
                                       "a scale the bearings cannot tell (one camera)")
        starts: int = param(4, "Gauss-Newton starts: the dead reckoning's best heading offset and the best in each "
                                 "other sector of the circle (starts sectors); the solution of least cost is kept")
        start_iter: int = param(8, "Gauss-Newton steps each start gets before the lowest cost is kept")
        offset_grid: int = param(36, "heading offsets tried for the dead-reckoning initial iterate")
        match: bool = param(True, "match phones to labels; false: no phone is used (the qp_smoother answer)")
        match_max: float = param(4.0, "largest mismatch D(h, i) per bearing of h for a phone claim, nats (right phones: "
                                      "at most 3.0 on development seeds, docs/fusion_smoother.md)")

    # ------------------------------------------------------------------------------------------
    def _validate(self) -> None:
        super()._validate()
        c = self.config
        if c.window_s > 0 or c.span != "recording":
            raise EstimatorError("fusion_smoother: only the batch smoother over the recording (window_s=0, "
                                 'span="recording") is implemented')
        for key in ("step_length", "step_length_sigma", "cadence_ref", "offset_sigma_deg", "heading_sigma_deg",
                    "speed_sigma", "stop_sigma", "nominal_speed", "huber", "gyro_sigma_deg", "match_max"):
            if not getattr(c, key) > 0:
                raise EstimatorError(f"fusion_smoother: {key} must be positive, got {getattr(c, key)}")
        if c.bearing_loss not in LOSSES or not c.bearing_robust > 0:
            raise EstimatorError(f"fusion_smoother: bearing_loss must be one of {LOSSES} and bearing_robust positive")
        if c.offset_knot_s < 0 or not c.offset_rate_deg > 0 or not c.offset_floor_m > 0:
            raise EstimatorError("fusion_smoother: need offset_knot_s >= 0, offset_rate_deg > 0 and offset_floor_m > 0")
        if c.heading_gyro_tau_s < 0 or not c.gyro_gravity_window_s > 0:
            raise EstimatorError("fusion_smoother: need heading_gyro_tau_s >= 0 and gyro_gravity_window_s > 0, got "
                                 f"{c.heading_gyro_tau_s} and {c.gyro_gravity_window_s}")
        if c.speed_rel < 0 or c.offset_grid < 1 or c.starts < 1 or c.start_iter < 1:
            raise EstimatorError("fusion_smoother: need speed_rel >= 0, offset_grid >= 1, starts >= 1 and start_iter >= 1")
        if not 0 <= c.cadence_zero < c.cadence_ref:
            raise EstimatorError(f"fusion_smoother: need 0 <= cadence_zero < cadence_ref, got {c.cadence_zero}")

    def factor_settings(self) -> PhoneFactorSettings:
        c = self.config
        return PhoneFactorSettings(
            f0=c.cadence_ref, f1=c.cadence_zero, sigma_speed=c.speed_sigma, rel_speed=c.speed_rel,
            sigma_psi=np.radians(c.heading_sigma_deg), sigma_stop=c.stop_sigma, sigma_gyro=np.radians(c.gyro_sigma_deg),
            nominal_speed=c.nominal_speed, huber=c.huber, gyro=c.gyro, turn_lag=c.turn_lag_s, speed_lag=c.speed_lag_s,
            scale_free=c.scale_free, loss=c.phone_loss,
        )

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        self._validate()
        c = self.config
        self.diagnostics_: dict[str, dict] = {}
        grid = self.grid(observations, calibration)
        self.cameras_ = calibration.cameras
        if grid is None:
            df = pd.DataFrame({k: pd.Series(dtype=float) for k in ("t", "x", "y", "vx", "vy")})
            df.insert(1, "track_id", pd.Series(dtype=object))
            df["phone_id"] = pd.Series(dtype=object)
            return df
        # the state's velocity v_k carries x_k to x_{k+1} (x_{k+1} = x_k + dt v_k, the prior's A):
        # it is the mean velocity over [t_k, t_k+1], so the phone is read at t_k + dt / 2
        motions = self.phone_motions(observations, calibration, (np.arange(grid.T) + 0.5) * grid.dt) if c.match else {}
        origin = (0.0, 0.0)
        if c.walls and calibration.floorplan is not None:
            origin = feasible_origin(calibration.floorplan, c.wall_margin)
        problems, fused, robust = {}, {}, {}
        for label in grid.labels:
            k, cams, u = grid.of_label(label)
            problems[label] = self.problem(k, cams, u, grid.T, grid.dt, grid.cameras, grid.sigma, calibration)
        if motions:
            for label in grid.labels:
                for pid, m in motions.items():
                    fused[label, pid] = self.solve_fused(problems[label], m, calibration)
            # the explanations alone, started from the best fused solution (a nearby minimum:
            # few iterations, and no worse than one from the paper's start)
            phone_only = {}
            for pid, m in motions.items():
                best = min((fused[h, pid] for h in grid.labels), key=lambda r: r.cost[-1])
                phone_only[pid] = self.solve_phone_only(problems[grid.labels[0]][0], m, calibration, best.X)
            for label in grid.labels:
                prior, obs, C, lower, extra = problems[label]
                best = min((fused[label, pid] for pid in motions), key=lambda r: r.cost[-1])
                robust[label] = solve_map(prior, Residuals(self.robust_bearings(obs, grid.cameras)), best.X[:NS * grid.T],
                                          C, lower, extra, self._evidence_settings())
            assignment, mismatch = self.assign(grid, robust, phone_only, fused, problems)
        else:
            assignment, mismatch = {}, {}
        plain = {}
        for label in grid.labels:
            if label not in assignment:  # no phone: exactly the qp_smoother answer
                prior, obs, C, lower, extra = problems[label]
                X0 = self.initial_guess(obs, grid.T, grid.cameras, origin)
                plain[label] = solve_map(prior, obs, X0, C, lower, extra, QPSmoother._settings(self))
        frames = []
        for label in grid.labels:
            pid = assignment.get(label, "")
            res = fused[label, pid] if pid else plain[label]
            d = res.summary()
            d["phone_id"] = pid
            d["mismatch"] = {p: float(v) for p, v in mismatch.get(label, {}).items()}
            if pid:
                d["step_length"] = float(res.X[NS * grid.T + IL])
                knots = self.factors(motions[pid], grid.T).offsets(res.X)
                # the mean offset (circular) over the knots; its spread along the path beside it
                mean = np.angle(np.mean(np.exp(1j * knots)))
                d["heading_offset_deg"] = float(np.degrees(mean))
                d["heading_offset_range_deg"] = float(np.degrees(np.ptp(np.angle(np.exp(1j * (knots - mean))))))
                d["heading_offset_knots_deg"] = np.degrees(knots).tolist()
            self.diagnostics_[label] = d
            f = track_frame(label, res.X, 0, grid.T, grid.dt)
            f["phone_id"] = pid
            frames.append(f)
            if not d["converged"]:
                warnings.warn(f"fusion_smoother: label {label!r} did not converge: {d['reason']}", RuntimeWarning, stacklevel=2)
        tracks = check_tracks(pd.concat(frames, ignore_index=True), self.name)
        tracks.attrs[self.name] = self.diagnostics_
        return tracks

    def _settings(self, keep_iterates: bool = False):
        """The QP smoother's settings, stopping at 1 mm steps or a relative cost decrease below
        1e-6 (the last iterations of a robust fit with the global step length and offset creep
        by millimetres), and steps that pass the KKT test taken without osqp's certification
        (``SolverSettings.trust_kkt``: at T = 3840 the no-phone evidence solve spent 23 s in 9000
        ADMM iterations)."""
        s = super()._settings(keep_iterates)
        s.tol_step = 1e-3
        s.tol_cost = 1e-6
        s.trust_kkt = True
        return s

    # --- phones --------------------------------------------------------------------------------
    def phone_motions(self, observations: Observations, calibration: Calibration, t_grid: np.ndarray) -> dict[str, PhoneMotion]:
        if not observations.has("imu"):
            return {}
        c = self.config
        try:
            gait = GaitModel.from_json(c.gait_model) if c.gait_model else load_default()
        except (OSError, ValueError, TypeError) as e:
            raise EstimatorError(f"fusion_smoother: cannot load the gait model: {e}") from None
        field = calibration.noise.get("magnetic_field", (0.0, -0.5, 0.0))
        imu = observations["imu"]
        out = {}
        for pid in sorted(imu["phone_id"].astype(str).unique()):
            try:
                out[pid] = phone_motion(imu, pid, t_grid, gait, field, MotionSettings(gyro_heading_tau_s=c.heading_gyro_tau_s, gyro_gravity_window_s=c.gyro_gravity_window_s))
            except ValueError as e:
                raise EstimatorError(f"fusion_smoother: phone {pid!r}: {e}") from None
        return out

    def factors(self, m: PhoneMotion, T: int) -> PhoneFactors:
        c = self.config
        kw = np.flatnonzero(m.walking)
        ks = np.flatnonzero(~m.walking)
        both = m.walking[:-1] & m.walking[1:]
        kg = np.flatnonzero(both)
        dt = float(m.t[1] - m.t[0]) if len(m.t) > 1 else 1.0
        rate = np.abs(np.concatenate([m.dyaw, [0.0]]) + np.concatenate([[0.0], m.dyaw])) / (2 * dt)  # yaw rate at t_k
        return PhoneFactors(T=T, kw=kw, psi=m.heading[kw], f=m.cadence[kw], ks=ks, kg=kg, dpsi=m.dyaw[kg],
                            psi_g=m.heading[kg + 1], l_prior=self.config.step_length, s=self.factor_settings(),
                            omega=rate[kw], accel=None if m.accel_h is None else m.accel_h[kw],
                            f_se=None if m.cadence_se is None or not c.cadence_noise else m.cadence_se[kw],
                            knot_steps=self.knot_steps(dt), bounded=self.config.offset_disturbance_deg > 0)

    def knot_steps(self, dt: float) -> int:
        """Grid steps between heading-offset knots (0: one constant offset)."""
        c = self.config
        return max(1, int(round(c.offset_knot_s / dt))) if c.offset_knot_s > 0 else 0

    def augmented_prior(self, prior: Prior, fac: PhoneFactors | None = None) -> Prior:
        """The prior with [l, delta_0, ..., delta_{K-1}] appended: l ~ N(step_length,
        step_length_sigma), the first knot ~ N(0, offset_sigma_deg) and each later knot a random walk
        from the one before, (delta_j - delta_{j-1}) ~ N(0, sigma_j) (``fusion_model.offset_knot_prior``:
        offset_rate_deg per sqrt of the metres the phone says were walked between them)."""
        c = self.config
        K = 1 if fac is None else fac.n_knots
        n_par = 1 + K if fac is None else fac.n_par
        inv = np.concatenate([[1.0 / c.step_length_sigma, 1.0 / np.radians(c.offset_sigma_deg)], np.zeros(n_par - 2)])
        W = sp.diags(inv).tolil()
        if K > 1:
            walked = np.zeros(prior.T)
            walked[fac.kw] = fac.s_nom * prior.dt  # metres per step at the prior's step length
            j = np.arange(1, K)
            if fac.bounded:  # [l, delta_c, b_0 .. b_{K-1}]
                rho, sig = offset_bounded_prior(walked, fac.knot_steps, prior.T, np.radians(c.offset_disturbance_deg),
                                                c.offset_length_m, c.offset_floor_m)
                W[2, 2] = 1.0 / np.radians(c.offset_disturbance_deg)
                W[2 + j, 2 + j] = 1.0 / sig
                W[2 + j, 1 + j] = -rho / sig
            else:  # [l, delta_0 .. delta_{K-1}]
                sig = offset_knot_prior(walked, fac.knot_steps, prior.T, np.radians(c.offset_rate_deg), c.offset_floor_m)
                W[1 + j, 1 + j] = 1.0 / sig
                W[1 + j, j] = -1.0 / sig
        w = np.zeros(n_par)
        w[0] = c.step_length / c.step_length_sigma
        return prior.with_parameter_rows(W.tocsc(), w, np.full(n_par, 0.1))

    def solve_phone_only(self, prior: Prior, m: PhoneMotion, calibration: Calibration, X0: np.ndarray | None = None) -> SolveResult:
        """The phone's own explanation: prior + phone rows, no bearings, no constraints (from X0,
        else the phone's dead reckoning from the origin)."""
        T = prior.T
        fac = self.factors(m, T)
        pa = self.fused_prior(prior, fac, calibration)
        if X0 is None:
            X0 = np.zeros(pa.n)
            X0[NS * T + IL] = self.config.step_length
            v = self._phone_velocity(fac, m, T, self.config.step_length, 0.0)
            X0[IVX:NS * T:NS], X0[IVY:NS * T:NS] = v[:, 0], v[:, 1]
        return solve_map(pa, Residuals(fac.robust()), X0, None, None, None, self._evidence_settings())

    def _evidence_settings(self):
        """The explanations alone only price the mismatch: a few Gauss-Newton steps from the fused
        solution (each lowers the cost; the phone alone leaves the path's place and turn free, and
        converges slowly to a minimum a few nats lower)."""
        s = self._settings()
        s.max_iter = min(s.max_iter, EVIDENCE_ITER)
        s.osqp_max_iter = EVIDENCE_OSQP
        return s

    def robust_bearings(self, obs: Bearings, cameras) -> Robust:
        """The bearings through the robust loss, with the noise widened near the image's left
        and right edges, where a detector sees a person cut by the border:
        sigma_j^2 = sigma^2 + (border_sigma_px max(0, 1 - d_j / border_px))^2, d_j the distance of
        u_j from the nearer edge (px)."""
        c = self.config
        width = np.array([cameras[n].width for n in obs.names], float)[obs.cam] if len(obs) else np.zeros(0)
        d = np.minimum(obs.u, width - obs.u)
        extra = c.border_sigma_px * np.clip(1.0 - d / c.border_px, 0.0, 1.0)
        scale = np.sqrt(1.0 + (extra / obs.sigma) ** 2)
        return Robust(obs, c.bearing_robust, c.bearing_loss, scale)

    def phone_prior(self, prior: Prior, fac: PhoneFactors, calibration: Calibration) -> Prior:
        """The prior with ``q_vel_phone`` on the transitions into and out of steps whose velocity
        the phone measures (a cadence), and the step length and heading offset appended.

        Why looser there: a Gaussian prior on the velocity's changes prefers a path shrunk
        towards the camera (its cost falls as the square of the scale), and with one camera the
        scale is what only the step length then holds; where the phone measures the velocity the
        prior has nothing to add but that pull."""
        c = self.config
        T = prior.T
        if c.q_vel_phone != c.q_vel and T > 1:
            measured = np.zeros(T, bool)
            measured[fac.kw[fac.has_f]] = True
            mask = measured[1:] & measured[:-1]
            prior = self.prior(T, prior.dt, calibration, alt=(GaussMarkovParams(c.q_pos, c.q_vel_phone), mask))
        return self.augmented_prior(prior, fac)

    def fused_prior(self, prior: Prior, fac: PhoneFactors, calibration: Calibration) -> Prior | ScaledPrior:
        """The prior of a solve with a phone: ``phone_prior``, with ``scale_free`` its transition
        rows in units of the step length (``fusion_model.ScaledPrior``)."""
        pa = self.phone_prior(prior, fac, calibration)
        if not self.config.scale_free or prior.T < 2:
            return pa
        return ScaledPrior(pa, self.config.step_length)

    def solve_fused(self, problem, m: PhoneMotion, calibration: Calibration) -> SolveResult:
        prior, obs, C, lower, extra = problem
        T = prior.T
        fac = self.factors(m, T)
        pa = self.fused_prior(prior, fac, calibration)
        # and the step length positive (l >= step_length_min): a walk run backwards with a
        # negative step length explains the bearings of a straight walk as well
        n_par = fac.n_par
        l_row = sp.csc_matrix(([1.0], ([0], [NS * T + IL])), shape=(1, NS * T + n_par))
        Ca = sp.vstack([sp.hstack([C, sp.csc_matrix((C.shape[0], n_par))]), l_row], format="csc")
        lower = np.append(lower, self.config.step_length_min)
        extra_a = None
        if extra is not None:
            def extra_a(X, _f=extra, _nx=NS * T, _np=n_par):  # noqa: F811 (the padded version of extra)
                out = _f(X[:_nx])
                Ce = sp.hstack([out[0], sp.csc_matrix((out[0].shape[0], _np))], format="csc")
                return (Ce,) + tuple(out[1:])
        obs_r = self.robust_bearings(obs, self.cameras_)
        resid = Residuals(obs_r, fac.robust())
        # several starts (the dead reckoning's best heading offset in each sector of the circle),
        # screened by their cost after ``start_iter`` Gauss-Newton steps; the lowest goes on to
        # convergence. With the bounded bearing loss a start on the wrong side of the camera
        # converges to a path that gives its bearings up as outliers, and that shows within a few
        # steps
        starts = self.dead_reckoning_init(obs, fac, m, T, prior.dt, calibration, self.config.starts)
        screen = self._settings()
        screen.max_iter = self.config.start_iter
        best = None
        for X0 in starts:
            if extra_a is not None:
                # walls and obstacles choose their face from the side the iterate is on: a dead
                # reckoning that runs through a wall would lock the wrong face in, so the path is
                # first found without them (the fixed rows stay), then the walls are added
                X0 = solve_map(pa, resid, X0, Ca, lower, None, self._settings()).X
            res = solve_map(pa, resid, X0, Ca, lower, extra_a, screen if len(starts) > 1 else self._settings())
            if best is None or res.cost[-1] < best.cost[-1]:
                best = res
        if len(starts) > 1 and not best.converged:
            best = solve_map(pa, resid, best.X, Ca, lower, extra_a, self._settings())
        return best

    def _phone_velocity(self, fac: PhoneFactors, m: PhoneMotion, T: int, l: float, delta: float) -> np.ndarray:
        """(T, 2) velocity the phone implies for step length l and offset delta."""
        a, b = self._speed_terms(fac, T)
        th = m.heading - delta
        s = np.maximum(l * a + b, 0.0)
        return s[:, None] * np.stack([np.cos(th), np.sin(th)], axis=1)

    def _speed_terms(self, fac: PhoneFactors, T: int) -> tuple[np.ndarray, np.ndarray]:
        """speed_k = l a_k + b_k: cadence steps l g(f) (``fusion_model.speed_per_step_length``),
        walking without cadence the nominal speed, stopped 0."""
        s = fac.s
        a, b = np.zeros(T), np.zeros(T)
        f = fac.f
        has = np.isfinite(f)
        kc = fac.kw[has]
        a[kc] = speed_per_step_length(f[has], s)
        b[fac.kw[~has]] = s.nominal_speed
        return a, b

    def dead_reckoning_init(self, obs: Bearings, fac: PhoneFactors, m: PhoneMotion, T: int, dt: float,
                            calibration: Calibration, starts: int = 1) -> list[np.ndarray]:
        """Up to ``starts`` initial iterates: dead reckoning aligned to the bearings (module
        docstring) at the best heading offset and the best one in each other sector of the
        circle, each with [l, delta] appended. It is left as it is, smooth, even where it breaks a
        field-of-view row: the first QP step restores feasibility, while moving points onto their rays would put jumps in the path
        that the prior then spends iterations (and wrong turns) undoing."""
        c = self.config
        a, b = self._speed_terms(fac, T)
        nrm = obs.a - obs.u[:, None] * obs.b
        h = obs.c - obs.u * obs.d
        scale = np.linalg.norm(nrm, axis=1)
        nrm, h = nrm / scale[:, None], h / scale
        fits = []
        sig_d = 1.0  # m: dead-reckoning drift between views, for the weight of the step-length prior
        deltas = np.linspace(-np.pi, np.pi, c.offset_grid, endpoint=False)
        for delta in deltas:
            e = np.stack([np.cos(m.heading - delta), np.sin(m.heading - delta)], axis=1)
            va, vb = a[:, None] * e, b[:, None] * e
            # integrated as the prior does (x_{k+1} = x_k + dt v_k, v_k the mean over the step): a
            # start that breaks the stiff position rows costs Gauss-Newton iterations to mend
            A = np.concatenate([[[0.0, 0.0]], np.cumsum(dt * va[:-1], axis=0)])
            B = np.concatenate([[[0.0, 0.0]], np.cumsum(dt * vb[:-1], axis=0)])
            if len(obs) == 0:
                sol, cost = np.array([0.0, 0.0, c.step_length]), 0.0
            else:
                M = np.column_stack([nrm, np.einsum("ij,ij->i", nrm, A[obs.k])]) / sig_d
                r = -(h + np.einsum("ij,ij->i", nrm, B[obs.k])) / sig_d
                M = np.vstack([M, [0.0, 0.0, 1.0 / c.step_length_sigma]])
                r = np.append(r, c.step_length / c.step_length_sigma)
                # iteratively reweighted (Cauchy, 1 sigma_d): false detections and clipped
                # people at the image border must not decide the offset
                w = np.ones(len(r))
                for _ in range(6):
                    sol = np.linalg.lstsq(M * w[:, None], r * w, rcond=None)[0]
                    e = M @ sol - r
                    w = 1.0 / np.sqrt(1.0 + e**2)
                    w[-1] = 1.0
                sol[2] = np.clip(sol[2], max(0.5 * c.step_length, c.step_length_min), 1.5 * c.step_length)
                e = M @ sol - r
                cost = float(np.sum(np.log1p(e[:-1] ** 2)) + e[-1] ** 2)
            fits.append((cost, delta, sol, A, B))
        # the best offset, and the best one in each of the other sectors of the circle (starts
        # sectors, the first centred on the best): with one camera the fit's cost over the
        # offsets can be flat or lowest at the wrong side (development seed 116, Gauss-Markov: its
        # only two local minima at +-90 degrees, the walker's offset 0)
        costs = np.array([f[0] for f in fits])
        n = len(costs)
        i0 = int(np.argmin(costs))
        k = max(1, min(starts, n))
        picks = []
        for j in range(k):
            centre = i0 + j * n / k
            idx = np.arange(int(np.ceil(centre - n / (2 * k))), int(np.ceil(centre + n / (2 * k)))) % n
            i = int(idx[np.argmin(costs[idx])])
            if i not in picks:
                picks.append(i)
        out = []
        for i in picks:
            _, delta, sol, A, B = fits[i]
            l = float(sol[2])
            e = np.stack([np.cos(m.heading - delta), np.sin(m.heading - delta)], axis=1)
            xy = sol[:2] + l * A + B
            v = (l * a + b)[:, None] * e
            X = np.zeros(NS * T + fac.n_par)
            X[IX:NS * T:NS], X[IY:NS * T:NS] = xy[:, 0], xy[:, 1]
            X[IVX:NS * T:NS], X[IVY:NS * T:NS] = v[:, 0], v[:, 1]
            X[NS * T + IL], X[NS * T + ID:] = l, 0.0 if fac.bounded else delta  # every knot at the start's offset
            X[NS * T + ID] = delta
            out.append(X)
        return out

    # --- matching ------------------------------------------------------------------------------
    def assign(self, grid, alone, phone_only, fused, problems):
        """Label -> phone id (absent: no phone), and the mismatch D(h, i) of every pair."""
        c = self.config
        labels, phones = grid.labels, sorted(phone_only)
        mismatch = {h: {} for h in labels}
        if not phones:
            return {}, mismatch
        L, P = len(labels), len(phones)
        D = np.zeros((L, P))
        for a, h in enumerate(labels):
            for j, pid in enumerate(phones):
                r = fused[h, pid]
                D[a, j] = r.cost[-1] - alone[h].cost[-1] - phone_only[pid].cost[-1]
                mismatch[h][pid] = D[a, j]
        n_obs = np.array([max(1, len(problems[h][1])) for h in labels], float)
        none = c.match_max * n_obs
        cost = np.full((L, P + L), np.inf)
        cost[:, :P] = D
        cost[np.arange(L), P + np.arange(L)] = none
        cost = np.where(np.isfinite(cost), cost, 1e18)
        ri, ci = linear_sum_assignment(cost)
        return {labels[r]: phones[j] for r, j in zip(ri, ci) if j < P}, mismatch
