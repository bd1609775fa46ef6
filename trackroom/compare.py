"""The comparison engine: scenes x seeds x estimators -> results.csv, summary.md, plots.

A comparison is described by a ``CompareSpec`` (from a TOML file, the command line, or code).
Per (scene, seed) one recording task (read from the recordings cache folder when it is there,
else simulate and, with a cache folder, write it) and per estimator one task that runs it on that
recording (the runner checks applicability and records the reason when one does not apply) and
scores the tracks (``metrics.score``). The tasks run in this process (``jobs = 1``), on a dask
``LocalCluster`` of ``jobs`` worker processes, or on an existing dask cluster (``run_comparison``'s
``scheduler``; ``trackroom.cluster``), with a progress bar over the runs; rows come out in the
spec's order (scene, seed, estimator) whichever ran them, so the tables are the same.

TOML format (every key optional except scenes; command-line options override)::

    duration = 20.0          # simulated seconds per recording
    sensing = "analytic"     # or "rendered"
    seeds = "0-4"            # or [0, 1, 2]
    gate = 1.0               # CLEAR MOT / IDF1 gate, m; HOTA similarity max(0, 1 - d / gate)
    jobs = 2                 # 1: in this process; N > 1: a dask LocalCluster of N workers
    plugins = ["my_tracker", "extra/tracker.py"]   # estimator plug-ins: modules or .py files
                                     # (files relative to this TOML file); workers import them too
    set = ["walkers.count=3"]        # scene overrides for every scene
    scenes = ["overhead_lab"]        # plain names, or tables:
    [[scenes]]
    name = "overhead_lab"
    label = "overhead_lab_10"        # how it is named in the tables (default: name[overrides])
    set = ["walkers.count=10"]
    [[estimators]]                   # or estimators = ["ekf", ...]; default: every registered one
    name = "ekf"
    label = "ekf_rts"                # default: name, or name[k=v;...] with params
    params = { smooth = true }       # checked strictly against the estimator's Config types

Outputs (``write_outputs``): ``results.csv`` (one row per scene, seed and estimator, skipped
and failed runs included with the reason), ``per_frame.csv`` (error, misses, false positives
and switches per evaluation frame), ``summary.md`` (mean and 95% interval per scene and
estimator), ``metric_<name>.png`` (metric per estimator) and ``error_over_time.png``;
``spec.toml`` (the resolved ``CompareSpec``, loadable by ``spec_from_toml``) and
``provenance.json`` (command line, versions, git commit, start and end time, seeds, the scenes'
hashes, how many runs were reused and where the tasks ran: ``backend``).

The recordings cache (``recordings``): one folder per scene (name and overrides), duration,
sensing and seed. Its manifest is checked against the cache key, ``cache_key``: the resolved
scene's SHA-256, seed, duration, sensing mode and the trackroom version (not the git commit: it
changes with every commit, documentation included, and "+dirty" does not change with further
edits, so it would neither keep nor invalidate a cache reliably; bump the version when the
simulation changes). A stale entry (key mismatch, unreadable or corrupt) is regenerated, with one
line on stderr saying so.

Finished runs (``runs_dir``, ``OUT/runs`` from the command line): each (scene, seed, estimator)
run is stored as it finishes, written atomically: ``<scene>/seed<seed>/<estimator>.json`` (the
result row and the run's key), ``.per_frame.parquet``, ``.tracks.csv`` and, for an estimator that
keeps one (``Estimator.estimate_with_status``), its per-camera status ``.status.parquet``; the
report (``trackroom report``) draws the tracks and status from them. A run whose stored key
matches (scene hash, seed, duration, sensing, gate, estimator and parameters, version, and the
scoring's revision, ``metrics.score.SCORE_REVISION``, so runs stored before a metric was added
are scored again) is reused, not re-run (``compare --resume``).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import shlex
import sys
import time
import tomllib
import uuid
from datetime import datetime, timezone
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from trackroom.dataset import atomic_write

PLOT_METRICS = ("mota", "rmse", "idf1", "hota")
PLOT_COLUMNS = 2  # scene panels per row of a metric plot


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
    # estimator plug-ins (module names, absolute .py paths) every worker process imports
    plugins: list[str] = field(default_factory=list)

    def validate(self) -> "CompareSpec":
        from trackroom.estimators import get, load_plugins

        load_plugins(self.plugins)

        if not self.scenes:
            raise CompareError("no scenes to compare")
        if not self.seeds:
            raise CompareError("no seeds")
        if not self.estimators:
            raise CompareError("no estimators")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise CompareError(f"duration must be positive and finite (seconds), got {self.duration:g}")
        if self.sensing not in ("analytic", "rendered"):
            raise CompareError(f"sensing must be analytic or rendered, got {self.sensing!r}")
        if not self.gate > 0:
            raise CompareError(f"gate must be positive, got {self.gate}")
        if self.jobs < 1:
            raise CompareError(f"jobs must be at least 1, got {self.jobs}")
        if self.recordings and "://" in str(self.recordings):
            raise CompareError(f"recordings {self.recordings}: give a folder path (on a filesystem every worker mounts); "
                               "URLs are not supported")
        for what, keys in (("scene", [s.key for s in self.scenes]), ("estimator", [e.key for e in self.estimators])):
            dup = sorted({k for k in keys if keys.count(k) > 1})
            if dup:
                raise CompareError(f"{what} label(s) {dup} appear twice: give each a distinct label")
        from trackroom.estimators.runner import parse_params

        for e in self.estimators:
            parse_params(get(e.name), dict(e.params))  # unknown estimators or parameters fail now
        from trackroom.scenes import load_scene

        from trackroom.sim.simulate import memory_problem

        parallel = min(self.jobs, len(self.scenes) * len(self.seeds), os.cpu_count() or 1)
        for s in self.scenes:
            scene = load_scene(s.name, list(s.overrides))  # bad scenes or overrides fail now, not in a worker
            problem = memory_problem(scene, self.duration, self.sensing, parallel)
            if problem:
                raise CompareError(f"{s.key}: {problem}")
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
    """``ekf`` or ``ekf[smooth=true;filter=ukf]`` (``;`` or ``,`` between parameters; values parsed
    strictly by the Config field's type, lists in brackets: ``target_planes[initial_xy=[1, 2]]``)."""
    from trackroom.estimators import get
    from trackroom.estimators.base import coerce_param

    name, _, rest = text.partition("[")
    name = name.strip()
    params = []
    if rest:
        if not rest.endswith("]"):
            raise CompareError(f"bad estimator {text!r}: use name[key=value;...]")
        cls = get(name)
        for item in split_top(rest[:-1].replace(";", ",")):
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
    known = {"duration", "sensing", "seeds", "gate", "jobs", "set", "scenes", "estimators", "recordings", "plugins"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise CompareError(f"{p}: unknown key(s) {unknown}; known: {sorted(known)}")
    from trackroom.estimators import get, load_plugins, resolve_plugin
    from trackroom.estimators.base import coerce_value

    plugins = raw.get("plugins", [])
    if not (isinstance(plugins, list) and all(isinstance(x, str) for x in plugins)):
        raise CompareError(f"{p}: plugins must be a list of module names or .py paths, got {plugins!r}")
    plugins = [resolve_plugin(x, p.parent) for x in plugins]
    load_plugins(plugins)  # before the estimators are looked up
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
            name, params = e.get("name"), e.get("params", {})
            if not isinstance(name, str):
                raise CompareError(f"{p}: every [[estimators]] table needs a name")
            if not isinstance(params, dict):
                raise CompareError(f"{p}: estimator {name}: params must be a table, got {params!r}")
            cls = get(name)
            # in the file's order, as on the command line (the order shows in the default label)
            ests.append(EstimatorRun(name, tuple((k, coerce_value(cls, k, v)) for k, v in params.items()),
                                     e.get("label", "")))
    return CompareSpec(
        scenes=scenes,
        seeds=parse_seeds(raw.get("seeds", [0])),
        estimators=ests or all_estimators(),
        duration=float(raw.get("duration", 20.0)),
        sensing=raw.get("sensing", "analytic"),
        gate=float(raw.get("gate", 1.0)),
        jobs=int(raw.get("jobs", 1)),
        recordings=raw.get("recordings"),
        plugins=plugins,
    )


def spec_to_toml(spec: CompareSpec) -> str:
    """The spec as a comparison TOML file; ``spec_from_toml`` reads it back to an equal spec."""
    import tomli_w

    doc: dict[str, Any] = {"duration": float(spec.duration), "sensing": spec.sensing, "seeds": [int(x) for x in spec.seeds],
                           "gate": float(spec.gate), "jobs": int(spec.jobs)}
    if spec.recordings:
        doc["recordings"] = str(spec.recordings)
    if spec.plugins:
        doc["plugins"] = list(spec.plugins)
    doc["scenes"] = [{"name": s.name, **({"label": s.label} if s.label else {}), **({"set": list(s.overrides)} if s.overrides else {})}
                     for s in spec.scenes]
    doc["estimators"] = [{"name": e.name, **({"label": e.label} if e.label else {}), **({"params": dict(e.params)} if e.params else {})}
                         for e in spec.estimators]
    return "# trackroom compare: the resolved comparison (trackroom compare spec.toml runs it again)\n" + tomli_w.dumps(doc)


# ----------------------------------------------------------------------------- running
def recording_folder(root: str | Path, scene: SceneRun, seed: int, duration: float, sensing: str) -> Path:
    """Cache path: one folder per scene (name or file, and overrides), duration, sensing and seed.
    What the scene holds is checked against the folder's manifest (``stale_reason``)."""
    key = json.dumps([scene.name, list(scene.overrides), duration, sensing])
    h = hashlib.sha1(key.encode()).hexdigest()[:10]
    # a scene given as a file is named by its stem (its full path is in the hash)
    stem = Path(scene.name).stem if scene.name.endswith(".toml") else scene.name
    stem = re.sub(r"[^A-Za-z0-9._=-]+", "_", stem).strip("._") or "scene"
    return Path(root) / f"{stem}_{sensing}_{duration:g}s_{h}_seed{seed}"


def cache_key(scene, seed: int, duration: float, sensing: str) -> dict[str, Any]:
    """What a cached recording must match: the resolved scene's hash, seed, duration, sensing mode,
    the trackroom version (see the module docstring for why not the git commit) and the perception
    model's hash (a refitted ``sim/perception_default.json`` changes recordings, not the scene)."""
    from trackroom.provenance import versions
    from trackroom.scenes.loader import scene_sha256

    from trackroom.sim.perception_model import model_sha256

    return {"scene_sha256": scene_sha256(scene), "seed": int(seed), "duration": float(duration), "sensing": sensing,
            "trackroom_version": versions().get("trackroom"),
            "perception_sha256": model_sha256(scene.sensors.perception)}


def stale_reason(folder: Path, key: dict[str, Any]) -> str | None:
    """Why the cached recording in ``folder`` cannot be used for ``key`` (None: it can)."""
    from trackroom.dataset import read_manifest
    from trackroom.recording import RecordingError

    try:
        manifest = read_manifest(folder)
    except RecordingError as e:
        return f"unreadable: {e}"
    if manifest.get("scene_sha256") is None:
        return "no scene hash: written by an older trackroom"
    if manifest["scene_sha256"] != key["scene_sha256"]:
        return "scene changed"
    for field_, what in (("seed", "seed"), ("duration", "duration"), ("sensing", "sensing"), ("trackroom_version", "trackroom version")):
        if manifest.get(field_) != key[field_]:
            return f"{what} changed: {manifest.get(field_)} -> {key[field_]}"
    meta = manifest.get("meta") if isinstance(manifest.get("meta"), dict) else {}
    perception = meta.get("perception") if isinstance(meta.get("perception"), dict) else {}
    if perception.get("sha256") != key["perception_sha256"]:
        return "perception model changed (sensors.perception)"
    return None


def get_recording(scene: SceneRun, seed: int, duration: float, sensing: str, cache: str | None, command: list[str] | None = None,
                  resolved=None):
    """Read the cached recording when its key matches, or simulate it (and write it to the cache);
    returns (recording, simulation seconds, 0 when read). ``resolved``: the scene already loaded."""
    from trackroom.scenes import load_scene
    from trackroom.dataset import read_recording, write_recording
    from trackroom.recording import RecordingError
    from trackroom.sim.simulate import simulate

    if resolved is None:
        resolved = load_scene(scene.name, list(scene.overrides))
    folder = recording_folder(cache, scene, seed, duration, sensing) if cache else None
    if folder is not None and folder.exists():
        reason = stale_reason(folder, cache_key(resolved, seed, duration, sensing))
        if reason is None:
            try:
                return read_recording(folder), 0.0
            except RecordingError as e:
                reason = f"unreadable: {e}"
        print(f"cache: {scene.key} seed {seed} is stale ({reason}), regenerating", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    rec = simulate(resolved, seed, duration, sensing)
    seconds = time.perf_counter() - t0
    if folder is not None:
        folder.parent.mkdir(parents=True, exist_ok=True)
        write_recording(rec, folder, overwrite=True, command=command)  # atomic: a concurrent reader sees old or new
    return rec, seconds


def run_key(scene: SceneRun, scene_hash: str, seed: int, est: EstimatorRun, spec: CompareSpec) -> dict[str, Any]:
    """What a stored run must match to be reused."""
    from trackroom.metrics.score import SCORE_REVISION
    from trackroom.provenance import versions

    return {"scene": scene.key, "scene_name": scene.name, "overrides": list(scene.overrides), "scene_sha256": scene_hash,
            "seed": int(seed), "duration": float(spec.duration), "sensing": spec.sensing, "gate": float(spec.gate),
            "estimator": est.key, "estimator_name": est.name, "params": [[k, _jsonable(v)] for k, v in est.params],
            "trackroom_version": versions().get("trackroom"), "score_revision": SCORE_REVISION}


def _jsonable(v: Any) -> Any:
    return v if isinstance(v, (bool, int, float, str)) or v is None else str(v)


def run_paths(runs_dir: str | Path, scene: SceneRun, seed: int, est: EstimatorRun) -> dict[str, Path]:
    """Where one finished run is stored: the row (json, written last), per-frame errors, tracks,
    the per-camera status table."""
    base = Path(runs_dir) / _safe_name(scene.key) / f"seed{seed}" / _safe_name(est.key)
    return {"row": base.with_name(base.name + ".json"), "per_frame": base.with_name(base.name + ".per_frame.parquet"),
            "tracks": base.with_name(base.name + ".tracks.csv"), "status": base.with_name(base.name + ".status.parquet")}


def _safe_name(key: str) -> str:
    """A file name for a label: its plain characters and a short hash (labels may hold / [ ] ;)."""
    plain = re.sub(r"[^A-Za-z0-9._=-]+", "_", key).strip("._")[:80] or "x"
    return f"{plain}-{hashlib.sha1(key.encode()).hexdigest()[:8]}"


def _load_run(paths: dict[str, Path], key: dict[str, Any]) -> tuple[dict, pd.DataFrame] | None:
    """A stored run matching ``key``, or None (absent, different, unreadable)."""
    try:
        stored = json.loads(paths["row"].read_text())
        if stored.get("key") != key:
            return None
        per_frame = pd.read_parquet(paths["per_frame"]) if stored.get("per_frame") else pd.DataFrame()
        return stored["row"], per_frame
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _store_run(paths: dict[str, Path], key: dict[str, Any], row: dict, per_frame: pd.DataFrame, tracks,
               camera_status: pd.DataFrame | None = None) -> None:
    """Write one finished run; the row file goes last, so it marks a complete run."""
    from trackroom.estimators.base import CAMERA_STATUS_COLUMNS

    paths["row"].parent.mkdir(parents=True, exist_ok=True)
    if tracks is not None:
        atomic_write(paths["tracks"], lambda p: tracks.to_csv(p, index=False, float_format="%.6f"))
    if camera_status is not None:
        st = camera_status[CAMERA_STATUS_COLUMNS].astype({"track_id": str, "camera": str, "status": str, "reason": str})
        atomic_write(paths["status"], lambda p: st.to_parquet(p, index=False))
    if len(per_frame):
        atomic_write(paths["per_frame"], lambda p: per_frame.to_parquet(p, index=False))
    doc = {"key": key, "row": row, "per_frame": bool(len(per_frame))}
    atomic_write(paths["row"], lambda p: p.write_text(json.dumps(doc, indent=1, default=_json_default) + "\n"))


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    return str(o)




def _scene_hash(resolved) -> str:
    from trackroom.scenes.loader import scene_sha256

    return scene_sha256(resolved)


@dataclass
class _Job:
    """One (scene, seed): its resolved scene, the runs already stored and the estimators to run."""
    index: int
    scene: SceneRun
    seed: int
    resolved: Any = field(repr=False)
    done: dict[str, tuple[dict, pd.DataFrame]] = field(default_factory=dict)  # estimator key -> stored run
    todo: list[EstimatorRun] = field(default_factory=list)


def _plan(spec: CompareSpec, runs_dir: str | Path | None) -> list[_Job]:
    """Every (scene, seed) job in the spec's order, each scene loaded once, with the finished
    runs found in ``runs_dir`` (a matching key) and the estimators still to run."""
    from trackroom.scenes import load_scene

    jobs = []
    for s in spec.scenes:
        resolved = load_scene(s.name, list(s.overrides))
        scene_hash = _scene_hash(resolved)
        for seed in spec.seeds:
            job = _Job(len(jobs), s, seed, resolved)
            for est in spec.estimators:
                stored = None
                if runs_dir is not None:
                    stored = _load_run(run_paths(runs_dir, s, seed, est), run_key(s, scene_hash, seed, est, spec))
                if stored is None:
                    job.todo.append(est)
                else:
                    job.done[est.key] = stored
            jobs.append(job)
    return jobs


def recording_task(scene: SceneRun, seed: int, spec: CompareSpec, resolved, command: list[str] | None = None):
    """Task: the recording of one (scene, seed), read from the cache or simulated (and cached);
    returns (recording, simulation seconds). ``resolved``: the scene, loaded by the caller (a worker
    on another machine need not have the scene file)."""
    os.environ.setdefault("MUJOCO_GL", "egl")  # a dask worker started by hand: before mujoco loads
    return get_recording(scene, seed, spec.duration, spec.sensing, spec.recordings, command, resolved)


def estimator_task(recording: tuple, scene: SceneRun, scene_hash: str, seed: int, est: EstimatorRun, spec: CompareSpec,
                   runs_dir: str | Path | None = None) -> tuple[dict, pd.DataFrame]:
    """Task: run one estimator on ``recording`` (``recording_task``'s result) and score it; stores
    the run in ``runs_dir``. Returns the result row and the per-frame error series."""
    from trackroom.estimators import load_plugins
    from trackroom.estimators.runner import run_estimator
    from trackroom.metrics.score import evaluate

    load_plugins(spec.plugins)  # a worker process started afresh knows only the bundled estimators
    rec, sim_s = recording
    base = {"scene": scene.key, "seed": seed, "sensing": spec.sensing, "estimator": est.key,
            "duration": spec.duration, "overrides": ";".join(scene.overrides),
            "params": ";".join(f"{k}={_text(v)}" for k, v in est.params), "sim_s": sim_s}
    r = run_estimator(rec, est.name, dict(est.params), errors="record")
    row = {**base, "status": r.status, "reason": r.reason, "runtime_s": r.seconds}
    s = pd.DataFrame()
    if r.status == "ok":
        ev = evaluate(rec, r.tracks, spec.gate)
        row.update(ev.metrics())
        s = ev.error_over_time()
        s.insert(0, "estimator", est.key)
        s.insert(0, "seed", seed)
        s.insert(0, "scene", scene.key)
    if runs_dir is not None:
        ok = r.status == "ok"
        _store_run(run_paths(runs_dir, scene, seed, est), run_key(scene, scene_hash, seed, est, spec), row, s,
                   r.tracks if ok else None, r.camera_status if ok else None)
    return row, s


def run_job(scene: SceneRun, seed: int, spec: CompareSpec, runs_dir: str | Path | None = None,
            command: list[str] | None = None) -> tuple[list[dict], pd.DataFrame, int]:
    """One recording, every estimator, in this process: score rows, per-frame error series and how
    many runs were reused from ``runs_dir`` (where each finished run is also stored)."""
    from trackroom.estimators import load_plugins

    load_plugins(spec.plugins)
    one = CompareSpec([scene], [seed], spec.estimators, spec.duration, spec.sensing, spec.gate, 1, spec.recordings,
                      spec.plugins)
    (job,) = _plan(one, runs_dir)
    results = _run_serial([job], spec, runs_dir, command, _Progress(0, 0, 0, enabled=False))
    return _gather([job], spec, results) + (len(job.done),)


class _Progress:
    """One bar on stderr over the estimator runs (rate, ETA), the recordings made or read beside it;
    off with ``enabled=False`` and where stderr is not a terminal."""

    def __init__(self, runs: int, recordings: int, reused: int, enabled: bool = True):
        from tqdm import tqdm

        self.recordings, self.recordings_done = recordings, 0
        self.bar = tqdm(total=runs, initial=reused, desc="compare", unit="run", mininterval=0.5,
                        disable=None if enabled else True)  # None: off when stderr is not a terminal
        self._postfix()

    def _postfix(self) -> None:
        self.bar.set_postfix_str(f"recordings {self.recordings_done}/{self.recordings}", refresh=False)

    def recording(self) -> None:
        self.recordings_done += 1
        self._postfix()
        self.bar.refresh()

    def run(self) -> None:
        self.bar.update()

    def close(self) -> None:
        self.bar.close()


def _run_serial(jobs: list[_Job], spec: CompareSpec, runs_dir, command, progress: _Progress) -> dict:
    """Every job's pending runs in this process: {(job index, estimator key): (row, per_frame)}."""
    out = {}
    for job in jobs:
        if not job.todo:
            continue
        recording = recording_task(job.scene, job.seed, spec, job.resolved, command)
        progress.recording()
        scene_hash = _scene_hash(job.resolved)
        for est in job.todo:
            out[job.index, est.key] = estimator_task(recording, job.scene, scene_hash, job.seed, est, spec, runs_dir)
            progress.run()
    return out


def _run_dask(jobs: list[_Job], spec: CompareSpec, runs_dir, command, progress: _Progress, client) -> dict:
    """The same on ``dask.distributed``: a recording task per job, an estimator task per pending run
    that takes it (dask runs it where the recording is); a recording is released when its runs are done."""
    from distributed import as_completed

    what, recordings, left, out = {}, {}, {}, {}
    ac = as_completed()
    for job in jobs:
        if not job.todo:
            continue
        rec = client.submit(recording_task, job.scene, job.seed, spec, job.resolved, command, pure=False,
                            key=f"recording-{job.index}-{uuid.uuid4().hex}")
        recordings[job.index], left[job.index] = rec, len(job.todo)
        what[rec.key] = (job.index, None)
        ac.add(rec)
        scene_hash = _scene_hash(job.resolved)
        for est in job.todo:
            f = client.submit(estimator_task, rec, job.scene, scene_hash, job.seed, est, spec, runs_dir, pure=False,
                              key=f"run-{job.index}-{uuid.uuid4().hex}")
            what[f.key] = (job.index, est)
            ac.add(f)
    for f in ac:
        index, est = what.pop(f.key)
        if f.status == "error":
            f.result()  # raises the task's error here
        if est is None:
            progress.recording()  # its result stays on the workers
            continue
        out[index, est.key] = f.result()
        progress.run()
        left[index] -= 1
        if not left[index]:
            del recordings[index]  # no reference left: the scheduler forgets the recording
    return out


def _gather(jobs: list[_Job], spec: CompareSpec, results: dict) -> tuple[list[dict], pd.DataFrame]:
    """Rows and per-frame series in the spec's order (scene, seed, estimator), whichever backend
    ran them and in whatever order they finished."""
    rows, series = [], []
    for job in jobs:
        for est in spec.estimators:
            row, s = job.done[est.key] if est.key in job.done else results[job.index, est.key]
            rows.append(row)
            if len(s):
                series.append(s)
    return rows, pd.concat(series, ignore_index=True) if series else pd.DataFrame()


@dataclass
class Comparison:
    spec: CompareSpec
    results: pd.DataFrame
    per_frame: pd.DataFrame = field(repr=False)
    seconds: float = 0.0
    started: str = ""  # UTC, ISO 8601
    reused: int = 0  # finished runs taken from runs_dir instead of run again
    backend: str = "serial"  # "serial", "local cluster (N workers)" or the scheduler's address


def run_comparison(spec: CompareSpec, progress: bool = True, runs_dir: str | Path | None = None,
                   command: list[str] | None = None, scheduler: str | None = None) -> Comparison:
    """Run every (scene, seed) recording and every estimator on it; rows in the spec's order.

    Where the tasks run: with ``scheduler`` (a ``dask.distributed`` address, e.g.
    ``tcp://host:8786``) on that cluster; else with ``spec.jobs`` > 1 on a local dask cluster of
    that many worker processes; else in this process, one after another. The results are the same
    (but for the runtime columns) whichever runs them.

    ``runs_dir``: where each finished (scene, seed, estimator) run is stored, and reused from when
    its key matches (see the module docstring); with a cluster it and ``spec.recordings`` must be
    paths every worker can reach. ``command``: recorded in cached recordings.
    """
    spec.validate()
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    t0 = time.perf_counter()
    if runs_dir is not None:
        runs_dir = Path(runs_dir).resolve()  # workers may run from another folder
    given = spec
    if spec.recordings:  # the tasks get an absolute path; the spec as given is what is recorded
        spec = dataclasses.replace(spec, recordings=str(Path(spec.recordings).resolve()))
    jobs = _plan(spec, runs_dir)
    reused = sum(len(j.done) for j in jobs)
    todo = [j for j in jobs if j.todo]
    bar = _Progress(len(jobs) * len(spec.estimators), len(todo), reused, enabled=progress)
    try:
        if scheduler is None and (spec.jobs == 1 or len(todo) <= 1):
            backend = "serial"
            results = _run_serial(todo, spec, runs_dir, command, bar)
        else:
            from trackroom.cluster import connect

            # no more local workers than cores or tasks (as the process pool before it)
            workers = min(spec.jobs, os.cpu_count() or 1, sum(1 + len(j.todo) for j in todo))
            with connect(scheduler, workers, spec.plugins) as (client, backend):
                results = _run_dask(todo, spec, runs_dir, command, bar, client)
    finally:
        bar.close()
    rows, per_frame = _gather(jobs, spec, results)
    return Comparison(given, pd.DataFrame(rows), per_frame, time.perf_counter() - t0, started, reused, backend)


# ----------------------------------------------------------------------------- outputs
OUTPUT_FILES = ("results.csv", "per_frame.csv", "summary.md", "spec.toml", "provenance.json", "error_over_time.png",
                "report.html")


def write_outputs(comp: Comparison, out_dir: str | Path, plots: bool = True, command: list[str] | None = None) -> dict[str, Path]:
    """results.csv, per_frame.csv, summary.md, spec.toml, provenance.json and the plots (each
    written atomically); returns their paths by name. ``command``: the command line to record."""
    from trackroom.metrics.aggregate import INTERVAL_NOTE, summary_markdown

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"results": out / "results.csv", "per_frame": out / "per_frame.csv", "summary": out / "summary.md",
             "spec": out / "spec.toml", "provenance": out / "provenance.json"}
    atomic_write(paths["results"], lambda p: comp.results.to_csv(p, index=False, float_format="%.6g"))
    atomic_write(paths["per_frame"], lambda p: comp.per_frame.to_csv(p, index=False, float_format="%.6g"))
    s = comp.spec
    head = (f"# Comparison\n\n{len(s.scenes)} scene(s) x {len(s.seeds)} seed(s) ({_seed_text(s.seeds)}) x "
            f"{len(s.estimators)} estimator(s); {s.duration:g} s each, {s.sensing} sensing, gate {s.gate:g} m "
            f"(HOTA: similarity max(0, 1 - d / {s.gate:g} m), mean over alpha 0.05-0.95). {INTERVAL_NOTE}\n\n")
    atomic_write(paths["summary"], lambda p: p.write_text(head + summary_markdown(comp.results) + "\n"))
    atomic_write(paths["spec"], lambda p: p.write_text(spec_to_toml(s)))
    atomic_write(paths["provenance"], lambda p: p.write_text(json.dumps(provenance_record(comp, command), indent=2) + "\n"))
    if plots:
        paths.update(plot_metrics(comp.results, out))
        if len(comp.per_frame):
            paths["error_over_time"] = plot_error_over_time(comp.per_frame, out / "error_over_time.png")
    return paths


def provenance_record(comp: Comparison, command: list[str] | None = None) -> dict[str, Any]:
    """Where a comparison's results came from: command line, versions, git commit, times, seeds,
    the scenes' hashes, how many runs were reused and where the tasks ran."""
    from trackroom.provenance import versions
    from trackroom.scenes import load_scene
    from trackroom.scenes.loader import scene_sha256

    v = versions()
    s = comp.spec
    return {
        "command": list(command) if command is not None else None,
        "command_text": shlex.join(command) if command is not None else None,
        "trackroom_version": v.get("trackroom"),
        "git_commit": v.get("git_commit"),
        "versions": v,
        "started": comp.started,
        "finished": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "seconds": round(comp.seconds, 3),
        "seeds": [int(x) for x in s.seeds],
        "scenes": [{"key": sc.key, "name": sc.name, "overrides": list(sc.overrides),
                    "scene_sha256": scene_sha256(load_scene(sc.name, list(sc.overrides)))} for sc in s.scenes],
        "estimators": [e.key for e in s.estimators],
        "reused_runs": comp.reused,
        "backend": comp.backend,
    }


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
    from trackroom.metrics.aggregate import mean_interval, metric_label

    plt = _pyplot()
    ok = results[results["status"] == "ok"] if "status" in results else results
    paths = {}
    scenes = list(dict.fromkeys(results["scene"]))
    ests = list(dict.fromkeys(results["estimator"]))
    for m in metrics:
        if m not in ok.columns or not ok[m].notna().any():
            continue
        cols = min(len(scenes), PLOT_COLUMNS)  # scenes wrap onto rows, so the text stays legible on a page
        rows = -(-len(scenes) // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(max(4.0, 1.2 * len(ests) + 1.5) * cols, 3.6 * rows), squeeze=False)
        for ax in axes.ravel()[len(scenes):]:
            ax.set_visible(False)
        for ax, sc in zip(axes.ravel(), scenes):
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
            ax.set_ylabel(metric_label(m))
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


def ci_spec(thresholds: pd.DataFrame, scene: str, sensing: str, jobs: int = 1, plugins: list[str] | None = None):
    """The ``CompareSpec`` CI runs for one scene and sensing: the estimators with bounds there
    (``plugins``: the plug-ins that provide some of them)."""
    from trackroom.estimators import load_plugins
    from trackroom.metrics.thresholds import CI_DEFAULT, CI_RUNS, CI_SEEDS

    load_plugins(plugins)

    rows = thresholds[(thresholds["scene"] == scene) & (thresholds["sensing"] == sensing)]
    cfg = CI_RUNS.get(scene, CI_DEFAULT)
    ests = []
    for name in dict.fromkeys(rows["estimator"]):
        e = parse_estimator(name)
        ests.append(type(e)(e.name, e.params, label=name))
    return CompareSpec(
        scenes=[SceneRun(scene, tuple(cfg["overrides"]), label=scene)],
        seeds=list(CI_SEEDS), estimators=ests, duration=float(cfg["duration"]), sensing=sensing, jobs=jobs,
        plugins=list(plugins or []),
    )
