"""Flow windows lying wholly above the heads, or wholly below the feet, of the people in their columns.

    python scripts/measure_window_rows.py DIR [DIR ...]     # occlusion_lab recordings, either mode

For each window of the ``boxes`` table (oblique cameras), the people whose projected cylinders
(the tracker's person model: ``height`` 1.8 m, the tallest person with the gait bob, ``radius``
0.2 m) overlap its columns: whether its bottom row lies above every one's projected head, or its
top row below every one's projected feet, and by how many pixels. ``target_planes``' joint
explanation (``rows_explain``) holds no track whose projected rows a window's do not reach
(``JointTracker.rows_reach``): a window wholly off a person's rows is not that person's. Run on
rendered recordings and on analytic ones to see whether the simulated windows ever are. The truth
is read here, by the experimenter.
"""
from __future__ import annotations

import sys

import numpy as np

from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes

HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m


def frame_off_rows(people: np.ndarray, windows: np.ndarray) -> tuple[int, list[float], list[float]]:
    """One camera frame: ``people`` (P, 4) the projected person models' [u_left, u_right, v_top,
    v_bottom] (NaN: behind the camera), ``windows`` (k, 4) the windows' the same way. Returns
    (windows over no person's columns, gaps (px) of those wholly above every overlapping person's
    head, gaps of those wholly below every one's feet)."""
    none = 0
    above: list[float] = []
    below: list[float] = []
    for w in windows:
        over = np.isfinite(people[:, 0]) & (people[:, 0] <= w[1]) & (people[:, 1] >= w[0])
        if not over.any():
            none += 1
            continue
        head, feet = people[over, 2].min(), people[over, 3].max()
        if w[3] < head:
            above.append(float(head - w[3]))
        if w[2] > feet:
            below.append(float(w[2] - feet))
    return none, above, below


def off_rows(d) -> tuple[int, int, list[float], list[float]]:
    """(windows, windows over no person's columns, gaps above the heads, gaps below the feet) of
    one recording (``frame_off_rows`` over its oblique cameras' frames)."""
    rec = read_recording(d)
    people, boxes = rec.truth.people, rec.observations["boxes"]
    cams = rec.calibration.cameras_of_kind("oblique")
    at = {round(float(t), 6): g for t, g in people.groupby(people.t.round(6))}
    n = none = 0
    above: list[float] = []
    below: list[float] = []
    for (t, c), g in boxes[boxes.camera.isin(list(cams))].groupby([boxes.t.round(6), "camera"]):
        p = at.get(round(float(t), 6))
        if p is None:
            continue
        win = geo.cylinder_window(np.asarray(cams[c].P, float), p[["x", "y"]].to_numpy(), HEIGHT, RADIUS)
        k, a, b = frame_off_rows(win, g[["u_left", "u_right", "v_top", "v_bottom"]].to_numpy(float))
        n, none = n + len(g), none + k
        above += a
        below += b
    return n, none, above, below


def summary(n: int, none: int, above: list[float], below: list[float]) -> str:
    def gaps(g: list[float]) -> str:
        return f" (gap median {np.median(g):.1f} px, max {max(g):.1f} px)" if g else ""
    return (f"{n} windows, {none} over no person's columns; wholly above every overlapping person's head: {len(above)} "
            f"({100 * len(above) / max(n, 1):.3f} %){gaps(above)}; wholly below every one's feet: {len(below)} "
            f"({100 * len(below) / max(n, 1):.3f} %){gaps(below)}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    n = none = 0
    above: list[float] = []
    below: list[float] = []
    for d in recording_folders(sys.argv[1:], "measure_window_rows"):
        a, b, c, e = off_rows(d)
        n, none = n + a, none + b
        above += c
        below += e
    print(summary(n, none, above, below))
