"""Summaries of score rows: mean and 95% interval per group, as tables and markdown.

For a metric with values m_1..m_n over the seeds of one (scene, sensing, estimator) group:

    mean = (1/n) sum m_i,   s = sample standard deviation,
    95% interval = mean -+ t_{0.975, n-1} s / sqrt(n)      (Student t; NaN when n < 2)

NaN values (a metric that does not apply, e.g. ``id_accuracy`` without phone claims) are left
out. Rows whose ``status`` is not "ok" (skipped estimators, errors) are listed with their reason
instead of numbers.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

GROUP = ["scene", "sensing", "estimator"]
SUMMARY_METRICS = ["mota", "motp", "idf1", "id_switches", "rmse", "p90", "id_accuracy", "runtime_s"]


def mean_interval(values) -> tuple[float, float, float, int]:
    """(mean, low, high, n) of the finite values: the Student-t 95% interval of the mean."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    n = v.size
    if n == 0:
        return float("nan"), float("nan"), float("nan"), 0
    m = float(v.mean())
    if n < 2:
        return m, float("nan"), float("nan"), 1
    half = float(stats.t.ppf(0.975, n - 1) * v.std(ddof=1) / np.sqrt(n))
    return m, m - half, m + half, n


def summarise(results: pd.DataFrame, metrics: list[str] | None = None, by: list[str] | None = None) -> pd.DataFrame:
    """Long table: one row per group and metric with ``mean, low, high, n`` (ok rows only)."""
    by = by or GROUP
    metrics = [m for m in (metrics or SUMMARY_METRICS) if m in results.columns]
    ok = results[results["status"] == "ok"] if "status" in results.columns else results
    rows = []
    for key, g in ok.groupby(by, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        for m in metrics:
            mean, lo, hi, n = mean_interval(g[m])
            rows.append({**dict(zip(by, key)), "metric": m, "mean": mean, "low": lo, "high": hi, "n": n})
    return pd.DataFrame(rows, columns=[*by, "metric", "mean", "low", "high", "n"])


def skipped(results: pd.DataFrame, by: list[str] | None = None) -> pd.DataFrame:
    """Groups that did not run everywhere: ``status``, ``reason`` and how many runs."""
    by = by or GROUP
    if "status" not in results.columns:
        return pd.DataFrame(columns=[*by, "status", "reason", "runs"])
    bad = results[results["status"] != "ok"]
    out = bad.groupby([*by, "status", "reason"], sort=True).size().rename("runs").reset_index()
    return out


def _fmt(mean: float, lo: float, hi: float, metric: str) -> str:
    if not np.isfinite(mean):
        return "-"
    digits = 0 if metric in ("id_switches", "fp", "fn") and not np.isfinite(lo) else 3
    if metric in ("runtime_s",):
        digits = 2
    s = f"{mean:.{digits}f}"
    if np.isfinite(lo):
        s += f" [{lo:.{digits}f}, {hi:.{digits}f}]"
    return s


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def summary_markdown(results: pd.DataFrame, metrics: list[str] | None = None) -> str:
    """A markdown table (mean [95% interval] per scene, sensing and estimator) plus skipped runs."""
    metrics = [m for m in (metrics or SUMMARY_METRICS) if m in results.columns]
    summ = summarise(results, metrics)
    # Drop metrics that are NaN everywhere (e.g. id_accuracy when no estimator claims phones).
    metrics = [m for m in metrics if summ.loc[summ["metric"] == m, "mean"].notna().any()]
    rows = []
    for key, g in summ.groupby(GROUP, sort=True):
        cells = {r.metric: _fmt(r.mean, r.low, r.high, r.metric) for r in g.itertuples()}
        n = int(g["n"].max())
        rows.append([*key, n, *[cells.get(m, "-") for m in metrics]])
    out = markdown_table([*GROUP, "runs", *metrics], rows) if rows else "(no successful runs)"
    sk = skipped(results)
    if len(sk):
        out += "\n\nNot run:\n\n" + markdown_table(
            [*GROUP, "status", "reason", "runs"], sk[[*GROUP, "status", "reason", "runs"]].values.tolist()
        )
    return out
