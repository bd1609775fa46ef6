"""Summaries of score rows: mean and 95% interval per group, as tables and markdown.

For a metric with values m_1..m_n over the seeds of one (scene, sensing, estimator) group:

    mean = (1/n) sum m_i
    95% interval = the 2.5th and 97.5th percentiles of the means of B = 2000 bootstrap resamples
                   (n values drawn with replacement; a fixed seed, so the same values give the
                   same interval), then clipped to the metric's valid range (``METRIC_RANGES``:
                   MOTA <= 1, IDF1, HOTA and its parts, recall, precision and ID accuracy in [0, 1], distances and
                   counts >= 0). No interval when n < 2.

A percentile interval of the mean lies within [min m_i, max m_i], so unlike the Student-t
interval (which gave MOTA [0.998, 1.001] and IDF1 [-1.14, 2.35] from two seeds) it never leaves
the range the values came from. With few seeds it is narrow, not conservative: with n = 2 it
is the two values themselves; read it with the ``runs`` column.

NaN values (a metric that does not apply, e.g. ``id_accuracy`` without phone claims) are left
out. Rows whose ``status`` is not "ok" (skipped estimators, errors) are listed with their reason
instead of numbers.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

GROUP = ["scene", "sensing", "estimator"]
SUMMARY_METRICS = ["mota", "motp", "idf1", "hota", "deta", "assa", "id_switches", "rmse", "p90", "id_accuracy", "runtime_s"]

_UNIT = (0.0, 1.0)
_NONNEGATIVE = (0.0, np.inf)
# (low, high) bounds of every metric a score row holds; metrics not listed are not clipped.
METRIC_RANGES: dict[str, tuple[float, float]] = {
    "mota": (-np.inf, 1.0),
    **{m: _UNIT for m in ("idf1", "idp", "idr", "recall", "precision", "id_accuracy", "id_accuracy_all",
                          "hota", "deta", "assa", "loca", "detre", "detpr", "assre", "asspr")},
    **{m: _NONNEGATIVE for m in ("motp", "rmse", "p50", "p90", "p95", "rmse_cam0", "rmse_cam1", "rmse_cam2plus",
                                 "id_switches", "fp", "fn", "matches", "frames", "objects", "predictions",
                                 "tracks", "people", "n_cam0", "n_cam1", "n_cam2plus", "runtime_s", "gate")},
}
# Units of score columns, for axis labels and table headers; a metric not listed is shown by name.
_DISTANCES = ("motp", "rmse", "p50", "p90", "p95", "rmse_cam0", "rmse_cam1", "rmse_cam2plus", "gate")
_COUNTS = ("id_switches", "fp", "fn", "matches", "frames", "objects", "predictions", "tracks", "people",
           "n_cam0", "n_cam1", "n_cam2plus")
METRIC_UNITS: dict[str, str] = {
    "mota": "<= 1",
    **{m: "0-1" for m in ("idf1", "idp", "idr", "recall", "precision", "id_accuracy", "id_accuracy_all",
                          "hota", "deta", "assa", "loca", "detre", "detpr", "assre", "asspr")},
    **{m: "m" for m in _DISTANCES},
    **{m: "count" for m in _COUNTS},
    "runtime_s": "s", "sim_s": "s", "duration": "s",
}


def robust_sigma(values) -> float:
    """1.4826 times the median absolute deviation from the median: a normal sample's standard
    deviation, little moved by outliers (the measurement scripts' "robust sigma"). NaN values are
    left out, as pandas' median leaves them; NaN when none is left."""
    x = np.asarray(values, float).ravel()
    x = x[~np.isnan(x)]
    if not x.size:
        return float("nan")
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def metric_label(metric: str) -> str:
    """``metric (unit)`` for an axis or a header, e.g. ``rmse (m)``; the name alone when no unit is known."""
    unit = METRIC_UNITS.get(metric)
    return f"{metric} ({unit})" if unit else metric


BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0
INTERVAL_NOTE = ("Mean [95% bootstrap percentile interval of the mean over seeds, 2000 seeded resamples, "
                 "clipped to each metric's valid range; no interval from one seed].")


def mean_interval(values, metric: str | None = None, level: float = 0.95) -> tuple[float, float, float, int]:
    """(mean, low, high, n) of the finite values: the bootstrap percentile interval of the mean
    (module docstring), clipped to ``METRIC_RANGES[metric]``; low and high are NaN when n < 2."""
    v = np.asarray(values, float).ravel()
    v = v[np.isfinite(v)]
    n = v.size
    if n == 0:
        return float("nan"), float("nan"), float("nan"), 0
    m = float(v.mean())
    if n < 2:
        return m, float("nan"), float("nan"), 1
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    means = v[rng.integers(0, n, size=(BOOTSTRAP_RESAMPLES, n))].mean(axis=1)
    lo, hi = np.percentile(means, [50 * (1 - level), 50 * (1 + level)])
    # A resample mean lies within [min v, max v] but for rounding of huge values: clip it back,
    # then to the metric's range (values outside it, from elsewhere, do not widen the interval).
    lo_ok, hi_ok = METRIC_RANGES.get(metric, (-np.inf, np.inf))
    lo, hi = (float(np.clip(np.clip(b, v.min(), v.max()), lo_ok, hi_ok)) for b in (lo, hi))
    return m, lo, hi, n


def summarise(results: pd.DataFrame, metrics: list[str] | None = None, by: list[str] | None = None) -> pd.DataFrame:
    """Long table: one row per group and metric with ``mean, low, high, n`` (ok rows only)."""
    by = by or GROUP
    metrics = [m for m in (metrics or SUMMARY_METRICS) if m in results.columns]
    ok = results[results["status"] == "ok"] if "status" in results.columns else results
    rows = []
    for key, g in ok.groupby(by, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        for m in metrics:
            mean, lo, hi, n = mean_interval(g[m], m)
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
