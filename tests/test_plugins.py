"""Estimator plug-ins: the example package in docs/example_plugin installed into a temporary folder
(never the global environment) and run through `compare` in worker processes; listed by
`trackroom estimators`; a plug-in file loaded with --plugin; a plug-in that fails gives one line."""
from __future__ import annotations

import os
import subprocess
import sys
from multiprocessing import get_context
from pathlib import Path

import pandas as pd
import pytest

import trackroom.estimators as registry
from trackroom.cli import main
from trackroom.compare import CompareSpec, EstimatorRun, SceneRun, run_job, spec_from_toml
from trackroom.estimators.base import REGISTRY, EstimatorError

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "example_plugin"
PLUGIN_FILE = EXAMPLE / "floor_nearest.py"


def run_cli(*args, pythonpath: list[Path] = (), cwd: Path = ROOT):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(str(p) for p in [*pythonpath, ROOT])}
    return subprocess.run([sys.executable, "-m", "trackroom", *args], capture_output=True, text=True, timeout=300,
                          env=env, cwd=cwd)


def one_line_error(r, needle: str) -> None:
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2 and len(lines) == 1 and needle in lines[0] and "Traceback" not in r.stderr, r.stderr


@pytest.fixture
def own_registry():
    """Plug-ins loaded by a test are forgotten after it, so other tests see the bundled set only."""
    registry.available()  # the bundled estimators are registered once per process, on import
    saved = dict(REGISTRY), dict(registry.SOURCES), dict(registry._loaded)
    modules = set(sys.modules)
    yield
    for target, old in zip((REGISTRY, registry.SOURCES, registry._loaded), saved):
        target.clear()
        target.update(old)
    for name in set(sys.modules) - modules:  # so the next load of the plug-in registers it afresh
        if name.startswith("trackroom_plugin_"):
            del sys.modules[name]


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """docs/example_plugin pip-installed into a temporary target folder (a copy is built, so no
    build/ or egg-info lands in the repository)."""
    tmp = tmp_path_factory.mktemp("plugin")
    src, site = tmp / "src", tmp / "site"
    subprocess.run(["cp", "-r", str(EXAMPLE), str(src)], check=True)
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--quiet",
                        "--disable-pip-version-check", "--target", str(site), str(src)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (site / "floor_nearest.py").is_file()
    return site


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    from trackroom.dataset import write_recording
    from trackroom.scenes import load_scene
    from trackroom.sim.simulate import simulate

    out = tmp_path_factory.mktemp("rec") / "overhead"
    write_recording(simulate(load_scene("overhead_lab", ["walkers.count=2"]), 0, 5.0, "analytic"), out)
    return out


def test_installed_plugin_is_listed_and_runs_in_compare_workers(installed, tmp_path):
    r = run_cli("estimators", pythonpath=[installed])
    assert r.returncode == 0, r.stderr
    assert "floor_nearest  (entry point floor_nearest (trackroom-floor-nearest))" in r.stdout
    for p in ("gate_m", "duplicate_m", "max_missed_s"):
        assert p in r.stdout
    out = tmp_path / "cmp"
    r = run_cli("compare", "--scenes", "overhead_lab", "--set", "walkers.count=2", "--seeds", "0-1", "--duration", "5",
                "--jobs", "2", "--estimators", "floor_nearest,floor_nearest[gate_m=0.5]", "--out", str(out), "--quiet",
                pythonpath=[installed])
    assert r.returncode == 0, r.stderr
    res = pd.read_csv(out / "results.csv")
    assert sorted(res["estimator"]) == ["floor_nearest"] * 2 + ["floor_nearest[gate_m=0.5]"] * 2
    assert (res["status"] == "ok").all(), res[["estimator", "status", "reason"]]
    assert (res["mota"] > 0.5).all()  # two people seen by overhead cameras: it tracks them


def test_plugin_file_in_estimate(recording, tmp_path, monkeypatch, capsys, own_registry):
    tracks = tmp_path / "tracks.csv"
    r = run_cli("estimate", str(recording), "--plugin", str(PLUGIN_FILE), "--estimator", "floor_nearest",
                "--param", "gate_m=0.8", "--out", str(tracks))
    assert r.returncode == 0, r.stderr
    t = pd.read_csv(tracks)
    assert list(t.columns) == ["t", "track_id", "x", "y"] and t["track_id"].nunique() >= 2
    # in-process from here on (the same code path, without another interpreter start-up)
    monkeypatch.chdir(ROOT)  # a relative path works from where the command runs
    assert main(["estimate", str(recording), "--plugin", "docs/example_plugin/floor_nearest.py", "--estimator",
                 "floor_nearest", "--out", str(tracks)]) == 0
    capsys.readouterr()
    assert main(["estimate", str(recording), "--plugin", str(PLUGIN_FILE), "--estimator", "floor_nearest",
                 "--param", "gate_m=far", "--out", str(tracks)]) == 2
    assert capsys.readouterr().err.strip() == ("trackroom estimate: error: floor_nearest: parameter gate_m: expected a "
                                               "finite number, got 'far'")


def test_plugin_in_demo_does_not_apply_table(tmp_path, capsys, own_registry):
    assert main(["demo", "--scenes", "occlusion_lab", "--duration", "2", "--plugin", str(PLUGIN_FILE),
                 "--out", str(tmp_path)]) == 0
    res = pd.read_csv(tmp_path / "results.csv").set_index("estimator")
    assert res.loc["floor_nearest", "status"] == "skipped"
    reason = "needs floor_detections observations; the recording has none"
    assert res.loc["floor_nearest", "reason"] == reason
    assert f"| occlusion_lab | analytic | floor_nearest | skipped | {reason} |" in capsys.readouterr().out


def test_worker_process_started_afresh_imports_the_plugins(recording, own_registry):
    """A spawned worker (as dask or a 'spawn' pool would start) knows only the bundled estimators
    until it imports the spec's plug-ins."""
    spec = CompareSpec(scenes=[SceneRun(str(ROOT / "scenes" / "overhead_lab.toml"), ("walkers.count=2",))], seeds=[0],
                       estimators=[EstimatorRun("floor_nearest")], duration=3.0, plugins=[str(PLUGIN_FILE)])
    with get_context("spawn").Pool(1) as pool:
        rows, _, _ = pool.apply(run_job, (spec.scenes[0], 0, spec))
    assert rows[0]["estimator"] == "floor_nearest" and rows[0]["status"] == "ok", rows[0]


def test_compare_toml_plugins_relative_to_the_file(tmp_path, own_registry):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "floor_nearest.py").write_text(PLUGIN_FILE.read_text())
    toml = tmp_path / "cmp.toml"
    toml.write_text('plugins = ["mine/floor_nearest.py"]\nscenes = ["overhead_lab"]\n'
                    '[[estimators]]\nname = "floor_nearest"\nparams = { gate_m = 2 }\n')
    spec = spec_from_toml(toml)
    assert spec.plugins == [str((tmp_path / "mine" / "floor_nearest.py").resolve())]
    assert spec.estimators[0].params == (("gate_m", 2.0),)  # an integer for a float field becomes a float
    toml.write_text('plugins = ["mine/floor_nearest.py"]\nscenes = ["overhead_lab"]\n'
                    '[[estimators]]\nname = "floor_nearest"\nparams = { gate_m = "far" }\n')
    with pytest.raises(EstimatorError, match="parameter gate_m: expected a finite number, got 'far'"):
        spec_from_toml(toml)


def test_broken_plugins_give_one_line_naming_them(tmp_path, capsys, own_registry):
    def error_of(*args) -> str:
        assert main(list(args)) == 2
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        assert len(lines) == 1, lines
        return lines[0]

    bad = tmp_path / "broken.py"
    bad.write_text("import no_such_dependency_xyz\n")
    assert (f"plugin {str(bad)!r} failed to import: ModuleNotFoundError: No module named 'no_such_dependency_xyz'"
            in error_of("estimators", "--plugin", str(bad)))
    assert "plugin 'no_such_plugin_xyz': no module named" in error_of("estimators", "--plugin", "no_such_plugin_xyz")
    assert "no such file" in error_of("estimators", "--plugin", str(tmp_path / "absent.py"))
    empty = tmp_path / "empty.py"
    empty.write_text("X = 1\n")
    assert "registers no estimator" in error_of("compare", "--scenes", "overhead_lab", "--plugin", str(empty),
                                                "--out", str(tmp_path / "o"))
    clash = tmp_path / "clash.py"
    clash.write_text("from trackroom.estimators import Estimator, register\n"
                     "@register\nclass E(Estimator):\n    name = 'ekf'\n")
    assert "estimator name 'ekf' registered twice" in error_of("estimators", "--plugin", str(clash))
    # an installed plug-in whose entry point names a module that is not there (a fresh interpreter:
    # entry points are read once per process)
    site = tmp_path / "site"
    dist = site / "broken_plugin-0.1.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[trackroom.estimators]\nbroken = not_installed_module_xyz\n")
    one_line_error(run_cli("estimators", pythonpath=[site]),
                   "plugin 'broken' (entry point 'not_installed_module_xyz' (broken-plugin) in group trackroom.estimators)"
                   " failed to load")
