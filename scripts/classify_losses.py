"""Where and how the target is first lost: the single-target run of each recording, at its first loss.

    python scripts/classify_losses.py DIR [DIR ...]        # occlusion_lab recordings, either mode

For each recording, ``target_planes``' single-target run as ``scripts/experiment_tsutsui.py`` makes
it (the seeded click, the calibration's noise), then at its first loss (the first ``RUN`` frames
running whose output is not held: not nearest the target, or over 1 m from it) the truth around
it: the target's lowest speed over the second before, the nearest other person (distance, speed)
and whom the output is nearest. One line per recording and a class:

- ``taken while slow``: the output is nearest another person who walks (>= ``WALKING`` m/s)
  and the target's lowest speed over the second before is under ``WALKING``: the target stops or
  sets off beside a walker;
- ``taken``: the output is nearest another person, the target walking;
- ``off``: the output is nearest the target but over 1 m from it;
- ``no output``: no track carries the identity.

The truth is read here, by the experimenter, never by the estimator. Used to classify the misses
of evaluation sets (docs/target_planes.md, issue 12's sixty-first session).
"""
from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from scripts import experiment_tsutsui as ts
from trackroom.dataset import read_recording, recording_folders

RUN = 3  # frames running not held: a loss, not a one-frame slip
WALKING = 0.5  # m/s: walking, as scripts/measure_flow_errors.py's walkers
BEFORE_S = 1.0  # the target's speed over this long before the loss


def first_loss(held: np.ndarray, run: int = RUN) -> int | None:
    """Index of the first of ``run`` frames running not held, or None."""
    bad = ~np.asarray(held, bool)
    for k in range(len(bad) - run + 1):
        if bad[k:k + run].all():
            return k
    return None


def loss_context(people: pd.DataFrame, t: float, xy: tuple[float, float]) -> dict:
    """The truth at a loss at time ``t`` with the output at ``xy`` (NaN: none): ``people`` the
    truth table (t, person_id, x, y, vx, vy). Returns the target's lowest speed over the
    ``BEFORE_S`` before, the nearest other person (id, distance, speed), the person nearest the
    output and their distances, and the class (module docstring)."""
    speed = np.hypot(people["vx"].to_numpy(float), people["vy"].to_numpy(float))
    people = people.assign(speed=speed)
    times = np.unique(people["t"].to_numpy(float))
    now = people[people["t"] == times[np.argmin(np.abs(times - t))]].set_index("person_id")
    if ts.TARGET not in now.index:
        raise ValueError(f"no {ts.TARGET!r} in the truth at t = {t:.2f} s")
    target = now.loc[ts.TARGET]
    window = people[(people["person_id"] == ts.TARGET) & (people["t"] >= t - BEFORE_S - 1e-9) & (people["t"] <= t + 1e-9)]
    out = {"t": float(t), "target_min_speed": float(window["speed"].min()), "target_speed": float(target["speed"])}
    others = now.drop(index=ts.TARGET)
    if len(others):
        d = np.hypot(others["x"] - target["x"], others["y"] - target["y"])
        k = str(d.idxmin())
        out.update(nearest=k, nearest_m=float(d.min()), nearest_speed=float(others.loc[k, "speed"]))
    x, y = xy
    if not (np.isfinite(x) and np.isfinite(y)):
        out["kind"] = "no output"
        return out
    d = np.hypot(now["x"] - x, now["y"] - y)
    who = str(d.idxmin())
    out.update(output_nearest=who, output_nearest_m=float(d.min()), output_target_m=float(d.loc[ts.TARGET]))
    if who == ts.TARGET:
        out["kind"] = "off"
    elif now.loc[who, "speed"] >= WALKING and out["target_min_speed"] < WALKING:
        out["kind"] = "taken while slow"
    else:
        out["kind"] = "taken"
    return out


def describe(name: str, held_share: float, ctx: dict | None) -> str:
    """One line for a recording."""
    if ctx is None:
        return f"{name}: held {100 * held_share:.1f} %, no loss of {RUN} frames running"
    line = (f"{name}: held {100 * held_share:.1f} %; first loss {ctx['t']:.1f} s, {ctx['kind']}; the target's lowest speed over "
            f"the {BEFORE_S:g} s before {ctx['target_min_speed']:.2f} m/s (now {ctx['target_speed']:.2f})")
    if "nearest" in ctx:
        line += f"; nearest {ctx['nearest']} {ctx['nearest_m']:.2f} m away ({ctx['nearest_speed']:.2f} m/s)"
    if "output_nearest" in ctx:
        line += f"; the output nearest {ctx['output_nearest']} ({ctx['output_nearest_m']:.2f} m), {ctx['output_target_m']:.2f} m from the target"
    return line


def classify(d) -> str:
    """``describe`` of one recording folder's single-target run."""
    rec = read_recording(d)
    out = ts.every_frame(ts.run_target(rec))
    names, D = ts.person_distances(rec, out.fillna(1e6))
    held = ts.target_held(names, D)
    k = first_loss(held)
    ctx = None if k is None else loss_context(rec.truth.people, float(out["t"].iloc[k]), (float(out["x"].iloc[k]), float(out["y"].iloc[k])))
    return describe(str(d), float(np.mean(held)), ctx)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for d in recording_folders(sys.argv[1:], "classify_losses"):
        print(classify(d))
