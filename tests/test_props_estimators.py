"""Property-based tests: every registered estimator, fed mutated observation tables.

One tiny analytic recording per scene an estimator needs is simulated once per module (5 s).
Hypothesis then mutates its observation tables (emptied, one row kept, NaN or inf injected, rows
duplicated, out of time order, a camera the calibration lacks, a camera that sees nothing, huge
values, times outside the recording or off the frame grid, numbers as text) and feeds the result
through the runner, the boundary every command goes through. Each case must end in a valid
tracks table, a "skipped" result with its reason, or one ``EstimatorError``/``RecordingError``
whose message is one line; any other exception is a defect.

Case counts: ``examples(n)`` (tests/conftest.py), n in CI, >= 1000 with TRACKROOM_HYPOTHESIS=slow.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tests.props import examples
from trackroom.estimators import available
from trackroom.estimators.base import EstimatorError, check_tracks
from trackroom.estimators.runner import run_estimator
from trackroom.recording import Calibration, Observations, Recording, RecordingError

DURATION = 5.0  # s: long enough for every estimator to confirm a track, short enough to run fast

# The scene each estimator is fed, with the parameters it needs to run unattended.
CASES = {
    "ekf": ("overhead_lab", ["walkers.count=2"], {}),
    "ekf_bearings": ("bearing_hall", ["walkers.count=2"], {}),
    "qp_smoother": ("bearing_hall", ["walkers.count=2"], {}),
    "fusion_smoother": ("bearing_hall", ["walkers.count=2"], {}),
    "hmm_matcher": ("overhead_lab", ["walkers.count=2"], {}),
    "target_planes": ("occlusion_lab", [], {"multi_person": True}),
}
ESTIMATOR_OF = {"ekf_bearings": "ekf"}
# Cases per estimator in CI (each run takes 10-100 ms on the 5 s recordings).
N_CI = 60

OPS = ("empty", "single", "nan", "inf", "duplicate", "shuffle", "unknown_camera", "silent_camera",
       "uncalibrated_camera", "huge", "time_shift", "null_text", "all_empty", "scale", "jitter_t", "double", "as_text")


@lru_cache(maxsize=None)
def recording(scene: str, overrides: tuple[str, ...]) -> Recording:
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    return simulate(load_scene(scene, list(overrides)), seed=0, duration=DURATION)


def test_every_registered_estimator_is_covered():
    assert set(available()) <= {ESTIMATOR_OF.get(c, c) for c in CASES}


def mutate(rec: Recording, op: str, data) -> Recording:
    """A copy of ``rec`` whose observations (or calibration) are mutated by ``op``."""
    tables = {k: v.copy() for k, v in rec.observations.tables.items()}
    cameras = dict(rec.calibration.cameras)
    kinds = sorted(k for k, v in tables.items() if len(v))
    kind = data.draw(st.sampled_from(kinds), label="table")
    df = tables[kind]
    row = lambda: data.draw(st.integers(0, max(len(df) - 1, 0)), label="row")  # noqa: E731
    numeric = [c for c in df.columns if pd.api.types.is_numeric_dtype(df[c]) and c != "t"]
    text = [c for c in df.columns if not pd.api.types.is_numeric_dtype(df[c])]
    if op == "empty":
        df = df.iloc[:0]
    elif op == "all_empty":
        tables = {k: v.iloc[:0] for k, v in tables.items()}
        df = tables[kind]
    elif op == "single":
        i = row()
        df = df.iloc[i:i + 1]
    elif op in ("nan", "inf", "huge"):
        col = data.draw(st.sampled_from(numeric + ["t"]), label="column")
        choices = {"nan": [np.nan], "inf": [np.inf, -np.inf], "huge": [1e12, -1e12, 1e-300, 0.0, -5.0]}[op]
        value = data.draw(st.sampled_from(choices), label="value")
        df = df.copy()
        df[col] = df[col].astype(float)
        df.iloc[row(), df.columns.get_loc(col)] = value
    elif op == "duplicate":
        idx = data.draw(st.lists(st.integers(0, len(df) - 1), min_size=1, max_size=5), label="rows")
        df = pd.concat([df, df.iloc[idx]]).sort_values("t", kind="stable")
    elif op == "as_text":  # a numeric column read as text, perhaps with a word in it
        col = data.draw(st.sampled_from(numeric + ["t"]), label="column")
        df = df.copy()
        df[col] = df[col].astype(str).astype(object)
        if data.draw(st.booleans(), label="word"):
            df.iloc[row(), df.columns.get_loc(col)] = "abc"
    elif op == "double":  # every row twice
        df = pd.concat([df, df]).sort_values("t", kind="stable")
    elif op == "scale":  # every value of one column scaled: far away, or all in one point
        col = data.draw(st.sampled_from(numeric), label="column")
        df = df.copy()
        df[col] = df[col].astype(float) * data.draw(st.sampled_from([1e6, -1.0, 1e-9, 0.0]), label="factor")
    elif op == "jitter_t":  # times off the camera frame grid, kept inside the recording
        seed = data.draw(st.integers(0, 2**32 - 1), label="seed")
        df = df.copy()
        df["t"] = np.clip(df["t"] + np.random.default_rng(seed).uniform(-0.02, 0.02, len(df)), 0.0, DURATION)
        df = df.sort_values("t", kind="stable")
    elif op == "shuffle":
        seed = data.draw(st.integers(0, 2**32 - 1), label="seed")
        df = df.sample(frac=1.0, random_state=seed)
    elif op in ("unknown_camera", "silent_camera", "uncalibrated_camera"):
        if "camera" not in df.columns:
            return mutate(rec, "single", data)
        cam = data.draw(st.sampled_from(list(pd.unique(df["camera"]))), label="camera")
        if op == "unknown_camera":
            df = df.copy()
            df.loc[df.index[row()], "camera"] = "cam_nowhere"
        elif op == "silent_camera":
            df = df[df["camera"] != cam]
        else:
            cameras.pop(cam, None)
    elif op == "time_shift":
        shift = data.draw(st.sampled_from([-1.0, -1e-3, DURATION, 1e6]), label="shift")
        df = df.copy()
        df["t"] = df["t"] + shift
    elif op == "null_text":
        if not text:
            return mutate(rec, "nan", data)
        col = data.draw(st.sampled_from(text), label="column")
        df = df.copy()
        df[col] = df[col].astype(object)
        df.iloc[row(), df.columns.get_loc(col)] = data.draw(st.sampled_from([None, np.nan, 7]))
    tables[kind] = df.reset_index(drop=True)
    cal = Calibration(cameras, rec.calibration.floorplan, dict(rec.calibration.noise))
    return Recording(cal, Observations(tables, rec.observations.duration), rec.truth, dict(rec.meta))


def check_outcome(name: str, params: dict, rec: Recording) -> None:
    try:
        result = run_estimator(rec, ESTIMATOR_OF.get(name, name), params)
    except (EstimatorError, RecordingError) as e:
        msg = str(e)
        assert msg and "\n" not in msg, f"error message is not one line: {msg!r}"
        event(f"{type(e).__name__}")  # outcome counts: --hypothesis-show-statistics
        return
    event(result.status)
    if result.status == "skipped":
        assert result.reason
        return
    assert result.status == "ok"
    tracks = result.tracks
    check_tracks(tracks)  # columns and finite t, x, y
    assert tracks["track_id"].notna().all()
    assert not tracks.duplicated(["t", "track_id"]).any(), "a track reports twice at one time"


@pytest.mark.parametrize("name", sorted(CASES))
@settings(max_examples=examples(N_CI), deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(ops=st.lists(st.sampled_from(OPS), min_size=1, max_size=3), data=st.data())
def test_estimator_survives_mutated_observations(name, ops, data):
    scene, overrides, params = CASES[name]
    rec = recording(scene, tuple(overrides))
    for op in sorted(ops, key=lambda o: o == "as_text"):  # the others do arithmetic on numbers
        if not any(len(v) for v in rec.observations.tables.values()):
            break
        rec = mutate(rec, op, data)
    check_outcome(name, params, rec)


@pytest.mark.parametrize("name", sorted(CASES))
def test_estimator_runs_on_the_unmutated_recording(name):
    scene, overrides, params = CASES[name]
    result = run_estimator(recording(scene, tuple(overrides)), ESTIMATOR_OF.get(name, name), params)
    assert result.status == "ok" and len(result.tracks)


# --------------------------------------------------------------------- the boundary, case by case
def with_tables(rec: Recording, **tables) -> Recording:
    obs = Observations({**rec.observations.tables, **tables}, rec.observations.duration)
    return Recording(rec.calibration, obs, rec.truth, dict(rec.meta))


def overhead() -> Recording:
    return recording("overhead_lab", ("walkers.count=2",))


def test_an_empty_stream_is_skipped_with_its_reason():
    rec = with_tables(overhead(), floor_detections=overhead().observations["floor_detections"].iloc[:0])
    result = run_estimator(rec, "hmm_matcher")
    assert result.status == "skipped"
    assert result.reason == "needs floor_detections observations; the recording has none"


def test_a_nan_in_the_stream_names_table_column_and_row():
    det = overhead().observations["floor_detections"].copy()
    det.loc[3, "x"] = np.nan
    with pytest.raises(RecordingError, match=r"^floor_detections: column 'x' must hold finite numbers; row 3 has nan$"):
        run_estimator(with_tables(overhead(), floor_detections=det), "ekf")


def test_a_missing_camera_name_and_an_uncalibrated_camera_are_refused():
    det = overhead().observations["floor_detections"].copy()
    det["camera"] = det["camera"].astype(object)
    det.loc[0, "camera"] = None
    with pytest.raises(RecordingError, match=r"missing value in column 'camera' \(first at row 0\)"):
        run_estimator(with_tables(overhead(), floor_detections=det), "ekf")
    det.loc[0, "camera"] = "ceil_x"
    with pytest.raises(RecordingError, match=r"cameras not in the calibration: \['ceil_x'\]; calibrated: \['ceil_ne'"):
        run_estimator(with_tables(overhead(), floor_detections=det), "ekf")


def test_times_outside_the_recording_are_refused():
    # found by the property test: qp_smoother indexed a negative frame, the lazy tracker of
    # hmm_matcher tried to allocate 146 TiB for a time of 1e12 s
    det = overhead().observations["floor_detections"].copy()
    det.loc[5, "t"] = 1e12
    with pytest.raises(RecordingError, match=r"times must lie within the recording \[0, 5\] s; row 5 has t = 1e\+12"):
        run_estimator(with_tables(overhead(), floor_detections=det), "hmm_matcher")


def test_out_of_order_rows_are_sorted_and_give_the_same_tracks():
    det = overhead().observations["floor_detections"]
    shuffled = det.sample(frac=1.0, random_state=1).reset_index(drop=True)
    a = run_estimator(overhead(), "ekf").tracks
    b = run_estimator(with_tables(overhead(), floor_detections=shuffled), "ekf").tracks
    # rows of one time may come in another order, so compare positions per time, not track ids
    key = ["t", "x", "y"]
    pd.testing.assert_frame_equal(a[key].sort_values(key).reset_index(drop=True),
                                  b[key].sort_values(key).reset_index(drop=True), atol=1e-6)


def test_a_camera_that_sees_nothing_is_no_error():
    det = overhead().observations["floor_detections"]
    quiet = det[det["camera"] != det["camera"].iloc[0]]
    result = run_estimator(with_tables(overhead(), floor_detections=quiet), "ekf")
    assert result.status == "ok"


def test_estimate_command_on_an_empty_stream_is_one_line(tmp_path, capsys):
    from trackroom.cli import main
    from trackroom.dataset import write_recording

    rec = with_tables(overhead(), floor_detections=overhead().observations["floor_detections"].iloc[:0])
    folder = write_recording(rec, tmp_path / "rec")
    assert main(["estimate", str(folder), "--estimator", "ekf", "--out", str(tmp_path / "t.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("trackroom estimate: error: ekf does not apply to") and err.endswith(
        "needs floor_detections or bearings observations; the recording has none")


def test_image_coordinates_an_image_away_are_refused():
    # found by the property test: u = 1e12 px made qp_smoother's QP non-convex (a warning, and
    # tracks from an unconverged solve)
    rec = recording("bearing_hall", ("walkers.count=2",))
    b = rec.observations["bearings"].copy()
    b.loc[2, "u"] = 1e12
    with pytest.raises(RecordingError, match=r"^bearings: column 'u' lies more than an image width outside camera "):
        run_estimator(with_tables(rec, bearings=b), "qp_smoother")


def test_numbers_written_as_text_are_read_as_numbers_or_named():
    det = overhead().observations["floor_detections"].copy()
    det["x"] = det["x"].astype(str).astype(object)
    assert run_estimator(with_tables(overhead(), floor_detections=det), "ekf").status == "ok"
    det.loc[4, "x"] = "abc"
    with pytest.raises(RecordingError, match=r"^floor_detections: column 'x' must hold finite numbers; row 4 has 'abc'$"):
        run_estimator(with_tables(overhead(), floor_detections=det), "ekf")
