"""Does the target_planes track lag behind its person? Along- and across-track error of the target.

    python -m scripts.measure_tp_lag DIR [DIR ...] [--param KEY=VALUE ...]   # occlusion_lab recordings

Runs target_planes on each recording with the experiment's click (``experiment_tsutsui.click``)
and compares the reported target track with the target's true position, frame by frame, where
the track is updated by two or more cameras, walks (reported speed over 0.5 m/s) and is within
1 m of the target (a lost track is an identity question, not this one). The error is split along
the reported velocity (negative: the track is behind its person) and across it. A systematic
along-track error is a lag: a flow that falls short of the person's motion drags the velocity,
and the position with it. The truth is read here, by the experimenter.
"""
import numpy as np

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts import experiment_tsutsui as ts
from trackroom.dataset import read_recording


def errors(d, params: dict) -> np.ndarray:
    """(n, 2) along- and across-track errors (m) of the target track in recording ``d``."""
    rec = read_recording(d)
    res = ts.run_target(rec, params)
    tr = res.tracks
    times = tr["t"].to_numpy(float)
    tru = ts.truth_at(rec, times)
    target = tru[tru["person_id"] == ts.TARGET][["x", "y"]].to_numpy(float)
    err = tr[["x", "y"]].to_numpy(float) - target
    v = tr[["vx", "vy"]].to_numpy(float)
    speed = np.hypot(v[:, 0], v[:, 1])
    keep = (tr["n_cameras"].to_numpy() >= 2) & (speed > 0.5) & (np.hypot(err[:, 0], err[:, 1]) <= 1.0)
    u = v[keep] / speed[keep, None]
    e = err[keep]
    return np.column_stack([(e * u).sum(1), e[:, 1] * u[:, 0] - e[:, 0] * u[:, 1]])


def main(argv=None) -> int:
    recordings, params, _ = ts.recordings_and_params(__doc__, argv)
    e = np.vstack([errors(d, params) for d in recordings])
    along, across = e[:, 0], e[:, 1]
    print(f"{len(e)} walking frames of the target track (>= 2 cameras, within 1 m) in {len(recordings)} recording(s)")
    print(f"along-track error: median {np.median(along):+.3f} m (negative: behind), rms {np.sqrt(np.mean(along**2)):.3f} m")
    print(f"across-track error: median {np.median(across):+.3f} m, rms {np.sqrt(np.mean(across**2)):.3f} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
