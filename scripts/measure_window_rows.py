"""Flow windows lying wholly above the heads, or wholly below the feet, of the people in their columns.

    python scripts/measure_window_rows.py DIR [DIR ...]     # occlusion_lab recordings, either mode
    python scripts/measure_window_rows.py --analytic 109,118 [--draw 1] [--set KEY=VALUE]
                                          # analytic ones simulated here, by the part of the model that drew each window

For each window of the ``boxes`` table (oblique cameras), the people whose projected cylinders
(the tracker's person model: ``height`` 1.8 m, the tallest person with the gait bob, ``radius``
0.2 m) overlap its columns: whether its bottom row lies above every one's projected head, or its
top row below every one's projected feet, and by how many pixels. ``target_planes``' joint
explanation (``rows_explain``) holds no track whose projected rows a window's do not reach
(``JointTracker.rows_reach``): a window wholly off a person's rows is not that person's. Run on
rendered recordings and on analytic ones to see whether the simulated windows ever are. The truth
is read here, by the experimenter.

``--analytic SEEDS`` simulates analytic occlusion_lab recordings (35 s; ``--draw``, ``--set`` as
``scripts/experiment_tsutsui.py``'s) and counts the windows by the part of the perception model
that drew them (``sim/analytic_detectors.py``): a person's window (alone or merged), a fragment
of a detected person, a partial window of a missed one, a false window. It labels them by
wrapping the model's ``WindowIds`` methods while it simulates; the recordings are not changed.
"""
from __future__ import annotations

import argparse
import contextlib
import sys
from collections import Counter

import numpy as np

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
import trackroom.sim.analytic_detectors as detectors
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate

HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m


def window_off_rows(people: np.ndarray, w: np.ndarray) -> tuple[str | None, float]:
    """One window ``w`` [u_left, u_right, v_top, v_bottom] against the people's projected person
    models ``people`` (P, 4; NaN: behind the camera): ("none", 0) over no person's columns,
    ("above", gap px) wholly above every overlapping person's head, ("below", gap px) wholly
    below every one's feet, else (None, 0)."""
    over = np.isfinite(people[:, 0]) & (people[:, 0] <= w[1]) & (people[:, 1] >= w[0])
    if not over.any():
        return "none", 0.0
    head, feet = people[over, 2].min(), people[over, 3].max()
    if w[3] < head:
        return "above", float(head - w[3])
    if w[2] > feet:
        return "below", float(w[2] - feet)
    return None, 0.0


def frame_off_rows(people: np.ndarray, windows: np.ndarray) -> tuple[int, list[float], list[float]]:
    """One camera frame: ``people`` (P, 4) the projected person models' [u_left, u_right, v_top,
    v_bottom] (NaN: behind the camera), ``windows`` (k, 4) the windows' the same way. Returns
    (windows over no person's columns, gaps (px) of those wholly above every overlapping person's
    head, gaps of those wholly below every one's feet)."""
    none = 0
    above: list[float] = []
    below: list[float] = []
    for w in windows:
        kind, gap = window_off_rows(people, w)
        none += kind == "none"
        if kind == "above":
            above.append(gap)
        elif kind == "below":
            below.append(gap)
    return none, above, below


def camera_frames(rec):
    """(camera name, windows (k, 4), their ids, the people's projected person models (P, 4)) of
    each oblique camera frame of a recording."""
    people, boxes = rec.truth.people, rec.observations["boxes"]
    cams = rec.calibration.cameras_of_kind("oblique")
    at = {round(float(t), 6): g for t, g in people.groupby(people.t.round(6))}
    for (t, c), g in boxes[boxes.camera.isin(list(cams))].groupby([boxes.t.round(6), "camera"]):
        p = at.get(round(float(t), 6))
        if p is None:
            continue
        win = geo.cylinder_window(np.asarray(cams[c].P, float), p[["x", "y"]].to_numpy(), HEIGHT, RADIUS)
        yield c, g[["u_left", "u_right", "v_top", "v_bottom"]].to_numpy(float), g.track.to_numpy(), win


def off_rows(d) -> tuple[int, int, list[float], list[float]]:
    """(windows, windows over no person's columns, gaps above the heads, gaps below the feet) of
    one recording (``frame_off_rows`` over its oblique cameras' frames)."""
    n = none = 0
    above: list[float] = []
    below: list[float] = []
    for _, windows, _, people in camera_frames(read_recording(d)):
        k, a, b = frame_off_rows(people, windows)
        n, none = n + len(windows), none + k
        above += a
        below += b
    return n, none, above, below


PARTS = {"fragments": "fragment", "partials": "partial", "clutter": "false"}  # WindowIds method -> label


@contextlib.contextmanager
def labelled_windows():
    """While open, the analytic windows the perception model draws are labelled: yields a dict
    (camera name, window id) -> "fragment", "partial" or "false"; a window not in it is a
    person's (alone or merged). Window ids are per camera, so ``windows`` is wrapped to know
    which camera's ids the ``WindowIds`` methods draw."""
    labels: dict = {}
    camera = {"name": None}
    saved = {name: getattr(detectors.WindowIds, name) for name in PARTS}
    saved_windows = detectors.windows

    def labelling(name):
        def draw(self, *args, **kwargs):
            out = saved[name](self, *args, **kwargs)
            labels.update({(camera["name"], int(i)): PARTS[name] for i in np.unique(out[3])})
            return out
        return draw

    def windows(cam, *args, **kwargs):
        camera["name"] = cam.name
        return saved_windows(cam, *args, **kwargs)

    try:
        for name in PARTS:
            setattr(detectors.WindowIds, name, labelling(name))
        detectors.windows = windows
        yield labels
    finally:
        for name, f in saved.items():
            setattr(detectors.WindowIds, name, f)
        detectors.windows = saved_windows


def off_rows_by_part(rec, labels: dict) -> Counter:
    """(part, kind) -> windows of an analytic recording, ``labels`` from ``labelled_windows``;
    kind "all", "none", "above" or "below" (``window_off_rows``); part "person", "fragment",
    "partial" or "false"."""
    out: Counter = Counter()
    for c, windows, ids, people in camera_frames(rec):
        for w, i in zip(windows, ids):
            part = labels.get((c, int(i)), "person")
            out[part, "all"] += 1
            kind, _ = window_off_rows(people, w)
            if kind:
                out[part, kind] += 1
    return out


def part_table(counts: Counter) -> str:
    """A markdown table of ``off_rows_by_part``'s counts."""
    lines = ["| part of the model | windows | over no one's columns | wholly above every head | wholly below every foot |",
             "| --- | --- | --- | --- | --- |"]
    for part in ("person", "fragment", "partial", "false"):
        n = counts[part, "all"]
        cells = [f"{counts[part, k]} ({100 * counts[part, k] / max(n, 1):.2f} %)" for k in ("none", "above", "below")]
        lines.append(f"| {part} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def analytic_by_part(seeds: list[int], draw: int = 0, overrides: list[str] | None = None, duration: float = 35.0) -> Counter:
    """``off_rows_by_part`` summed over analytic occlusion_lab recordings simulated here."""
    scene = load_scene("occlusion_lab", overrides or None)
    total: Counter = Counter()
    for seed in seeds:
        with labelled_windows() as labels:
            rec = simulate(scene, seed=seed, duration=duration, sensing="analytic", perception_draw=draw)
        total += off_rows_by_part(rec, labels)
    return total


def summary(n: int, none: int, above: list[float], below: list[float]) -> str:
    def gaps(g: list[float]) -> str:
        return f" (gap median {np.median(g):.1f} px, max {max(g):.1f} px)" if g else ""
    return (f"{n} windows, {none} over no person's columns; wholly above every overlapping person's head: {len(above)} "
            f"({100 * len(above) / max(n, 1):.3f} %){gaps(above)}; wholly below every one's feet: {len(below)} "
            f"({100 * len(below) / max(n, 1):.3f} %){gaps(below)}")


def main(argv: list[str]) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="*", help="recording folders")
    ap.add_argument("--analytic", help="comma-separated seeds: analytic recordings simulated here, by part of the model")
    ap.add_argument("--draw", type=int, default=0, help="the perception model's draw (with --analytic)")
    ap.add_argument("--set", dest="overrides", action="append", default=[], help="scene override KEY=VALUE (with --analytic)")
    args = ap.parse_args(argv)
    if bool(args.dirs) == bool(args.analytic):
        ap.error("give recording folders or --analytic SEEDS, not both")
    if args.analytic:
        try:
            seeds = [int(s) for s in args.analytic.split(",")]
        except ValueError:
            ap.error(f"--analytic takes comma-separated integer seeds, got {args.analytic!r}")
        print(part_table(analytic_by_part(seeds, args.draw, args.overrides)))
        return
    n = none = 0
    above: list[float] = []
    below: list[float] = []
    for d in recording_folders(args.dirs, "measure_window_rows"):
        a, b, c, e = off_rows(d)
        n, none = n + a, none + b
        above += c
        below += e
    print(summary(n, none, above, below))


if __name__ == "__main__":
    main(sys.argv[1:])
