"""How far below the floor plan's occluding edge the windows of a person seen over a box reach,
rendered against analytic.

    python scripts/measure_hidden_rows.py DIR [DIR ...]     # occlusion_lab recordings, either mode

For each frame of each oblique camera and each mover (the scene's target and distractor) that the
floor plan's boxes hide from the camera below some height on its axis while a higher part is seen
(behind a shelf or a low wall; ``tp_joint.Occluders.clear_heights`` at 21 heights from the floor
to the top of the head on 5 vertical lines across its cylinder, at the true position and height),
the seen part's bottom row: the row, on the axis, of the highest hidden height below the lowest
clear one on any line. Every window of the ``boxes`` table that overlaps that person's projected
columns and no other person's (a window of that person alone) is compared with it: its bottom row
minus the seen part's (px; positive: the window reaches below where the camera can see the
person), also as a share of the person's projected height. A flow tracker's window is made of
moving pixels, so a window of that person alone cannot reach far below the box's edge;
``target_planes``' trial ``occluded_rows`` (issue 12's seventy-second session,
docs/trials/72_occluded_rows.diff) relied on it (rendered windows stop at the edge; analytic ones
did not before the twelfth fit of the perception model, which cuts them at the boxes:
docs/sensing.md). The truth is read here, by the experimenter, with a ray test of its own
(``Occluders``), not the simulator's cut (``sim.analytic.box_cut_rows``)."""
import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_joint import Occluders

RADIUS = TargetPlanes.Config.radius  # the tracker's person model, m
STEPS = 21  # heights on the axis, floor to the top of the head
LINES = 5  # vertical lines across the person's cylinder, edge to edge
MOVERS = ("target", "distractor")


def lines(occ: Occluders, c: str, x: float, y: float) -> np.ndarray:
    """Floor points (LINES, 2) of the vertical lines a person at (x, y) is taken as: its axis and
    lines across camera c's view out to the cylinder's radius either side (a person at a box's
    end is seen beside it down to the floor)."""
    xy = np.array([x, y])
    along = xy - occ.centres[c][:2]
    along /= max(float(np.hypot(*along)), 1e-9)
    return xy + np.outer(np.linspace(-RADIUS, RADIUS, LINES), [-along[1], along[0]])


def hidden_rows(rec, name: str = "") -> pd.DataFrame:
    """One row per (frame, camera, mover partly hidden by a box, window of it alone) of a
    recording: its ``name``, time, camera, person, the seen part's bottom row, the window's
    bottom row, their difference ``below`` (px) and the person's projected height (px)."""
    people, boxes = rec.truth.people, rec.observations["boxes"]
    cols_out = ["rec", "t", "camera", "person", "seen_bottom", "window_bottom", "below", "height_px"]
    if not len(boxes):  # a kind the recording lacks reads as an empty table
        return pd.DataFrame(columns=cols_out)
    cams = rec.calibration.cameras_of_kind("oblique")
    Ps = {c: np.asarray(cam.P, float) for c, cam in cams.items()}
    occ = Occluders(rec.calibration.floorplan, Ps, 1.0)
    by = {k: g for k, g in boxes.groupby([boxes.t.round(6), "camera"])}
    rows = []
    for t, now in people.groupby(people.t.round(6)):
        for c, cam in cams.items():
            g = by.get((t, c))
            if g is None:
                continue
            cols = {r.person_id: geo.cylinder_window(Ps[c], (r.x, r.y), 2.0 * r.z, RADIUS) for r in now.itertuples()}
            for r in now.itertuples():
                if r.person_id not in MOVERS or not np.isfinite(cols[r.person_id]).all():
                    continue
                h = 2.0 * r.z  # the person's height (the body centre is half-way up)
                z = h * np.linspace(0.0, 1.0, STEPS)
                clear = occ.clear_heights(c, lines(occ, c, r.x, r.y), z).any(0)
                if clear[0] or not clear.any():
                    continue  # the feet seen, or wholly hidden
                k = int(np.argmax(clear))
                (_, v_seen), _ = geo.project(Ps[c], np.array([r.x, r.y, z[k - 1]]))
                (_, v_head), _ = geo.project(Ps[c], np.array([r.x, r.y, h]))
                (_, v_feet), _ = geo.project(Ps[c], np.array([r.x, r.y, 0.0]))
                w = cols[r.person_id]
                others = [cols[o] for o in cols if o != r.person_id and np.isfinite(cols[o]).all()]
                for b in g.itertuples():
                    if b.u_right < w[0] or b.u_left > w[1]:
                        continue
                    if any(b.u_right >= o[0] and b.u_left <= o[1] for o in others):
                        continue  # it may be someone else's, or merged
                    rows.append((name, t, c, r.person_id, float(v_seen), float(b.v_bottom), float(b.v_bottom - v_seen),
                                 float(v_feet - v_head)))
    return pd.DataFrame(rows, columns=cols_out)


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Of the measured windows ``df`` (``main`` gives it one recording mode at a time): how many,
    and the share reaching below the seen part by more than 5 px, 15 px and a quarter of the
    person's projected height, with the median reach (px)."""
    share = df.below / df.height_px
    return pd.DataFrame({
        "windows": [len(df)],
        "below >5 px": [float((df.below > 5).mean())],
        "below >15 px": [float((df.below > 15).mean())],
        "below >1/4 height": [float((share > 0.25).mean())],
        "median below, px": [float(df.below.median())],
    }).round(3)


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        sys.exit(__doc__)
    parts = []
    for d in recording_folders(argv, "measure_hidden_rows"):
        rec = read_recording(d)
        part = hidden_rows(rec, str(d))
        if len(part):
            part["sensing"] = rec.meta.get("sensing", "?")
            parts.append(part)
    if not parts:
        sys.exit("measure_hidden_rows: no window of a mover partly hidden by the floor plan's boxes in these recordings")
    df = pd.concat(parts, ignore_index=True)
    for mode, sub in df.groupby("sensing"):
        print(f"{mode}: {sub.rec.nunique()} recordings")
        print(summary(sub).to_string(index=False))


if __name__ == "__main__":
    main()
