"""Two runs of `target_planes` over the same recordings, compared target by target.

    python -m scripts.compare_tp_runs BEFORE.jsonl AFTER.jsonl [BEFORE.jsonl AFTER.jsonl ...]

Each file holds ``scripts/experiment_tsutsui.py --json`` lines, one per recording; each pair of
files is one set of recordings run twice (the committed code, then a trial), named by the AFTER
file. Runs are matched by (sensing, seed, perception draw); a run in only one file of a pair is
an error, since counts over different recordings do not compare. For each set and over all of
them it prints, before -> after:

- the number of recordings meeting each of issue 12's four targets (identity held >= 99 %, RMSE
  <= 0.15 m with >= 2 tracking cameras and <= 0.5 m with one - a recording with no such frame
  meets it -, the movers' MOTA >= 0.9);
- the movers' false positives and negatives, summed;
- the mean identity held and the median RMSEs;

and each recording that gained or lost a target, with its figures. This is how the development
judgements in docs/target_planes.md are counted ("development: identity >= 99 % 732 -> 731 ...").
The development sets and the commands that make their files are listed there (Seeds).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

# (key, threshold, higher is better): issue 12's targets
TARGETS = (("identity_held", 0.99, True), ("rmse_2plus", 0.15, False), ("rmse_1", 0.5, False), ("multi_mota", 0.9, True))
SHORT = {"identity_held": "identity", "rmse_2plus": "RMSE>=2", "rmse_1": "RMSE1", "multi_mota": "MOTA"}
NEED = [k for k, _, _ in TARGETS] + ["seed", "multi_fp", "multi_fn"]  # the fields a run must have


def read_runs(path: str) -> dict[tuple, dict]:
    """The runs of one ``--json`` file, by (sensing, seed, perception draw); a clear error for a
    missing file, a line that is not a run, or a recording run twice."""
    p = Path(path)
    if not p.is_file():
        raise SystemExit(f"compare_tp_runs: {path}: no such file")
    runs: dict[tuple, dict] = {}
    for n, line in enumerate(p.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError as e:
            raise SystemExit(f"compare_tp_runs: {path}, line {n}: not JSON ({e.msg})") from None
        missing = [k for k in NEED if k not in r] if isinstance(r, dict) else NEED
        if missing:
            raise SystemExit(f"compare_tp_runs: {path}, line {n}: not an experiment_tsutsui --json run (missing {', '.join(missing)})")
        key = (r.get("sensing", "?"), r["seed"], r.get("perception_draw", 0))
        if key in runs:
            raise SystemExit(f"compare_tp_runs: {path}: recording {key} appears twice")
        runs[key] = r
    if not runs:
        raise SystemExit(f"compare_tp_runs: {path}: no runs")
    return runs


def meets(run: dict, key: str, threshold: float, higher: bool) -> bool:
    """Whether a run meets a target; a figure with no frames (NaN, None) meets it."""
    v = run[key]
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return True
    return v >= threshold if higher else v <= threshold


def _median(xs: list) -> float:
    """The median of the figures that have frames (None and NaN left out); NaN if none has."""
    x = np.asarray(xs, float)
    x = x[~np.isnan(x)]
    return float(np.median(x)) if x.size else math.nan


def set_figures(runs: list[dict]) -> dict:
    """Counts of recordings meeting each target, summed false positives and negatives, the mean
    identity held and the median RMSEs of one set's runs."""
    out = {k: sum(meets(r, k, t, h) for r in runs) for k, t, h in TARGETS}
    out["multi_fp"] = sum(int(r["multi_fp"]) for r in runs)
    out["multi_fn"] = sum(int(r["multi_fn"]) for r in runs)
    out["identity_mean"] = sum(float(r["identity_held"]) for r in runs) / len(runs)
    out["rmse_2plus_median"] = _median([r["rmse_2plus"] for r in runs])
    out["rmse_1_median"] = _median([r["rmse_1"] for r in runs])
    out["runs"] = len(runs)
    return out


def changes(before: dict[tuple, dict], after: dict[tuple, dict]) -> list[tuple[tuple, str, str, float, float]]:
    """(recording, target, 'gained' / 'lost', before, after) for each target a recording changed."""
    out = []
    for key in sorted(before):
        for k, t, h in TARGETS:
            a, b = meets(before[key], k, t, h), meets(after[key], k, t, h)
            if a != b:
                out.append((key, k, "gained" if b else "lost", before[key][k], after[key][k]))
    return out


def compare(pairs: list[tuple[str, str]]) -> str:
    """The report for pairs of (before, after) files."""
    lines, total_b, total_a = [], {}, {}
    for fb, fa in pairs:
        before, after = read_runs(fb), read_runs(fa)
        if set(before) != set(after):
            only_b, only_a = sorted(set(before) - set(after))[:3], sorted(set(after) - set(before))[:3]
            raise SystemExit(f"compare_tp_runs: {fb} and {fa} hold different recordings "
                             f"(only in the first: {only_b or 'none'}; only in the second: {only_a or 'none'})")
        keys = sorted(before)
        sb, sa = set_figures([before[k] for k in keys]), set_figures([after[k] for k in keys])
        for k in [t[0] for t in TARGETS] + ["multi_fp", "multi_fn", "runs"]:
            total_b[k] = total_b.get(k, 0) + sb[k]
            total_a[k] = total_a.get(k, 0) + sa[k]
        name = Path(fa).stem
        counts = "  ".join(f"{SHORT[k]} {sb[k]} -> {sa[k]}" for k, _, _ in TARGETS)
        lines.append(f"{name} ({sb['runs']} recordings): {counts}  FP {sb['multi_fp']} -> {sa['multi_fp']}  "
                     f"FN {sb['multi_fn']} -> {sa['multi_fn']}")
        lines.append(f"    identity mean {100 * sb['identity_mean']:.1f} -> {100 * sa['identity_mean']:.1f} %  "
                     f"RMSE>=2 median {sb['rmse_2plus_median']:.3f} -> {sa['rmse_2plus_median']:.3f} m  "
                     f"RMSE1 median {sb['rmse_1_median']:.3f} -> {sa['rmse_1_median']:.3f} m")
        for (sensing, seed, draw), k, what, vb, va in changes(before, after):
            lines.append(f"    {sensing} seed {seed} draw {draw}: {SHORT[k]} {what} ({vb:.3f} -> {va:.3f})")
    if len(pairs) > 1:
        counts = "  ".join(f"{SHORT[k]} {total_b[k]} -> {total_a[k]}" for k, _, _ in TARGETS)
        lines.append(f"all ({total_b['runs']} recordings): {counts}  FP {total_b['multi_fp']} -> {total_a['multi_fp']}  "
                     f"FN {total_b['multi_fn']} -> {total_a['multi_fn']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", metavar="JSONL", help="pairs of files: BEFORE AFTER [BEFORE AFTER ...]")
    a = ap.parse_args(argv)
    if len(a.files) % 2:
        raise SystemExit("compare_tp_runs: give the files in pairs, BEFORE AFTER (an odd number was given)")
    print(compare(list(zip(a.files[0::2], a.files[1::2]))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
