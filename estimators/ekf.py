"""The plain baseline: constant-velocity Kalman filters (filterpy EKF or UKF), one per person,
with global-nearest-neighbour data association, M-of-N track initiation and coast-out deletion.

Motion model (per track, state x = [x, y, vx, vy], metres and m/s), white acceleration of
power spectral density q (``accel_psd``, m^2/s^3) per axis:

    x_{k+1} = F x_k + w,   F = [[I, dt I], [0, I]],
    w ~ N(0, Q),           Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]

(Q composes exactly over sub-steps, so predicting to any time in pieces is the same as at once).

Measurements:

- floor detections (overhead cameras), linear: z = [x, y] + v, R = (sigma_f^2 + s^2/12) I, with
  sigma_f = ``floor_sigma_m`` of the calibration and s the quantisation step of a privacy camera
  (a uniform quantisation error has variance s^2/12).
- bearings (horizontal or oblique cameras), nonlinear: the horizontal image coordinate
  u = f r / w + c_x of the person, where (r, w) are the person's right and forward offsets in the
  camera frame: ``Camera.bearing_u`` for horizontal cameras (height does not matter), the full
  projection ``K (R X + t)`` of X = [x, y, body_height] for oblique ones; R = sigma_u^2 (pixels).
  The EKF linearises with the analytic Jacobian du/d[x, y] = f (R_0 w - r R_2) / w^2 (R_i: the
  rows of the rotation, first two columns); the UKF passes sigma points through u(x) (and
  resamples them from the current x, P before each of several updates at one time).

Association, per scan (all floor detections at one time form one scan; bearings form one scan
per camera and time): Mahalanobis distances d^2 = y^T S^-1 y with S = H P H^T + R, gated at the
``gate_probability`` quantile of chi^2 (2 dof for floor positions, 1 for bearings), then
``linear_sum_assignment`` minimises the summed d^2. Bearings carry an appearance label (the colour
of the person); with ``use_labels`` a labelled bearing goes to the track holding that label (one
track per label, no gate: the label is trusted) and starts it when there is none. Unassigned
measurements start tentative tracks: from a floor detection at its position; from a bearing at
the point of its ray (the floor line whose points project to u) nearest the room's centre, with a
covariance long along the ray.

Track management: a tentative track is confirmed after ``confirm_m`` hits among the first
``confirm_n`` scans whose sensor covers its predicted position (an overhead camera's floor tile,
a camera's field of view), and deleted as soon as that can no longer happen. Any track is deleted
after ``max_coast`` seconds without an update (``max_coast_labelled`` for a labelled track: the
label says who it is, so it may coast between sparse cameras), and a track that comes within
``merge_distance`` of an older one is deleted (two filters on one person would take turns with its
detections and both survive). A measurement that falls inside the looser ``spawn_probability``
gate of an existing track starts no new track (a rare large innovation is not a new person).

Output: at every camera frame time, the state of each confirmed track (a coasting track is
reported at its prediction). With ``smooth=true`` an RTS (Rauch-Tung-Striebel) pass
(``filterpy.kalman.KalmanFilter.rts_smoother``; the motion model is linear) smooths each track
over all its filter epochs, and, since smoothing is offline anyway, a track that was ever
confirmed is reported from its first to its last update (its tentative start included, its
coasting tail dropped).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from filterpy.kalman import ExtendedKalmanFilter, KalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from trackroom.scenes.camera import Camera
from trackroom.recording import Calibration, Observations

from .base import Estimator, EstimatorError, param, register

H_FLOOR = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


def cv_model(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of the constant-velocity, white-acceleration model over dt seconds."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    Q = np.zeros((4, 4))
    Q[0, 0] = Q[1, 1] = q * dt**3 / 3
    Q[0, 2] = Q[2, 0] = Q[1, 3] = Q[3, 1] = q * dt**2 / 2
    Q[2, 2] = Q[3, 3] = q * dt
    return F, Q


# ----------------------------------------------------------------------------- measurement models
@dataclass(frozen=True)
class BearingModel:
    """u(x): the horizontal image coordinate (pixels) of a person at floor position x[:2]."""

    camera: Camera
    body_height: float

    def h(self, x) -> np.ndarray:
        x = np.ravel(x)
        if self.camera.kind == "horizontal":
            return np.atleast_1d(self.camera.bearing_u(x[:2]))
        uv, _ = self.camera.project(np.array([x[0], x[1], self.body_height]))
        return np.atleast_1d(uv[0])

    def depth(self, x) -> float:
        """Distance along the optical axis (m); <= 0 means behind the camera."""
        x = np.ravel(x)
        return float(self.camera.to_camera(np.array([x[0], x[1], self.body_height]))[2])

    def jacobian(self, x) -> np.ndarray:
        """du/dx (1, 4): f (R_0 w - r R_2) / w^2 on the first two columns of R."""
        x = np.ravel(x)
        cam = self.camera
        pc = cam.to_camera(np.array([x[0], x[1], self.body_height]))
        R = cam.R
        J = np.zeros((1, 4))
        J[0, :2] = cam.focal * (R[0, :2] * pc[2] - pc[0] * R[2, :2]) / pc[2] ** 2
        return J

    def covers(self, xy) -> bool:
        xy = np.asarray(xy, float)
        if self.camera.kind == "horizontal":
            return bool(self.camera.in_horizontal_fov(xy))
        return bool(self.camera.in_fov(np.array([xy[0], xy[1], self.body_height])))

    def ray(self, u: float, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The floor line of points that project to u: its point nearest ``centre`` and direction.

        With X = [x, y, h]: f (R_0 X + t_0) - (u - c_x)(R_2 X + t_2) = 0, i.e. a . [x, y] + b = 0.
        """
        cam = self.camera
        R, t, f, du = cam.R, cam.t, cam.focal, u - cam.width / 2.0
        a = f * R[0, :2] - du * R[2, :2]
        b = f * (R[0, 2] * self.body_height + t[0]) - du * (R[2, 2] * self.body_height + t[2])
        p = centre - (a @ centre + b) * a / (a @ a)
        e = np.array([-a[1], a[0]]) / np.linalg.norm(a)
        return p, e


def floor_covered(cameras: dict[str, Camera], xy) -> bool:
    """True when an overhead camera reports detections at floor point xy (its tile, or its view)."""
    x, y = float(xy[0]), float(xy[1])
    for c in cameras.values():
        if c.region is not None:
            if c.in_region((x, y)):
                return True
        elif c.in_fov(np.array([x, y, 0.0])):
            return True
    return False


# ----------------------------------------------------------------------------- one filter
class _Filter:
    """filterpy EKF or UKF behind one small interface (state as a flat (4,) vector)."""

    def __init__(self, kind: str, x0: np.ndarray, P0: np.ndarray, q: float):
        self.kind, self.q = kind, q
        if kind == "ekf":
            self.f = ExtendedKalmanFilter(dim_x=4, dim_z=1)
            self.f.x = np.asarray(x0, float).reshape(4, 1)
        else:
            points = MerweScaledSigmaPoints(4, alpha=0.5, beta=2.0, kappa=-1.0)
            self.f = UnscentedKalmanFilter(dim_x=4, dim_z=1, dt=0.0, hx=None, fx=self._fx, points=points)
            self.f.x = np.asarray(x0, float).copy()
        self.f.P = np.asarray(P0, float).copy()

    @staticmethod
    def _fx(x, dt):
        return cv_model(dt, 0.0)[0] @ x

    @property
    def x(self) -> np.ndarray:
        return np.ravel(self.f.x).copy()

    @property
    def P(self) -> np.ndarray:
        return self.f.P.copy()

    def predict(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        F, Q = cv_model(dt, self.q)
        if dt > 0:
            if self.kind == "ekf":
                self.f.F, self.f.Q = F, Q
                self.f.predict()
            else:
                self.f.Q = Q
                self.f.predict(dt=dt)
        return F, Q

    def update(self, z: np.ndarray, h, H, R: np.ndarray) -> None:
        z = np.atleast_1d(np.asarray(z, float))
        if self.kind == "ekf":
            self.f.update(z.reshape(-1, 1), lambda x: H(x), lambda x: h(x).reshape(-1, 1), R=R)
        else:
            self.f.sigmas_f = self.f.points_fn.sigma_points(self.f.x, self.f.P)
            self.f.update(z, R=R, hx=h)


@dataclass
class _Track:
    id: int
    filt: _Filter
    t_update: float
    label: str = ""
    hits: int = 1
    scans: int = 1
    confirmed: bool = False
    t_first: float = 0.0
    history: list = field(default_factory=list)  # (t, x, P, F, Q) per epoch


# ----------------------------------------------------------------------------- the estimator
@register
class EKF(Estimator):
    """Constant-velocity EKF/UKF with GNN association: the plain baseline (module docstring)."""

    name = "ekf"
    description = "constant-velocity EKF (or UKF) per person, global nearest neighbour association, optional RTS smoothing"
    requires_any = ("floor_detections", "bearings")

    @dataclasses.dataclass
    class Config:
        filter: str = param("ekf", '"ekf" (extended Kalman filter, analytic bearing Jacobian) or "ukf" (unscented)')
        accel_psd: float = param(0.5, "q: white-acceleration power spectral density per axis, m^2/s^3 (accelerations "
                                      "below ~1 m/s^2 lasting ~1 s give q ~ a^2 tau)")
        floor_sigma: float = param(-1.0, "floor detection noise per axis, m; < 0: the calibration's floor_sigma_m")
        bearing_sigma: float = param(-1.0, "bearing noise, px; < 0: the calibration's bearing_sigma_px")
        body_height: float = param(0.9, "height of the body point an oblique camera's u refers to, m")
        gate_probability: float = param(0.99, "chi^2 quantile of the association gate (2 dof floor, 1 dof "
                                              "bearings), in (0, 1)")
        confirm_m: int = param(3, "M of M-of-N initiation: hits that confirm a tentative track (1 <= M <= N)")
        confirm_n: int = param(5, "N of M-of-N initiation: a tentative track's first N scans whose sensor covers "
                                  "its predicted position")
        max_coast: float = param(1.0, "a track without an update for this long is deleted, s")
        max_coast_labelled: float = param(10.0, "the same for a track holding an appearance label (it may coast "
                                                "between sparse cameras), s")
        spawn_probability: float = param(0.9999, "no new track from a measurement inside this chi^2 quantile gate "
                                                 "of an existing track, in (0, 1)")
        merge_distance: float = param(0.3, "of two tracks closer than this, the younger is deleted, m")
        init_speed_sigma: float = param(1.0, "initial velocity uncertainty of a new track (std per axis), m/s")
        use_labels: bool = param(True, "associate labelled bearings by their appearance label (one track per label, "
                                       "no gate)")
        measurements: str = param("all", 'measurements used: "all", "floor" (floor detections) or "bearings"')
        smooth: bool = param(False, "RTS (Rauch-Tung-Striebel) smoothing pass over each track (offline)")

    def _check_config(self) -> None:
        c = self.config
        if c.filter not in ("ekf", "ukf"):
            raise EstimatorError(f"ekf: filter must be 'ekf' or 'ukf', got {c.filter!r}")
        if c.measurements not in ("all", "floor", "bearings"):
            raise EstimatorError(f"ekf: measurements must be all, floor or bearings, got {c.measurements!r}")
        if not c.accel_psd > 0:
            raise EstimatorError(f"ekf: accel_psd must be positive, got {c.accel_psd}")
        if not 0 < c.gate_probability < 1:
            raise EstimatorError(f"ekf: gate_probability must be in (0, 1), got {c.gate_probability}")
        if not 1 <= c.confirm_m <= c.confirm_n:
            raise EstimatorError(f"ekf: need 1 <= confirm_m <= confirm_n, got {c.confirm_m}, {c.confirm_n}")
        if not (c.max_coast > 0 and c.max_coast_labelled > 0):
            raise EstimatorError(f"ekf: max_coast and max_coast_labelled must be positive, got {c.max_coast}, {c.max_coast_labelled}")

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        self._check_config()
        return _Run(self.config, observations, calibration).run()


class _Run:
    """One pass of the tracker over a recording's observations (state kept off the estimator)."""

    def __init__(self, cfg, obs: Observations, cal: Calibration):
        self.cfg, self.cal = cfg, cal
        noise = cal.noise or {}
        self.sigma_f = cfg.floor_sigma if cfg.floor_sigma >= 0 else float(noise.get("floor_sigma_m", 0.15))
        self.sigma_u = cfg.bearing_sigma if cfg.bearing_sigma >= 0 else float(noise.get("bearing_sigma_px", 1.0))
        quantum = float(noise.get("privacy_quantum_m", 0.0))
        self.floor_var = {
            n: self.sigma_f**2 + ((c.quantum or quantum) ** 2 / 12.0 if c.privacy else 0.0)
            for n, c in cal.cameras.items()
        }
        self.overhead = cal.cameras_of_kind("overhead")
        self.bearing_models = {n: BearingModel(c, cfg.body_height) for n, c in cal.cameras.items() if c.kind != "overhead"}
        lo = cal.floorplan.outline.min(axis=0)
        hi = cal.floorplan.outline.max(axis=0)
        self.centre, self.extent = 0.5 * (lo + hi), float(np.max(hi - lo))
        self.gate2 = {d: float(chi2.ppf(cfg.gate_probability, d)) for d in (1, 2)}
        self.spawn2 = {d: float(chi2.ppf(max(cfg.spawn_probability, cfg.gate_probability), d)) for d in (1, 2)}
        self.tracks: list[_Track] = []
        self.dead: list[_Track] = []
        self.next_id = 1

        use_floor = cfg.measurements in ("all", "floor")
        use_bear = cfg.measurements in ("all", "bearings")
        floor = obs["floor_detections"] if use_floor else obs["floor_detections"].iloc[:0]
        bear = obs["bearings"] if use_bear else obs["bearings"].iloc[:0]
        if len(floor) == 0 and len(bear) == 0:
            raise EstimatorError(f"ekf: no {cfg.measurements} measurements to track with")
        unknown = sorted(set(bear["camera"]) - set(self.bearing_models)) + sorted(set(floor["camera"]) - set(cal.cameras))
        if unknown:
            raise EstimatorError(f"ekf: observations from cameras not in the calibration: {unknown}")
        self.floor = floor.assign(te=np.round(floor["t"].to_numpy(float), 6)).reset_index(drop=True)
        self.bear = bear.assign(te=np.round(bear["t"].to_numpy(float), 6)).reset_index(drop=True)
        self.floor_xy = self.floor[["x", "y"]].to_numpy(float)
        self.floor_r = np.array([self.floor_var[c] for c in self.floor["camera"]], float)
        self.bear_cam = self.bear["camera"].astype(str).to_numpy()
        self.bear_u = self.bear["u"].to_numpy(float)
        lab = self.bear["label"] if "label" in self.bear else pd.Series("", index=self.bear.index)
        self.bear_label = lab.fillna("").astype(str).to_numpy()
        grid = np.concatenate([c.frame_times(obs.duration) for c in cal.cameras.values()]) if cal.cameras else np.zeros(0)
        self.grid = set(np.round(grid, 6).tolist())
        self.epochs = np.unique(np.concatenate([np.round(grid, 6), self.floor["te"], self.bear["te"]]))

    # --- main loop ----------------------------------------------------------------------
    def run(self) -> pd.DataFrame:
        # Per-epoch row indices, computed once (pandas access per scan would dominate the run time).
        floor_at = {t: idx for t, idx in self.floor.groupby("te", sort=True).indices.items()}
        bear_at = {t: idx for t, idx in self.bear.groupby("te", sort=True).indices.items()}
        rows = []
        t_prev = None
        for t in self.epochs:
            trans = {}
            for tr in self.tracks:
                trans[tr.id] = tr.filt.predict(t - t_prev if t_prev is not None else 0.0)
            if t in floor_at:
                idx = floor_at[t]
                self._floor_scan(t, self.floor_xy[idx], self.floor_r[idx])
            if t in bear_at:
                idx = bear_at[t]
                for cam in sorted(set(self.bear_cam[idx])):
                    sel = idx[self.bear_cam[idx] == cam]
                    self._bearing_scan(t, cam, self.bear_u[sel], self.bear_label[sel])
            self._prune(t)
            for tr in self.tracks:
                F, Q = trans.get(tr.id, (np.eye(4), np.zeros((4, 4))))
                tr.history.append((t, tr.filt.x, tr.filt.P, F, Q))
                if tr.confirmed and t in self.grid and not self.cfg.smooth:
                    rows.append((t, tr.id, *tr.filt.x))
            t_prev = t
        if self.cfg.smooth:
            rows = self._smoothed_rows()
        df = pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "vx", "vy"])
        df["track_id"] = df["track_id"].astype(int)
        return df.sort_values(["t", "track_id"], kind="stable").reset_index(drop=True)

    # --- scans --------------------------------------------------------------------------
    def _floor_scan(self, t: float, Z: np.ndarray, r: np.ndarray) -> None:
        """Z (n, 2) floor detections at time t, r (n,) their noise variances (m^2)."""
        Rs = [ri * np.eye(2) for ri in r]
        h = lambda x: np.ravel(x)[:2]  # noqa: E731
        H = lambda x: H_FLOOR  # noqa: E731
        d2 = np.full((len(self.tracks), len(Z)), np.inf)
        for i, tr in enumerate(self.tracks):
            x, P = tr.filt.x, tr.filt.P
            y = Z - x[:2]
            # S_j = P_pos + r_j I, inverted in closed form for all detections j at once
            a, b, c = P[0, 0] + r, P[0, 1], P[1, 1] + r
            d2[i] = (c * y[:, 0] ** 2 - 2 * b * y[:, 0] * y[:, 1] + a * y[:, 1] ** 2) / (a * c - b * b)
        cost = np.where(d2 <= self.gate2[2], d2, np.nan)
        used = self._assign(t, cost, lambda tr, j: tr.filt.update(Z[j], h, H, Rs[j]),
                            covered=lambda tr: floor_covered(self.overhead, tr.filt.x[:2]))
        near = (d2 <= self.spawn2[2]).any(axis=0) if len(self.tracks) else np.zeros(len(Z), bool)
        for j in np.flatnonzero(~used & ~near):
            P0 = np.diag([Rs[j][0, 0], Rs[j][1, 1], self.cfg.init_speed_sigma**2, self.cfg.init_speed_sigma**2])
            self._new_track(t, np.array([Z[j, 0], Z[j, 1], 0.0, 0.0]), P0)

    def _bearing_scan(self, t: float, cam: str, u: np.ndarray, labels: np.ndarray) -> None:
        """Bearings u (pixels) of one camera at time t with their appearance labels ("" none)."""
        model = self.bearing_models[cam]
        R = np.array([[self.sigma_u**2]])
        labelled = (labels != "") & self.cfg.use_labels
        done = np.zeros(len(u), bool)
        for j in np.flatnonzero(labelled):
            tr = next((tr for tr in self.tracks if tr.label == labels[j]), None)
            if tr is not None and model.depth(tr.filt.x) > 0:
                tr.filt.update(u[j:j + 1], model.h, model.jacobian, R)
                self._hit(tr, t)
                done[j] = True
            elif tr is None:
                self._bearing_track(t, model, u[j], labels[j])
                done[j] = True
        rest = np.flatnonzero(~done & ~labelled)
        if not len(rest):
            return
        free = [tr for tr in self.tracks if not tr.label]
        d2 = np.full((len(free), len(rest)), np.inf)
        for i, tr in enumerate(free):
            x, P = tr.filt.x, tr.filt.P
            if model.depth(x) <= 0:
                continue
            Hj = model.jacobian(x)
            S = float(Hj @ P @ Hj.T + R)
            d2[i] = (u[rest] - model.h(x)[0]) ** 2 / S
        cost = np.where(d2 <= self.gate2[1], d2, np.nan)
        used = self._assign(t, cost, lambda tr, k: tr.filt.update(u[rest[k]:rest[k] + 1], model.h, model.jacobian, R),
                            covered=lambda tr: model.covers(tr.filt.x[:2]), tracks=free)
        near = (d2 <= self.spawn2[1]).any(axis=0) if len(free) else np.zeros(len(rest), bool)
        for k in np.flatnonzero(~used & ~near):
            self._bearing_track(t, model, u[rest[k]], "")

    def _assign(self, t, cost, update, covered, tracks=None) -> np.ndarray:
        """GNN: ``linear_sum_assignment`` on gated costs; updates matches, books M-of-N counts."""
        tracks = self.tracks if tracks is None else tracks
        used = np.zeros(cost.shape[1], bool)
        matched = set()
        valid = np.isfinite(cost)
        if valid.any():
            big = 2 * min(cost.shape) * (np.abs(cost[valid]).max() + 1) + 1
            rows, cols = linear_sum_assignment(np.where(valid, cost, big))
            for i, j in zip(rows, cols):
                if valid[i, j]:
                    update(tracks[i], j)
                    self._hit(tracks[i], t)
                    used[j] = True
                    matched.add(i)
        for i, tr in enumerate(tracks):
            if i not in matched and not tr.confirmed and covered(tr):
                tr.scans += 1
        return used

    def _hit(self, tr: _Track, t: float) -> None:
        tr.t_update = t
        if not tr.confirmed:
            tr.hits += 1
            tr.scans += 1
            if tr.hits >= self.cfg.confirm_m:
                tr.confirmed = True

    # --- track life ---------------------------------------------------------------------
    def _new_track(self, t: float, x0: np.ndarray, P0: np.ndarray, label: str = "") -> None:
        tr = _Track(self.next_id, _Filter(self.cfg.filter, x0, P0, self.cfg.accel_psd), t, label=label, t_first=t)
        tr.confirmed = self.cfg.confirm_m <= 1
        self.next_id += 1
        self.tracks.append(tr)

    def _bearing_track(self, t: float, model: BearingModel, u: float, label: str) -> None:
        p, e = model.ray(u, self.centre)
        n = np.array([-e[1], e[0]])
        s_along, s_across = self.extent / 3.0, 0.3
        P0 = np.zeros((4, 4))
        P0[:2, :2] = s_along**2 * np.outer(e, e) + s_across**2 * np.outer(n, n)
        P0[2:, 2:] = self.cfg.init_speed_sigma**2 * np.eye(2)
        self._new_track(t, np.array([p[0], p[1], 0.0, 0.0]), P0, label)

    def _prune(self, t: float) -> None:
        keep = []
        for tr in self.tracks:  # oldest first
            hopeless = not tr.confirmed and tr.hits + (self.cfg.confirm_n - tr.scans) < self.cfg.confirm_m
            dup = any(np.hypot(*(tr.filt.x[:2] - o.filt.x[:2])) < self.cfg.merge_distance for o in keep)
            coast = self.cfg.max_coast_labelled if tr.label else self.cfg.max_coast
            if hopeless or dup or t - tr.t_update > coast:
                self.dead.append(tr)
            else:
                keep.append(tr)
        self.tracks = keep

    # --- smoothing ----------------------------------------------------------------------
    def _smoothed_rows(self) -> list:
        rows = []
        kf = KalmanFilter(dim_x=4, dim_z=2)
        for tr in self.dead + self.tracks:
            if not tr.confirmed or len(tr.history) == 0:
                continue
            ts = np.array([h[0] for h in tr.history])
            Xs = np.array([h[1] for h in tr.history])
            Ps = np.array([h[2] for h in tr.history])
            Fs = np.array([h[3] for h in tr.history])
            Qs = np.array([h[4] for h in tr.history])
            xs, _, _, _ = kf.rts_smoother(Xs, Ps, Fs, Qs)
            for t, x in zip(ts, xs):
                if tr.t_first <= t <= tr.t_update and t in self.grid:
                    rows.append((t, tr.id, *x))
        return rows
