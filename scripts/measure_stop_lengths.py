"""How long the movers stand: the truth's stops, for ``target_planes``' ``hold_s``.

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
"""
import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders

MOVERS = ("target", "distractor")
SLOW = 0.05  # m/s
MIN_S = 0.5  # s


def stop_lengths(people: pd.DataFrame, movers=MOVERS, slow: float = SLOW, min_s: float = MIN_S) -> pd.DataFrame:
    """Every stop of the ``movers`` in a truth people table (t, person_id, vx, vy): person, start
    and end time (s; the first and last slow sample), length (s) and whether the recording's start
    or end cuts it (``censored``)."""
    rows = []
    for pid in movers:
        p = people[people.person_id == pid].sort_values("t")
        if p.empty:
            continue
        t = p.t.to_numpy(float)
        slow_now = np.hypot(p.vx.to_numpy(float), p.vy.to_numpy(float)) < slow
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


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    dirs = recording_folders(sys.argv[1:], "measure_stop_lengths")
    stops = pd.concat([stop_lengths(read_recording(d).truth.people) for d in dirs], ignore_index=True)
    print(f"{len(dirs)} recordings; movers' stops (slower than {SLOW} m/s for at least {MIN_S} s), length in s:")
    print(summary(stops).round(2).to_string())
