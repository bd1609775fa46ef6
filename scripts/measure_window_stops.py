"""Flow windows on a walker slowing to a stop, rendered against analytic.

    python scripts/measure_window_stops.py DIR [DIR ...]     # occlusion_lab recordings, either mode

For each stop of a mover (the scene's target and distractor: speed below 0.05 m/s after at least
0.5 m/s from 2 s to 1 s before) and each oblique camera that sees the stopping point whole (inside
the image, not hidden by the floor plan's boxes, as ``target_planes`` decides it): whether a
window of the ``boxes`` table holds the person's axis column (+-3 px) at frames -8 ... +3 from the
stop. Run on rendered recordings and on their analytic twins (same seeds, same paths) to compare
how long each keeps a window on someone slowing down: ``target_planes``' existence test charges
a miss to a track it still predicts moving. The truth is read here, by the experimenter.
"""
import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_joint import Occluders

HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m
FRAMES = range(-8, 4)


def stops(d) -> pd.DataFrame:
    rec = read_recording(d)
    people, boxes = rec.truth.people, rec.observations["boxes"]
    by = {k: g for k, g in boxes.groupby([boxes.t.round(6), "camera"])}
    cams = rec.calibration.cameras_of_kind("oblique")
    Ps = {c: np.asarray(cam.P, float) for c, cam in cams.items()}
    occ = Occluders(rec.calibration.floorplan, Ps, HEIGHT)
    rows = []
    for pid in ("target", "distractor"):
        p = people[people.person_id == pid].sort_values("t").reset_index(drop=True)
        t, speed = p.t.to_numpy(), np.hypot(p.vx, p.vy).to_numpy()
        for k in range(1, len(p)):
            if not (speed[k] < 0.05 <= speed[k - 1] and t[k] > 2.5 and (speed[(t >= t[k] - 2.0) & (t <= t[k] - 1.0)] > 0.5).all()):
                continue
            xy = np.array([p.x[k], p.y[k]])
            for c, cam in cams.items():
                win = geo.cylinder_window(Ps[c], xy, HEIGHT, RADIUS)
                if not occ.visible(c, xy) or win[0] < 0 or win[1] > cam.width:
                    continue
                u = 0.5 * (win[0] + win[1])
                seen = []
                for r in FRAMES:
                    g = by.get((round(round(t[k] * cam.fps) / cam.fps + r / cam.fps, 6), c))
                    seen.append(bool(g is not None and ((g.u_left.to_numpy() - 3 <= u) & (u <= g.u_right.to_numpy() + 3)).any()))
                rows.append((str(d), pid, t[k], c, *seen))
    return pd.DataFrame(rows, columns=["rec", "pid", "t", "camera", *[f"{r:+d}" for r in FRAMES]])


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    df = pd.concat([stops(d) for d in recording_folders(sys.argv[1:], "measure_window_stops")])
    print(f"{len(df)} camera-stops; share with a window on the axis, by frame from the stop:")
    print(df[[f"{r:+d}" for r in FRAMES]].mean().round(3).to_frame("window").T.to_string(index=False))
