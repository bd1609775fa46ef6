"""How wide a rendered flow window is against a person model's image: for ``target_planes``'
``width_depth`` (``JointTracker.body_width``).

    python -m scripts.measure_window_widths DIR [DIR ...]     # rendered occlusion_lab recordings (from the repository root)

Each window of a walker (faster than 0.3 m/s) seen whole (``visible_fraction`` > 0.97, the
segmentation labels of the rendered recording) and not touching an image border is matched to
its person (``experiment_tsutsui.window_errors``) and its width compared with two models' image
widths at the person's true floor position: the model cylinder (rims at the floor and at
``HEIGHT``, the tracker's person model) and the body's cylindrical part (rims at ``RADIUS`` and
``HEIGHT`` - ``RADIUS``: the walkers are capsules). Printed per model: the window width minus the
model's, median and robust sigma (1.4826 MAD), over all windows and by the model's width. The
truth is read here, by the experimenter (issue 12's twenty-eighth session).
"""
import argparse
import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_tsutsui import window_errors
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.metrics.aggregate import robust_sigma

HEIGHT, RADIUS = 1.8, 0.2  # target_planes' person model (Config height, radius)
BORDER_PX = 1.0  # a window or model this close to the image's side is cut by it


def width_table(rec) -> pd.DataFrame:
    """One row per window of a walker seen whole: camera, window width, the two models' widths."""
    E = window_errors(rec)
    E = E[E["person"].notna()]
    E = E[(E["speed"] > 0.3) & (E["visible_fraction"] > 0.97)]
    boxes = rec.observations["boxes"].set_index(["t", "camera", "track"]).sort_index()
    people = {pid: g.sort_values("t") for pid, g in rec.truth.people.groupby("person_id")}
    rows = []
    for r in E.itertuples():
        cam = rec.calibration.cameras[r.camera]
        P = np.asarray(cam.P, float)
        g = people[r.person]
        k = min(int(np.searchsorted(g["t"].to_numpy(), r.t - 1e-9)), len(g) - 1)
        xy = g[["x", "y"]].to_numpy()[k]
        b = boxes.loc[(r.t, r.camera, r.track)]
        b = b.iloc[0] if isinstance(b, pd.DataFrame) else b
        full = geo.cylinder_window(P, xy, HEIGHT, RADIUS)
        W = float(cam.width)
        if full[0] < BORDER_PX or full[1] > W - BORDER_PX or b.u_left < BORDER_PX or b.u_right > W - BORDER_PX:
            continue
        rows.append({"camera": r.camera, "window": float(b.u_right - b.u_left), "cylinder": float(full[1] - full[0]),
                     "body": float(geo.cylinder_image_width(P, xy, RADIUS, HEIGHT - RADIUS, RADIUS))})
    return pd.DataFrame(rows, columns=["camera", "window", "cylinder", "body"])


def summary(D: pd.DataFrame, bins=(0, 25, 40, 60, 1000)) -> pd.DataFrame:
    """Window minus model width, per model and model-width bin: count, median, robust sigma."""
    out = []
    for model in ("cylinder", "body"):
        e = D["window"] - D[model]
        for lo, hi in [(bins[0], bins[-1])] + list(zip(bins[:-1], bins[1:])):
            sel = e[(D[model] >= lo) & (D[model] < hi)]
            if not len(sel):
                continue
            med = float(sel.median())
            out.append({"model": model, "model width px": f"{lo}-{hi}" if hi < bins[-1] or lo > bins[0] else "all",
                        "windows": len(sel), "median px": round(med, 2),
                        "robust sigma px": round(robust_sigma(sel), 2)})
    return pd.DataFrame(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR", help="rendered occlusion_lab recording folders (globs allowed)")
    dirs = recording_folders(ap.parse_args(argv).recordings, ap.prog)
    D = pd.concat([width_table(read_recording(d)) for d in dirs], ignore_index=True)
    if not len(D):
        raise SystemExit("no window of a walker seen whole: are these rendered occlusion_lab recordings?")
    print(summary(D).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
