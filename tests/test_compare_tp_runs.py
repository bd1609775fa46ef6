"""scripts/compare_tp_runs: two runs of the same recordings counted target by target."""
from __future__ import annotations

import json
import math

import pytest

from scripts.compare_tp_runs import compare, main, meets, read_runs


def run(seed: int, identity: float, rmse2: float, rmse1: float, mota: float, fp: int = 0, fn: int = 0, draw: int = 0) -> dict:
    return {"sensing": "analytic", "seed": seed, "perception_draw": draw, "identity_held": identity, "rmse_2plus": rmse2,
            "rmse_1": rmse1, "multi_mota": mota, "multi_fp": fp, "multi_fn": fn}


def write(path, runs) -> str:
    # json.dumps writes NaN as the experiment script's --json does
    path.write_text("\n".join(json.dumps(r) for r in runs) + "\n")
    return str(path)


def test_a_figure_without_frames_meets_its_target():
    assert meets(run(1, 1.0, math.nan, 0.2, 0.95), "rmse_2plus", 0.15, False)
    assert meets(run(1, 0.99, 0.15, 0.2, 0.9), "identity_held", 0.99, True)
    assert not meets(run(1, 0.989, 0.15, 0.2, 0.9), "identity_held", 0.99, True)
    assert not meets(run(1, 1.0, 0.151, 0.2, 0.9), "rmse_2plus", 0.15, False)


def test_counts_sums_and_the_recordings_that_changed(tmp_path):
    before = write(tmp_path / "before.jsonl", [run(100, 1.0, 0.10, 0.20, 0.95, 3, 10), run(101, 0.50, 1.2, 1.5, 0.80, 5, 40),
                                               run(102, 1.0, math.nan, 0.30, 0.99, 0, 1)])
    after = write(tmp_path / "trial.jsonl", [run(100, 0.98, 0.10, 0.20, 0.95, 4, 10), run(101, 1.0, 0.10, 0.2, 0.95, 1, 2),
                                             run(102, 1.0, math.nan, 0.30, 0.99, 0, 1)])
    out = compare([(before, after)])
    first = out.splitlines()[0]
    assert first.startswith("trial (3 recordings): identity 2 -> 2  RMSE>=2 2 -> 3  RMSE1 2 -> 3  MOTA 2 -> 3")
    assert first.endswith("FP 8 -> 5  FN 51 -> 13")
    assert "analytic seed 100 draw 0: identity lost (1.000 -> 0.980)" in out
    assert "analytic seed 101 draw 0: identity gained (0.500 -> 1.000)" in out
    assert "analytic seed 101 draw 0: MOTA gained (0.800 -> 0.950)" in out
    assert "seed 102" not in out  # nothing changed there
    assert "all (" not in out  # one set: no total


def test_pairs_are_totalled_and_draws_kept_apart(tmp_path):
    a0 = write(tmp_path / "a0.jsonl", [run(100, 1.0, 0.1, 0.2, 0.95), run(100, 0.5, 0.1, 0.2, 0.95, draw=1)])
    a1 = write(tmp_path / "a1.jsonl", [run(100, 1.0, 0.1, 0.2, 0.85), run(100, 1.0, 0.1, 0.2, 0.95, draw=1)])
    out = compare([(a0, a1), (a0, a0)])
    assert "analytic seed 100 draw 0: MOTA lost" in out and "analytic seed 100 draw 1: identity gained" in out
    assert out.splitlines()[-1].startswith("all (4 recordings): identity 2 -> 3  RMSE>=2 4 -> 4  RMSE1 4 -> 4  MOTA 4 -> 3")


def test_bad_input_names_the_problem(tmp_path):
    good = write(tmp_path / "good.jsonl", [run(100, 1.0, 0.1, 0.2, 0.95)])
    other = write(tmp_path / "other.jsonl", [run(101, 1.0, 0.1, 0.2, 0.95)])
    with pytest.raises(SystemExit, match="hold different recordings"):
        compare([(good, other)])
    with pytest.raises(SystemExit, match="in pairs"):
        main([good])
    with pytest.raises(SystemExit, match="no such file"):
        read_runs(str(tmp_path / "missing.jsonl"))
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"seed": 1}\n')
    with pytest.raises(SystemExit, match=r"line 1: not an experiment_tsutsui --json run \(missing identity_held"):
        read_runs(str(bad))
    bad.write_text("not json\n")
    with pytest.raises(SystemExit, match="line 1: not JSON"):
        read_runs(str(bad))
    twice = write(tmp_path / "twice.jsonl", [run(100, 1.0, 0.1, 0.2, 0.95), run(100, 1.0, 0.1, 0.2, 0.95)])
    with pytest.raises(SystemExit, match="appears twice"):
        read_runs(twice)
    empty = tmp_path / "empty.jsonl"
    empty.write_text("\n")
    with pytest.raises(SystemExit, match="no runs"):
        read_runs(str(empty))
