"""scripts/experiment_tsutsui.py: the issue-12 measurement's perception draws."""
from __future__ import annotations

import pytest

from scripts import experiment_tsutsui as ts


def test_a_perception_draw_redraws_the_windows_and_keeps_the_walkers():
    """``--draw K`` (``run(..., draw=K)``): an analytic recording's camera tables drawn anew
    through the perception model, the same people on the same paths (so the same click); draw 0
    is the seed's own recording, drawn the same every time."""
    rec0, _, m0 = ts.run("analytic", 3.0, 5)
    rec0b, _, _ = ts.run("analytic", 3.0, 5, draw=0)
    rec1, _, m1 = ts.run("analytic", 3.0, 5, draw=1)
    assert rec0.observations["boxes"].equals(rec0b.observations["boxes"])
    assert not rec0.observations["boxes"].equals(rec1.observations["boxes"])
    assert rec0.truth.people.equals(rec1.truth.people)
    assert ts.click(rec0) == ts.click(rec1)
    assert "perception_draw" not in m0 and m1["perception_draw"] == 1


def test_a_draw_is_refused_where_nothing_is_simulated(capsys):
    for argv in (["--sensing", "rendered", "--draw", "1"], ["--sensing", "analytic", "--draw", "-1"]):
        with pytest.raises(SystemExit):
            ts.main(argv)
        assert "--draw K" in capsys.readouterr().err


def _runs(out: str) -> list[dict]:
    """The JSON runs of ``--json`` output, without the timings (which differ run to run)."""
    import json

    runs = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    for r in runs:
        r.pop("sim_s"), r.pop("estimate_s")
    return runs


def test_worker_processes_give_the_same_runs_in_the_same_order(capsys):
    """``--jobs 2`` runs the list in two worker processes: the same figures as one process, in
    the order the seeds were given (not the order they finish)."""
    argv = ["--sensing", "analytic", "--duration", "3", "--seeds", "7,5,6", "--json"]
    assert ts.main(argv) == 0
    one = _runs(capsys.readouterr().out)
    assert ts.main(argv + ["--jobs", "2"]) == 0
    out = capsys.readouterr()
    two = _runs(out.out)
    assert all(line.startswith("{") for line in out.out.splitlines())  # only runs: a file compare_tp_runs reads
    assert "identity_held" in out.err  # the summary over runs goes to stderr
    assert [r["seed"] for r in one] == [7, 5, 6]
    assert one == two


def test_a_missing_recording_is_named_before_anything_runs(tmp_path, capsys):
    """Every recording folder is checked before the first run: a missing one is named and
    nothing is printed for the others."""
    from trackroom.dataset import write_recording
    from trackroom.sim.simulate import simulate

    good = tmp_path / "good"
    write_recording(simulate(ts.load_scene("occlusion_lab"), 3, 2.0, "analytic"), good)
    with pytest.raises(SystemExit, match="no such recording folder"):
        ts.main(["--recording", f"{good},{tmp_path / 'missing'}", "--json"])
    assert capsys.readouterr().out == ""
    with pytest.raises(SystemExit):
        ts.main(["--sensing", "analytic", "--jobs", "0"])
    assert "--jobs N" in capsys.readouterr().err
