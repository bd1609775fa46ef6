"""Scores people can read (issue 16): one person's score, intervals inside each metric's range,
and tracks CSVs that end in one clear line (regressions for the cases the issue lists)."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from tests.test_metrics_score import tiny_recording
from trackroom.estimators.base import EstimatorError
from trackroom.metrics.aggregate import INTERVAL_NOTE, mean_interval, summary_markdown
from trackroom.metrics.score import evaluate, evaluation_frames, score
from trackroom.recording import RecordingError


def two_people():
    """tiny_recording's p0 (walking along x from (2, 5) at 1 m/s) and p1 standing at (8, 3)."""
    rec = tiny_recording()
    p0 = rec.truth.people
    p1 = p0.assign(person_id="p1", x=8.0, y=3.0, vx=0.0, walking=False, phone_id="")
    rec.truth.tables["people"] = pd.concat([p0, p1]).sort_values("t", kind="stable").reset_index(drop=True)
    return rec


def follow_p0(rec):
    times = evaluation_frames(rec)
    return pd.DataFrame({"t": times, "track_id": 7, "x": 2.0 + times, "y": 5.0})


def test_one_person_scores_a_single_target_tracker_against_that_person():
    rec = two_people()
    tracks = follow_p0(rec)
    n = len(evaluation_frames(rec))
    everyone = evaluate(rec, tracks).metrics()
    assert (everyone["people"], everyone["fn"], everyone["fp"]) == (2, n, 0)  # p1 is never tracked
    p0 = evaluate(rec, tracks, person="p0").metrics()
    assert (p0["people"], p0["fn"], p0["fp"], p0["mota"], p0["idf1"]) == (1, 0, 0, 1.0, 1.0)
    # against the other person every row is a false positive and every frame a miss
    p1 = evaluate(rec, tracks, person="p1").metrics()
    assert (p1["fn"], p1["fp"], p1["mota"], p1["idf1"]) == (n, n, -1.0, 0.0)
    row = score(rec, tracks, "mine", person="p0").iloc[0]
    assert row["person"] == "p0" and row["mota"] == 1.0


def test_unknown_person_is_one_clear_error_listing_the_ids():
    with pytest.raises(RecordingError, match=r"no person 'p9' in the recording's truth; person ids: p0, p1$"):
        evaluate(two_people(), follow_p0(two_people()), person="p9")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    from trackroom.dataset import write_recording
    from trackroom.scenes import load_scene
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("overhead_lab", ["walkers.count=2"]), 1, 2.0)
    return write_recording(rec, tmp_path_factory.mktemp("score") / "rec")


def write_csv(tmp_path, text):
    p = tmp_path / "tracks.csv"
    p.write_text(text)
    return p


GOOD = "t,track_id,x,y\n0.0,1,2.0,3.0\n0.05,1,2.1,3.0\n0.1,1,2.2,3.0\n"


def test_score_person_command(folder, tmp_path, capsys):
    from trackroom.cli import main

    tracks = write_csv(tmp_path, GOOD)
    assert main(["score", str(folder), str(tracks), "--person", "p1", "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["person"] == "p1" and js["people"] == 1
    assert main(["score", str(folder), str(tracks), "--person", "p1"]) == 0
    assert "person p1" in capsys.readouterr().out.splitlines()[0]
    assert main(["score", str(folder), str(tracks), "--person", "nobody"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "trackroom score: error: --person: no person 'nobody' in the recording's truth; person ids: p0, p1"


@pytest.mark.parametrize("text,needle", [
    # the issue: "a tracks CSV with a non-numeric x (traceback)"
    ("t,track_id,x,y\n0.0,1,2.0,3.0\n0.05,1,abc,3.0\n", "column 'x' must hold finite numbers; line 3 has 'abc'"),
    # the issue: "NaN in track_id (scored silently, exit 0)"
    ("t,track_id,x,y\n0.0,1,2.0,3.0\n0.05,nan,2.1,3.0\n", "column 'track_id' is empty at line 3"),
    ("t,track_id,x,y\n0.0,1,2.0,3.0\n0.05,,2.1,3.0\n", "column 'track_id' is empty at line 3"),
    ("t,track_id,x,y\n0.0,1,2.0,3.0\n0.0,1,2.1,3.0\n", "track 1 has two rows at t = 0 s (line 3)"),
    ("t,track_id,x,y\n0.0,1,2.0,inf\n", "column 'y' must hold finite numbers; line 2 has"),
    ("t,track_id,x\n0.0,1,2.0\n", "missing columns ['y']"),
    ("", "not a readable CSV"),
])
def test_bad_tracks_csv_is_one_line_and_exit_2(folder, tmp_path, capsys, text, needle):
    from trackroom.cli import main

    assert main(["score", str(folder), str(write_csv(tmp_path, text))]) == 2
    out = capsys.readouterr()
    assert out.out == "" and needle in out.err and len(out.err.strip().splitlines()) == 1


def test_text_track_ids_and_blank_phone_ids_are_scored(folder, tmp_path, capsys):
    from trackroom.cli import main

    tracks = write_csv(tmp_path, "t,track_id,x,y,phone_id\n0.0,a,2.0,3.0,\n0.05,a,2.1,3.0,phone0\n0.05,b,5,5,\n")
    assert main(["score", str(folder), str(tracks), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tracks"] == 2


def test_intervals_are_bootstrap_percentiles_inside_the_valid_range():
    # the cases: Student-t gave MOTA [0.998, 1.001] and IDF1 [-1.14, 2.35] from two seeds
    m, lo, hi, n = mean_interval([0.9990, 1.0], "mota")
    assert (n, lo, hi) == (2, 0.999, 1.0) and m == pytest.approx(0.9995)
    m, lo, hi, n = mean_interval([0.0, 1.0], "idf1")
    assert (lo, hi) == (0.0, 1.0)
    # deterministic, and narrower than the values' span with enough seeds
    v = np.linspace(0.2, 0.8, 10)
    assert mean_interval(v, "idf1") == mean_interval(v, "idf1")
    m, lo, hi, n = mean_interval(v, "idf1")
    assert 0.2 < lo < m < hi < 0.8 and hi - lo == pytest.approx(0.2, abs=0.05)  # ~ 2 x 1.96 s / sqrt(n)
    # one seed: a mean, no interval; values out of range do not widen it past the range
    assert np.isnan(mean_interval([0.5], "mota")[1])
    assert mean_interval([1.5, 2.5], "idf1")[1:3] == (1.0, 1.0)
    assert mean_interval([-3.0, -1.0], "rmse")[1:3] == (0.0, 0.0)


def test_summary_header_says_which_interval(tmp_path):
    from trackroom.compare import Comparison, CompareSpec, EstimatorRun, SceneRun, write_outputs

    res = pd.DataFrame({"scene": "overhead_lab", "sensing": "analytic", "estimator": "a", "status": "ok", "reason": "",
                        "seed": [0, 1], "mota": [0.999, 1.0], "idf1": [0.2, 0.9]})
    spec = CompareSpec(scenes=[SceneRun("overhead_lab")], seeds=[0, 1], estimators=[EstimatorRun("a")], duration=1.0)
    paths = write_outputs(Comparison(spec, res, pd.DataFrame(), 0.0), tmp_path / "out", plots=False)
    text = paths["summary"].read_text()
    assert INTERVAL_NOTE in text and "bootstrap percentile" in text
    assert "1.000 [0.999, 1.000]" in text and "0.550 [0.200, 0.900]" in text
    assert summary_markdown(res) in text
