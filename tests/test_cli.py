"""The command line: clear one-line errors with exit status 2, and the commands that need no simulator."""
from __future__ import annotations

import subprocess
import sys

import pandas as pd
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
        (["generate", "bearing_hall", "--set", "walkers.count=0", "--out", "x"], "no people to simulate"),
        (["show", "."], "not a trackroom recording"),
        (["generate", "bearing_hall", "--sensing", "rendered", "--render-workers", "-1", "--out", "x"],
         "--render-workers must be a whole number >= 0"),
        (["generate", "bearing_hall", "--render-workers", "2", "--out", "x"], "--render-workers needs --sensing rendered"),
        (["generate", "bearing_hall", "--perception-draw", "-1", "--out", "x"], "--perception-draw must be a whole number >= 0"),
        (["generate", "bearing_hall", "--sensing", "rendered", "--perception-draw", "1", "--out", "x"],
         "--perception-draw needs --sensing analytic"),
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


def test_generate_leaves_the_collector_on_with_its_objects_frozen(tmp_path):
    """generate imports with the cyclic collector off, then freezes what it loaded and, once the
    recording is written, everything else: the collector is on again (for a caller in the same
    process) and the interpreter's exit collections have next to nothing to walk. An error before
    simulating leaves it on too."""
    code = ("import gc, sys; from trackroom.cli import main; "
            "assert main(['generate', 'bearing_hall', '--duration', '-1', '--out', 'x']) == 2; "
            "print(gc.isenabled()); "
            f"assert main(['generate', 'bearing_hall', '--duration', '1', '--out', {str(tmp_path / 'rec')!r}, '--quiet']) == 0; "
            "print(gc.isenabled(), gc.get_freeze_count() > 10 * len(gc.get_objects()))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.strip().splitlines()
    assert lines[0] == "True" and lines[-1] == "True True", r.stdout


def test_bad_render_workers_variable_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("TRACKROOM_RENDER_WORKERS", "many")
    r = run_cli("generate", "bearing_hall", "--sensing", "rendered", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and r.stderr.strip().splitlines() == [
        "trackroom generate: error: TRACKROOM_RENDER_WORKERS must be a whole number >= 0 (0: no worker threads), got 'many'"], r.stderr
    assert not (tmp_path / "x").exists()


def _stderr_on_a_terminal(args, timeout=300) -> tuple[int, str]:
    """Runs ``trackroom ARGS`` with stderr on a pseudo-terminal (100 columns); (status, what it drew)."""
    import fcntl
    import os
    import pty
    import struct
    import termios

    try:
        master, slave = pty.openpty()
    except OSError as e:  # a sandbox without pseudo-terminals
        pytest.skip(f"no pseudo-terminal: {e}")
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    p = subprocess.Popen([sys.executable, "-m", "trackroom", *args], stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    out = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    os.close(master)
    return p.wait(timeout=timeout), out.decode(errors="replace")


def test_rendered_generate_shows_one_bar_over_the_camera_frames(tmp_path):
    """On a terminal, a rendered generate draws one bar over its camera frames (4 cameras at
    20 Hz for 0.5 s: 40), with the rate and the time left, up to 40/40; into a pipe it draws
    nothing (and the analytic mode's bar over simulation steps is not shown in rendered mode)."""
    import re

    args = ["generate", "overhead_lab", "--duration", "0.5", "--sensing", "rendered", "--set", "walkers.count=2"]
    status, err = _stderr_on_a_terminal([*args, "--out", str(tmp_path / "tty")])
    assert status == 0, err
    assert re.search(r"overhead_lab \(rendered\): 100%.*\| 40/40 \[\d\d:\d\d<\d\d:\d\d, +[\d.]+frame/s\]", err), err
    bars = [seg for seg in re.split(r"[\r\n]", err) if "%|" in seg]
    assert bars and all("/40 " in b and "frame" in b for b in bars), bars  # one bar, over frames only
    r = run_cli(*args, "--out", str(tmp_path / "pipe"))
    assert r.returncode == 0 and "%|" not in r.stderr and "frame/s" not in r.stderr, r.stderr


def test_summary_line_shows_speeds_below_real_time():
    """A rendered run slower than real time reads 0.29x, not 0x."""
    from types import SimpleNamespace

    from trackroom.cli.commands.generate import summary_line

    rec = SimpleNamespace(observations=SimpleNamespace(tables={}), truth=SimpleNamespace(people=pd.DataFrame({"person_id": ["a"]})),
                          duration=30.0, scene="s", seed=1, sensing="rendered")
    assert "(0.29x real time)" in summary_line(rec, 104.5, "out")
    assert "(150x real time)" in summary_line(rec, 0.2, "out")


def test_generate_perception_draw_writes_the_redrawn_camera_tables(tmp_path):
    """``--perception-draw K``: the recording ``simulate(..., perception_draw=K)`` gives (what
    ``experiment_tsutsui --draw K`` runs): the same walkers and phones as the seed's own recording,
    other camera tables; the command line is in the manifest."""
    import json

    from trackroom.dataset import read_recording
    from trackroom.scenes import load_scene
    from trackroom.sim.simulate import simulate

    out0, out1 = tmp_path / "d0", tmp_path / "d1"
    for out, draw in ((out0, "0"), (out1, "1")):
        r = run_cli("generate", "occlusion_lab", "--seed", "5", "--duration", "3", "--perception-draw", draw,
                    "--out", str(out), "--quiet")
        assert r.returncode == 0, r.stderr
    d0, d1 = read_recording(out0), read_recording(out1)
    direct = simulate(load_scene("occlusion_lab"), 5, 3.0, perception_draw=1)
    pd.testing.assert_frame_equal(d1.observations.tables["boxes"].reset_index(drop=True),
                                  direct.observations.tables["boxes"].reset_index(drop=True), check_dtype=False)
    pd.testing.assert_frame_equal(d0.truth.people, d1.truth.people)
    pd.testing.assert_frame_equal(d0.observations.tables["imu"], d1.observations.tables["imu"])
    assert not d0.observations.tables["boxes"].equals(d1.observations.tables["boxes"])
    assert "--perception-draw" in json.dumps(json.load(open(out1 / "manifest.json")))

