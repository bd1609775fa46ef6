"""How often `target_planes`' hand-over decision is right: each new track it scored, against the truth.

    python -m scripts.measure_tp_handover DIR [DIR ...] [--param KEY=VALUE ...] [--csv FILE]

An encounter of the target's track with another one that ends during it (dropped as a duplicate,
rejected by the existence test) is decided ``identity_lag_s`` after the end with each track
confirmed since the encounter began (``tp_identity.IdentityLag.hand_over``, in
``TargetPlanesResult.handovers``). Each scored pair is labelled here from the truth, by the
experimenter: the person nearest each pre state at the encounter's start (the survivor's, p_S, and
the gone track's, p_G) and nearest each track at the decision (the survivor's, q_S, and the new
track's, q_T):

- ``exchanged``: q_S = p_G and q_T = p_S (the survivor went onto the other person, the new track
  is on its own): the identities should be exchanged;
- ``kept``: q_S = p_S (the survivor is still on its own person): they should not;
- ``same``: p_S = p_G (both tracks were on one person: a duplicate), or ``other`` (anything else).

It prints, per label, the count and the log-odds' spread, and how many decisions each threshold
on the log-odds gets right (exchange above it): 0 (the Bayes decision at even prior odds), and
log 99 (the 1 % level of the pair exchange decision). Evaluation seeds are not for this: the
threshold is chosen on development seeds (docs/target_planes.md).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from scripts.experiment_tsutsui import recordings_and_params, run_target
from trackroom.dataset import read_recording

THRESHOLDS = {"0 (even odds)": 0.0, "log 99 (1 % level)": float(np.log(99.0))}


def nearest_person(people: pd.DataFrame, t: float, xy: np.ndarray) -> str:
    """The true person nearest floor point ``xy`` at the truth frame nearest ``t``."""
    times = people["t"].to_numpy(float)
    tk = times[np.argmin(np.abs(times - t))]
    g = people[people["t"] == tk]
    d = np.hypot(g["x"].to_numpy(float) - xy[0], g["y"].to_numpy(float) - xy[1])
    return str(g["person_id"].to_numpy()[np.argmin(d)])


def label(row: pd.Series, people: pd.DataFrame) -> str:
    p_s = nearest_person(people, row.t_pre, (row.survivor_pre_x, row.survivor_pre_y))
    p_g = nearest_person(people, row.t_pre, (row.gone_pre_x, row.gone_pre_y))
    q_s = nearest_person(people, row.t, (row.survivor_xy_x, row.survivor_xy_y))
    q_t = nearest_person(people, row.t, (row.new_xy_x, row.new_xy_y))
    if p_s == p_g:
        return "same"
    if q_s == p_g and q_t == p_s:
        return "exchanged"
    if q_s == p_s:
        return "kept"
    return "other"


def measure(d: str, params: dict | None = None) -> pd.DataFrame:
    rec = read_recording(d)
    ho = run_target(rec, params).handovers
    if not len(ho):
        return pd.DataFrame()
    people = rec.truth.tables["people"]
    ho = ho.assign(recording=d, seed=rec.seed)
    ho["label"] = [label(r, people) for r in ho.itertuples()]
    return ho


def main(argv=None) -> int:
    dirs, params, csv = recordings_and_params(__doc__, argv, csv_help="write the scored pairs here")
    parts = [p for p in (measure(d, params) for d in dirs) if len(p)]
    df = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    if csv:
        df.to_csv(csv, index=False)
    if not len(df):
        print(f"{len(dirs)} recordings: no hand-over was scored")
        return 0
    print(f"{len(dirs)} recordings, {len(df)} new tracks scored in {df.groupby(['recording', 't']).ngroups} hand-overs")
    print(df.groupby("label")["log_odds"].describe()[["count", "min", "25%", "50%", "75%", "max"]].round(2).to_string())
    decided = df[df["label"].isin(["exchanged", "kept"])]
    for name, thr in THRESHOLDS.items():
        x = decided["log_odds"] > thr
        right = int(((decided["label"] == "exchanged") & x).sum() + ((decided["label"] == "kept") & ~x).sum())
        wrong_x = int(((decided["label"] == "kept") & x).sum())
        missed = int(((decided["label"] == "exchanged") & ~x).sum())
        print(f"threshold {name}: {right} of {len(decided)} right; exchanged wrongly {wrong_x}, exchange missed {missed}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
