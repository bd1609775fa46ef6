"""Flow windows' region flow against the true image velocity, by image speed.

    python scripts/measure_flow_errors.py DIR [DIR ...]     # occlusion_lab recordings, either mode

For every window of the ``boxes`` table that holds exactly one walking mover (the scene's target
or distractor, speed over 0.5 m/s: the window covers 30 % of the width of that person's projected
cylinder, 1.8 m by 0.2 m, and of no other person's, standing or not, hidden or not), the
window's flow against the image velocity of that person's body centre (0.85 m above the floor,
``tp_geometry.flow_jacobian`` times the true velocity, eq. 7). Errors are split along the true image
motion (negative: the flow is short of it) and across it, per bin of true image speed, with their
median, robust standard deviation (1.4826 MAD), the robust one relative to the speed, and the
90 % quantile of their size. Run it on rendered recordings to see how the flow detector's error
grows with the image speed (``target_planes``' ``flow_rel_sigma``), and on their analytic twins
to compare. The truth is read here, by the experimenter.
"""
import sys

import numpy as np
import pandas as pd

from trackroom.dataset import read_recording
from trackroom.estimators import tp_geometry as geo

MOVERS = ("target", "distractor")
CENTRE_Z = 0.85
HEIGHT, RADIUS = 1.8, 0.2
SPEED_BINS = (5, 10, 20, 30, 40, 60, 80, 1000)  # px/s


def errors(d) -> pd.DataFrame:
    rec = read_recording(d)
    boxes, people = rec.observations["boxes"], rec.truth.people
    Ps = {c: np.asarray(cam.P, float) for c, cam in rec.calibration.cameras_of_kind("oblique").items()}
    at = {t: g for t, g in people.groupby(people.t.round(2))}
    rows = []
    for b in boxes[boxes.camera.isin(list(Ps))].itertuples():
        t = round(b.t, 2)
        g = at.get(t)
        if g is None:
            continue
        spans = np.array([geo.cylinder_window(Ps[b.camera], np.array([x, y]), HEIGHT, RADIUS)[:2] for x, y in zip(g.x, g.y)])
        overlap = np.clip(np.minimum(spans[:, 1], b.u_right) - np.maximum(spans[:, 0], b.u_left), 0.0, None)
        holds = overlap > 0.3 * np.maximum(spans[:, 1] - spans[:, 0], 1.0)
        if holds.sum() != 1:
            continue
        k = int(np.argmax(holds))
        pid = g.person_id.to_numpy()[k]
        if pid not in MOVERS:
            continue
        x, y, vx, vy = (float(g[c].to_numpy()[k]) for c in ("x", "y", "vx", "vy"))
        if np.hypot(vx, vy) < 0.5:
            continue
        f = geo.flow_jacobian(Ps[b.camera], np.array([x, y, CENTRE_Z])) @ np.array([vx, vy, 0.0])  # eq. 7
        speed = float(np.hypot(*f))
        if speed <= 0.0:
            continue
        e = np.array([b.flow_u, b.flow_v]) - f
        along = float(e @ f) / speed
        across = float(e[1] * f[0] - e[0] * f[1]) / speed
        rows.append((str(d), t, b.camera, pid, speed, along, across))
    return pd.DataFrame(rows, columns=["rec", "t", "camera", "pid", "speed", "along", "across"])


def rsd(x: pd.Series) -> float:
    return float(1.4826 * (x - x.median()).abs().median())


def table(df: pd.DataFrame) -> pd.DataFrame:
    out = []
    for lo, hi in zip(SPEED_BINS[:-1], SPEED_BINS[1:]):
        g = df[(df.speed > lo) & (df.speed <= hi)]
        if not len(g):
            continue
        out.append({"speed px/s": f"{lo}-{hi}", "n": len(g),
                    "along median": g.along.median(), "along rsd": rsd(g.along), "along q90": g.along.abs().quantile(0.9),
                    "across rsd": rsd(g.across), "across q90": g.across.abs().quantile(0.9),
                    "along rsd / speed": rsd(g.along / g.speed), "across rsd / speed": rsd(g.across / g.speed)})
    return pd.DataFrame(out)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    df = pd.concat([errors(d) for d in sys.argv[1:]], ignore_index=True)
    print(f"{len(df)} windows holding one walking mover; flow error (px/s) by true image speed:")
    print(table(df).round(2).to_string(index=False))
