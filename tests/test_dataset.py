"""Dataset folders: round trip, byte-identical files, atomic writes, clear errors on bad folders."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from trackroom.scenes import load_scene
from trackroom.dataset import read_recording, write_recording
from trackroom.recording import Calibration, Observations, Recording, RecordingError, Truth


def small_recording(seed=0) -> Recording:
    scene = load_scene("bearing_hall")
    rng = np.random.default_rng(seed)
    t = np.arange(0, 5, 0.01)
    people = pd.DataFrame({
        "t": t, "person_id": "p0", "x": 5 + np.cos(t), "y": 5 + np.sin(t), "z": 0.9 + 0.0 * t, "yaw": t + np.pi / 2,
        "vx": -np.sin(t), "vy": np.cos(t), "walking": True, "phone_id": "phone0",
    })
    bearings = pd.DataFrame({"t": t[::25], "camera": "cam_south", "u": rng.uniform(0, 320, len(t[::25])), "label": "red"})
    imu = pd.DataFrame({"t": t, "phone_id": "phone0", **{c: rng.normal(size=len(t)) for c in ["ax", "ay", "az", "gx", "gy", "gz", "mx", "my", "mz"]}})
    return Recording(
        calibration=Calibration({c.name: c for c in scene.cameras}, scene.floorplan, {"bearing_sigma_px": 1.0}),
        observations=Observations({"bearings": bearings, "imu": imu}, duration=5.0),
        truth=Truth({"people": people}),
        meta={"scene": "bearing_hall", "seed": seed, "sensing": "analytic", "walkers": [{"name": "p0", "color": [0.85, 0.1, 0.1]}]},
    )


def test_round_trip(tmp_path):
    rec = small_recording()
    out = write_recording(rec, tmp_path / "rec")
    back = read_recording(out)
    for k, df in rec.observations.tables.items():
        pd.testing.assert_frame_equal(back.observations[k], df.reset_index(drop=True))
    pd.testing.assert_frame_equal(back.truth.people, rec.truth.people)
    for name, cam in rec.calibration.cameras.items():
        np.testing.assert_allclose(back.calibration.cameras[name].P, cam.P, rtol=1e-12)
        assert back.calibration.cameras[name].kind == cam.kind
    np.testing.assert_array_equal(back.calibration.floorplan.outline, rec.calibration.floorplan.outline)
    assert back.meta["seed"] == 0 and back.duration == 5.0
    gt = pd.read_csv(out / "gt_world.csv")
    assert list(gt.columns) == ["frame", "id", "x", "y"] and gt["frame"].min() == 1


def test_gt_world_is_truth_at_the_camera_frames(tmp_path):
    """gt_world.csv holds the truth rows on the cameras' frames (bearing_hall: 4 Hz; truth at
    100 Hz): frame = t * fps + 1, ids 1-based in first-appearance order, x, y to 6 decimals."""
    from trackroom.dataset import gt_world_rate

    rec = small_recording()
    fps = gt_world_rate(rec)
    assert fps == max(c.fps for c in rec.calibration.cameras.values()) and fps < 100
    out = write_recording(rec, tmp_path / "rec")
    text = (out / "gt_world.csv").read_text()
    assert text.startswith("frame,id,x,y\n1,1,")
    gt = pd.read_csv(out / "gt_world.csv")
    people = rec.truth.people
    on_frame = people[np.isclose(people["t"] * fps, np.round(people["t"] * fps))]
    assert len(gt) == len(on_frame) == int(5.0 * fps)
    np.testing.assert_array_equal(gt["frame"], np.round(on_frame["t"] * fps).astype(int) + 1)
    assert (gt["id"] == 1).all()
    np.testing.assert_allclose(gt["x"], on_frame["x"], atol=5e-7)
    np.testing.assert_allclose(gt["y"], on_frame["y"], atol=5e-7)
    # no cameras: the truth rate
    bare = small_recording()
    bare.calibration.cameras.clear()
    bare.meta["sim_rate"] = 100.0
    assert gt_world_rate(bare) == 100.0


def test_same_recording_gives_byte_identical_files(tmp_path):
    a = write_recording(small_recording(), tmp_path / "a")
    b = write_recording(small_recording(), tmp_path / "b")
    ma, mb = json.loads((a / "manifest.json").read_text()), json.loads((b / "manifest.json").read_text())
    assert ma["files"] == mb["files"]
    assert any(k.endswith(".parquet") for k in ma["files"])


def test_existing_folder_is_not_overwritten_and_failure_leaves_nothing(tmp_path):
    write_recording(small_recording(), tmp_path / "rec")
    with pytest.raises(FileExistsError):
        write_recording(small_recording(), tmp_path / "rec")
    bad = small_recording()
    bad.observations.tables["bearings"].loc[3, "u"] = np.nan
    with pytest.raises(RecordingError, match="non-finite"):
        write_recording(bad, tmp_path / "bad")
    assert not (tmp_path / "bad").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["rec"]  # no partial folder left behind


def test_bad_folders_give_clear_errors(tmp_path):
    with pytest.raises(RecordingError, match="no such recording"):
        read_recording(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match="no manifest.json"):
        read_recording(tmp_path / "empty")
    out = write_recording(small_recording(), tmp_path / "rec")
    with open(out / "bearings.parquet", "ab") as f:
        f.write(b"tampered")
    with pytest.raises(RecordingError, match="bearings.parquet does not match its hash"):
        read_recording(out)
