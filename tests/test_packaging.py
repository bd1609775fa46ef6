"""One installed name: a non-editable install puts only ``trackroom`` into site-packages, runs the
command from outside the checkout, and imports the recording contract without the simulator."""
from __future__ import annotations

import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GENERIC = {"scripts", "sim", "metrics", "scenes", "estimators", "tests"}


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh venv (dependencies from the running environment) with ``pip install .`` of this tree."""
    env_dir = tmp_path_factory.mktemp("venv")
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    site = Path(subprocess.check_output([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True).strip())
    # Build from a copy so the checkout's build/ and egg-info are left alone.
    src = tmp_path_factory.mktemp("src")
    files = subprocess.check_output(["git", "-C", ROOT, "ls-files", "--cached", "--others", "--exclude-standard"],
                                    text=True).split()
    for rel in files:
        if (ROOT / rel).is_file():
            (src / rel).parent.mkdir(parents=True, exist_ok=True)
            (src / rel).write_bytes((ROOT / rel).read_bytes())
    r = subprocess.run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "--no-build-isolation",
                        "-q", str(src)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return py, site


def test_site_packages_holds_trackroom_and_nothing_generic(installed):
    _, site = installed
    names = {p.name for p in site.iterdir()}
    assert "trackroom" in names
    assert not (GENERIC & names), GENERIC & names
    assert (site / "trackroom" / "scenes" / "overhead_lab.toml").is_file()
    assert (site / "trackroom" / "metrics" / "thresholds.csv").is_file()
    assert (site / "trackroom" / "templates" / "report.html.j2").is_file()  # the HTML report's template
    assert not (site / "trackroom" / "fig_rahimi.py").exists()


def test_installed_copy_runs_outside_the_checkout(installed, tmp_path):
    py, site = installed
    code = ("import sys, trackroom, trackroom.recording, trackroom.dataset, trackroom.metrics.score,"
            " trackroom.metrics.thresholds, trackroom.metrics.aggregate, trackroom.estimators;"
            "trackroom.estimators.available();"
            "print(trackroom.__file__); print('mujoco' in sys.modules);"
            "print(any(m.startswith(('trackroom.cli', 'trackroom.compare')) for m in sys.modules))")
    out = subprocess.run([py, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True).stdout.split()
    assert out[0].startswith(str(site)), out
    assert out[1] == "False", "reading, estimating and scoring a recording must not import the simulator"
    assert out[2] == "False", "the recording contract, estimators and metrics never import the command line"
    r = subprocess.run([py, "-m", "trackroom", "--version"], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.startswith("trackroom "), r.stdout + r.stderr
