"""Where on the floor plan `target_planes` can test a standing person, by the estimator's own
geometry.

    python scripts/measure_detector_cover.py DIR [--step M] [--map]

A person who stands makes no flow window, so a track that is likelier standing is tested only by
the cameras' person detections (``person_detections``: ``JointTracker.detection_evidence``), and
only where a camera's detector sees the place (``JointTracker.detectable``: the person model's
cylinder in the image, its rays clear of the floor plan's boxes; with ``partial_detections`` also
partly, as often detected). Elsewhere a standing track - a person or a ghost - keeps its existence
log-odds: flow windows and detections say nothing there. For every point of a floor grid where a
person's axis can be (``clear_of_walls``), this counts the cameras that would see a walker there
(the projected cylinder partly in the image and a ray clear: ``partly_in_image``,
``Occluders.visible``) and those whose detector would test someone standing there, with the
recording's calibration and the estimator's default Config; no truth and no observation is read.

It prints the share of that floor by the number of cameras of each kind and, with ``--map``, a
map (north up, one character a grid cell): ``#`` no axis can be there, ``x`` no camera sees a
walker, ``o`` seen by some camera but tested by no detector, a digit the number of detectors that
test it.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes, clear_of_walls
from trackroom.estimators.tp_joint import JointTracker, Occluders, partly_in_image


def cover(calibration, step: float = 0.1, cfg=None) -> pd.DataFrame:
    """One row per grid point (x, y, m; spacing ``step``, cell centres) of the floor plan where a
    person's axis can be: ``seen`` the cameras that would see a walker there, ``tested`` those
    whose person detector would test someone standing there."""
    cfg = cfg or TargetPlanes(multi_person=True).resolved_config(calibration)
    cams = sorted(calibration.cameras)
    Ps = {c: np.asarray(calibration.cameras[c].P, float) for c in cams}
    widths = {c: float(calibration.cameras[c].width) for c in cams}
    # only its geometry is used (``detectable``): the flow and edge noises are placeholders
    jt = JointTracker(cfg, Ps, widths, {c: 1.0 for c in cams}, 1.0, 1.0, {c: float(calibration.cameras[c].fps) for c in cams})
    jt.occluders = Occluders(calibration.floorplan, Ps, cfg.height)
    x0, y0, x1, y1 = calibration.floorplan.bounds()
    xs = np.arange(x0 + 0.5 * step, x1, step)
    ys = np.arange(y0 + 0.5 * step, y1, step)
    grid = np.array([(x, y) for y in ys for x in xs], float)
    grid = grid[clear_of_walls(calibration.floorplan, grid)]
    seen = np.zeros(len(grid), int)
    tested = np.zeros(len(grid), int)
    for c in cams:
        vis = jt.occluders.visible_many(c, grid)
        for k, xy in enumerate(grid):
            win = geo.cylinder_window(Ps[c], xy, cfg.height, cfg.radius)
            if bool(partly_in_image(win, widths[c])) and vis[k]:
                seen[k] += 1
            if jt.detectable(c, xy, win, partial=cfg.partial_detections):
                tested[k] += 1
    return pd.DataFrame({"x": grid[:, 0], "y": grid[:, 1], "seen": seen, "tested": tested})


def shares(cells: pd.DataFrame) -> pd.DataFrame:
    """The share of the grid points (of the floor where an axis can be) by the number of cameras
    that see a walker there (``seen``) and that test someone standing there (``tested``): 0, 1,
    2 or more."""
    out = {}
    for col in ("seen", "tested"):
        n = cells[col].clip(upper=2)
        out[col] = [float((n == k).mean()) for k in (0, 1, 2)]
    return pd.DataFrame(out, index=["0", "1", ">= 2"]).T


def text_map(cells: pd.DataFrame, calibration, step: float) -> str:
    """The grid as text, north up (the module docstring's legend)."""
    x0, y0, x1, y1 = calibration.floorplan.bounds()
    nx, ny = int(round((x1 - x0) / step)), int(round((y1 - y0) / step))
    rows = [["#"] * nx for _ in range(ny)]
    for r in cells.itertuples():
        i, j = int((r.x - x0) / step), int((r.y - y0) / step)
        rows[j][i] = str(min(r.tested, 9)) if r.tested else ("o" if r.seen else "x")
    return "\n".join("".join(row) for row in reversed(rows))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", metavar="DIR", help="a recording folder (its calibration and floor plan are read)")
    ap.add_argument("--step", type=float, default=0.1, help="grid spacing, m (default 0.1)")
    ap.add_argument("--map", action="store_true", help="also print the map")
    args = ap.parse_args(argv)
    if not args.step > 0:
        ap.error(f"--step must be a positive number of metres, got {args.step}")
    try:
        rec = read_recording(args.dir)
    except (OSError, ValueError) as exc:
        print(f"measure_detector_cover: cannot read the recording {args.dir}: {exc}", file=sys.stderr)
        return 2
    cells = cover(rec.calibration, args.step)
    print(f"{len(cells)} grid points ({args.step} m) where a person's axis can be; share by number of cameras:")
    print(shares(cells).to_string(float_format=lambda v: f"{100 * v:.1f} %"))
    if args.map:
        print(text_map(cells, rec.calibration, args.step))
    return 0


if __name__ == "__main__":
    sys.exit(main())
