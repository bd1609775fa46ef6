"""Accuracy thresholds: every bound in metrics/thresholds.csv holds on the small CI versions of the
bundled scenes; an impossible bound makes the check fail; the file format is validated."""
from __future__ import annotations

import pandas as pd
import pytest

from trackroom.metrics.thresholds import ThresholdError, check_thresholds, failure_table, load_thresholds
from trackroom.compare import ci_spec, run_comparison

THRESHOLDS = load_thresholds()
GROUPS = sorted(set(zip(THRESHOLDS["scene"], THRESHOLDS["sensing"])))
_results: dict = {}


def ci_results(scene: str, sensing: str) -> pd.DataFrame:
    """The CI comparison for one scene, run once per test session."""
    if (scene, sensing) not in _results:
        _results[scene, sensing] = run_comparison(ci_spec(THRESHOLDS, scene, sensing), progress=False).results
    return _results[scene, sensing]


@pytest.mark.parametrize("scene,sensing", GROUPS)
def test_thresholds_hold(scene, sensing):
    rows = THRESHOLDS[(THRESHOLDS["scene"] == scene) & (THRESHOLDS["sensing"] == sensing)]
    checked = check_thresholds(ci_results(scene, sensing), rows)
    assert checked["passed"].all(), "\n" + failure_table(checked)


def test_an_impossible_bound_fails_with_a_table():
    scene, sensing = "overhead_lab", "analytic"
    impossible = pd.DataFrame([
        {"scene": scene, "sensing": sensing, "estimator": "ekf", "metric": "rmse", "op": "<=", "bound": 1e-4},
        {"scene": scene, "sensing": sensing, "estimator": "ekf", "metric": "mota", "op": ">=", "bound": 0.5},
        {"scene": scene, "sensing": sensing, "estimator": "nobody", "metric": "mota", "op": ">=", "bound": 0.5},
        {"scene": scene, "sensing": sensing, "estimator": "ekf", "metric": "hota", "op": ">=", "bound": 1.001},
    ])
    checked = check_thresholds(ci_results(scene, sensing), impossible)
    assert checked["passed"].tolist() == [False, True, False, False]
    table = failure_table(checked)
    assert "3 accuracy threshold(s) not met" in table and "rmse" in table and "not run" in table and "hota" in table


def test_skipped_estimator_fails_its_bound():
    results = pd.DataFrame([{"scene": "s", "sensing": "analytic", "estimator": "e", "status": "skipped",
                             "reason": "needs imu observations", "mota": float("nan")}])
    th = pd.DataFrame([{"scene": "s", "sensing": "analytic", "estimator": "e", "metric": "mota", "op": ">=", "bound": 0.1}])
    checked = check_thresholds(results, th)
    assert not checked["passed"].any() and "needs imu" in checked["note"].iloc[0]


@pytest.mark.parametrize("text,problem", [
    ("scene,sensing,estimator,metric,op\n", "missing columns"),
    ("scene,sensing,estimator,metric,op,bound\na,analytic,e,mota,>,0.5\n", "op must be"),
    ("scene,sensing,estimator,metric,op,bound\na,analytic,e,mota,>=,high\n", "not a number"),
    ("scene,sensing,estimator,metric,op,bound\na,painted,e,mota,>=,0.5\n", "sensing"),
    ("scene,sensing,estimator,metric,op,bound\na,analytic,e,mota,>=,0.5\na,analytic,e,mota,>=,0.6\n", "twice"),
])
def test_bad_threshold_files(tmp_path, text, problem):
    p = tmp_path / "t.csv"
    p.write_text("# a comment line\n" + text)
    with pytest.raises(ThresholdError, match=problem):
        load_thresholds(p)


def test_user_thresholds_replace_bundled_rows_and_add_their_own(tmp_path):
    from trackroom.metrics.thresholds import load_merged

    user = tmp_path / "mine.csv"
    user.write_text("scene,sensing,estimator,metric,op,bound\n"
                    "overhead_lab,analytic,ekf,rmse,<=,0.5\n"          # replaces the bundled bound
                    "overhead_lab,analytic,my_tracker,mota,>=,0.8\n")  # a bound of one's own
    bundled = load_thresholds()
    merged = load_merged([user])
    key = ["scene", "sensing", "estimator", "metric", "op"]
    assert len(merged) == len(bundled) + 1
    assert not merged.duplicated(key).any()
    ekf_rmse = merged[(merged["scene"] == "overhead_lab") & (merged["estimator"] == "ekf") & (merged["metric"] == "rmse")]
    assert ekf_rmse["bound"].tolist() == [0.5]
    assert merged.iloc[-1].to_dict() == {"scene": "overhead_lab", "sensing": "analytic", "estimator": "my_tracker",
                                         "metric": "mota", "op": ">=", "bound": 0.8}
    assert load_merged([user], bundled=False)["estimator"].tolist() == ["ekf", "my_tracker"]


def test_check_thresholds_command_with_a_plugin(tmp_path):
    """trackroom check-thresholds: a user's bounds on a plug-in estimator; exit 1 with the failure table."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    plugin = root / "docs" / "example_plugin" / "floor_nearest.py"
    user = tmp_path / "mine.csv"
    user.write_text("scene,sensing,estimator,metric,op,bound\n"
                    "overhead_lab,analytic,floor_nearest,mota,>=,0.5\n"
                    "overhead_lab,analytic,floor_nearest[gate_m=0.5],rmse,<=,0.0001\n")
    r = subprocess.run([sys.executable, "-m", "trackroom", "check-thresholds", "--thresholds", str(user), "--no-bundled",
                        "--plugin", str(plugin), "--quiet"], capture_output=True, text=True, cwd=root, timeout=300)
    assert r.returncode == 1, r.stderr
    assert "overhead_lab (analytic, 3 seeds, 20 s): 1 of 2 bounds met" in r.stdout
    assert "1 accuracy threshold(s) not met" in r.stdout and "floor_nearest[gate_m=0.5]" in r.stdout
