"""Is the target_planes track consistent? Its target track's errors against the spread it reports.

    python -m scripts.measure_tp_consistency DIR [DIR ...] [--param KEY=VALUE ...]   # occlusion_lab recordings

Runs target_planes on each recording with the experiment's click (``experiment_tsutsui.click``)
and reads, frame by frame, the hand-chosen target's track inside the tracker (``tp_joint``): its
state s and covariance S after the frame's updates, against the target's true position and
velocity, where the track is within 1 m of the target (a lost track is an identity question).
Prints the position error (median) against the reported standard deviation (median of sqrt(trace
S_xy / 2)), the along-track errors of the position and the velocity (negative: behind its person,
slower than it; frames of the target walking over 0.5 m/s), and the normalised error squared e^T
S^-1 e of the position and of the velocity: a consistent filter averages 2 (chi^2 with 2 degrees
of freedom; median 1.39). Also by the target's true turn rate (frames within 0.5 s of a turn),
and, for each kind of update the track took (a window's centroid plane, an edge plane, a flow),
the true measurement error against the sigma the tracker gave it: mean z^2 is 1 for a calibrated
sigma. And the whiteness of the track's own centroid-plane innovations (a window of the track
alone: the column's plane against the state before that update, over the innovation's predicted
sd): their mean square (1 for a consistent filter) and the correlation of one camera's innovation
with the same camera's in the next frame (0 for a filter whose model of the measurements and the
motion is right: persistent window errors, or a filter that reacts too little, make it positive).
Where the innovations persist because the track lags its person and not because the windows do,
the centroid planes of the target walking (over 0.5 m/s) tell it: the along-track offset of the
planes from the truth and of the track's state before each update, each the least-squares L of r =
(a . m) L over the planes (r: the plane's or the state's displacement from the truth along the
plane's normal a, m the direction of motion; negative: behind). The truth is read here, by the
experimenter.
"""
import numpy as np

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts import experiment_tsutsui as ts
from trackroom.dataset import read_recording
from trackroom.estimators import tp_joint

GATE_M = 1.0  # a track farther than this from the target is lost, not noisy
TURN_BINS = ((0.0, 0.3), (0.3, 1.0), (1.0, np.inf))  # rad/s


class Probe:
    """Wraps ``tp_joint.JointTracker``'s per-frame methods for one run, recording what the
    target's track (id 0) reports and the errors of the measurements it takes."""

    def __init__(self):
        self.truth: dict = {}
        self.t = 0.0
        self.frames: list = []  # (NEES position, NEES velocity, position error, reported sd, along-track error, turn rate, along-track velocity error)
        self.updates: list = []  # (kind, z = true error / sigma)
        self.innovations: list = []  # (recording, camera, frame, innovation / its predicted sd) of the target track's own centroid planes
        self.along: list = []  # (a . m, the plane's displacement from the truth along a, the state's before the update), centroid planes of the walking target
        self.frame, self.rec = 0, 0
        JT = tp_joint.JointTracker
        self.orig = JT.step, JT.update_plane, JT.update_flow
        probe = self

        def step(jt, tracks, frame, dt, *args):
            probe.t += dt
            probe.frame += 1
            out = probe.orig[0](jt, tracks, frame, dt, *args)
            x = probe.now()
            for tr in tracks:
                if tr.tid == 0 and tr.located and x is not None and np.linalg.norm(tr.s[:2] - x[:2]) < GATE_M:
                    e = tr.s - x[:4]
                    sp = float(np.linalg.norm(x[2:4]))
                    probe.frames.append((float(e[:2] @ np.linalg.solve(tr.S[:2, :2], e[:2])), float(e[2:] @ np.linalg.solve(tr.S[2:, 2:], e[2:])),
                                         float(np.linalg.norm(e[:2])), float(np.sqrt(np.trace(tr.S[:2, :2]) / 2)),
                                         float(e[:2] @ x[2:4]) / sp if sp > 0.5 else np.nan, float(x[4]),
                                         float(e[2:] @ x[2:4]) / sp if sp > 0.5 else np.nan))
            return out

        def update_plane(jt, tr, c, p, u, sigma_px, offset_sign=0.0, **kw):
            x = probe.now()
            if tr.tid == 0 and x is not None and np.linalg.norm(tr.s[:2] - x[:2]) < GATE_M:
                row = jt.plane_row(c, p, u, offset_sign)
                if row is not None:
                    a, b, g = row
                    probe.updates.append(("edge plane" if offset_sign else "centroid plane", float(b - a @ x[:2]) / (sigma_px / g)))
                    if not offset_sign:
                        speed = float(np.linalg.norm(x[2:4]))
                        if speed > 0.5:
                            probe.along.append((float(a @ x[2:4]) / speed, float(b - a @ x[:2]), float(a @ (tr.s[:2] - x[:2]))))
                        if kw.get("own", True) and kw.get("weight", 1.0) == 1.0:
                            sy = float(a @ tr.S[:2, :2] @ a) + (sigma_px / g) ** 2
                            probe.innovations.append((probe.rec, c, probe.frame, float(b - a @ tr.s[:2]) / np.sqrt(sy)))
            return probe.orig[1](jt, tr, c, p, u, sigma_px, offset_sign, **kw)

        def update_flow(jt, tr, c, p, flow, extra_var=0.0, **kw):
            x = probe.now()
            if tr.tid == 0 and x is not None and np.linalg.norm(tr.s[:2] - x[:2]) < GATE_M:
                r = np.asarray(flow, float) - p.J[:, :2] @ x[2:4]
                probe.updates.append(("flow", float(r @ np.linalg.solve(jt.flow_noise(c, p, extra_var), r)) / 2.0))  # per component, the update's noise
            return probe.orig[2](jt, tr, c, p, flow, extra_var, **kw)

        JT.step, JT.update_plane, JT.update_flow = step, update_plane, update_flow

    def close(self):
        tp_joint.JointTracker.step, tp_joint.JointTracker.update_plane, tp_joint.JointTracker.update_flow = self.orig

    def now(self):
        return self.truth.get(round(self.t, 2))

    def run(self, d, params: dict) -> None:
        rec = read_recording(d)
        people = rec.truth.people
        g = people[people["person_id"] == ts.TARGET].sort_values("t")
        t = g["t"].to_numpy(float)
        xy, v = g[["x", "y"]].to_numpy(float), g[["vx", "vy"]].to_numpy(float)
        acc = np.gradient(v, t, axis=0)
        turn = np.abs(v[:, 0] * acc[:, 1] - v[:, 1] * acc[:, 0]) / np.maximum((v**2).sum(1), 0.04)
        k = max(int(round(0.5 / max(float(np.median(np.diff(t))), 1e-3))), 1)
        turn = np.convolve(turn, np.ones(2 * k + 1) / (2 * k + 1), mode="same")  # within 0.5 s of a turn
        self.truth = {round(float(a), 2): np.r_[p, q, w] for a, p, q, w in zip(t, xy, v, turn)}
        self.t = 0.0
        self.rec += 1
        ts.run_target(rec, params)


def whiteness(innovations: list) -> tuple[int, float, float, int]:
    """(count, mean square, lag-one correlation, pairs) of normalised innovations given as
    (recording, camera, frame, z): the correlation of z with the same recording's and camera's
    z in the next frame (NaN with fewer than three pairs)."""
    if not innovations:
        return 0, float("nan"), float("nan"), 0
    z = {(r, c, k): v for r, c, k, v in innovations}
    pairs = np.array([(v, z[(r, c, k + 1)]) for (r, c, k), v in z.items() if (r, c, k + 1) in z]).reshape(-1, 2)
    vals = np.array(list(z.values()))
    rho = float(np.corrcoef(pairs[:, 0], pairs[:, 1])[0, 1]) if len(pairs) > 2 else float("nan")
    return len(vals), float(np.mean(vals**2)), rho, len(pairs)


def along_offset(along: list) -> tuple[int, float, float]:
    """(count, L of the planes, L of the states): the along-track offsets (m; negative: behind)
    that best explain, by least squares, the displacements r from the truth along each plane's
    normal a as r = (a . m) L, m the direction of motion; given as (a . m, r plane, r state)."""
    if not along:
        return 0, float("nan"), float("nan")
    c, rw, rs = np.array(along, float).T
    cc = float(c @ c)
    if cc <= 0.0:
        return len(c), float("nan"), float("nan")
    return len(c), float(c @ rw) / cc, float(c @ rs) / cc


def main(argv=None) -> int:
    recordings, params, _ = ts.recordings_and_params(__doc__, argv)
    ts.refuse_lookahead("measure_tp_consistency", params, "measure")
    probe = Probe()
    try:
        for d in recordings:
            probe.run(d, params)
    finally:
        probe.close()
    if not probe.frames:
        print("the target's track was never within 1 m of the target")
        return 1
    f = np.array(probe.frames)
    print(f"{len(f)} frames of the target track within {GATE_M:g} m of the target in {len(recordings)} recording(s)")
    print(f"position error median {np.median(f[:, 2]):.3f} m, reported sd median {np.median(f[:, 3]):.3f} m; "
          f"along-track error median {np.nanmedian(f[:, 4]):+.3f} m (negative: behind), along-track velocity error median "
          f"{np.nanmedian(f[:, 6]):+.3f} m/s (negative: slower than its person)")
    print(f"NEES position mean {f[:, 0].mean():.1f} (median {np.median(f[:, 0]):.2f}), velocity mean {f[:, 1].mean():.1f} "
          f"(median {np.median(f[:, 1]):.2f}); consistent: mean 2, median 1.39")
    for lo, hi in TURN_BINS:
        m = (f[:, 5] >= lo) & (f[:, 5] < hi)
        if m.any():
            print(f"  turn rate {lo:g}-{hi:g} rad/s: {m.sum()} frames, error median {np.median(f[m, 2]):.3f} m, q90 {np.quantile(f[m, 2], 0.9):.3f} m, "
                  f"NEES position mean {f[m, 0].mean():.1f}")
    n, ms, rho, npairs = whiteness(probe.innovations)
    if n:
        print(f"  own centroid-plane innovations {n}: mean square {ms:.2f} (1 if consistent), correlation with the same camera's "
              f"next frame {rho:+.2f} over {npairs} pairs (0 if white)")
    n, lw, ls = along_offset(probe.along)
    if n:
        print(f"  centroid planes of the target walking {n}: along-track offset (least squares), the planes {lw:+.3f} m, "
              f"the track before each update {ls:+.3f} m (negative: behind)")
    kinds = sorted({k for k, _ in probe.updates})
    for kind in kinds:
        z = np.array([v for k, v in probe.updates if k == kind])
        print(f"  {kind} updates {len(z)}: true error against the tracker's sigma, mean z^2 per component {np.mean(z if kind == 'flow' else z**2):.2f} (1 if calibrated)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
