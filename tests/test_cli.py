"""The command line: clear one-line errors with exit status 2, and the commands that need no simulator."""
from __future__ import annotations

import subprocess
import sys

import pytest

from scripts.cli import main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "scripts.cli", *args], capture_output=True, text=True, timeout=300)


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
