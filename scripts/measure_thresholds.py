"""Measure what the CI thresholds guard, on development seeds: the figures to set bounds from.

    python -m scripts.measure_thresholds [--seeds 100-111] [--scene occlusion_lab] [--sensing analytic]
                                         [--jobs N] [--csv OUT]

For every (scene, sensing) group of ``metrics/thresholds.csv`` (or the ones named), runs the same
comparison CI runs (``trackroom.compare.ci_spec``: the scene's CI version, ``CI_RUNS``) on the
given seeds instead of CI's 0-2, and prints for each bound row: the metric's range over single
seeds, its range over the means of consecutive seed triples (what CI checks is a 3-seed mean),
the bound, and whether the worst triple meets it. Bounds are set with margin from these figures,
on development seeds only (100-111 by default; CI's seeds 0-2 are never used to set them).
"""
from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file


def triples(values: np.ndarray) -> np.ndarray:
    """Means of consecutive seed triples (a trailing incomplete triple is dropped; a seed without a
    value, e.g. an RMSE with no frame within the gate, is left out of its triple's mean, as CI does)."""
    n = len(values) // 3 * 3
    if not n:
        return np.zeros(0)
    with np.errstate(all="ignore"):
        return np.nanmean(values[:n].reshape(-1, 3), axis=1)


def measure(th: pd.DataFrame, seeds: list[int], jobs: int = 1, progress: bool = True) -> pd.DataFrame:
    """One row per bound: per-seed and triple-mean ranges of its metric over ``seeds``."""
    from trackroom.compare import ci_spec, run_comparison
    from trackroom.metrics.thresholds import OPS

    out = []
    for scene, sensing in dict.fromkeys(zip(th["scene"], th["sensing"])):
        spec = ci_spec(th, scene, sensing, jobs)
        spec.seeds = list(seeds)
        res = run_comparison(spec.validate(), progress=progress).results
        for _, row in th[(th["scene"] == scene) & (th["sensing"] == sensing)].iterrows():
            r = res[res["estimator"] == row["estimator"]].sort_values("seed")
            v = pd.to_numeric(r[row["metric"]], errors="coerce").to_numpy(float)
            tm = triples(v)
            worst = (tm.min() if row["op"] == ">=" else tm.max()) if len(tm) else np.nan
            out.append({**row.to_dict(), "seeds": len(v), "seed_min": np.nanmin(v), "seed_max": np.nanmax(v),
                        "triple_min": tm.min() if len(tm) else np.nan, "triple_max": tm.max() if len(tm) else np.nan,
                        "worst_triple_meets": bool(OPS[row["op"]](worst, row["bound"])) if np.isfinite(worst) else False})
    return pd.DataFrame(out)


def main(argv=None) -> int:
    from trackroom.cli.commands.calibrate_sensing import parse_seeds
    from trackroom.metrics.thresholds import load_thresholds

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="100-111", help="development seeds (default 100-111)")
    ap.add_argument("--scene", action="append", help="only this scene (repeatable)")
    ap.add_argument("--sensing", choices=["analytic", "rendered"], help="only this sensing mode")
    ap.add_argument("--jobs", type=int, default=1, help="local worker processes")
    ap.add_argument("--csv", help="write the table here")
    a = ap.parse_args(argv)
    th = load_thresholds()
    if a.scene:
        th = th[th["scene"].isin(a.scene)]
    if a.sensing:
        th = th[th["sensing"] == a.sensing]
    if not len(th):
        print("no bounds match", file=sys.stderr)
        return 2
    df = measure(th, parse_seeds(a.seeds), a.jobs)
    if a.csv:
        df.to_csv(a.csv, index=False, float_format="%.4g")
    with pd.option_context("display.width", 200, "display.max_rows", 500, "display.max_colwidth", 40):
        print(df.drop(columns=["sensing"]).round(4).to_string(index=False))
    return 0 if df["worst_triple_meets"].all() else 1


if __name__ == "__main__":
    raise SystemExit(main())
