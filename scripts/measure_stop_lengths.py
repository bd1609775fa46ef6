"""How long the movers stand and walk: the truth's stops, for ``hold_s``, ``stand_s``, ``walk_s``.

    python scripts/measure_stop_lengths.py DIR [DIR ...]     # occlusion_lab recordings, either mode

A stop is a run of a mover's truth samples (the scene's target and distractor) slower than
``SLOW`` (0.05 m/s), at least ``MIN_S`` (0.5 s) long: the turns at waypoints that pass through a
low speed are shorter. A flow tracker sees no window of someone standing, so a tracker that
drops a person unseen for ``hold_s`` loses every stop longer than that. Walkers stop at a waypoint
for U(``walkers.pause``) s (0-5 s by default) and, when their next leg would come too close to
someone, wait a second at a time until it is clear (``sim/walkers.py``): the head-on variant's
walkers wait for each other much longer. Printed: the number of stops, their length's median,
90 %, 99 % quantile and maximum, among stops inside the recording and among those cut by its
start or end (censored: the person stood before the recording began or until it ended). The
truth is read here, by the experimenter (issue 12's twenty-second session).

Also printed (issue 12's ninety-sixth session), for the walking / standing modes' switching
(``walk_s``, ``stand_s``): how many slow runs of any length there are and how many of them are
shorter than ``MIN_S`` (turns), the mean length of the stops inside the recordings, the movers'
walking time per stop begun (time not in a stop over the stops that begin inside the recording),
and, per ``FRAME_S`` frame, the chance that a stop begins within the next frame given the mover's
true speed now (``onset_by_speed``): every turn at a waypoint slows through a low speed, so speed
alone says little about a stop to come.
"""
import sys
from collections.abc import Iterator

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders

MOVERS = ("target", "distractor")
SLOW = 0.05  # m/s
MIN_S = 0.5  # s
FRAME_S = 0.1  # s, the cameras' frame period in occlusion_lab
SPEED_BINS = (0.05, 0.1, 0.15, 0.25, 0.5, 0.85, 3.0)  # m/s


def mover_speeds(people: pd.DataFrame, movers=MOVERS) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """Each mover present in a truth people table (t, person_id, vx, vy): (person, its sample
    times in order, s, and its true speed at them, m/s)."""
    for pid in movers:
        p = people[people.person_id == pid].sort_values("t")
        if not p.empty:
            yield pid, p.t.to_numpy(float), np.hypot(p.vx.to_numpy(float), p.vy.to_numpy(float))


def stop_lengths(people: pd.DataFrame, movers=MOVERS, slow: float = SLOW, min_s: float = MIN_S) -> pd.DataFrame:
    """Every stop of the ``movers`` in a truth people table (t, person_id, vx, vy): person, start
    and end time (s; the first and last slow sample), length (s) and whether the recording's start
    or end cuts it (``censored``)."""
    rows = []
    for pid, t, speed in mover_speeds(people, movers):
        slow_now = speed < slow
        edges = np.flatnonzero(np.diff(np.r_[0, slow_now.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):  # slow on samples a .. b - 1
            length = t[b - 1] - t[a]
            if length >= min_s:
                rows.append((pid, float(t[a]), float(t[b - 1]), float(length), bool(a == 0 or b == len(t))))
    return pd.DataFrame(rows, columns=["person_id", "t0", "t1", "length", "censored"])


def summary(stops: pd.DataFrame) -> pd.DataFrame:
    """Count, median, 90 % and 99 % quantile and maximum of the stops' length (s), inside the
    recordings and censored."""
    out = {}
    cut = stops.censored.astype(bool).to_numpy()
    for name, g in (("inside", stops[~cut]), ("censored", stops[cut])):
        L = g.length
        out[name] = {"stops": len(L), "median": L.median(), "q90": L.quantile(0.9), "q99": L.quantile(0.99), "max": L.max()}
    return pd.DataFrame(out).T


def switching(people: pd.DataFrame, stops: pd.DataFrame, movers=MOVERS) -> dict[str, float]:
    """The movers' walking time (s; outside any stop) and the number of stops that begin after
    the recording's start (each ends a walk): their ratio is the walking mode's mean duration
    ``walk_s`` as the truth gives it."""
    walking = sum(float(t[-1] - t[0]) for _, t, _ in mover_speeds(people, movers))
    walking -= float(stops.length.sum())
    begun = int((stops.t0 > people.t.min()).sum())
    return {"walking_s": walking, "stops_begun": begun}


def onset_frames(people: pd.DataFrame, stops: pd.DataFrame, movers=MOVERS, frame_s: float = FRAME_S) -> pd.DataFrame:
    """The movers at each ``frame_s`` frame outside any stop: true speed (m/s) and whether a stop
    begins within the next ``frame_s``."""
    out = []
    for pid, t, speed in mover_speeds(people, movers):
        if len(t) < 2:
            continue
        frames = np.arange(t[0], t[-1] - frame_s, frame_s)
        v = speed[np.searchsorted(t, frames - 1e-9)]
        mine = stops[stops.person_id == pid]
        t0, t1 = mine.t0.to_numpy(float), mine.t1.to_numpy(float)
        inside = ((frames[:, None] >= t0) & (frames[:, None] <= t1)).any(axis=1)
        begins = ((t0 > frames[:, None]) & (t0 <= frames[:, None] + frame_s + 1e-9)).any(axis=1)
        out.append(pd.DataFrame({"speed": v[~inside], "onset": begins[~inside]}))
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame({"speed": [], "onset": []})


def onset_by_speed(frames: pd.DataFrame, bins=SPEED_BINS) -> pd.DataFrame:
    """Per true-speed bin (m/s) of ``onset_frames``: frames, and the share after which a stop
    begins within a frame."""
    b = pd.cut(frames.speed, bins, right=False)
    return frames.groupby(b, observed=False).onset.agg(frames="size", p_onset="mean")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    dirs = recording_folders(sys.argv[1:], "measure_stop_lengths")
    people = [read_recording(d).truth.people for d in dirs]
    slow_runs = [stop_lengths(pp, min_s=0.0) for pp in people]  # every slow run; the stops are the long ones
    per = [r[r.length >= MIN_S] for r in slow_runs]
    stops = pd.concat(per, ignore_index=True)
    print(f"{len(dirs)} recordings; movers' stops (slower than {SLOW} m/s for at least {MIN_S} s), length in s:")
    print(summary(stops).round(2).to_string())
    sw = [switching(pp, st) for pp, st in zip(people, per)]
    walking, begun = sum(x["walking_s"] for x in sw), sum(x["stops_begun"] for x in sw)
    inside = stops[~stops.censored.astype(bool)]
    runs = pd.concat(slow_runs, ignore_index=True)
    runs = runs[~runs.censored.astype(bool)]
    if len(runs):
        print(f"runs slower than {SLOW} m/s of any length inside the recordings: {len(runs)}, "
              f"{(runs.length < MIN_S).mean():.0%} shorter than {MIN_S} s (median {runs.length.median():.2f} s: turns)")
    per_stop = f"{walking / begun:.1f} s" if begun else "unbounded (no stop begun)"
    print(f"mean stop inside the recordings {inside.length.mean():.2f} s (stand_s); walking per stop begun "
          f"{per_stop} ({walking:.0f} s, {begun} stops; walk_s)")
    frames = pd.concat([onset_frames(pp, st) for pp, st in zip(people, per)], ignore_index=True)
    print(f"chance that a stop begins within the next {FRAME_S:g} s frame, by the mover's true speed now (m/s):")
    print(onset_by_speed(frames).round(4).to_string())
