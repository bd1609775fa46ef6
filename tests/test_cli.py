"""The command line: clear one-line errors with exit status 2, and the commands that need no simulator."""
from __future__ import annotations

import subprocess
import sys

import pytest

from trackroom.cli import main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "trackroom", *args], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize(
    "args,needle",
    [
        (["generate", "no_such_scene", "--out", "x"], "no_such_scene: not a scene file or a bundled scene"),
        (["generate", "bearing_hall", "--duration", "-1", "--out", "x"], "--duration must be positive"),
        (["generate", "bearing_hall", "--set", "walkers.count=99", "--out", "x"], "walkers.count"),
        (["show", "."], "not a trackroom recording"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(args, needle):
    r = run_cli(*args)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0], r.stderr
    assert "Traceback" not in r.stderr


def test_show_scene_writes_png(tmp_path):
    out = tmp_path / "hall.png"
    assert main(["show", "bearing_hall", "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000


def test_generate_estimate_score_round_trip(tmp_path):
    import json

    rec = tmp_path / "rec"
    r = run_cli("generate", "overhead_lab", "--seed", "3", "--duration", "6", "--set", "walkers.count=2", "--out", str(rec), "--quiet")
    assert r.returncode == 0, r.stderr
    assert (rec / "manifest.json").exists() and (rec / "calibration" / "ceil_sw.xml").exists()
    r = run_cli("generate", "overhead_lab", "--out", str(rec), "--duration", "1", "--quiet")
    assert r.returncode == 2 and "exists" in r.stderr  # an existing recording is never clobbered
    tracks = tmp_path / "tracks.csv"
    r = run_cli("estimate", str(rec), "--estimator", "ekf", "--out", str(tracks))
    assert r.returncode == 0, r.stderr
    r = run_cli("score", str(rec), str(tracks), "--json")
    assert r.returncode == 0, r.stderr
    scores = json.loads(r.stdout)
    assert {"mota", "motp", "id_switches", "idf1", "fp", "fn", "rmse"} <= set(scores)
    assert scores["mota"] > 0.8
    r = run_cli("show", str(rec))
    assert r.returncode == 0 and (rec / "topdown.png").exists()
    # `trackroom score ... | head` and `trackroom estimators | head`: the reader is gone before the
    # first line is written (closed at once, so it is gone whatever the timing); the command ends
    # quietly with SIGPIPE's status, no BrokenPipeError traceback
    for args in (["score", str(rec), str(tracks)], ["estimators"]):
        p = subprocess.Popen([sys.executable, "-m", "trackroom", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        p.stdout.close()
        err = p.stderr.read()
        assert p.wait(timeout=300) == 141 and err == "", (args, err)


def test_rendered_frames_and_contact_sheets(tmp_path):
    rec = tmp_path / "rendered"
    r = run_cli("generate", "occlusion_lab", "--duration", "0.6", "--sensing", "rendered", "--save-frames", "--out", str(rec), "--quiet")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (rec / "frames").glob("*.mp4")) == ["obl_ne.mp4", "obl_nw.mp4", "obl_se.mp4", "obl_sw.mp4"]
    r = run_cli("show", str(rec), "--frames")
    assert r.returncode == 0, r.stderr
    from pathlib import Path

    sheets = [Path(ln.split()[-1]) for ln in r.stdout.splitlines() if ln.startswith("wrote")]
    sheets = [p for p in sheets if p.name.startswith("frames_")]
    assert len(sheets) == 4 and all(p.stat().st_size > 10_000 for p in sheets)


def test_the_command_line_loads_libraries_only_when_a_command_needs_them():
    """Parsing the command line (every sub-command's options) imports no numerical or plotting
    library; `generate` (analytic) imports what it simulates and writes with, not matplotlib,
    the estimators' libraries or dask."""
    heavy = ("numpy", "pandas", "scipy", "mujoco", "cv2", "matplotlib", "pyarrow", "dask", "distributed", "tqdm",
             "filterpy", "osqp")
    code = ("import sys; from trackroom.cli import build_parser; build_parser(); "
            f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({heavy!r})))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


def test_generate_imports_no_plotting_estimators_or_dask(tmp_path):
    code = ("import sys; from trackroom.cli import main; "
            f"main(['generate', 'bearing_hall', '--duration', '1', '--out', {str(tmp_path / 'rec')!r}, '--quiet']); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'matplotlib', 'filterpy', 'osqp', 'dask', 'distributed', 'tqdm', 'trackroom.estimators'}), "
            "any(m.startswith(('trackroom.estimators', 'trackroom.metrics')) for m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip().splitlines()[-1] == "[] False", r.stdout
