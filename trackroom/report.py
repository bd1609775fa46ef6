"""One self-contained HTML page for a comparison folder (``trackroom compare --out DIR``).

``write_report(DIR)`` reads what ``compare`` wrote - ``results.csv``, ``spec.toml``,
``provenance.json``, the plots (``metric_*.png``, ``error_over_time.png``), the stored runs
(``runs/<scene>/seed<seed>/<estimator>.tracks.csv`` and ``.status.parquet``) and the recordings
cache - and writes ``DIR/report.html`` (atomically) from the Jinja2 template
``trackroom/templates/report.html.j2``. Every picture is embedded as a base64 PNG, so the file can
be mailed or archived alone. It holds:

- the summary (mean and 95% interval over seeds per scene, sensing and estimator) of every metric
  column ``results.csv`` holds (numeric columns other than the run's settings), and every row of
  ``results.csv``; both sortable by clicking a header;
- the summary plots compare wrote;
- per scene, for its first seed whose recording is still in the cache, a top-down view with each
  estimator's tracks over the truth and their identity switches (``topdown.draw_tracks``), and a
  per-camera status timeline for estimators that report one (``Estimator.estimate_with_status``);
- the provenance: command line, versions, git commit, times, seeds, scene hashes and the spec.

A folder that is not a comparison, or one whose tables cannot be read, ends in one ``ReportError``.
"""
from __future__ import annotations

import base64
import io
import json
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

REQUIRED = ("results.csv", "spec.toml", "provenance.json")
# numeric results.csv columns that describe a run rather than score it
SETTING_COLUMNS = ("seed", "duration", "sim_s", "gate", "frames")
MAX_TIMELINE_TRACKS = 4  # status timelines show this many tracks (the longest), every camera each
STATUS_COLOURS = {"tracking": "tab:green", "merged": "tab:blue", "unreliable": "tab:orange", "lost": "0.75"}


class ReportError(ValueError):
    """A folder that cannot be reported on; the message says why."""


@dataclass
class Figure:
    title: str
    png: str  # base64
    caption: str = ""


@dataclass
class SceneSection:
    key: str
    seed: int | None
    topdown: Figure | None = None
    timelines: list[Figure] = field(default_factory=list)
    note: str = ""


# ----------------------------------------------------------------------------- reading
def read_comparison(folder: str | Path) -> tuple[pd.DataFrame, Any, dict]:
    """``results.csv``, the spec (``spec.toml``) and ``provenance.json`` of a comparison folder."""
    from trackroom.compare import CompareError, spec_from_toml

    d = Path(folder)
    if not d.is_dir():
        raise ReportError(f"{d}: no such folder (give the --out folder of trackroom compare)")
    missing = [n for n in REQUIRED if not (d / n).is_file()]
    if missing:
        raise ReportError(f"{d}: not a trackroom compare folder (no {', '.join(missing)})")
    try:
        results = pd.read_csv(d / "results.csv", keep_default_na=False, na_values=["", "nan", "NaN"])
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise ReportError(f"{d / 'results.csv'}: not a readable CSV: {' '.join(str(e).split())}") from None
    need = [c for c in ("scene", "seed", "estimator", "status") if c not in results.columns]
    if need:
        raise ReportError(f"{d / 'results.csv'}: missing columns {need}")
    try:
        spec = spec_from_toml(d / "spec.toml")
    except CompareError as e:
        raise ReportError(str(e)) from None
    except Exception as e:  # an estimator or plug-in the spec names is unknown here
        raise ReportError(f"{d / 'spec.toml'}: {' '.join(str(e).split())}") from None
    try:
        prov = json.loads((d / "provenance.json").read_text())
        if not isinstance(prov, dict):
            raise ValueError("not a JSON object")
    except (ValueError, UnicodeDecodeError) as e:
        raise ReportError(f"{d / 'provenance.json'}: not valid JSON: {e}") from None
    return results, spec, prov


def metric_columns(results: pd.DataFrame) -> list[str]:
    """The score columns: numeric, not a run setting (``SETTING_COLUMNS``), not NaN everywhere;
    those of summary.md first (``aggregate.SUMMARY_METRICS``), then the others in the file's order
    (whatever metrics the scoring wrote, HOTA included when present)."""
    from trackroom.metrics.aggregate import SUMMARY_METRICS

    out = []
    for c in results.columns:
        if c in SETTING_COLUMNS or not pd.api.types.is_numeric_dtype(results[c]) or pd.api.types.is_bool_dtype(results[c]):
            continue
        if results[c].notna().any():
            out.append(c)
    first = [m for m in SUMMARY_METRICS if m in out]
    return first + [m for m in out if m not in first]


# ----------------------------------------------------------------------------- tables
def _cell(v: Any) -> dict[str, Any]:
    """``text`` to show, ``sort`` key (numbers as numbers; blank sorts last) and ``num`` (right-aligned)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return {"text": "-", "sort": "", "num": True}
    if isinstance(v, (bool, np.bool_)):
        return {"text": str(bool(v)).lower(), "sort": str(bool(v)), "num": False}
    if isinstance(v, (int, np.integer)):
        return {"text": str(int(v)), "sort": int(v), "num": True}
    if isinstance(v, (float, np.floating)):
        v = float(v)
        text = str(int(v)) if v.is_integer() and abs(v) < 1e15 else f"{v:.0f}" if abs(v) >= 1e4 else f"{v:.4g}"
        return {"text": text, "sort": v, "num": True}
    return {"text": str(v), "sort": str(v), "num": False}


def summary_table(results: pd.DataFrame, metrics: list[str]) -> dict[str, Any]:
    """Mean [95% interval] over seeds per scene, sensing and estimator, for every metric."""
    from trackroom.metrics.aggregate import GROUP, metric_label, summarise

    by = [c for c in GROUP if c in results.columns]
    summ = summarise(results, metrics, by=by)
    header = [*by, "runs", *[metric_label(m) for m in metrics]]
    rows = []
    for key, g in summ.groupby(by, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        cells = {r.metric: r for r in g.itertuples()}
        row = [_cell(k) for k in key] + [_cell(int(g["n"].max()))]
        for m in metrics:
            r = cells.get(m)
            if r is None or not np.isfinite(r.mean):
                row.append(_cell(None))
                continue
            c = _cell(r.mean)
            if np.isfinite(r.low):
                c["text"] += f" [{_cell(r.low)['text']}, {_cell(r.high)['text']}]"
            row.append(c)
        rows.append(row)
    return {"header": header, "rows": rows}


def runs_table(results: pd.DataFrame) -> dict[str, Any]:
    """Every row of results.csv, every column."""
    from trackroom.metrics.aggregate import metric_label

    return {"header": [metric_label(c) for c in results.columns],
            "rows": [[_cell(v) for v in r] for r in results.itertuples(index=False)]}


def not_run_table(results: pd.DataFrame) -> dict[str, Any] | None:
    from trackroom.metrics.aggregate import GROUP, skipped

    sk = skipped(results, by=[c for c in GROUP if c in results.columns])
    if not len(sk):
        return None
    return {"header": list(sk.columns), "rows": [[_cell(v) for v in r] for r in sk.itertuples(index=False)]}


# ----------------------------------------------------------------------------- pictures
def png_base64(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def summary_plots(folder: Path) -> list[Figure]:
    """The plots compare wrote, embedded: one per metric, then the error over time."""
    files = sorted(folder.glob("metric_*.png")) + [p for p in [folder / "error_over_time.png"] if p.is_file()]
    out = []
    for p in files:
        title = p.stem.removeprefix("metric_").replace("_", " ")
        caption = (f"{title}: per scene, bar = mean over seeds with its 95% interval, dots = seeds" if p.stem.startswith("metric_")
                   else "per scene: RMSE of the matched positions per frame, mean over seeds")
        out.append(Figure(title, base64.b64encode(p.read_bytes()).decode("ascii"), caption))
    return out


def find_recording(folder: Path, spec, scene, seed: int):
    """The cached recording of (scene, seed) when it is still there and matches, else (None, why)."""
    from trackroom.compare import cache_key, recording_folder, stale_reason
    from trackroom.dataset import read_recording
    from trackroom.recording import RecordingError
    from trackroom.scenes import load_scene

    roots = [Path(spec.recordings)] if spec.recordings else []
    roots.append(folder / "recordings")  # compare's default cache, wherever the folder was moved
    for root in dict.fromkeys(roots):
        path = recording_folder(root, scene, seed, spec.duration, spec.sensing)
        if not path.is_dir():
            continue
        resolved = load_scene(scene.name, list(scene.overrides))
        reason = stale_reason(path, cache_key(resolved, seed, spec.duration, spec.sensing))
        if reason:
            return None, f"the cached recording changed since ({reason})"
        try:
            return read_recording(path), ""
        except RecordingError as e:
            return None, f"the cached recording cannot be read ({e})"
    return None, "its recording was not kept (compare --no-cache)"


def topdown_figure(rec, runs: list[tuple[str, pd.DataFrame]], gate: float, title: str) -> Figure:
    """A panel per estimator: the floor plan, the truth in grey, its tracks and identity switches."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from trackroom.topdown import TRUTH_GREY, draw_cameras, draw_floorplan, draw_tracks

    cols = min(3, len(runs))
    rows = -(-len(runs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.3 * cols, 4.3 * rows + 0.5), squeeze=False)
    fp = rec.calibration.floorplan
    for ax, (name, tracks) in zip(axes.ravel(), runs):
        draw_floorplan(ax, fp)
        draw_cameras(ax, rec.calibration.cameras.values(), fp)
        n = draw_tracks(ax, rec, tracks, gate, legend=False)
        ax.set_title(f"{name}: {tracks['track_id'].nunique()} tracks, {n} ID switch{'es' if n != 1 else ''}", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(alpha=0.2)
    for ax in axes.ravel()[len(runs):]:
        ax.set_visible(False)
    handles = [Line2D([], [], color=TRUTH_GREY, lw=2.2, label="truth (person id at start)"),
               Line2D([], [], color="tab:blue", lw=1, label="a track (#id at start)"),
               Line2D([], [], color="red", marker="X", ls="", label="identity switch (person: old\u2192new)")]
    ncol = 3 if cols > 1 else 1
    bottom = (0.06 if ncol == 3 else 0.14) / rows
    fig.legend(handles=handles, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, bottom, 1, 0.97))
    return Figure(title, png_base64(fig))


def status_timeline(status: pd.DataFrame, title: str) -> Figure:
    """Per track (the longest ``MAX_TIMELINE_TRACKS``) and camera, a bar over time coloured by the
    camera's status (tracking / merged / unreliable / lost)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    lengths = status.groupby("track_id", sort=False)["t"].nunique().sort_values(ascending=False, kind="stable")
    shown = list(lengths.index[:MAX_TIMELINE_TRACKS])
    cams = sorted(status["camera"].unique())
    keys = [(tid, c) for tid in shown for c in cams]
    times = np.unique(status["t"].to_numpy(float))
    dt = float(np.median(np.diff(times))) if len(times) > 1 else 0.1
    names = list(dict.fromkeys([*STATUS_COLOURS, *sorted(status["status"].unique())]))
    colours = {s: STATUS_COLOURS.get(s, f"C{i}") for i, s in enumerate(names)}
    fig, ax = plt.subplots(figsize=(9, 0.9 + 0.28 * len(keys)))
    for row, (tid, cam) in enumerate(keys):
        g = status[(status["track_id"] == tid) & (status["camera"] == cam)].sort_values("t", kind="stable")
        if not len(g):
            continue
        t = g["t"].to_numpy(float)
        s = g["status"].to_numpy(object)
        # runs of one status; a run ends one frame after its last row, or where a gap starts
        brk = np.flatnonzero((s[1:] != s[:-1]) | (np.diff(t) > 1.5 * dt)) + 1
        for a, b in zip(np.r_[0, brk], np.r_[brk, len(t)]):
            ax.broken_barh([(t[a], t[b - 1] - t[a] + dt)], (row - 0.4, 0.8), color=colours[s[a]], lw=0)
    ax.set_yticks(range(len(keys)), [f"track {tid} / {c}" for tid, c in keys], fontsize=7)
    ax.set_ylim(len(keys) - 0.5, -0.5)
    ax.set_xlabel("time (s)")
    ax.grid(axis="x", alpha=0.3)
    used = [n for n in names if (status["status"] == n).any()]
    ax.legend(handles=[Patch(color=colours[n], label=n) for n in used], loc="upper left", bbox_to_anchor=(1.01, 1.0),
              fontsize=8, frameon=False)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    more = len(lengths) - len(shown)
    caption = f"{title} (the {len(shown)} longest of {len(lengths)} tracks)" if more > 0 else ""
    return Figure(title, png_base64(fig), caption)


def scene_sections(folder: Path, spec, results: pd.DataFrame) -> list[SceneSection]:
    """Per scene: the first seed with a kept recording; its tracks over the truth and status timelines."""
    from trackroom.compare import run_paths
    from trackroom.dataset import read_tracks
    from trackroom.recording import RecordingError

    ok = results[results["status"] == "ok"]
    out = []
    for scene in spec.scenes:
        sec = SceneSection(scene.key, None)
        seeds = [int(s) for s in dict.fromkeys(ok.loc[ok["scene"] == scene.key, "seed"])]
        if not seeds:
            sec.note = "no estimator ran successfully on this scene"
            out.append(sec)
            continue
        rec, why = None, ""
        for seed in seeds:
            rec, why = find_recording(folder, spec, scene, seed)
            if rec is not None:
                sec.seed = seed
                break
        if rec is None:
            sec.note = f"no top-down view: {why}"
            out.append(sec)
            continue
        runs, statuses = [], []
        for est in spec.estimators:
            paths = run_paths(folder / "runs", scene, sec.seed, est)
            if paths["tracks"].is_file():
                try:
                    tracks = read_tracks(paths["tracks"])
                except (RecordingError, ValueError) as e:
                    raise ReportError(f"{paths['tracks']}: {' '.join(str(e).split())}") from None
                if len(tracks):
                    runs.append((est.key, tracks))
            if paths["status"].is_file():
                statuses.append((est.key, pd.read_parquet(paths["status"])))
        if runs:
            title = f"{scene.key}, seed {sec.seed} ({spec.sensing}, {spec.duration:g} s): tracks over the truth"
            sec.topdown = topdown_figure(rec, runs, spec.gate, title)
        else:
            sec.note = "no stored tracks for this seed"
        for name, st in statuses:
            if len(st):
                sec.timelines.append(status_timeline(st, f"{name}: camera status per track, seed {sec.seed}"))
        out.append(sec)
    return out


# ----------------------------------------------------------------------------- the page
def render_report(folder: str | Path) -> str:
    """The report's HTML text for a comparison folder."""
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    from trackroom.compare import spec_to_toml
    from trackroom.metrics.aggregate import INTERVAL_NOTE

    d = Path(folder)
    results, spec, prov = read_comparison(d)
    metrics = metric_columns(results)
    env = Environment(loader=PackageLoader("trackroom", "templates"), autoescape=select_autoescape(["html", "j2"]),
                      undefined=StrictUndefined, trim_blocks=True, lstrip_blocks=True)
    return env.get_template("report.html.j2").render(
        title=f"trackroom comparison: {d.resolve().name}",
        generated=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        setup=(f"{len(spec.scenes)} scene(s) x {len(spec.seeds)} seed(s) x {len(spec.estimators)} estimator(s); "
               f"{spec.duration:g} s each, {spec.sensing} sensing, gate {spec.gate:g} m"),
        interval_note=INTERVAL_NOTE,
        summary=summary_table(results, metrics),
        not_run=not_run_table(results),
        runs=runs_table(results),
        plots=summary_plots(d),
        scenes=scene_sections(d, spec, results),
        prov=prov,
        versions=prov.get("versions") or {},
        spec_toml=spec_to_toml(spec),
    )


def write_report(folder: str | Path, out: str | Path | None = None) -> Path:
    """Write the report (default ``folder/report.html``) atomically; returns its path."""
    from trackroom.dataset import atomic_write

    html = render_report(folder)
    path = Path(out) if out else Path(folder) / "report.html"
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write(path, lambda p: p.write_text(html, encoding="utf-8"))
