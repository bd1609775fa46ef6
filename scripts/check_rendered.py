"""Do re-rendered recordings equal the ones the figures were measured on?

    python -m scripts.check_rendered DIR [DIR ...]            # compare with docs/rendered_digests.json
    python -m scripts.check_rendered DIR [DIR ...] --record   # record (or replace) their digests

Recordings do not survive a new machine: issue 12's development and evaluation recordings are
rendered again from their seeds (``trackroom generate occlusion_lab --seed N --duration 35
--sensing rendered``). For one set of versions, rendering on the CPU gives the same files byte for
byte on one machine (occlusion_lab 3220 rendered twice, issue 12's seventy-fifth session: every
file of the manifest the same). Across machines, truth's ``z`` and ``yaw`` and the IMU table may
differ in the last bits: numpy computes some functions (``arctan2`` among them) with SIMD code
that depends on the CPU (AVX-512 or not), as issue 12's eighty-fifth session found (3460 on an
AVX-512 machine: ``x``, ``y``, ``vx``, ``vy`` and the camera tables the same, ``yaw`` within
4e-15). This script checks a re-render against the record: each folder's files against its own
manifest first (as ``read_recording`` verifies), then the digests of its tables (``TABLES``, the
first 16 hex digits of the manifest's sha256) against those recorded for the same scene, seed,
duration, overrides and sensing in ``--digests``. One line per recording: ``same``, ``differs``
(naming the tables; their columns, where the record has column digests; and the versions and
numpy SIMD targets where they differ from the recorded ones) or ``not recorded``; the exit status
is 1 when any differs."""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_manifest, recording_folders, verify_files
from trackroom.recording import RecordingError

DIGESTS = Path(__file__).resolve().parents[1] / "docs" / "rendered_digests.json"
TABLES = ("bearings.parquet", "boxes.parquet", "floor_detections.parquet", "imu.parquet", "truth.parquet",
          "truth_labels.parquet", "truth_visibility.parquet")
DIGITS = 16
VERSIONS = ("mujoco", "numpy", "opencv-python-headless", "python")  # what rendering depends on, as the manifest names them


def key(manifest: dict) -> str:
    """The record's name for a recording: scene, seed, duration, sensing and overrides."""
    m = manifest["meta"]
    over = "".join(f" --set {o}" for o in m.get("overrides", []))
    return f"{m['scene']} seed {m['seed']} {float(m['duration']):g} s {m['sensing']}{over}"


def digests(folder: Path) -> tuple[str, dict, dict]:
    """(``key``, {table: digest}, versions) of a recording folder whose files match its manifest
    (``dataset.verify_files``, as ``read_recording`` checks them); a file that does not ends the
    script with one line naming it."""
    manifest = read_manifest(folder)
    try:
        verify_files(folder, manifest)
    except RecordingError as e:
        raise SystemExit(f"check_rendered: {e}") from None
    files = {t: manifest["files"][t][:DIGITS] for t in TABLES if t in manifest["files"]}
    versions = manifest["meta"].get("versions", {})
    return key(manifest), files, {k: versions[k] for k in VERSIONS if k in versions}


def column_digests(folder: Path, table: str) -> dict[str, str]:
    """{column: the first ``DIGITS`` hex digits of the sha256 of its values} of one table: float
    and integer columns by their bytes, others by their values' text."""
    df = pd.read_parquet(folder / table, engine="pyarrow")
    out = {}
    for c in df.columns:
        v = df[c].to_numpy()
        raw = np.ascontiguousarray(v).tobytes() if v.dtype.kind in "fiub" else "\0".join(map(str, v)).encode()
        out[str(c)] = hashlib.sha256(raw).hexdigest()[:DIGITS]
    return out


def simd() -> list[str]:
    """The SIMD targets numpy dispatches to on this machine (its results for some functions differ
    between them)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # another numpy layout: nothing to report
        return []
    return [t for t in __cpu_dispatch__ if __cpu_features__.get(t)]


def differing(folder: Path, tables: list[str], old: dict) -> str:
    """The differing tables, each with its differing columns where the record has them."""
    cols = old.get("columns", {})
    out = []
    for t in tables:
        if t in cols and (folder / t).is_file():
            now = column_digests(folder, t)
            bad = [c for c in sorted(set(now) | set(cols[t])) if now.get(c) != cols[t].get(c)]
            out.append(f"{t} ({', '.join(bad)})")
        else:
            out.append(t)
    return ", ".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR", help="recording folders (globs allowed)")
    ap.add_argument("--digests", default=str(DIGESTS), help=f"the record (default {DIGESTS.relative_to(DIGESTS.parents[1])})")
    ap.add_argument("--record", action="store_true", help="record these recordings' digests instead of checking them")
    args = ap.parse_args(argv)
    folders = recording_folders(args.recordings, "check_rendered")
    path = Path(args.digests)
    record = json.loads(path.read_text()) if path.is_file() else {}
    differs = 0
    here = simd()  # this machine's, once for every recording
    for d in folders:
        name, files, versions = digests(Path(d))
        if args.record:
            columns = {t: column_digests(Path(d), t) for t in files}
            record[name] = {"tables": files, "columns": columns, "versions": versions, "simd": here}
            continue
        old = record.get(name)
        if old is None:
            print(f"{d}: {name}: not recorded")
            continue
        bad = sorted(t for t in set(files) | set(old["tables"]) if files.get(t) != old["tables"].get(t))
        if not bad:
            print(f"{d}: {name}: same")
            continue
        differs += 1
        moved = {k: (old["versions"].get(k), v) for k, v in versions.items() if old["versions"].get(k) != v}
        if "simd" in old and old["simd"] != here:
            moved["numpy SIMD"] = (" ".join(old["simd"]) or "none", " ".join(here) or "none")
        print(f"{d}: {name}: differs in {differing(Path(d), bad, old)}"
              + (f" (recorded -> now: {moved})" if moved else ""))
    if args.record:
        tmp = path.with_suffix(".tmp")
        lines = [f"{json.dumps(k)}: {json.dumps(v, sort_keys=True)}" for k, v in sorted(record.items())]  # one line a recording
        tmp.write_text("{\n" + ",\n".join(lines) + "\n}\n")
        tmp.replace(path)
        print(f"recorded {len(folders)} recording(s) in {path}")
    return 1 if differs else 0


if __name__ == "__main__":
    sys.exit(main())
