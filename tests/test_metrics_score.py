"""Scoring a tracks table against a recording: evaluation frames, resampling, the tidy row, the CLI."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from trackroom.metrics.score import build_frames, evaluate, evaluation_frames, score, tracks_at
from trackroom.scenes import load_scene
from trackroom.recording import Calibration, Observations, Recording, Truth


def tiny_recording(duration=1.0) -> Recording:
    """bearing_hall's four 4 fps cameras; one person walking along x at 1 m/s from (2, 5), 100 Hz truth.

    Visibility: cam_south sees the person in the first half second, nobody afterwards.
    """
    sc = load_scene("bearing_hall")
    t = np.round(np.arange(0, duration, 0.01), 6)
    people = pd.DataFrame({"t": t, "person_id": "p0", "x": 2.0 + t, "y": 5.0, "z": 0.9, "yaw": 0.0,
                           "vx": 1.0, "vy": 0.0, "walking": True, "phone_id": "phone0"})
    vis = []
    for c in sc.cameras:
        ft = c.frame_times(duration)
        vis.append(pd.DataFrame({"t": ft, "camera": c.name, "person_id": "p0", "in_fov": True,
                                 "visible": (c.name == "cam_south") & (ft < 0.5)}))
    vis = pd.concat(vis).sort_values("t", kind="stable").reset_index(drop=True)
    cal = Calibration({c.name: c for c in sc.cameras}, sc.floorplan, {})
    return Recording(cal, Observations({}, duration), Truth({"people": people, "visibility": vis}),
                     {"scene": "bearing_hall", "seed": 7, "sensing": "analytic"})


def test_frames_are_the_union_of_camera_frames():
    rec = tiny_recording()
    np.testing.assert_allclose(evaluation_frames(rec), [0.0, 0.25, 0.5, 0.75])


def test_tracks_on_the_grid_with_offset_score_exactly():
    rec = tiny_recording()
    tf = evaluation_frames(rec)
    tracks = pd.DataFrame({"t": tf, "track_id": 1, "x": 2.0 + tf, "y": 5.1})
    m = evaluate(rec, tracks).metrics()
    assert m["mota"] == 1.0 and m["fp"] == 0 and m["fn"] == 0
    assert m["rmse"] == pytest.approx(0.1) and m["motp"] == pytest.approx(0.1)
    assert m["idf1"] == 1.0
    # HOTA: similarity 1 - 0.1 / gate in every frame, a true positive for the alphas up to it
    assert m["hota"] == m["deta"] == m["assa"] == pytest.approx(18 / 19)  # 0.9: alphas 0.05-0.90
    assert m["loca"] == pytest.approx((18 * 0.9 + 1) / 19)  # LocA is 1 where nothing is matched
    assert evaluate(rec, tracks, gate=0.5).metrics()["hota"] == pytest.approx(16 / 19)  # 0.8: 0.05-0.80
    # visible to one camera in the frames at 0 and 0.25 s, to none at 0.5 and 0.75 s
    assert (m["n_cam1"], m["n_cam0"], m["n_cam2plus"]) == (2, 2, 0)


def test_resampling_snaps_interpolates_and_keeps_gaps():
    times = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 1.25])
    tracks = pd.DataFrame({
        "t": [0.0004, 0.1, 0.35, 0.75, 1.25],  # snap at 0; bridge 0.25 (0.1-0.35); gap 0.35-0.75 too long
        "track_id": 3, "x": [0.0, 1.0, 2.0, 3.0, 4.0], "y": 0.0,
    })
    got = tracks_at(tracks, times, max_gap=0.3)
    assert got["frame"].tolist() == [0, 1, 3, 5]  # 0.5 and 1.0 fall in gaps longer than max_gap
    np.testing.assert_allclose(got["x"], [0.0, 1.0 + 0.15 / 0.25, 3.0, 4.0])
    with pytest.raises(ValueError, match="same time"):
        tracks_at(pd.DataFrame({"t": [0.0, 0.0], "track_id": 1, "x": 0.0, "y": 0.0}), times, 0.3)


def test_missing_frames_are_misses_and_extra_tracks_false_positives():
    rec = tiny_recording()
    tracks = pd.DataFrame({"t": [0.0, 0.25, 0.25], "track_id": [1, 1, 2], "x": [2.0, 2.25, 8.0], "y": 5.0})
    m = evaluate(rec, tracks).metrics()
    assert (m["fn"], m["fp"], m["objects"]) == (2, 1, 4)
    assert m["mota"] == pytest.approx(1 - 3 / 4)


def test_score_row_and_phone_claims():
    rec = tiny_recording()
    tf = evaluation_frames(rec)
    tracks = pd.DataFrame({"t": tf, "track_id": 1, "x": 2.0 + tf, "y": 5.0,
                           "phone_id": ["phone0", "phone0", "phone9", ""]})
    row = score(rec, tracks, "mine", runtime_s=1.5)
    assert len(row) == 1
    r = row.iloc[0]
    assert (r["scene"], r["seed"], r["sensing"], r["estimator"], r["runtime_s"]) == ("bearing_hall", 7, "analytic", "mine", 1.5)
    assert r["id_accuracy"] == pytest.approx(2 / 3)  # three claims, two right
    assert r["id_accuracy_all"] == pytest.approx(2 / 4)  # four appearances of a phone carrier
    no_claims = score(rec, tracks.drop(columns="phone_id")).iloc[0]
    assert np.isnan(no_claims["id_accuracy"])


def test_build_frames_needs_cameras():
    rec = tiny_recording()
    rec.calibration.cameras = {}
    with pytest.raises(ValueError, match="no cameras"):
        build_frames(rec, pd.DataFrame(columns=["t", "track_id", "x", "y"]))


def test_estimate_and_score_commands(tmp_path, capsys):
    from trackroom.cli import main
    from trackroom.dataset import write_recording
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("overhead_lab", ["walkers.count=2"]), 3, 4.0)
    folder = write_recording(rec, tmp_path / "rec")
    out = tmp_path / "tracks.csv"
    assert main(["estimate", str(folder), "--estimator", "ekf", "--param", "smooth=true", "--out", str(out)]) == 0
    tracks = pd.read_csv(out)
    assert list(tracks.columns[:6]) == ["t", "track_id", "x", "y", "vx", "vy"]
    capsys.readouterr()
    assert main(["score", str(folder), str(out), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    for k in ("mota", "motp", "id_switches", "idf1", "fp", "fn", "rmse", "hota", "deta", "assa", "loca"):
        assert k in js
    assert "id_accuracy" not in js and js["mota"] > 0.8
    assert main(["score", str(folder), str(out), "--gate", "0.5"]) == 0
    text = capsys.readouterr().out
    assert "MOTA" in text and "HOTA" in text and "DetA / AssA" in text
    assert main(["score", str(folder), str(out), "--gate", "-1"]) == 2
    assert main(["estimate", str(folder), "--estimator", "ekf", "--param", "nonsense=1", "--out", str(out)]) == 2
    assert "unknown parameter" in capsys.readouterr().err
