"""Provenance and safe outputs: what a manifest records, the compare cache and its staleness,
compare's spec/provenance/--force/--resume, generate's input limits, atomic writes under SIGKILL
and output piped into a reader that stops early."""
from __future__ import annotations

import dataclasses
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trackroom.cli import main
from trackroom.dataset import read_recording
from trackroom.provenance import git_commit, versions
from trackroom.scenes import bundled_scenes, load_scene, scene_sha256, scene_toml

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "trackroom", *args], capture_output=True, text=True, timeout=300, cwd=ROOT, **kw)


def same(a, b, where="scene") -> None:
    """Field-by-field equality of (nested) dataclasses holding numpy arrays."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            if f.name not in ("source", "raw", "overrides"):
                same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b, where


def strings(obj):
    if isinstance(obj, str):
        yield obj
    elif isinstance(obj, dict):
        for k, v in obj.items():
            yield k
            yield from strings(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from strings(v)


# ----------------------------------------------------------------------------- manifest
def test_manifest_records_command_override_and_resolved_scene(tmp_path):
    out = tmp_path / "rec"
    fresh = git_commit.__wrapped__  # uncached: a commit may land in the working tree mid-suite
    commits = {fresh()}  # and the one after
    r = run_cli("generate", "overhead_lab", "--set", "walkers.count=3", "--duration", "2", "--out", str(out), "--quiet")
    commits.add(fresh())
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["overrides"] == ["walkers.count=3"] and m["meta"]["overrides"] == ["walkers.count=3"]
    assert m["command"][:5] == ["trackroom", "generate", "overhead_lab", "--set", "walkers.count=3"]
    assert m["command"][m["command"].index("--out") + 1] == os.path.relpath(out, ROOT)
    assert m["source"] == "overhead_lab" and m["scene_file"] == "scene.toml"
    assert m["trackroom_version"] == versions()["trackroom"] and m["git_commit"] in commits
    absolute = [s for s in strings(m) if os.path.isabs(s)]
    assert absolute == []  # relative paths only
    # the resolved scene loads back, with 3 walkers, equal to the scene generate ran, same hash
    back = load_scene(out / "scene.toml")
    expected = load_scene("overhead_lab", ["walkers.count=3"])
    assert len(back.walkers) == 3
    same(back, expected)
    assert scene_sha256(back) == scene_sha256(expected) == m["scene_sha256"]
    assert "scene.toml" in m["files"]  # hashed like every other file
    rec = read_recording(out)
    assert rec.scene_toml == (out / "scene.toml").read_text() and rec.truth.people["person_id"].nunique() == 3


def test_a_recording_is_made_again_from_its_scene_toml(tmp_path):
    """What format.md promises: generate REC/scene.toml with the manifest's seed and duration gives
    byte-identical tables."""
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["generate", "overhead_lab", "--set", "walkers.count=2", "--seed", "4", "--duration", "2",
                 "--out", str(a), "--quiet"]) == 0
    m = json.loads((a / "manifest.json").read_text())
    assert main(["generate", str(a / "scene.toml"), "--seed", str(m["seed"]), "--duration", str(m["duration"]),
                 "--out", str(b), "--quiet"]) == 0
    tables = sorted(f for f in m["files"] if f.endswith(".parquet"))
    assert tables and all((a / f).read_bytes() == (b / f).read_bytes() for f in tables)
    assert json.loads((b / "manifest.json").read_text())["scene_sha256"] == m["scene_sha256"]


@pytest.mark.parametrize("name", bundled_scenes())
def test_resolved_scene_round_trips(tmp_path, name):
    scene = load_scene(name, ["sensors.floor_sigma_m=0.2", "render.shadows=true"])
    p = tmp_path / "s.toml"
    p.write_text(scene_toml(scene))
    back = load_scene(p)
    same(back, scene)
    assert scene_sha256(back) == scene_sha256(scene) != scene_sha256(load_scene(name))
    assert back.source == os.path.relpath(p) and scene.source == name


# ----------------------------------------------------------------------------- compare cache
SCENE = """
[scene]
name = "cache_room"
[room]
outline = [[0, 0], [8, 0], [8, 8], [0, 8]]
[[cameras]]
name = "top"
kind = "overhead"
position = [4, 4, 2.9]
fovy_deg = 120
resolution = [160, 120]
fps = 10
[walkers]
count = {count}
"""


def test_compare_cache_regenerates_an_edited_scene(tmp_path, capsys):
    scene = tmp_path / "room.toml"
    cache = tmp_path / "cache"

    def compare(out):
        rc = main(["compare", "--scenes", str(scene), "--estimators", "ekf", "--duration", "2", "--recordings", str(cache),
                   "--out", str(tmp_path / out), "--quiet"])
        assert rc == 0
        return pd.read_csv(tmp_path / out / "results.csv"), capsys.readouterr().err

    scene.write_text(SCENE.format(count=5))
    first, err = compare("a")
    assert first["people"].tolist() == [5] and "stale" not in err
    again, err = compare("b")  # unchanged: read from the cache, no note
    assert again["sim_s"].tolist() == [0.0] and "stale" not in err
    scene.write_text(SCENE.format(count=2))  # same file, same name: only its content changed
    edited, err = compare("c")
    assert edited["people"].tolist() == [2] and edited["sim_s"].iloc[0] > 0
    assert f"cache: {scene} seed 0 is stale (scene changed), regenerating" in err
    (folder,) = [p for p in cache.iterdir() if not p.name.startswith(".")]
    assert read_recording(folder).truth.people["person_id"].nunique() == 2


def test_compare_cache_regenerates_when_the_perception_model_changes(tmp_path, capsys):
    """A refitted model file under the same name changes recordings, not the scene: the cache
    notices it by the model's hash (manifest meta.perception)."""
    import json

    from trackroom.sim.perception_model import DEFAULT_FILE

    model = tmp_path / "model.json"
    model.write_text(DEFAULT_FILE.read_text())
    args = ["compare", "--scenes", "overhead_lab", "--set", "walkers.count=1", "--set", f"sensors.perception={model}",
            "--estimators", "ekf", "--duration", "1", "--recordings", str(tmp_path / "cache"), "--quiet"]
    assert main(args + ["--out", str(tmp_path / "a")]) == 0
    (folder,) = [p for p in (tmp_path / "cache").iterdir() if not p.name.startswith(".")]
    meta = read_recording(folder).meta["perception"]
    assert meta["model"] == str(model) and len(meta["sha256"]) == 64
    capsys.readouterr()
    d = json.loads(model.read_text())
    d["detectors"]["overhead"]["clutter"] = 0.5
    model.write_text(json.dumps(d))
    assert main(args + ["--out", str(tmp_path / "b")]) == 0
    assert "is stale (perception model changed (sensors.perception)), regenerating" in capsys.readouterr().err


def test_compare_cache_regenerates_a_corrupt_entry(tmp_path, capsys):
    args = ["compare", "--scenes", "overhead_lab", "--set", "walkers.count=1", "--estimators", "ekf", "--duration", "1",
            "--recordings", str(tmp_path / "cache"), "--quiet"]
    assert main(args + ["--out", str(tmp_path / "a")]) == 0
    (folder,) = (tmp_path / "cache").iterdir()
    (folder / "imu.parquet").write_bytes(b"not parquet")
    capsys.readouterr()
    assert main(args + ["--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "seed 0 is stale (unreadable:" in err and "imu.parquet" in err
    read_recording(folder)  # regenerated, whole again
    m = json.loads((folder / "manifest.json").read_text())
    m["trackroom_version"] = "0.0.0"
    (folder / "manifest.json").write_text(json.dumps(m))
    assert main(args + ["--out", str(tmp_path / "c")]) == 0
    assert f"(trackroom version changed: 0.0.0 -> {versions()['trackroom']})" in capsys.readouterr().err


# ----------------------------------------------------------------------------- compare outputs
def test_compare_writes_spec_and_provenance_and_refuses_existing_out(tmp_path, capsys):
    from trackroom.compare import spec_from_toml

    out = tmp_path / "cmp"
    args = ["compare", "--scenes", "overhead_lab", "--set", "walkers.count=1", "--seeds", "0,2",
            "--estimators", "ekf[smooth=true;accel_psd=0.3],ekf", "--duration", "1", "--quiet"]
    assert main(args + ["--out", str(out)]) == 0
    spec = spec_from_toml(out / "spec.toml")
    assert spec.seeds == [0, 2] and spec.duration == 1.0
    assert [e.key for e in spec.estimators] == ["ekf[smooth=true;accel_psd=0.3]", "ekf"]
    assert spec.scenes[0].overrides == ("walkers.count=1",)
    again = spec_from_toml(out / "spec.toml").validate()
    assert again == spec
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["command"][:2] == ["trackroom", "compare"] and "--seeds" in prov["command_text"]
    assert prov["seeds"] == [0, 2] and prov["trackroom_version"] == versions()["trackroom"]
    assert prov["git_commit"] == git_commit() and prov["started"] <= prov["finished"]
    assert prov["scenes"][0]["scene_sha256"] == scene_sha256(load_scene("overhead_lab", ["walkers.count=1"]))
    capsys.readouterr()
    # an existing --out is refused in one line; --force replaces its results
    before = (out / "results.csv").stat().st_mtime_ns
    assert main(args + ["--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "output folder exists (use --force" in err[0]
    assert (out / "results.csv").stat().st_mtime_ns == before
    assert main(args + ["--out", str(out), "--force"]) == 0
    assert (out / "results.csv").stat().st_mtime_ns != before


def test_resume_reuses_finished_runs(tmp_path, monkeypatch):
    import trackroom.estimators.runner as runner

    calls = []
    real = runner.run_estimator

    def counting(rec, name, *a, **k):
        calls.append((rec.seed, name))
        return real(rec, name, *a, **k)

    monkeypatch.setattr(runner, "run_estimator", counting)
    out = tmp_path / "cmp"
    assert main(["compare", "--scenes", "overhead_lab", "--set", "walkers.count=2", "--seeds", "0-1",
                 "--estimators", "ekf,ekf[smooth=true]", "--duration", "2", "--out", str(out), "--quiet"]) == 0
    assert len(calls) == 4
    full = pd.read_csv(out / "results.csv")
    # an interrupted comparison: seed 1's smoother had not finished
    (run,) = [p for p in (out / "runs").rglob("*.json") if "seed1" in str(p) and "smooth" in p.name]
    run.unlink()
    calls.clear()
    assert main(["compare", "--resume", "--out", str(out), "--quiet"]) == 0  # the spec comes from OUT/spec.toml
    assert calls == [(1, "ekf")]
    resumed = pd.read_csv(out / "results.csv")
    timing = ["runtime_s", "sim_s"]
    pd.testing.assert_frame_equal(resumed.drop(columns=timing), full.drop(columns=timing))
    assert json.loads((out / "provenance.json").read_text())["reused_runs"] == 3
    # nothing left to do: nothing runs, and the results are the same file
    calls.clear()
    text = (out / "results.csv").read_text()
    assert main(["compare", "--resume", "--out", str(out), "--quiet"]) == 0
    assert calls == [] and (out / "results.csv").read_text() == text
    # a changed spec does not reuse runs made for another one
    assert main(["compare", "--resume", "--scenes", "overhead_lab", "--set", "walkers.count=2", "--seeds", "0",
                 "--estimators", "ekf", "--duration", "2", "--gate", "0.5", "--out", str(out), "--quiet"]) == 0
    assert calls == [(0, "ekf")]
    # runs scored before the metrics changed (SCORE_REVISION) are run again, so every row has every metric
    import trackroom.metrics.score as scoring

    calls.clear()
    monkeypatch.setattr(scoring, "SCORE_REVISION", scoring.SCORE_REVISION + 1)
    assert main(["compare", "--resume", "--out", str(out), "--quiet"]) == 0
    assert calls == [(0, "ekf")] and pd.read_csv(out / "results.csv")["hota"].notna().all()


# ----------------------------------------------------------------------------- generate's limits
@pytest.mark.parametrize("duration,needle", [
    ("nan", "--duration must be positive and finite (seconds), got nan"),
    ("inf", "--duration must be positive and finite (seconds), got inf"),
    ("-3", "--duration must be positive and finite (seconds), got -3"),
    ("1e9", "for 1e+09 s of overhead_lab; this machine has"),
])
def test_generate_refuses_bad_durations_in_one_line(tmp_path, capsys, duration, needle):
    out = tmp_path / "rec"
    assert main(["generate", "overhead_lab", "--duration", duration, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("trackroom generate: error: ") and needle in err[0], err
    assert not out.exists()


def test_memory_estimate_refuses_up_front(tmp_path, capsys, monkeypatch):
    import trackroom.sim.simulate as simulate

    scene = load_scene("overhead_lab")
    small, big = simulate.estimate_memory(scene, 10), simulate.estimate_memory(scene, 1000)
    # linear in duration; a 20 s overhead_lab run peaks at ~200 MB above the interpreter's baseline
    assert big - simulate.BASE_BYTES == pytest.approx(100 * (small - simulate.BASE_BYTES))
    assert 2**20 < small < 2**30
    assert simulate.estimate_memory(load_scene("overhead_lab", ["walkers.count=10"]), 100) > simulate.estimate_memory(scene, 100)
    monkeypatch.setattr(simulate, "available_memory", lambda: 2.0 * 2**30)
    assert simulate.memory_problem(scene, 60) is None
    msg = simulate.memory_problem(scene, 1e6)
    assert msg.startswith("about ") and "this machine has 2 GiB available" in msg
    # the same estimate guards compare, counting parallel jobs
    assert main(["compare", "--scenes", "overhead_lab", "--duration", "1e6", "--estimators", "ekf",
                 "--out", str(tmp_path / "c")]) == 2
    assert "overhead_lab: about" in capsys.readouterr().err and not (tmp_path / "c").exists()
    huge = main(["generate", "overhead_lab", "--set", "walkers.count=100000", "--out", str(tmp_path / "g")])
    assert huge == 2 and "walkers.count" in capsys.readouterr().err


# ----------------------------------------------------------------------------- atomic writes
def test_generate_killed_at_random_points_leaves_no_dataset(tmp_path):
    """SIGKILL before, while and after the folder is written: never a partial folder at --out."""
    out = tmp_path / "D"
    rng = random.Random(16)
    cmd = [sys.executable, "-m", "trackroom", "generate", "overhead_lab", "--duration", "20", "--out", str(out), "--quiet", "--force"]
    # where the kills land: during start-up, as soon as the hidden partial folder appears, a
    # random moment into writing it
    plans = [("startup", rng.uniform(0.2, 1.0)), ("writing", 0.0), ("writing", rng.uniform(0.0, 0.15))]
    landed = []
    for when, delay in plans:
        p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if when == "writing":
            deadline = time.monotonic() + 120
            while not any(c.name.startswith(".D.partial-") for c in tmp_path.iterdir()) and p.poll() is None:
                assert time.monotonic() < deadline
                time.sleep(0.001)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.wait()
        landed.append(any(c.name == f".D.partial-{p.pid}" for c in tmp_path.iterdir()))
        if out.exists():  # the kill came after the rename: then it is whole
            read_recording(out)
    assert any(landed)  # a kill did land mid-write
    r = run_cli("generate", "overhead_lab", "--duration", "20", "--out", str(out), "--quiet", "--force")
    assert r.returncode == 0, r.stderr
    assert read_recording(out).duration == 20.0
    assert [c.name for c in tmp_path.iterdir()] == ["D"]  # the killed writers' leftovers are gone


def test_demo_into_a_closed_pipe_ends_quietly_and_leaves_nothing(tmp_path):
    out = tmp_path / "demo"
    p = subprocess.Popen([sys.executable, "-m", "trackroom", "demo", "--scenes", "overhead_lab", "--duration", "2",
                          "--out", str(out)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = p.stdout.readline()  # `| head -1`
    p.stdout.close()
    err = p.stderr.read()
    rc = p.wait(timeout=300)
    assert first.startswith("overhead_lab seed 0: 2 s")
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert rc == 141
    assert list(tmp_path.iterdir()) == []  # no demo folder, no hidden partial one


# ----------------------------------------------------------------------------- reading
def test_corrupt_parquet_with_matching_hash_is_one_clear_error(tmp_path):
    out = tmp_path / "rec"
    assert run_cli("generate", "overhead_lab", "--duration", "1", "--out", str(out), "--quiet").returncode == 0
    from trackroom.dataset import _sha256
    from trackroom.recording import RecordingError

    path = out / "floor_detections.parquet"
    data = path.read_bytes()
    path.write_bytes(data[:-100])  # truncated: the footer is gone
    m = json.loads((out / "manifest.json").read_text())
    m["files"]["floor_detections.parquet"] = _sha256(path)  # the hash updated to match
    (out / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(RecordingError, match=r"rec/floor_detections.parquet: not a readable Parquet table \("):
        read_recording(out)
    r = run_cli("show", str(out))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "floor_detections.parquet: not a readable Parquet table" in lines[0], r.stderr
    path.write_bytes(b"PAR1")  # truncated to the magic number
    m["files"]["floor_detections.parquet"] = _sha256(path)
    (out / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(RecordingError, match="floor_detections.parquet: not a readable Parquet table"):
        read_recording(out)
    path.write_bytes(data + b"x")  # changed, hash not updated: named as changed
    with pytest.raises(RecordingError, match="file floor_detections.parquet does not match its hash"):
        read_recording(out)
