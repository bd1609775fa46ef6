"""Accuracy thresholds guarded in CI: ``metrics/thresholds.csv`` and its checks.

The file has one row per bound, columns ``scene, sensing, estimator, metric, op, bound``:

- ``scene``: a bundled scene; CI runs its small version, ``CI_RUNS[scene]`` (duration and
  overrides), for the seeds ``CI_SEEDS``, in the given ``sensing`` mode.
- ``estimator``: a registered estimator name, or ``name[key=value;...]`` with parameters.
- ``metric``: a column of the score rows (``metrics.score``: mota, motp, idf1, hota, deta, assa, id_switches, rmse,
  p90, id_accuracy, ...).
- ``op`` and ``bound``: the mean over the CI seeds must satisfy ``mean op bound``, op ``>=`` or ``<=``.

Lines starting with ``#`` are comments. Adding an estimator = appending its rows (with margin
from what it measures over several seeds); a scene missing from ``CI_RUNS`` runs at
``CI_DEFAULT``. A bound on an estimator that does not apply to the scene, or fails, fails too.

Users keep their own bounds in files of the same format (``trackroom check-thresholds
--thresholds PATH``): ``merge_thresholds`` lays them over the bundled file, and a user row with
the same scene, sensing, estimator, metric and op replaces the bundled one (a later file
replaces an earlier one); other user rows are added.
"""
from __future__ import annotations

import operator
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

COLUMNS = ["scene", "sensing", "estimator", "metric", "op", "bound"]
OPS = {">=": operator.ge, "<=": operator.le}
CI_SEEDS = (0, 1, 2)
CI_DEFAULT = {"duration": 20.0, "overrides": ()}
CI_RUNS: dict[str, dict] = {
    "overhead_lab": {"duration": 20.0, "overrides": ("walkers.count=3",)},
    "occlusion_lab": {"duration": 15.0, "overrides": ()},
    "bearing_hall": {"duration": 30.0, "overrides": ()},
    "office_floor": {"duration": 30.0, "overrides": ()},
    "bearing_corridor": {"duration": 20.0, "overrides": ()},
}


class ThresholdError(ValueError):
    """A thresholds file that cannot be used, with the line at fault."""


def default_path() -> Path:
    return Path(str(resources.files("trackroom.metrics") / "thresholds.csv"))


def load_thresholds(path: str | Path | None = None) -> pd.DataFrame:
    """Read and validate a thresholds file (``#`` comment lines allowed)."""
    p = Path(path) if path else default_path()
    try:
        df = pd.read_csv(p, comment="#", skipinitialspace=True, dtype={"scene": str, "sensing": str,
                                                                       "estimator": str, "metric": str, "op": str})
    except FileNotFoundError:
        raise ThresholdError(f"{p}: no such thresholds file") from None
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ThresholdError(f"{p}: missing columns {missing} (need {', '.join(COLUMNS)})")
    for c in COLUMNS[:5]:
        df[c] = df[c].astype(str).str.strip()
    bad_op = df[~df["op"].isin(list(OPS))]
    if len(bad_op):
        raise ThresholdError(f"{p}: op must be >= or <=, got {bad_op['op'].iloc[0]!r} ({_where(bad_op)})")
    bound = pd.to_numeric(df["bound"], errors="coerce")
    if bound.isna().any():
        raise ThresholdError(f"{p}: bound is not a number ({_where(df[bound.isna()])})")
    df["bound"] = bound.astype(float)
    bad_sensing = df[~df["sensing"].isin(["analytic", "rendered"])]
    if len(bad_sensing):
        raise ThresholdError(f"{p}: sensing must be analytic or rendered ({_where(bad_sensing)})")
    dup = df[df.duplicated(["scene", "sensing", "estimator", "metric", "op"], keep=False)]
    if len(dup):
        raise ThresholdError(f"{p}: the same bound is given twice ({_where(dup)})")
    return df[COLUMNS].reset_index(drop=True)


KEY = ["scene", "sensing", "estimator", "metric", "op"]


def merge_thresholds(*tables: pd.DataFrame) -> pd.DataFrame:
    """Thresholds tables laid over each other in order: a row of a later table replaces the row of
    an earlier one with the same scene, sensing, estimator, metric and op; other rows are kept.
    Replaced rows keep their place; new rows follow."""
    frames = [t[COLUMNS] for t in tables if len(t)]
    if not frames:
        return pd.DataFrame(columns=COLUMNS)
    merged = pd.concat(frames, ignore_index=True)
    last = merged.drop_duplicates(KEY, keep="last").set_index(KEY)
    first = merged.drop_duplicates(KEY, keep="first")
    out = first[KEY].join(last, on=KEY)
    return out[COLUMNS].reset_index(drop=True)


def load_merged(paths=(), bundled: bool = True) -> pd.DataFrame:
    """The bundled thresholds (unless ``bundled`` is false) with the users' files laid over them
    (``merge_thresholds``); each file is validated by ``load_thresholds``."""
    tables = ([load_thresholds()] if bundled else []) + [load_thresholds(p) for p in paths]
    return merge_thresholds(*tables)


def _where(rows: pd.DataFrame) -> str:
    r = rows.iloc[0]
    return f"{r['scene']}, {r['sensing']}, {r['estimator']}, {r['metric']}"


def check_thresholds(results: pd.DataFrame, thresholds: pd.DataFrame) -> pd.DataFrame:
    """Every bound against the mean over seeds of ``results`` (score rows with ``status``).

    Returns the thresholds with ``value`` (the mean), ``n`` (seeds that ran), ``passed`` and
    ``note`` (why it failed when it did not run).
    """
    out = []
    for th in thresholds.itertuples(index=False):
        g = results[(results["scene"] == th.scene) & (results["sensing"] == th.sensing) & (results["estimator"] == th.estimator)]
        row = {**th._asdict(), "value": float("nan"), "n": 0, "passed": False, "note": ""}
        if not len(g):
            row["note"] = "not run"
        elif (g["status"] != "ok").any():
            bad = g[g["status"] != "ok"].iloc[0]
            row["note"] = f"{bad['status']}: {bad['reason']}"
        elif th.metric not in g.columns:
            row["note"] = f"no metric {th.metric!r}"
        else:
            v = g[th.metric].to_numpy(float)
            row["n"] = int(np.isfinite(v).sum())
            row["value"] = float(np.nanmean(v)) if row["n"] else float("nan")
            row["passed"] = bool(row["n"] and OPS[th.op](row["value"], th.bound))
            if not row["n"]:
                row["note"] = "metric is NaN in every run"
        out.append(row)
    return pd.DataFrame(out, columns=[*COLUMNS, "value", "n", "passed", "note"])


def failure_table(checked: pd.DataFrame) -> str:
    """The failed bounds as a readable table (empty string when all passed)."""
    bad = checked[~checked["passed"]]
    if not len(bad):
        return ""
    lines = [f"{len(bad)} accuracy threshold(s) not met:"]
    lines.append(f"{'scene':<16}{'sensing':<10}{'estimator':<28}{'metric':<14}{'bound':>14}{'measured':>12}  note")
    for r in bad.itertuples(index=False):
        lines.append(f"{r.scene:<16}{r.sensing:<10}{r.estimator:<28}{r.metric:<14}{r.op + ' ' + format(r.bound, 'g'):>14}"
                     f"{r.value:>12.4g}  {r.note}")
    return "\n".join(lines)
