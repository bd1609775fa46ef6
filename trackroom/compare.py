"""The comparison engine: scenes x seeds x estimators -> results.csv, summary.md, plots.

A comparison is described by a ``CompareSpec`` (from a TOML file, the command line, or code).
One job per (scene, seed): get the recording (read from the recordings cache folder when it is
there, else simulate and, with a cache folder, write it), run every estimator on it (the runner
checks applicability and records the reason when one does not apply), and score each tracks
table (``metrics.score``). Jobs run in parallel processes (``jobs``) with a progress bar.

TOML format (every key optional except scenes; command-line options override)::

    duration = 20.0          # simulated seconds per recording
    sensing = "analytic"     # or "rendered"
    seeds = "0-4"            # or [0, 1, 2]
    gate = 1.0               # CLEAR MOT / IDF1 gate, m
    jobs = 2
    set = ["walkers.count=3"]        # scene overrides for every scene
    scenes = ["overhead_lab"]        # plain names, or tables:
    [[scenes]]
    name = "overhead_lab"
    label = "overhead_lab_10"        # how it is named in the tables (default: name[overrides])
    set = ["walkers.count=10"]
    [[estimators]]                   # or estimators = ["ekf", ...]; default: every registered one
    name = "ekf"
    label = "ekf_rts"                # default: name, or name[k=v;...] with params
    params = { smooth = true }

Outputs (``write_outputs``): ``results.csv`` (one row per scene, seed and estimator, skipped
and failed runs included with the reason), ``per_frame.csv`` (error, misses, false positives
and switches per evaluation frame), ``summary.md`` (mean and 95% interval per scene and
estimator), ``metric_<name>.png`` (metric per estimator) and ``error_over_time.png``.
"""
from __future__ import annotations

import hashlib
import json
import os
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

PLOT_METRICS = ("mota", "rmse", "idf1")


class CompareError(ValueError):
    """A comparison that cannot be set up as described."""


@dataclass(frozen=True)
class SceneRun:
    name: str
    overrides: tuple[str, ...] = ()
    label: str = ""

    @property
    def key(self) -> str:
        return self.label or (f"{self.name}[{';'.join(self.overrides)}]" if self.overrides else self.name)


@dataclass(frozen=True)
class EstimatorRun:
    name: str
    params: tuple[tuple[str, Any], ...] = ()
    label: str = ""

    @property
    def key(self) -> str:
        if self.label:
            return self.label
        if not self.params:
            return self.name
        return f"{self.name}[{';'.join(f'{k}={_text(v)}' for k, v in self.params)}]"


def _text(v: Any) -> str:
    return str(v).lower() if isinstance(v, bool) else str(v)


@dataclass
class CompareSpec:
    scenes: list[SceneRun]
    seeds: list[int]
    estimators: list[EstimatorRun]
    duration: float = 20.0
    sensing: str = "analytic"
    gate: float = 1.0
    jobs: int = 1
    recordings: str | None = None  # cache folder for recordings (None: simulate every time)

    def validate(self) -> "CompareSpec":
        from trackroom.estimators import get

        if not self.scenes:
            raise CompareError("no scenes to compare")
        if not self.seeds:
            raise CompareError("no seeds")
        if not self.estimators:
            raise CompareError("no estimators")
        if not self.duration > 0:
            raise CompareError(f"duration must be positive, got {self.duration}")
        if self.sensing not in ("analytic", "rendered"):
            raise CompareError(f"sensing must be analytic or rendered, got {self.sensing!r}")
        if not self.gate > 0:
            raise CompareError(f"gate must be positive, got {self.gate}")
        if self.jobs < 1:
            raise CompareError(f"jobs must be at least 1, got {self.jobs}")
        for what, keys in (("scene", [s.key for s in self.scenes]), ("estimator", [e.key for e in self.estimators])):
            dup = sorted({k for k in keys if keys.count(k) > 1})
            if dup:
                raise CompareError(f"{what} label(s) {dup} appear twice: give each a distinct label")
        from trackroom.estimators.runner import parse_params

        for e in self.estimators:
            parse_params(get(e.name), dict(e.params))  # unknown estimators or parameters fail now
        from trackroom.scenes import load_scene

        for s in self.scenes:
            load_scene(s.name, list(s.overrides))  # bad scenes or overrides fail now, not in a worker
        return self


# ----------------------------------------------------------------------------- parsing
def parse_seeds(text: str | int | list) -> list[int]:
    """``"0-4,7"`` -> [0, 1, 2, 3, 4, 7]; a list or an int as is."""
    if isinstance(text, int):
        return [text]
    if isinstance(text, list):
        return [int(s) for s in text]
    out: list[int] = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        try:
            if "-" in part:
                a, b = part.split("-", 1)
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise CompareError(f"seed range {part!r} runs backwards")
                out.extend(range(lo, hi + 1))
            else:
                out.append(int(part))
        except ValueError:
            raise CompareError(f"bad seed list {text!r}: use e.g. 0-4 or 0,3,5") from None
    return list(dict.fromkeys(out))


def split_top(text: str) -> list[str]:
    """Split on commas that are not inside brackets: ``"a,b[x=1,y=2]"`` -> ["a", "b[x=1,y=2]"]."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        depth += (ch == "[") - (ch == "]")
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [p.strip() for p in parts if p.strip()]


def parse_estimator(text: str) -> EstimatorRun:
    """``ekf`` or ``ekf[smooth=true;filter=ukf]`` (values parsed as TOML, else text)."""
    from trackroom.estimators import get
    from trackroom.estimators.base import coerce_param

    name, _, rest = text.partition("[")
    name = name.strip()
    params = []
    if rest:
        if not rest.endswith("]"):
            raise CompareError(f"bad estimator {text!r}: use name[key=value;...]")
        cls = get(name)
        for item in rest[:-1].replace(",", ";").split(";"):
            if item.strip():
                k, eq, v = item.partition("=")
                if not eq:
                    raise CompareError(f"bad estimator parameter {item!r} in {text!r}: use key=value")
                params.append((k.strip(), coerce_param(cls, k.strip(), v.strip())))
    return EstimatorRun(name, tuple(params))


def all_estimators() -> list[EstimatorRun]:
    from trackroom.estimators import available

    return [EstimatorRun(n) for n in available()]


def spec_from_toml(path: str | Path) -> CompareSpec:
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise CompareError(f"{p}: no such comparison file") from None
    except tomllib.TOMLDecodeError as e:
        raise CompareError(f"{p}: not valid TOML: {e}") from None
    known = {"duration", "sensing", "seeds", "gate", "jobs", "set", "scenes", "estimators", "recordings"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise CompareError(f"{p}: unknown key(s) {unknown}; known: {sorted(known)}")
    common = tuple(raw.get("set", []))
    scenes = []
    for s in raw.get("scenes", []):
        if isinstance(s, str):
            scenes.append(SceneRun(s, common))
        else:
            scenes.append(SceneRun(s["name"], common + tuple(s.get("set", [])), s.get("label", "")))
    ests = []
    for e in raw.get("estimators", []):
        if isinstance(e, str):
            ests.append(parse_estimator(e))
        else:
            ests.append(EstimatorRun(e["name"], tuple(sorted(e.get("params", {}).items())), e.get("label", "")))
    return CompareSpec(
        scenes=scenes,
        seeds=parse_seeds(raw.get("seeds", [0])),
        estimators=ests or all_estimators(),
        duration=float(raw.get("duration", 20.0)),
        sensing=raw.get("sensing", "analytic"),
        gate=float(raw.get("gate", 1.0)),
        jobs=int(raw.get("jobs", 1)),
        recordings=raw.get("recordings"),
    )


# ----------------------------------------------------------------------------- running
def recording_folder(root: str | Path, scene: SceneRun, seed: int, duration: float, sensing: str) -> Path:
    """Cache path: one folder per scene, overrides, duration, sensing and seed."""
    key = json.dumps([scene.name, list(scene.overrides), duration, sensing])
    h = hashlib.sha1(key.encode()).hexdigest()[:10]
    return Path(root) / f"{scene.name}_{sensing}_{duration:g}s_{h}_seed{seed}"


def get_recording(scene: SceneRun, seed: int, duration: float, sensing: str, cache: str | None):
    """Read the cached recording, or simulate it (and write it to the cache)."""
    from trackroom.scenes import load_scene
    from trackroom.dataset import read_recording, write_recording
    from trackroom.sim.simulate import simulate

    folder = recording_folder(cache, scene, seed, duration, sensing) if cache else None
    if folder is not None and (folder / "manifest.json").exists():
        return read_recording(folder), 0.0
    t0 = time.perf_counter()
    rec = simulate(load_scene(scene.name, list(scene.overrides)), seed, duration, sensing)
    seconds = time.perf_counter() - t0
    if folder is not None:
        folder.parent.mkdir(parents=True, exist_ok=True)
        try:
            write_recording(rec, folder)
        except FileExistsError:
            pass  # written meanwhile by another comparison: same content
    return rec, seconds


def run_job(scene: SceneRun, seed: int, spec: CompareSpec) -> tuple[list[dict], pd.DataFrame]:
    """One recording, every estimator: score rows and per-frame error series."""
    from trackroom.estimators.runner import run_estimator
    from trackroom.metrics.score import evaluate

    rec, sim_s = get_recording(scene, seed, spec.duration, spec.sensing, spec.recordings)
    rows, series = [], []
    for est in spec.estimators:
        base = {"scene": scene.key, "seed": seed, "sensing": spec.sensing, "estimator": est.key,
                "duration": spec.duration, "overrides": ";".join(scene.overrides),
                "params": ";".join(f"{k}={_text(v)}" for k, v in est.params), "sim_s": sim_s}
        r = run_estimator(rec, est.name, dict(est.params), errors="record")
        row = {**base, "status": r.status, "reason": r.reason, "runtime_s": r.seconds}
        if r.status == "ok":
            ev = evaluate(rec, r.tracks, spec.gate)
            row.update(ev.metrics())
            s = ev.error_over_time()
            s.insert(0, "estimator", est.key)
            s.insert(0, "seed", seed)
            s.insert(0, "scene", scene.key)
            series.append(s)
        rows.append(row)
    per_frame = pd.concat(series, ignore_index=True) if series else pd.DataFrame()
    return rows, per_frame


def _job(args):
    return run_job(*args)


@dataclass
class Comparison:
    spec: CompareSpec
    results: pd.DataFrame
    per_frame: pd.DataFrame = field(repr=False)
    seconds: float = 0.0


def run_comparison(spec: CompareSpec, progress: bool = True) -> Comparison:
    """Run every (scene, seed) job, in ``spec.jobs`` processes; rows in a fixed order."""
    from tqdm import tqdm

    spec.validate()
    t0 = time.perf_counter()
    jobs = [(s, seed, spec) for s in spec.scenes for seed in spec.seeds]
    out: dict[int, tuple[list[dict], pd.DataFrame]] = {}
    bar = tqdm(total=len(jobs), desc="compare", unit="rec", disable=not progress)
    if spec.jobs == 1 or len(jobs) == 1:
        for i, j in enumerate(jobs):
            bar.set_postfix_str(f"{j[0].key} seed {j[1]}")
            out[i] = _job(j)
            bar.update()
    else:
        workers = min(spec.jobs, len(jobs), os.cpu_count() or 1)
        with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("fork")) as pool:
            futures = {pool.submit(_job, j): i for i, j in enumerate(jobs)}
            for f in as_completed(futures):
                out[futures[f]] = f.result()
                bar.update()
    bar.close()
    rows = [r for i in range(len(jobs)) for r in out[i][0]]
    frames = [out[i][1] for i in range(len(jobs)) if len(out[i][1])]
    results = pd.DataFrame(rows)
    per_frame = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    return Comparison(spec, results, per_frame, time.perf_counter() - t0)


# ----------------------------------------------------------------------------- outputs
def write_outputs(comp: Comparison, out_dir: str | Path, plots: bool = True) -> dict[str, Path]:
    """results.csv, per_frame.csv, summary.md and the plots; returns their paths by name."""
    from trackroom.metrics.aggregate import INTERVAL_NOTE, summary_markdown

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"results": out / "results.csv", "per_frame": out / "per_frame.csv", "summary": out / "summary.md"}
    comp.results.to_csv(paths["results"], index=False, float_format="%.6g")
    comp.per_frame.to_csv(paths["per_frame"], index=False, float_format="%.6g")
    s = comp.spec
    head = (f"# Comparison\n\n{len(s.scenes)} scene(s) x {len(s.seeds)} seed(s) ({_seed_text(s.seeds)}) x "
            f"{len(s.estimators)} estimator(s); {s.duration:g} s each, {s.sensing} sensing, gate {s.gate:g} m. "
            f"{INTERVAL_NOTE}\n\n")
    paths["summary"].write_text(head + summary_markdown(comp.results) + "\n")
    if plots:
        paths.update(plot_metrics(comp.results, out))
        if len(comp.per_frame):
            paths["error_over_time"] = plot_error_over_time(comp.per_frame, out / "error_over_time.png")
    return paths


def _seed_text(seeds: list[int]) -> str:
    if seeds == list(range(seeds[0], seeds[-1] + 1)) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]}"
    return ",".join(map(str, seeds))


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_metrics(results: pd.DataFrame, out: Path, metrics=PLOT_METRICS) -> dict[str, Path]:
    """One figure per metric: a panel per scene, a bar (mean, 95% interval) and dots (seeds) per estimator."""
    from trackroom.metrics.aggregate import mean_interval

    plt = _pyplot()
    ok = results[results["status"] == "ok"] if "status" in results else results
    paths = {}
    scenes = list(dict.fromkeys(results["scene"]))
    ests = list(dict.fromkeys(results["estimator"]))
    for m in metrics:
        if m not in ok.columns or not ok[m].notna().any():
            continue
        fig, axes = plt.subplots(1, len(scenes), figsize=(max(4.0, 1.2 * len(ests) + 1.5) * len(scenes), 3.6), squeeze=False)
        for ax, sc in zip(axes[0], scenes):
            g = ok[ok["scene"] == sc]
            for i, e in enumerate(ests):
                v = g.loc[g["estimator"] == e, m].to_numpy(float)
                mean, lo, hi, n = mean_interval(v, m)
                if n == 0:
                    ax.text(i, 0, "n/a", ha="center", va="bottom", fontsize=8, color="0.4")
                    continue
                err = None if not np.isfinite(lo) else [[mean - lo], [hi - mean]]
                ax.bar(i, mean, color=f"C{i}", alpha=0.6, yerr=err, capsize=4)
                ax.plot(np.full(len(v), i) + np.linspace(-0.15, 0.15, len(v)), v, "k.", ms=4)
            ax.set_xticks(range(len(ests)), ests, rotation=20, ha="right", fontsize=8)
            ax.set_title(sc, fontsize=9)
            ax.set_ylabel(m)
        fig.tight_layout()
        p = out / f"metric_{m}.png"
        fig.savefig(p, dpi=100)
        plt.close(fig)
        paths[f"metric_{m}"] = p
    return paths


def plot_error_over_time(per_frame: pd.DataFrame, path: Path) -> Path:
    """Per scene: the matched-position RMSE per frame, averaged over seeds, one line per estimator."""
    plt = _pyplot()
    scenes = list(dict.fromkeys(per_frame["scene"]))
    fig, axes = plt.subplots(len(scenes), 1, figsize=(8, 2.6 * len(scenes)), squeeze=False)
    for ax, sc in zip(axes[:, 0], scenes):
        g = per_frame[per_frame["scene"] == sc]
        for i, (e, ge) in enumerate(g.groupby("estimator", sort=False)):
            mean = ge.groupby("t")["rmse"].mean()
            ax.plot(mean.index, mean.to_numpy(), lw=1, color=f"C{i}", label=e)
        ax.set_title(sc, fontsize=9)
        ax.set_ylabel("position error (m)")
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def ci_spec(thresholds: pd.DataFrame, scene: str, sensing: str, jobs: int = 1):
    """The ``CompareSpec`` CI runs for one scene and sensing: the estimators with bounds there."""
    from trackroom.metrics.thresholds import CI_DEFAULT, CI_RUNS, CI_SEEDS

    rows = thresholds[(thresholds["scene"] == scene) & (thresholds["sensing"] == sensing)]
    cfg = CI_RUNS.get(scene, CI_DEFAULT)
    ests = []
    for name in dict.fromkeys(rows["estimator"]):
        e = parse_estimator(name)
        ests.append(type(e)(e.name, e.params, label=name))
    return CompareSpec(
        scenes=[SceneRun(scene, tuple(cfg["overrides"]), label=scene)],
        seeds=list(CI_SEEDS), estimators=ests, duration=float(cfg["duration"]), sensing=sensing, jobs=jobs,
    )
