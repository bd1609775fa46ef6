"""Recordings on disk: a folder written atomically, and read back into the same objects.

Layout of a dataset folder::

    manifest.json              scene, seed, duration, sensing, versions, meta, sha256 of every file
    bearings.parquet           observation tables (see sim/recording.py), one per kind present
    boxes.parquet
    floor_detections.parquet
    imu.parquet
    truth.parquet              truth: t, person_id, x, y, z, yaw, vx, vy, walking, phone_id
    truth_visibility.parquet   truth: which camera could see whom at each frame
    truth_labels.parquet       truth (rendered mode): per-camera visible pixels, fraction, box
    gt_world.csv               MOTChallenge-style ground truth: frame, id, x, y (world metres)
    calibration/<camera>.xml   OpenCV FileStorage: K, R, t, P, resolution, kind, fps, pose
    calibration/sensors.json   calibrated sensor rates and noise
    floorplan.json             room outline, interior walls, obstacles
    frames/<camera>.mp4        optional rendered video (``--save-frames``)

It is written into a temporary sibling folder and renamed when complete, so a reader never sees
a half-written recording. Parquet tables are written without timestamps, so the same recording
gives byte-identical files.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from trackroom.scenes.camera import Camera
from trackroom.scenes.spec import Floorplan

from .recording import (
    OBSERVATION_COLUMNS,
    Calibration,
    Observations,
    Recording,
    RecordingError,
    Truth,
    check_table,
)

FORMAT_VERSION = 1
TRUTH_FILES = {"people": "truth.parquet", "visibility": "truth_visibility.parquet", "labels": "truth_labels.parquet"}


def write_recording(rec: Recording, out_dir: str | Path, overwrite: bool = False, extra_dirs: dict | None = None) -> Path:
    """Write ``rec`` to ``out_dir`` atomically; returns the folder.

    ``extra_dirs`` maps a sub-folder name to a folder whose files are moved in (e.g. rendered
    frames). An existing ``out_dir`` is an error unless ``overwrite``.
    """
    out = Path(out_dir)
    if out.exists() and not overwrite:
        raise FileExistsError(17, "output folder exists (use --force to replace it)", str(out))
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        for kind, df in rec.observations.tables.items():
            _write_parquet(check_table(kind, df), tmp / f"{kind}.parquet")
        for kind, df in rec.truth.tables.items():
            _write_parquet(df, tmp / TRUTH_FILES[kind])
        _write_gt_world(rec.truth.people, tmp / "gt_world.csv")
        (tmp / "calibration").mkdir()
        for cam in rec.calibration.cameras.values():
            write_camera_xml(cam, tmp / "calibration" / f"{cam.name}.xml")
        _write_json(rec.calibration.noise, tmp / "calibration" / "sensors.json")
        _write_json(rec.calibration.floorplan.to_dict(), tmp / "floorplan.json")
        for name, src in (extra_dirs or {}).items():
            if src is not None and Path(src).exists():
                shutil.move(str(src), str(tmp / name))
        files = sorted(p for p in tmp.rglob("*") if p.is_file())
        manifest = {
            "format": "trackroom-recording",
            "format_version": FORMAT_VERSION,
            "scene": rec.meta.get("scene", ""),
            "seed": rec.meta.get("seed"),
            "duration": rec.observations.duration,
            "sensing": rec.meta.get("sensing", "analytic"),
            "observations": sorted(rec.observations.tables),
            "meta": rec.meta,
            "files": {str(p.relative_to(tmp)): _sha256(p) for p in files},
        }
        _write_json(manifest, tmp / "manifest.json")
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def read_recording(path: str | Path, verify: bool = True) -> Recording:
    """Read a dataset folder back into a ``Recording``; ``verify`` checks every file's hash."""
    root = Path(path)
    manifest_path = root / "manifest.json"
    if not root.is_dir():
        raise RecordingError(f"{root}: no such recording folder")
    if not manifest_path.exists():
        raise RecordingError(f"{root}: not a trackroom recording (no manifest.json)")
    try:
        manifest = json.loads(manifest_path.read_text())
    except json.JSONDecodeError as e:
        raise RecordingError(f"{manifest_path}: not valid JSON: {e}") from None
    if manifest.get("format") != "trackroom-recording":
        raise RecordingError(f"{manifest_path}: not a trackroom recording manifest")
    if verify:
        for rel, digest in manifest["files"].items():
            p = root / rel
            if not p.exists():
                raise RecordingError(f"{root}: file {rel} listed in the manifest is missing")
            if _sha256(p) != digest:
                raise RecordingError(f"{root}: file {rel} does not match its hash in the manifest (modified or corrupt)")
    tables = {}
    for kind in manifest["observations"]:
        tables[kind] = check_table(kind, _read_parquet(root / f"{kind}.parquet"))
    truth = {k: _read_parquet(root / f) for k, f in TRUTH_FILES.items() if (root / f).exists()}
    cams = {}
    for xml in sorted((root / "calibration").glob("*.xml")):
        cam = read_camera_xml(xml)
        cams[cam.name] = cam
    noise = json.loads((root / "calibration" / "sensors.json").read_text())
    floorplan = Floorplan.from_dict(json.loads((root / "floorplan.json").read_text()))
    return Recording(
        calibration=Calibration(cameras=cams, floorplan=floorplan, noise=noise),
        observations=Observations(tables=tables, duration=float(manifest["duration"])),
        truth=Truth(tables=truth),
        meta=manifest["meta"],
    )


# ----------------------------------------------------------------------------- calibration XML
def write_camera_xml(cam: Camera, path: Path) -> None:
    """OpenCV FileStorage XML with K, R, t, P (as WILDTRACK/MultiviewX do) and the camera's pose."""
    import cv2

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("name", cam.name)
        fs.write("kind", cam.kind)
        fs.write("K", cam.K)
        fs.write("R", cam.R)
        fs.write("t", cam.t.reshape(3, 1))
        fs.write("P", cam.P)
        fs.write("image_width", int(cam.width))
        fs.write("image_height", int(cam.height))
        fs.write("fps", float(cam.fps))
        fs.write("position", np.asarray(cam.position, float).reshape(3, 1))
        fs.write("yaw", float(cam.yaw))
        fs.write("pitch", float(cam.pitch))
        fs.write("fovy", float(cam.fovy))
        fs.write("privacy", int(cam.privacy))
        fs.write("quantum", float(cam.quantum))
        fs.write("region", np.asarray(cam.region if cam.region is not None else [np.nan] * 4, float).reshape(4, 1))
    finally:
        fs.release()


def read_camera_xml(path: Path) -> Camera:
    import cv2

    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise RecordingError(f"{path}: cannot be read as OpenCV FileStorage")
    try:
        region = fs.getNode("region").mat().ravel()
        cam = Camera(
            name=fs.getNode("name").string(),
            kind=fs.getNode("kind").string(),
            position=fs.getNode("position").mat().ravel(),
            yaw=fs.getNode("yaw").real(),
            pitch=fs.getNode("pitch").real(),
            fovy=fs.getNode("fovy").real(),
            width=int(fs.getNode("image_width").real()),
            height=int(fs.getNode("image_height").real()),
            fps=fs.getNode("fps").real(),
            privacy=bool(int(fs.getNode("privacy").real())),
            quantum=fs.getNode("quantum").real(),
            region=None if np.isnan(region).any() else tuple(float(v) for v in region),
        )
        P = fs.getNode("P").mat()
    finally:
        fs.release()
    if P is None or not np.allclose(P, cam.P, rtol=1e-9, atol=1e-6):
        raise RecordingError(f"{path}: the stored P does not match the camera's pose and intrinsics")
    return cam


# ----------------------------------------------------------------------------- helpers
def _write_parquet(df: pd.DataFrame, path: Path) -> None:
    df.reset_index(drop=True).to_parquet(path, index=False, engine="pyarrow", compression="zstd")


def _read_parquet(path: Path) -> pd.DataFrame:
    if not path.exists():
        raise RecordingError(f"{path.parent}: missing table {path.name}")
    return pd.read_parquet(path, engine="pyarrow")


def _write_gt_world(people: pd.DataFrame, path: Path) -> None:
    """MOTChallenge-style world ground truth: frame (1-based, at the truth rate), id (1-based), x, y."""
    ids = {pid: i + 1 for i, pid in enumerate(pd.unique(people["person_id"]))}
    times = np.unique(people["t"].to_numpy())
    frame = np.searchsorted(times, people["t"].to_numpy()) + 1
    out = pd.DataFrame(
        {"frame": frame, "id": people["person_id"].map(ids).to_numpy(), "x": people["x"].round(6), "y": people["y"].round(6)}
    )
    out.to_csv(path, index=False)


def _write_json(obj, path: Path) -> None:
    path.write_text(json.dumps(obj, indent=2, sort_keys=True, default=_json_default) + "\n")


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, tuple):
        return list(o)
    raise TypeError(f"cannot store {type(o).__name__} in JSON")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


__all__ = ["OBSERVATION_COLUMNS", "read_recording", "write_recording", "read_camera_xml", "write_camera_xml"]
