"""The comparison engine: spec parsing, runs with skipped estimators, outputs, the CLI."""
from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from trackroom.estimators.base import REGISTRY, Estimator, register
from trackroom.metrics.aggregate import mean_interval, summarise, summary_markdown
from trackroom.compare import (CompareError, CompareSpec, EstimatorRun, SceneRun, parse_estimator, parse_seeds,
                             run_comparison, spec_from_toml, split_top, write_outputs)


@pytest.fixture
def needs_boxes():
    """A throwaway estimator that needs observations overhead_lab does not have."""

    @register
    class NeedsBoxes(Estimator):
        name = "test_needs_boxes"
        requires = ("boxes",)

        @dataclasses.dataclass
        class Config:
            pass

    yield NeedsBoxes.name
    REGISTRY.pop(NeedsBoxes.name, None)


def test_parse_seeds_and_estimators():
    assert parse_seeds("0-3,7,2") == [0, 1, 2, 3, 7]
    assert parse_seeds([4, 5]) == [4, 5] and parse_seeds(3) == [3]
    for bad in ("3-1", "a-b", "x"):
        with pytest.raises(CompareError):
            parse_seeds(bad)
    assert split_top("ekf,ekf[smooth=true,filter=ukf],x") == ["ekf", "ekf[smooth=true,filter=ukf]", "x"]
    e = parse_estimator("ekf[smooth=true;accel_psd=0.3]")
    assert e.name == "ekf" and dict(e.params) == {"smooth": True, "accel_psd": 0.3}
    assert e.key == "ekf[smooth=true;accel_psd=0.3]"
    assert SceneRun("overhead_lab", ("walkers.count=2",)).key == "overhead_lab[walkers.count=2]"


def test_spec_from_toml(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('duration = 5\nseeds = "1-2"\nset = ["walkers.count=2"]\n'
                 '[[scenes]]\nname = "overhead_lab"\nlabel = "small"\nset = ["sensors.floor_sigma_m=0.1"]\n'
                 '[[estimators]]\nname = "ekf"\nparams = { smooth = true }\n')
    s = spec_from_toml(p).validate()
    assert s.duration == 5.0 and s.seeds == [1, 2]
    assert s.scenes == [SceneRun("overhead_lab", ("walkers.count=2", "sensors.floor_sigma_m=0.1"), "small")]
    assert s.estimators[0].key == "ekf[smooth=true]"
    p.write_text("durations = 5\n")
    with pytest.raises(CompareError, match="unknown key"):
        spec_from_toml(p)
    with pytest.raises(CompareError, match="appear twice"):
        CompareSpec([SceneRun("overhead_lab")] * 2, [0], [EstimatorRun("ekf")]).validate()


def test_comparison_rows_skips_and_outputs(tmp_path, needs_boxes):
    spec = CompareSpec(scenes=[SceneRun("overhead_lab", ("walkers.count=2",), "oh")], seeds=[0, 1],
                       estimators=[EstimatorRun("ekf"), EstimatorRun(needs_boxes)], duration=3.0,
                       recordings=str(tmp_path / "recs"))
    comp = run_comparison(spec, progress=False)
    r = comp.results
    assert len(r) == 4 and r["seed"].tolist() == [0, 0, 1, 1]
    skipped = r[r["estimator"] == needs_boxes]
    assert (skipped["status"] == "skipped").all() and skipped["reason"].str.contains("boxes").all()
    ok = r[r["estimator"] == "ekf"]
    assert (ok["status"] == "ok").all() and (ok["mota"] > 0.5).all()
    paths = write_outputs(comp, tmp_path / "out")
    for name in ("results", "per_frame", "summary", "metric_mota", "metric_rmse", "metric_hota", "error_over_time"):
        assert paths[name].exists() and paths[name].stat().st_size > 0
    md = paths["summary"].read_text()
    assert "| oh | analytic | ekf | 2 |" in md and "needs boxes observations" in md
    # recordings were cached: a second run reads them and gives the same numbers
    again = run_comparison(spec, progress=False).results
    pd.testing.assert_frame_equal(again.drop(columns=["runtime_s", "sim_s"]), r.drop(columns=["runtime_s", "sim_s"]))
    assert (again["sim_s"] == 0).all()


def test_parallel_equals_serial():
    spec = CompareSpec([SceneRun("overhead_lab", ("walkers.count=2",))], [0, 1], [EstimatorRun("ekf")], duration=2.0)
    serial = run_comparison(spec, progress=False).results
    spec.jobs = 2
    par = run_comparison(spec, progress=False).results
    cols = ["scene", "seed", "estimator", "mota", "rmse", "idf1"]
    pd.testing.assert_frame_equal(serial[cols], par[cols])


def test_mean_interval_and_summary():
    m, lo, hi, n = mean_interval([1.0, 2.0, 3.0, float("nan")])
    assert (m, n) == (2.0, 3)
    assert 1.0 <= lo < m < hi <= 3.0  # bootstrap percentiles of the mean lie within the values
    assert mean_interval([]) [3] == 0 and mean_interval([5.0])[1] != mean_interval([5.0])[1]
    res = pd.DataFrame({"scene": "s", "sensing": "analytic", "estimator": ["a", "a", "b"], "status": ["ok", "ok", "skipped"],
                        "reason": ["", "", "needs imu"], "mota": [0.5, 0.7, float("nan")]})
    s = summarise(res, ["mota"])
    assert len(s) == 1 and s["mean"].iloc[0] == pytest.approx(0.6)
    md = summary_markdown(res, ["mota"])
    assert "0.600 [" in md and "needs imu" in md


def test_compare_command(tmp_path, capsys):
    from trackroom.cli import main

    out = tmp_path / "cmp"
    rc = main(["compare", "--scenes", "overhead_lab", "--set", "walkers.count=1", "--seeds", "0",
               "--estimators", "ekf[smooth=true]", "--duration", "2", "--out", str(out), "--quiet"])
    assert rc == 0
    assert "ekf[smooth=true]" in capsys.readouterr().out
    assert (out / "results.csv").exists() and any((out / "recordings").iterdir())
    assert main(["compare", "--out", str(out)]) == 2
    assert main(["compare", "--scenes", "overhead_lab", "--estimators", "nope", "--out", str(out)]) == 2
    assert "unknown estimator" in capsys.readouterr().err


def test_progress_on_a_terminal_only(monkeypatch, capsys, tmp_path):
    """One bar on stderr over the estimator runs with the recordings beside it, rate and ETA;
    nothing where stderr is not a terminal (or with progress=False)."""
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    spec = CompareSpec([SceneRun("overhead_lab", ("walkers.count=1",))], [0, 1], [EstimatorRun("ekf"),
                       EstimatorRun("ekf", (("smooth", True),))], duration=1.0)
    run_comparison(spec, progress=True)
    assert capsys.readouterr().err == ""  # captured: not a terminal
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    run_comparison(spec, progress=True)
    last = term.getvalue().split("\r")[-1]
    assert last.startswith("compare: 100%") and "4/4" in last and "run/s" in last and "recordings 2/2" in last, last
    term.seek(0)
    term.truncate()
    run_comparison(spec, progress=False)
    assert term.getvalue() == ""
