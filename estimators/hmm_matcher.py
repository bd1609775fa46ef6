"""HMM matcher: identify and localise people by matching overhead-camera tracks to phone IMUs.

T. Teixeira, D. Jung, A. Savvides, "Tasking Networked CCTV Cameras and Mobile Phones to Identify
and Localize Multiple People", UbiComp 2010 (``shared/papers/002_*``).

Pipeline (one call of ``estimate``):

1. **Lazy tracker** (``estimators/lazy_tracker.py``): anonymous floor detections -> track segments
   that are unambiguous between proximity / static ambiguities and drop-outs (track hypotheses
   theta, eq. 9), each with a Kalman-filtered position and velocity.
2. **Phone features** (``estimators/gait.py``): bobbing feature g_k and magnetometer heading psi_m,k
   for every phone at every camera frame time.
3. **Per-track MAP recursion** (eqs. 15-20) for every (segment h, phone i) pair. The hidden state is
   x_k = (s_k, psi_k) with s_k in {stopped, walking} and psi_k the walking direction. Emissions:

       camera  p(y_k | x_k):  speed |v_k| of the segment's least-squares velocity over the last
                              ``velocity_window_s`` (variance Pvv, ``lazy_tracker.window_velocity``):
                              stopped: Rayleigh(sqrt(Pvv + s0^2)), walking: N(mu_s, sigma_s^2 + Pvv)
                              heading psi_c = atan2(vy, vx), von Mises around psi_k with
                              kappa_c = |v|^2 / Pvv (heading spread of a 2-D Gaussian velocity)
       phone   p(w_k | x_k):  g_k: exponential (stopped) / Gaussian (walking), fitted by train-gait;
                              psi_m von Mises around psi_k with kappa_m (fitted by train-gait)
       prior   p(s_k | s_{k-1}): stay with probability 1 - dt / switch_s.

   The MAP sequence over s is found by the max-product recursion (eq. 19)
       V_k(s) = e_k(s) + max_s' [V_{k-1}(s') + log p(s | s')],   log L_MAP = max_s V_K(s)  (eq. 20)
   and psi_k, which has a flat prior, is integrated out within each frame in closed form:
       log int vm(psi_c; psi, kappa_c) vm(psi_m; psi, kappa_m) dpsi/2pi  ~=  log vm(psi_c - psi_m; kappa_eff)
       - log 2pi,   1/kappa_eff = 1/kappa_c + 1/kappa_m   (``scipy.stats.vonmises``).
   Omega is put on a likelihood-ratio scale: the same recursion is run for the segment alone and
   for the phone alone (independent states), and

       LLR(h, i) = log L_MAP(h, i) - log L_MAP(h) - log L_MAP(i) + Lambda(h, i),

   so an LLR near 0 means "no evidence either way". Consecutive frames share most of their data
   (1 s windows, a filtered velocity), so emissions are tempered by ``evidence_weight`` (the
   fraction of a frame that is new information).
4. **Carrying evidence across segment breaks** (beyond the paper): a new segment n inherits
       Lambda(n, i) = log sum_e  w(n|e) / W  exp(LLR(e, i))   (+ a "newcomer" term with LLR 0),
   over the segments e that ended shortly before near it, with the tracker's continuity weights
   w(n|e) and W their sum with the newcomer density. People who cross, meet or stop together are
   therefore re-identified instead of starting from zero evidence.
5. **Global assignment** each camera frame (eq. 21): maximise sum (LLR - log Omega_min) over
   (segment, phone) pairs with ``linear_sum_assignment`` on a matrix augmented with one
   zero-score "no phone" column per segment, so a pair below Omega_min is never chosen and people
   without phones stay unassigned.

Output tracks: ``t, track_id, x, y, vx, vy, phone_id``; ``track_id`` is the phone id while a phone
is assigned (segments joined into one identified track, as in Fig. 7c), else ``anon<segment>``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats
from scipy.optimize import linear_sum_assignment
from scipy.special import logsumexp

from sim.recording import Calibration, Observations

from .base import Estimator, EstimatorError, check_tracks, register
from .gait import GaitModel, bobbing_feature, load_default, phone_heading
from .lazy_tracker import Segments, TrackerConfig, frames_from_detections, track_segments

LOG_2PI = float(np.log(2 * np.pi))


@dataclass(frozen=True)
class PhoneFeatures:
    """Per phone, per camera frame: bobbing feature g (m/s^2) and heading psi_m (rad)."""

    phone_ids: list[str]
    g: np.ndarray  # (F, P)
    heading: np.ndarray  # (F, P)


def phone_features(imu: pd.DataFrame, frame_times: np.ndarray, gait: GaitModel, field_world, heading_window_s: float) -> PhoneFeatures:
    phone_ids = sorted(imu["phone_id"].astype(str).unique())
    F, P = len(frame_times), len(phone_ids)
    g = np.zeros((F, P)); psi = np.zeros((F, P))
    for j, pid in enumerate(phone_ids):
        d = imu[imu["phone_id"].astype(str) == pid]
        t = d["t"].to_numpy(float)
        g[:, j] = bobbing_feature(t, d[["ax", "ay", "az"]].to_numpy(float), frame_times, gait.window_s)
        psi[:, j] = phone_heading(t, d[["mx", "my", "mz"]].to_numpy(float), frame_times, heading_window_s, field_world)
    return PhoneFeatures(phone_ids, g, psi)


@register
class HMMMatcher(Estimator):
    """Teixeira et al. 2010: lazy tracker + per-track MAP recursion + Hungarian ID assignment."""

    name = "hmm_matcher"
    description = "overhead floor detections + phone IMUs -> identified tracks (Teixeira et al. 2010)"
    requires = ("floor_detections", "imu")

    @dataclass
    class Config:
        gait_model: str = ""  # path to a train-gait JSON; "" = the bundled estimators/gait_default.json
        # lazy tracker
        r_enter: float = 0.6  # m
        r_exit: float = 0.8  # m
        gate_m: float = 1.0  # m
        max_missed_s: float = 0.3  # s
        accel_q: float = 2.0  # Kalman white-acceleration density, m^2/s^3
        sigma_floor_m: float = 0.02  # lower bound on the detection noise used by the filter, m
        velocity_window_s: float = 1.0  # window of the evidence velocity, s
        # evidence
        evidence_weight: float = 0.2  # tempering of per-frame log-likelihoods (0, 1]
        switch_s: float = 3.0  # mean time between walking/stopped switches, s
        stop_speed_sigma: float = 0.05  # speed spread of a standing person beyond estimation noise, m/s
        kappa_max: float = 100.0  # cap on the camera heading concentration
        heading_window_s: float = 0.25  # magnetometer averaging window, s
        newcomer_density: float = 0.01  # 1/m^2: prior weight of "a new person" at a segment birth
        # assignment
        llr_min: float = 2.0  # log Omega_min: least log-likelihood ratio for an assignment

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        cfg = self.config
        if not 0 < cfg.evidence_weight <= 1:
            raise EstimatorError(f"hmm_matcher: evidence_weight must be in (0, 1] (got {cfg.evidence_weight})")
        det = observations["floor_detections"]
        imu = observations["imu"]
        if not len(det):
            raise EstimatorError("hmm_matcher: no floor detections")
        if not len(imu):
            raise EstimatorError("hmm_matcher: no IMU samples")
        gait = GaitModel.from_json(cfg.gait_model) if cfg.gait_model else load_default()
        segs = self.track(det, calibration, observations.duration)
        field_world = calibration.noise.get("magnetic_field", (0.0, -0.5, 0.0))
        phones = phone_features(imu, segs.frame_times, gait, field_world, cfg.heading_window_s)
        assigned = self.match(segs, phones, gait)
        rows = segs.rows
        phone = np.array([phones.phone_ids[a] if a >= 0 else "" for a in assigned], dtype=object)
        track_id = np.where(assigned >= 0, phone, np.char.add("anon", rows["segment"].to_numpy().astype(str)))
        out = pd.DataFrame({
            "t": rows["t"].to_numpy(float), "track_id": track_id.astype(str), "x": rows["x"].to_numpy(float),
            "y": rows["y"].to_numpy(float), "vx": rows["vx"].to_numpy(float), "vy": rows["vy"].to_numpy(float),
            "phone_id": phone.astype(str),
        })
        return check_tracks(out, self.name)

    # --- 1. tracker -------------------------------------------------------------------------
    def tracker_config(self, calibration: Calibration) -> TrackerConfig:
        cfg = self.config
        cams = calibration.cameras_of_kind("overhead")
        sigma = float(calibration.noise.get("floor_sigma_m", 0.15))
        quantum = max((c.quantum for c in cams.values() if c.privacy), default=0.0)
        # quantisation adds a uniform error of variance quantum^2 / 12 per axis
        sigma_eff = max(np.sqrt(sigma**2 + quantum**2 / 12.0), cfg.sigma_floor_m)
        return TrackerConfig(sigma_m=sigma_eff, q=cfg.accel_q, gate_m=cfg.gate_m, max_missed_s=cfg.max_missed_s,
                             r_enter=cfg.r_enter, r_exit=cfg.r_exit, velocity_window_s=cfg.velocity_window_s)

    def track(self, det: pd.DataFrame, calibration: Calibration, duration: float) -> Segments:
        cams = calibration.cameras_of_kind("overhead")
        fps = max((c.fps for c in cams.values()), default=0.0)
        if fps <= 0:
            raise EstimatorError("hmm_matcher: the calibration has no overhead camera (needed for its frame rate)")
        frame_times, fidx, x, y = frames_from_detections(det, fps, duration)
        return track_segments(frame_times, fidx, x, y, self.tracker_config(calibration))

    # --- 3. emissions ------------------------------------------------------------------------
    def emissions(self, segs: Segments, phones: PhoneFeatures, gait: GaitModel):
        """Tempered log emissions: camera (N, 2), phone (F, P, 2), joint (N, P, 2); index 0 = stopped."""
        cfg = self.config
        rows = segs.rows
        frame = rows["frame"].to_numpy()
        vx, vy, pvv = rows["svx"].to_numpy(float), rows["svy"].to_numpy(float), rows["svv"].to_numpy(float)
        speed = np.hypot(vx, vy)
        cam = np.stack([
            stats.rayleigh.logpdf(speed, scale=np.sqrt(pvv + cfg.stop_speed_sigma**2)),
            stats.norm.logpdf(speed, loc=gait.speed_mu, scale=np.sqrt(gait.speed_sigma**2 + pvv)),
        ], axis=-1)
        ph = gait.loglik(phones.g)
        kappa_c = np.clip(speed**2 / np.maximum(pvv, 1e-9), 1e-6, cfg.kappa_max)
        kappa_eff = 1.0 / (1.0 / kappa_c[:, None] + 1.0 / gait.heading_kappa)
        psi_c = np.arctan2(vy, vx)
        delta = np.angle(np.exp(1j * (phones.heading[frame] - psi_c[:, None])))
        heading = LOG_2PI + stats.vonmises.logpdf(delta, kappa_eff)  # log ratio vs independent headings
        w = cfg.evidence_weight
        joint = cam[:, None, :] + ph[frame]
        joint[..., 1] += heading
        return w * cam, w * ph, w * joint

    # --- 3-5. recursion, carrying, assignment -------------------------------------------------
    def match(self, segs: Segments, phones: PhoneFeatures, gait: GaitModel) -> np.ndarray:
        """Phone index assigned to every tracker row (-1: none)."""
        cfg = self.config
        rows = segs.rows
        N, P, S = len(rows), len(phones.phone_ids), segs.n_segments
        assigned = np.full(N, -1, np.int64)
        if N == 0 or P == 0:
            return assigned
        e_cam, e_ph, e_joint = self.emissions(segs, phones, gait)
        frame = rows["frame"].to_numpy()
        seg = rows["segment"].to_numpy()
        start = segs.info["start_frame"].to_numpy()
        dt = float(np.median(np.diff(segs.frame_times))) if len(segs.frame_times) > 1 else 0.05
        p_sw = min(dt / cfg.switch_s, 0.5)
        logT = np.log(np.array([[1 - p_sw, p_sw], [p_sw, 1 - p_sw]]))  # [s', s]
        log_prior = np.log(0.5)

        Vj = np.zeros((S, P, 2)); Vt = np.zeros((S, 2)); Vp = np.zeros((S, P, 2))
        Lam = np.zeros((S, P)); llr = np.zeros((S, P))
        bounds = np.searchsorted(frame, np.arange(len(segs.frame_times) + 1))
        zeros_dummy = None
        for k in range(len(segs.frame_times)):
            r0, r1 = bounds[k], bounds[k + 1]
            if r0 == r1:
                continue
            sk = seg[r0:r1]
            new = start[sk] == k
            old = ~new
            if new.any():
                sn = sk[new]
                for n in sn:
                    Lam[n] = self.inherit(int(n), segs, llr)
                Vj[sn] = log_prior + e_joint[r0:r1][new]
                Vt[sn] = log_prior + e_cam[r0:r1][new]
                Vp[sn] = log_prior + e_ph[k][None]
            if old.any():
                so = sk[old]
                Vj[so] = e_joint[r0:r1][old] + (Vj[so][..., :, None] + logT).max(axis=-2)
                Vt[so] = e_cam[r0:r1][old] + (Vt[so][..., :, None] + logT).max(axis=-2)
                Vp[so] = e_ph[k][None] + (Vp[so][..., :, None] + logT).max(axis=-2)
            L = Lam[sk] + Vj[sk].max(-1) - Vt[sk].max(-1)[:, None] - Vp[sk].max(-1)
            llr[sk] = L
            # eq. 21 with Omega_min: maximise sum(LLR - llr_min), a zero-score "no phone" per row
            R = len(sk)
            if zeros_dummy is None or zeros_dummy.shape[0] < R:
                zeros_dummy = np.zeros((max(R, 16), max(R, 16)))
            score = np.concatenate([L - cfg.llr_min, zeros_dummy[:R, :R]], axis=1)
            ri, ci = linear_sum_assignment(score, maximize=True)
            ok = (ci < P) & (score[ri, np.minimum(ci, score.shape[1] - 1)] > 0)
            assigned[r0 + ri[ok]] = ci[ok]
        return assigned

    def inherit(self, n: int, segs: Segments, llr: np.ndarray) -> np.ndarray:
        """Lambda(n, .) = log sum_e w(n|e)/W exp(LLR(e, .)), with a newcomer option of LLR 0."""
        preds = segs.predecessors.get(n)
        P = llr.shape[1]
        if not preds:
            return np.zeros(P)
        e = np.array([p[0] for p in preds])
        w = np.array([p[1] for p in preds] + [self.config.newcomer_density])
        logw = np.log(w / w.sum())
        terms = np.concatenate([llr[e], np.zeros((1, P))], axis=0) + logw[:, None]
        return logsumexp(terms, axis=0)
