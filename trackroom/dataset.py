"""Recordings on disk: a folder written atomically, and read back into the same objects.

Layout of a dataset folder::

    manifest.json              scene, seed, duration, sensing, provenance, sha256 of every file
    scene.toml                 the resolved scene (after --set overrides) it was simulated from
    bearings.parquet           observation tables (see trackroom/recording.py), one per kind present
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

Manifest fields (``manifest.json``, JSON object; paths in it are relative, never absolute):

    format, format_version     "trackroom-recording", FORMAT_VERSION
    scene                      the scene's name ([scene] name)
    source                     where the scene came from: a bundled scene's name (``overhead_lab``)
                               or the scene file's path relative to the working directory of the run
    overrides                  every ``--set key=value`` applied to the scene, in order (list of str)
    scene_file                 "scene.toml" (the resolved scene, loadable by ``load_scene``), or null
    scene_sha256               SHA-256 of the resolved scene in canonical form (its TOML tables as
                               JSON with sorted keys; ``trackroom.scenes.scene_sha256``), or null
    seed, duration, sensing    the simulation's seed, simulated seconds and sensing mode
    observations               the observation tables present (kinds)
    command                    the command line that wrote it, as a list of words starting with
                               "trackroom" (absolute paths made relative), or null from Python
    trackroom_version          the trackroom version that simulated it
    git_commit                 the git commit of the source checkout it ran from (``+dirty`` with
                               uncommitted changes), or null for an installed copy
    meta                       the simulation's record: scene, source, overrides, scene_sha256, seed,
                               duration, sensing, sim_rate, walkers (motion models and parameters),
                               versions (Python and package versions, git_commit)
    files                      {relative path: sha256} of every other file in the folder

It is written into a hidden temporary sibling folder (``.NAME.partial-PID``) and renamed when
complete, so a reader never sees a half-written recording, even if the writer is killed; a
replaced folder is first renamed aside (``.NAME.old-PID``). The next write of the same folder
removes such leftovers whose process is gone. Parquet tables are written without timestamps, so
the same recording gives byte-identical files.

Reading checks every file against its hash and names the file that changed; a file that matches
its hash but cannot be parsed is reported as one ``RecordingError`` naming the file.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
from contextlib import contextmanager
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
SCENE_FILE = "scene.toml"
TRUTH_FILES = {"people": "truth.parquet", "visibility": "truth_visibility.parquet", "labels": "truth_labels.parquet"}


def write_recording(rec: Recording, out_dir: str | Path, overwrite: bool = False, extra_dirs: dict | None = None,
                    command: list[str] | None = None) -> Path:
    """Write ``rec`` to ``out_dir`` atomically; returns the folder.

    ``extra_dirs`` maps a sub-folder name to a folder whose files are moved in (e.g. rendered
    frames). An existing ``out_dir`` is an error unless ``overwrite``. ``command`` is the command
    line recorded in the manifest (``trackroom.provenance.command_line``).
    """
    out = Path(out_dir)
    if out.exists() and not overwrite:
        raise FileExistsError(17, "output folder exists (use --force to replace it)", str(out))
    out.parent.mkdir(parents=True, exist_ok=True)
    clean_leftovers(out)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    aside = None
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
        if rec.scene_toml is not None:
            (tmp / SCENE_FILE).write_text(rec.scene_toml)
        for name, src in (extra_dirs or {}).items():
            if src is not None and Path(src).exists():
                shutil.move(str(src), str(tmp / name))
        files = sorted(p for p in tmp.rglob("*") if p.is_file())
        _write_json(_manifest(rec, command, {str(p.relative_to(tmp)): _sha256(p) for p in files}), tmp / "manifest.json")
        if out.exists():
            # renamed aside, not deleted in place: a kill mid-way must not leave half a folder at out
            aside = out.parent / f".{out.name}.old-{os.getpid()}"
            out.rename(aside)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if aside is not None and aside.exists() and not out.exists():
            aside.rename(out)
        raise
    if aside is not None:
        shutil.rmtree(aside, ignore_errors=True)
    return out


def _manifest(rec: Recording, command: list[str] | None, files: dict[str, str]) -> dict:
    from .provenance import versions

    meta = rec.meta
    vers = meta.get("versions") or versions()
    return {
        "format": "trackroom-recording",
        "format_version": FORMAT_VERSION,
        "scene": meta.get("scene", ""),
        "source": meta.get("source"),
        "overrides": list(meta.get("overrides", [])),
        "scene_file": SCENE_FILE if rec.scene_toml is not None else None,
        "scene_sha256": meta.get("scene_sha256"),
        "seed": meta.get("seed"),
        "duration": rec.observations.duration,
        "sensing": meta.get("sensing", "analytic"),
        "observations": sorted(rec.observations.tables),
        "command": list(command) if command is not None else None,
        "trackroom_version": vers.get("trackroom"),
        "git_commit": vers.get("git_commit"),
        "meta": meta,
        "files": files,
    }


def clean_leftovers(out: str | Path) -> list[Path]:
    """Remove ``.NAME.partial-PID`` / ``.NAME.old-PID`` siblings of ``out`` left by writers that
    were killed (their process is gone); returns what was removed."""
    out = Path(out)
    removed = []
    if not out.parent.is_dir():
        return removed
    for p in out.parent.iterdir():
        for tag in (".partial-", ".old-"):
            prefix = f".{out.name}{tag}"
            if p.name.startswith(prefix) and p.name[len(prefix):].isdigit() and not _process_alive(int(p.name[len(prefix):])):
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
    return removed


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # our own leftover from an earlier, failed write
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    return True


def read_manifest(path: str | Path) -> dict:
    """The manifest of a recording folder, checked for the keys a reader needs."""
    root = Path(path)
    manifest_path = root / "manifest.json"
    if not root.is_dir():
        raise RecordingError(f"{root}: no such recording folder")
    if not manifest_path.exists():
        raise RecordingError(f"{root}: not a trackroom recording (no manifest.json)")
    try:
        manifest = json.loads(manifest_path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise RecordingError(f"{manifest_path}: not valid JSON: {e}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != "trackroom-recording":
        raise RecordingError(f"{manifest_path}: not a trackroom recording manifest")
    for key, types in (("files", dict), ("observations", list), ("duration", (int, float)), ("meta", dict)):
        if not isinstance(manifest.get(key), types) or isinstance(manifest.get(key), bool):
            raise RecordingError(f"{manifest_path}: {key!r} is missing or of the wrong type")
    for rel in manifest["files"]:
        if Path(rel).is_absolute() or ".." in Path(rel).parts:
            raise RecordingError(f"{manifest_path}: file {rel!r} lies outside the recording")
    return manifest


def read_recording(path: str | Path, verify: bool = True) -> Recording:
    """Read a dataset folder back into a ``Recording``; ``verify`` checks every file's hash.

    Every problem (missing or changed file, a file that cannot be parsed, a table that breaks the
    contract) is one ``RecordingError`` naming the folder and the file.
    """
    root = Path(path)
    manifest = read_manifest(root)
    if verify:
        for rel, digest in manifest["files"].items():
            p = root / rel
            if not p.is_file():
                raise RecordingError(f"{root}: file {rel} listed in the manifest is missing")
            if _sha256(p) != digest:
                raise RecordingError(f"{root}: file {rel} does not match its hash in the manifest (modified or corrupt)")
    tables = {}
    for kind in manifest["observations"]:
        if kind not in OBSERVATION_COLUMNS:
            raise RecordingError(f"{root}: manifest.json lists an unknown observation table {kind!r}")
        with _reading(root, f"{kind}.parquet"):
            tables[kind] = check_table(kind, _read_parquet(root / f"{kind}.parquet"))
    truth = {}
    for k, f in TRUTH_FILES.items():
        if (root / f).exists():
            with _reading(root, f):
                truth[k] = _read_parquet(root / f)
    cams = {}
    for xml in sorted((root / "calibration").glob("*.xml")):
        with _reading(root, f"calibration/{xml.name}"):
            cam = read_camera_xml(xml)
        cams[cam.name] = cam
    with _reading(root, "calibration/sensors.json"):
        noise = json.loads((root / "calibration" / "sensors.json").read_text())
    with _reading(root, "floorplan.json"):
        floorplan = Floorplan.from_dict(json.loads((root / "floorplan.json").read_text()))
    scene_text = None
    if (root / SCENE_FILE).is_file():
        with _reading(root, SCENE_FILE):
            scene_text = (root / SCENE_FILE).read_text()
    with _reading(root, "manifest.json"):
        duration = float(manifest["duration"])
    return Recording(
        calibration=Calibration(cameras=cams, floorplan=floorplan, noise=noise),
        observations=Observations(tables=tables, duration=duration),
        truth=Truth(tables=truth),
        meta=manifest["meta"],
        scene_toml=scene_text,
    )


@contextmanager
def _reading(root: Path, rel: str):
    """Turn any failure to parse ``rel`` into one RecordingError naming the folder and the file."""
    try:
        yield
    except RecordingError as e:
        msg = str(e)
        raise RecordingError(msg if rel in msg else f"{root}: {rel}: {msg}") from None
    except Exception as e:  # pyarrow, OpenCV, JSON and TOML raise their own types; all mean the same here
        first = (str(e).strip().splitlines() or [""])[0][:200]
        raise RecordingError(f"{root}: {rel} cannot be read ({type(e).__name__}: {first})") from None


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


__all__ = ["OBSERVATION_COLUMNS", "clean_leftovers", "read_manifest", "read_recording", "write_recording", "read_camera_xml",
           "write_camera_xml"]
