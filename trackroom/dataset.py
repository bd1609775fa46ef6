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
    gt_world.csv               MOTChallenge-style ground truth at the cameras' frame rate: frame, id, x, y (m)
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

import glob
import hashlib
import json
import math
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from trackroom.scenes.camera import CAMERA_KINDS, Camera
from trackroom.scenes.spec import Floorplan

from .recording import (
    OBSERVATION_COLUMNS,
    SENSING_MODES,
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
            check_table(kind, df)
        # the tables are encoded, compressed and hashed in threads: pyarrow and hashlib release
        # the GIL, so a 10-minute recording's tables take about the time of the largest one
        writes = [(lambda df=df, p=tmp / f"{kind}.parquet": _write_parquet(df, p)) for kind, df in rec.observations.tables.items()]
        writes += [(lambda df=df, p=tmp / TRUTH_FILES[kind]: _write_parquet(df, p)) for kind, df in rec.truth.tables.items()]
        writes.append(lambda: _write_gt_world(rec.truth.people, tmp / "gt_world.csv", gt_world_rate(rec)))
        with ThreadPoolExecutor(max_workers=min(len(writes), os.cpu_count() or 1)) as pool:
            hashes = dict(pool.map(lambda write: _hashed(write()), writes))
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
        _write_json(_manifest(rec, command, {str(p.relative_to(tmp)): hashes.get(p) or _sha256(p) for p in files}),
                    tmp / "manifest.json")
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
    """The manifest of a recording folder, checked (keys, types, file paths, digests)."""
    root = Path(path)
    manifest_path = root / "manifest.json"
    if not root.is_dir():
        raise RecordingError(f"{root}: no such recording folder")
    if not manifest_path.exists():
        raise RecordingError(f"{root}: not a trackroom recording (no manifest.json)")
    return _check_manifest(_read_json(manifest_path), manifest_path)


def expand_recordings(patterns) -> list[str]:
    """Recording folders from command-line patterns: each quoted glob expanded (sorted), a
    pattern that matches nothing kept as given (so reading it names the missing folder)."""
    return [d for pat in patterns for d in (sorted(glob.glob(str(pat))) or [str(pat)])]


def recording_folders(patterns, prog: str) -> list[str]:
    """A command line's recording folders: ``expand_recordings``, then every folder's manifest
    read before anything runs, so that a missing or malformed folder ends the command ``prog``
    with one line naming it and nothing half printed, instead of a traceback partway through."""
    folders = expand_recordings(patterns)
    try:
        for d in folders:
            read_manifest(d)
    except RecordingError as e:
        raise SystemExit(f"{prog}: {e}") from None
    return folders


def verify_files(root: Path, manifest: dict) -> None:
    """Every file the manifest lists is in the folder ``root`` with its hash; else one
    ``RecordingError`` naming the first that is not."""
    for rel, digest in manifest["files"].items():
        p = root / rel
        if not p.is_file():
            raise RecordingError(f"{root}: file {rel} listed in the manifest is missing")
        if _sha256(p) != digest:
            raise RecordingError(f"{root}: file {rel} does not match its hash in the manifest (modified or corrupt)")


def read_recording(path: str | Path, verify: bool = True) -> Recording:
    """Read a dataset folder back into a ``Recording``; ``verify`` checks every file's hash.

    Anything wrong with the folder ends in one ``RecordingError`` naming the file and the problem:
    a missing or changed file, a manifest without its keys, a table with a missing column, a
    column of the wrong type, NaN or inf, unsorted time, a calibration file that does not parse or
    whose P does not match its pose, a camera used by a table but not calibrated.
    """
    root = Path(path)
    manifest = read_manifest(root)
    if verify:
        verify_files(root, manifest)
    tables = {kind: _read_parquet(root / f"{kind}.parquet", kind) for kind in manifest["observations"]}
    truth = {k: _read_parquet(root / f, k) for k, f in TRUTH_FILES.items() if (root / f).exists()}
    cams = {}
    for xml in sorted((root / "calibration").glob("*.xml")):
        cam = read_camera_xml(xml)
        cams[cam.name] = cam
    for kind, df in [*tables.items(), *truth.items()]:
        if "camera" in df.columns:
            unknown = sorted(set(df["camera"]) - set(cams))
            if unknown:
                f = f"{kind}.parquet" if kind in tables else TRUTH_FILES[kind]
                raise RecordingError(f"{root / f}: cameras {unknown} have no calibration/<camera>.xml")
    noise = _check_noise(_read_json(root / "calibration" / "sensors.json"), root / "calibration" / "sensors.json")
    floorplan = _read_floorplan(root / "floorplan.json")
    scene_text = None
    if (root / SCENE_FILE).is_file():
        try:
            scene_text = (root / SCENE_FILE).read_text(encoding="utf-8")
        except UnicodeDecodeError as e:
            raise RecordingError(f"{root / SCENE_FILE}: not UTF-8 text (byte {e.start})") from None
    duration = float(manifest["duration"])
    return Recording(
        calibration=Calibration(cameras=cams, floorplan=floorplan, noise=noise),
        observations=Observations(tables=tables, duration=duration),
        truth=Truth(tables=truth),
        meta=manifest["meta"],
        scene_toml=scene_text,
    )


def _check_manifest(manifest, path: Path) -> dict:
    """The manifest's keys and types (keys this reader does not use may be added freely)."""
    def bad(problem: str):
        raise RecordingError(f"{path}: {problem}")

    if not isinstance(manifest, dict):
        bad(f"expected a JSON object, got {type(manifest).__name__}")
    if manifest.get("format") != "trackroom-recording":
        bad("not a trackroom recording manifest (format is not 'trackroom-recording')")
    kinds = {"format_version": (int,), "duration": (int, float), "observations": (list,), "files": (dict,), "meta": (dict,)}
    for key, types in kinds.items():
        if key not in manifest:
            bad(f"missing key {key!r}")
        v = manifest[key]
        if isinstance(v, bool) or not isinstance(v, types):
            bad(f"{key}: expected {' or '.join(t.__name__ for t in types)}, got {_short(v)}")
    if manifest["format_version"] > FORMAT_VERSION:
        bad(f"format_version {manifest['format_version']} is newer than this trackroom reads ({FORMAT_VERSION})")
    if not (math.isfinite(manifest["duration"]) and manifest["duration"] > 0):
        bad(f"duration: expected a positive number of seconds, got {manifest['duration']!r}")
    obs = manifest["observations"]
    if not all(isinstance(k, str) and k in OBSERVATION_COLUMNS for k in obs) or len(set(obs)) != len(obs):
        bad(f"observations: expected distinct table kinds from {sorted(OBSERVATION_COLUMNS)}, got {_short(obs)}")
    for rel, digest in manifest["files"].items():
        parts = Path(rel).parts
        if Path(rel).is_absolute() or ".." in parts or not parts:
            bad(f"files: {rel!r} is not a path inside the recording")
        if not (isinstance(digest, str) and len(digest) == 64 and all(c in "0123456789abcdef" for c in digest)):
            bad(f"files: {rel}: expected a sha256 hex digest, got {_short(digest)}")
    for key, types in (("scene", (str,)), ("seed", (int, type(None))), ("sensing", (str,))):
        if key in manifest and (isinstance(manifest[key], bool) or not isinstance(manifest[key], types)):
            bad(f"{key}: expected {' or '.join(t.__name__ for t in types if t is not type(None))}, got {_short(manifest[key])}")
    if manifest.get("sensing", "analytic") not in SENSING_MODES:
        bad(f"sensing: expected one of {', '.join(SENSING_MODES)}, got {manifest['sensing']!r}")
    return manifest


def _check_noise(noise, path: Path) -> dict:
    """calibration/sensors.json: sensor noise and rates, each a finite number or list of numbers."""
    if not isinstance(noise, dict):
        raise RecordingError(f"{path}: expected a JSON object, got {type(noise).__name__}")
    for k, v in noise.items():
        values = v if isinstance(v, list) else [v]
        if not all(_finite_number(x) for x in values):
            raise RecordingError(f"{path}: {k}: expected a finite number (or a list of them), got {_short(v)}")
    return noise


def _read_floorplan(path: Path) -> Floorplan:
    """floorplan.json, checked key by key so a damaged file names what is wrong."""
    d = _read_json(path)

    def bad(problem: str):
        raise RecordingError(f"{path}: {problem}")

    def vec(x, n: int, where: str, positive: bool = False) -> None:
        if not (isinstance(x, list) and len(x) == n and all(_finite_number(v) for v in x)):
            bad(f"{where}: expected {n} finite numbers, got {_short(x)}")
        if positive and min(x) <= 0:
            bad(f"{where}: expected positive numbers, got {_short(x)}")

    def num(node: dict, key: str, where: str, positive: bool = True) -> None:
        if key not in node:
            bad(f"{where}{key}: missing")
        if not _finite_number(node[key]) or (positive and node[key] <= 0):
            bad(f"{where}{key}: expected a {'positive' if positive else 'finite'} number, got {_short(node[key])}")

    if not isinstance(d, dict):
        bad(f"expected a JSON object, got {type(d).__name__}")
    for key in ("outline", "walls", "obstacles"):
        if not isinstance(d.get(key), list):
            bad(f"{key}: expected a list, got {_short(d.get(key))}")
    if len(d["outline"]) < 3:
        bad("outline: expected at least 3 points")
    for i, p in enumerate(d["outline"]):
        vec(p, 2, f"outline[{i}]")
    num(d, "wall_height", "")
    num(d, "wall_thickness", "")
    for i, w in enumerate(d["walls"]):
        if not isinstance(w, dict):
            bad(f"walls[{i}]: expected an object")
        vec(w.get("start"), 2, f"walls[{i}].start")
        vec(w.get("end"), 2, f"walls[{i}].end")
        num(w, "thickness", f"walls[{i}].")
        num(w, "height", f"walls[{i}].")
    for i, o in enumerate(d["obstacles"]):
        if not isinstance(o, dict):
            bad(f"obstacles[{i}]: expected an object")
        vec(o.get("center"), 2, f"obstacles[{i}].center")
        vec(o.get("size"), 3, f"obstacles[{i}].size", positive=True)
        num(o, "yaw", f"obstacles[{i}].", positive=False)
        if not isinstance(o.get("name", ""), str):
            bad(f"obstacles[{i}].name: expected a string, got {_short(o['name'])}")
    return Floorplan.from_dict(d)


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
    """A camera from its OpenCV FileStorage XML; a missing node, a node of the wrong type, an
    impossible value or a P that does not match the pose ends in ``RecordingError``."""
    import cv2

    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as e:
        # OpenCV's parse error reaches Python as a SystemError wrapping the cv2.error
        cause = e.__context__ if isinstance(e, SystemError) and e.__context__ is not None else e
        raise RecordingError(f"{path}: not readable as OpenCV FileStorage XML ({_first_line(cause)})") from None
    if not fs.isOpened():
        raise RecordingError(f"{path}: cannot be read as OpenCV FileStorage")

    def bad(problem: str):
        raise RecordingError(f"{path}: {problem}")

    def node(key: str):
        n = fs.getNode(key)
        if n.empty() or n.isNone():
            bad(f"missing {key}")
        return n

    def text(key: str) -> str:
        n = node(key)
        if not n.isString():
            bad(f"{key}: expected text")
        return n.string()

    def real(key: str) -> float:
        n = node(key)
        if not (n.isReal() or n.isInt()):
            bad(f"{key}: expected a number")
        return float(n.real())

    def mat(key: str, shape: tuple[int, int]) -> np.ndarray:
        n = node(key)
        m = n.mat() if n.isMap() else None
        if m is None or m.shape[:2] != shape:
            bad(f"{key}: expected a {shape[0]}x{shape[1]} opencv-matrix")
        return np.asarray(m, float)

    try:
        name, kind = text("name"), text("kind")
        position, region, P = mat("position", (3, 1)).ravel(), mat("region", (4, 1)).ravel(), mat("P", (3, 4))
        values = {k: real(k) for k in ("yaw", "pitch", "fovy", "image_width", "image_height", "fps", "privacy", "quantum")}
    except (cv2.error, SystemError) as e:
        cause = e.__context__ if isinstance(e, SystemError) and e.__context__ is not None else e
        raise RecordingError(f"{path}: not readable as OpenCV FileStorage XML ({_first_line(cause)})") from None
    finally:
        fs.release()
    if name != path.stem:
        bad(f"name {name!r} does not match the file name (calibration/<camera>.xml)")
    if kind not in CAMERA_KINDS:
        bad(f"kind {kind!r} is not one of {', '.join(CAMERA_KINDS)}")
    if not (np.isfinite(position).all() and np.isfinite(P).all() and all(map(math.isfinite, values.values()))):
        bad("non-finite values (NaN or inf) in the camera's pose or intrinsics")
    w, h = values["image_width"], values["image_height"]
    if w != int(w) or h != int(h) or min(w, h) < 1:
        bad(f"image size {w} x {h}: expected whole pixels")
    if not 0 < values["fovy"] < math.pi or values["fps"] <= 0 or values["quantum"] < 0 or values["privacy"] not in (0, 1):
        bad("fovy, fps, quantum or privacy out of range (0 < fovy < pi, fps > 0, quantum >= 0, privacy 0 or 1)")
    if not (np.isnan(region).all() or (np.isfinite(region).all() and region[0] < region[2] and region[1] < region[3])):
        bad(f"region {region.tolist()}: expected [xmin, ymin, xmax, ymax] or all NaN (none)")
    cam = Camera(
        name=name, kind=kind, position=position, yaw=values["yaw"], pitch=values["pitch"], fovy=values["fovy"],
        width=int(w), height=int(h), fps=values["fps"], privacy=bool(values["privacy"]), quantum=values["quantum"],
        region=None if np.isnan(region).any() else tuple(float(v) for v in region),
    )
    if not np.allclose(P, cam.P, rtol=1e-9, atol=1e-6):
        raise RecordingError(f"{path}: the stored P does not match the camera's pose and intrinsics")
    return cam


# ----------------------------------------------------------------------------- helpers
def atomic_write(path: Path, write) -> Path:
    """``write(tmp)`` to a hidden sibling, then rename over ``path``: readers see old or new, never half."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _write_parquet(df: pd.DataFrame, path: Path) -> Path:
    # dictionary encoding only where values repeat (names, flags, ids): pyarrow tries it first on
    # every column, and measured floats almost never repeat (an overhead_lab recording, 10 walkers,
    # 600 s: 0.47 -> 0.29 s of CPU to write, files 6 % smaller)
    repeating = [c for c in df.columns if not pd.api.types.is_float_dtype(df[c])]
    df.reset_index(drop=True).to_parquet(path, index=False, engine="pyarrow", compression="zstd", use_dictionary=repeating)
    return path


def _hashed(path: Path) -> tuple[Path, str]:
    return path, _sha256(path)


def _read_parquet(path: Path, kind: str | None = None) -> pd.DataFrame:
    """A Parquet table, checked against its contract (``check_table``) when ``kind`` is given."""
    import pyarrow as pa

    if not path.is_file():
        raise RecordingError(f"{path.parent}: missing table {path.name}")
    try:
        df = pd.read_parquet(path, engine="pyarrow")
    except (pa.ArrowException, OSError, ValueError, TypeError, NotImplementedError) as e:
        # truncated or corrupt files, schemas pandas cannot hold (pyarrow raises all of these)
        detail = _first_line(e).replace(str(path), path.name)
        raise RecordingError(f"{path}: not a readable Parquet table ({type(e).__name__}: {detail})") from None
    if kind is not None:
        try:
            check_table(kind, df)
        except RecordingError as e:
            raise RecordingError(f"{path}: {e}") from None
    return df


def read_tracks(path) -> pd.DataFrame:
    """A tracks CSV (``t, track_id, x, y`` [+ ``vx, vy, pxx, pxy, pyy, phone_id``]), validated by
    ``check_tracks``: a bad value ends in one line naming the column and the file line; a file
    that is not CSV in one ``RecordingError``."""
    from trackroom.estimators.base import check_tracks

    try:
        df = pd.read_csv(path, dtype={"phone_id": str, "track_id": str}, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise RecordingError(f"{path}: not a readable CSV: {' '.join(str(e).split())}") from None
    if "track_id" in df.columns:
        # integer ids stay integers ("3" -> 3, as estimators write them); others stay text
        ids = pd.to_numeric(df["track_id"], errors="coerce")
        if ids.notna().all() and (ids == ids.round()).all():
            df["track_id"] = ids.astype("int64")
    if "phone_id" in df.columns:
        df["phone_id"] = df["phone_id"].fillna("")
    return check_tracks(df, str(path), first_line=2)


def _read_json(path: Path):
    if not path.is_file():
        raise RecordingError(f"{path}: missing")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise RecordingError(f"{path}: not valid JSON: {_first_line(e)}") from None


def _finite_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _short(v) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:57] + "..."


def _first_line(e: BaseException) -> str:
    lines = [ln.strip() for ln in str(e).splitlines() if ln.strip()]
    return _short_text(lines[0]) if lines else type(e).__name__


def _short_text(t: str) -> str:
    return t if len(t) <= 200 else t[:197] + "..."


def gt_world_rate(rec: Recording) -> float:
    """The frame rate of ``gt_world.csv`` (Hz): the cameras' (the highest, where they differ), or
    the simulation rate for a recording without cameras."""
    fps = [float(c.fps) for c in rec.calibration.cameras.values()]
    return max(fps) if fps else float(rec.meta.get("sim_rate", 100.0))


def _write_gt_world(people: pd.DataFrame, path: Path, rate: float) -> Path:
    """MOTChallenge-style world ground truth at ``rate`` (Hz; the truth times that fall on its
    frames): frame (1-based, t = (frame - 1) / rate), id (1-based, first-appearance order), x, y
    (m, 6 decimals). Written by pyarrow's CSV writer (the same text as pandas', ~10x faster)."""
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    t = people["t"].to_numpy()
    f = t * rate
    frame = np.rint(f)
    keep = np.abs(f - frame) < 1e-6
    codes, _ = pd.factorize(people["person_id"])  # 1-based below: in order of first appearance
    table = pa.table({"frame": frame[keep].astype(np.int64) + 1, "id": codes[keep].astype(np.int64) + 1,
                      "x": np.round(people["x"].to_numpy()[keep], 6), "y": np.round(people["y"].to_numpy()[keep], 6)})
    with open(path, "wb") as out:
        out.write(b"frame,id,x,y\n")
        pa_csv.write_csv(table, out, pa_csv.WriteOptions(include_header=False))
    return path


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


__all__ = ["OBSERVATION_COLUMNS", "clean_leftovers", "expand_recordings", "read_manifest", "read_recording", "recording_folders",
           "write_recording", "read_camera_xml", "write_camera_xml"]
