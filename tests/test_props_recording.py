"""Property-based tests of the recording reader: one tiny simulated recording, copied and damaged.

Damage: a file deleted or truncated; a Parquet table rewritten with a column of the wrong type,
missing or renamed columns, NaN/inf/None, no rows, unsorted time, repeated columns; the manifest,
floorplan.json or sensors.json as bad JSON, without keys or with values of the wrong type; a
calibration XML cut, with a node removed or holding junk. The manifest's hash of the damaged file
is updated or not, and the folder is read with and without hash checks, so both the hash check and
the content checks are exercised. Every case ends in a ``Recording`` that passes the checks below
or in one ``RecordingError`` whose one-line message names a file of the recording; never another
exception. Case counts from tests/props.py (profile ``ci`` or ``slow``, env TRACKROOM_HYPOTHESIS).
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from trackroom.dataset import TRUTH_FILES, read_recording, write_recording
from trackroom.recording import (
    FLAG_COLUMNS,
    OBSERVATION_COLUMNS,
    STRING_COLUMNS,
    TRUTH_COLUMNS,
    Recording,
    RecordingError,
    check_table,
)
from trackroom.scenes import parse_scene
from trackroom.scenes.camera import CAMERA_KINDS
from trackroom.sim.simulate import simulate

from .props import examples

# One camera of each kind, two walkers (one with a phone): every observation table has rows.
SCENE = """
[scene]
name = "fuzz_room"
[room]
outline = [[0, 0], [6, 0], [6, 5], [0, 5]]
wall_height = 2.8
[[obstacles]]
name = "box"
center = [4.5, 3.5]
size = [0.6, 0.6, 1.0]
[[cameras]]
name = "hor"
kind = "horizontal"
position = [0.06, 2.5, 1.5]
yaw_deg = 0
fovy_deg = 60
resolution = [160, 120]
fps = 5
[[cameras]]
name = "top"
kind = "overhead"
position = [3.0, 2.5, 2.7]
fovy_deg = 120
resolution = [160, 120]
fps = 5
[[cameras]]
name = "obl"
kind = "oblique"
position = [5.9, 0.1, 2.5]
look_at = [3.0, 2.5, 0.9]
fovy_deg = 60
resolution = [160, 120]
fps = 5
[sensors]
imu_rate = 20
sim_rate = 100
[walkers]
count = 2
phoneless = 1
"""


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A 3 s analytic recording of SCENE, written once per module."""
    rec = simulate(parse_scene(tomllib.loads(SCENE), source="fuzz_room"), seed=1, duration=3.0)
    out = write_recording(rec, tmp_path_factory.mktemp("base") / "rec")
    assert all(len(df) for df in rec.observations.tables.values()), "the fixture should fill every table"
    return out


# ----------------------------------------------------------------------------- damage
def _sha256(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _rehash(root, rel: str) -> None:
    """Point the manifest's hash of ``rel`` at its new content (if the manifest still allows it)."""
    m = root / "manifest.json"
    try:
        manifest = json.loads(m.read_text())
        if (root / rel).is_file():
            manifest["files"][rel] = _sha256(root / rel)
        else:
            manifest["files"].pop(rel, None)
    except (ValueError, TypeError, KeyError, AttributeError):
        return
    m.write_text(json.dumps(manifest))


TABLES = {**{k: f"{k}.parquet" for k in OBSERVATION_COLUMNS}, **TRUTH_FILES}
KIND_OF = {f: k for k, f in TABLES.items()}
BAD_CELLS = st.sampled_from([math.nan, math.inf, -math.inf, None, "x", "", 1e308, -1, 0, True])
JSON_BAD = st.one_of(
    st.sampled_from([math.nan, math.inf, -1, 0, 1e308, "", "x", [], {}, [1], {"a": 1}, None, True, 2**70]),
    st.text(max_size=4),
    st.floats(),
)


@st.composite
def table_damage(draw, df: pd.DataFrame, kind: str) -> pa.Table | pd.DataFrame:
    """A damaged copy of a table (a DataFrame, or a pyarrow Table for what pandas will not build)."""
    df = df.copy()
    cols = list(df.columns)
    what = draw(st.sampled_from(["dtype", "drop", "rename", "cells", "empty", "unsorted", "repeat", "other", "extra", "arrow"]))
    c = draw(st.sampled_from(cols))
    if what == "dtype":
        to = draw(st.sampled_from(["str", "int", "bool", "object", "category", "datetime", "nullable", "bytes"]))
        if to == "str":
            df[c] = df[c].astype(str)
        elif to == "int":
            df[c] = np.arange(len(df))
        elif to == "bool":
            df[c] = np.arange(len(df)) % 2 == 0
        elif to == "object":
            df[c] = pd.Series([{"a": 1.5}] * len(df), dtype=object)  # a struct column
        elif to == "category":
            df[c] = df[c].astype("category")
        elif to == "datetime":
            df[c] = pd.Timestamp("2026-01-01") + pd.to_timedelta(np.arange(len(df)), unit="s")
        elif to == "nullable":
            df[c] = pd.array([None] + [1] * (len(df) - 1), dtype="Int64")
        else:
            df[c] = [b"\x00\xff"] * len(df)
    elif what == "drop":
        df = df.drop(columns=draw(st.lists(st.sampled_from(cols), min_size=1, unique=True)))
    elif what == "rename":
        df = df.rename(columns={c: c.upper()})
    elif what == "cells":
        rows = draw(st.lists(st.integers(0, len(df) - 1), min_size=1, max_size=3))
        value = draw(BAD_CELLS)
        col = df[c].astype(object)
        col.iloc[rows] = value
        df[c] = col
    elif what == "empty":
        df = df.iloc[:0]
    elif what == "unsorted":
        df = df.iloc[::-1] if draw(st.booleans()) else df.sample(frac=1.0, random_state=draw(st.integers(0, 99)))
    elif what == "repeat":
        table = pa.Table.from_pandas(df, preserve_index=False)
        return table.append_column(c, table.column(c))  # two columns of one name
    elif what == "other":
        other = draw(st.sampled_from(sorted({**OBSERVATION_COLUMNS, **TRUTH_COLUMNS})))
        df = pd.DataFrame({k: ["a"] if k in STRING_COLUMNS else [1.0] for k in ({**OBSERVATION_COLUMNS, **TRUTH_COLUMNS})[other]})
    elif what == "extra":
        df["extra"] = draw(BAD_CELLS)
    else:
        nested = pa.array([[1.0, 2.0]] * len(df), type=pa.list_(pa.float64()))
        table = pa.Table.from_pandas(df, preserve_index=False)
        return table.set_column(cols.index(c), c, nested)
    return df.reset_index(drop=True)


def _json_paths(node, prefix=()):
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _json_paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _json_paths(v, prefix + (i,))


@st.composite
def json_damage(draw, text: str) -> str:
    """Bad JSON text, or valid JSON with a key removed, a value of the wrong type, NaN, an extra key."""
    what = draw(st.sampled_from(["text", "remove", "replace", "replace", "whole"]))
    if what == "text":
        i = draw(st.integers(0, len(text) - 1))
        return draw(st.sampled_from([text[:i], text[:i] + "}" + text[i:], text[:i] + "\xff" + text[i + 1:]]))
    obj = json.loads(text)
    if what == "whole":
        return json.dumps(draw(JSON_BAD))
    paths = [p for p, _ in _json_paths(obj) if p]
    p = draw(st.sampled_from(paths))
    parent = obj
    for k in p[:-1]:
        parent = parent[k]
    if what == "remove":
        del parent[p[-1]]
    else:
        parent[p[-1]] = draw(JSON_BAD)
    return json.dumps(obj)


XML_TAGS = ["name", "kind", "K", "R", "t", "P", "image_width", "image_height", "fps", "position", "yaw", "pitch",
            "fovy", "privacy", "quantum", "region"]


@st.composite
def xml_damage(draw, text: str) -> str:
    """A calibration XML cut, with a node removed, or a node's content replaced by junk."""
    what = draw(st.sampled_from(["cut", "remove", "junk", "junk"]))
    if what == "cut":
        return text[: draw(st.integers(0, len(text) - 1))]
    tag = draw(st.sampled_from(XML_TAGS))
    pattern = re.compile(rf"<{tag}( [^>]*)?>.*?</{tag}>", re.S)
    if what == "remove":
        return pattern.sub("", text, count=1)
    junk = draw(st.sampled_from(["abc", "nan", "1e999", "-5", "", "0", "<x/>", "zzz 1 2", "hor", "overhead", "2.5"]))
    if tag in ("K", "R", "t", "P", "position", "region") and draw(st.booleans()):
        return re.sub(rf"(<{tag} [^>]*>.*?<data>).*?(</data>)", lambda m: m.group(1) + junk + m.group(2), text, count=1, flags=re.S)
    return pattern.sub(lambda m: f"<{tag}>{junk}</{tag}>", text, count=1)


@st.composite
def damaged(draw, base) -> tuple[str, bool]:
    """Copy ``base`` to a fresh folder and damage it; returns (damaged file, whether it was rehashed)."""
    root = base.parent.parent / "work" / "rec"
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(base, root)
    files = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
    rel = draw(st.sampled_from(files))
    p = root / rel
    before = p.read_bytes()
    what = draw(st.sampled_from(["delete", "truncate", "content", "content", "content"]))
    if what == "delete":
        p.unlink()
        if rel.endswith(".parquet") and rel[:-8] in OBSERVATION_COLUMNS and draw(st.booleans()):
            m = json.loads((root / "manifest.json").read_text())  # the table dropped from the manifest too
            m["observations"].remove(rel[:-8])
            (root / "manifest.json").write_text(json.dumps(m))
    elif what == "truncate":
        data = p.read_bytes()
        p.write_bytes(data[: draw(st.integers(0, len(data) - 1))])
    elif rel in KIND_OF:
        out = draw(table_damage(pd.read_parquet(p), KIND_OF[rel]))
        try:
            table = out if isinstance(out, pa.Table) else pa.Table.from_pandas(out, preserve_index=False)
        except (pa.ArrowException, ValueError, TypeError):
            assume(False)  # a frame Parquet cannot hold (a str next to a float in one column): skip
        pq.write_table(table, p)
    elif rel.endswith(".json"):
        p.write_bytes(draw(json_damage(p.read_text())).encode("utf-8", "surrogateescape"))
    elif rel.endswith(".xml"):
        p.write_text(draw(xml_damage(p.read_text())))
    else:  # gt_world.csv: not read, only hashed
        p.write_text(p.read_text() + "junk\n")
    assume(not p.exists() or p.read_bytes() != before)  # junk equal to what was there is no damage
    rehash = rel != "manifest.json" and draw(st.booleans())
    if rehash:
        _rehash(root, rel)
    return root, rel, rehash


# ----------------------------------------------------------------------------- checks
def check_recording(rec: Recording) -> None:
    """What an estimator and the metrics may rely on in a recording that was read."""
    assert isinstance(rec.meta, dict) and math.isfinite(rec.duration) and rec.duration > 0
    cams = rec.calibration.cameras
    for name, cam in cams.items():
        assert cam.name == name and cam.kind in CAMERA_KINDS and np.isfinite(cam.P).all() and cam.fps > 0
    assert np.isfinite(rec.calibration.floorplan.outline).all() and len(rec.calibration.floorplan.outline) >= 3
    assert all(isinstance(k, str) for k in rec.calibration.noise)
    for tables in (rec.observations.tables, rec.truth.tables):
        for kind, df in tables.items():
            check_table(kind, df)
            if len(df):
                for c in df.columns:
                    if c in STRING_COLUMNS:
                        assert all(isinstance(v, str) for v in df[c])
                    elif c in FLAG_COLUMNS:
                        assert set(np.unique(df[c].to_numpy())) <= {0, 1, False, True}
                if "camera" in df.columns:
                    assert set(df["camera"]) <= set(cams)


def outcome(root, verify: bool):
    try:
        rec = read_recording(root, verify=verify)
    except RecordingError as e:
        msg = str(e)
        assert msg.startswith(str(root)), msg  # names the folder or a file in it
        assert "\n" not in msg and len(msg) > len(str(root)) + 5, msg
        return None
    check_recording(rec)
    return rec


# ----------------------------------------------------------------------------- properties
def test_fixture_reads_back(base):
    check_recording(read_recording(base))


@settings(max_examples=examples(300))
@given(data=st.data())
def test_damaged_recordings_read_or_fail_clearly(base, data):
    root, rel, rehash = data.draw(damaged(base))
    verify = data.draw(st.booleans())
    rec = outcome(root, verify)
    if verify and not rehash and rel != "manifest.json":
        assert rec is None  # a changed file fails its hash check


# ----------------------------------------------------------------------------- regressions
def _replace_table(root, name: str, df: pd.DataFrame) -> None:
    df.to_parquet(root / name, index=False)
    _rehash(root, name)


@pytest.fixture
def copy(base, tmp_path):
    shutil.copytree(base, tmp_path / "rec")
    return tmp_path / "rec"


def test_regression_non_numeric_column(copy):
    """Issue 16: a parquet table with a non-numeric column (and the hash updated) ended in a
    pyarrow/numpy traceback; now one RecordingError naming the file and the column."""
    df = pd.read_parquet(copy / "bearings.parquet")
    df["u"] = df["u"].astype(str)
    _replace_table(copy, "bearings.parquet", df)
    with pytest.raises(RecordingError, match=r"bearings\.parquet: bearings: column 'u' must be numeric"):
        read_recording(copy)


def test_regression_corrupt_parquet_with_hash_updated(copy):
    """Issue 16: a parquet file corrupted with its manifest hash updated ended in a pyarrow
    traceback; now one RecordingError naming the file."""
    data = bytearray((copy / "imu.parquet").read_bytes())
    data[len(data) // 2 : len(data) // 2 + 64] = b"\xff" * 64
    data[-12:-8] = b"\xff\xff\xff\x7f"  # footer length: past the start of the file
    (copy / "imu.parquet").write_bytes(bytes(data))
    _rehash(copy, "imu.parquet")
    with pytest.raises(RecordingError, match=r"imu\.parquet: not a readable Parquet table"):
        read_recording(copy)


def test_regression_corrupt_parquet_on_the_command_line(copy, tmp_path):
    """The same through ``trackroom estimate``: one line on stderr, exit status 2, no traceback."""
    data = bytearray((copy / "imu.parquet").read_bytes())
    (copy / "imu.parquet").write_bytes(bytes(data[: len(data) // 2]))
    _rehash(copy, "imu.parquet")
    repo = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, "-m", "trackroom", "estimate", "--estimator", "ekf", "--out", str(tmp_path / "t.csv"), str(copy)],
                       cwd=repo, capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert lines[0].startswith(f"trackroom estimate: error: {copy / 'imu.parquet'}: not a readable Parquet table")


def test_regression_empty_table(copy):
    """Issue 16: an empty table (no rows, the columns kept) reads as an empty table; one without
    columns, or a 0-byte file (was a pyarrow ArrowInvalid traceback), is refused by name."""
    df = pd.read_parquet(copy / "floor_detections.parquet").iloc[:0]
    _replace_table(copy, "floor_detections.parquet", df)
    rec = read_recording(copy)
    assert len(rec.observations["floor_detections"]) == 0 and not rec.observations.has("floor_detections")
    check_recording(rec)
    _replace_table(copy, "floor_detections.parquet", pd.DataFrame())
    with pytest.raises(RecordingError, match=r"floor_detections\.parquet: floor_detections: missing columns"):
        read_recording(copy)
    (copy / "floor_detections.parquet").write_bytes(b"")
    _rehash(copy, "floor_detections.parquet")
    with pytest.raises(RecordingError, match=r"floor_detections\.parquet: not a readable Parquet table"):
        read_recording(copy)


def test_regression_nan_in_observation_table(copy):
    """Issue 16: NaN in an observation table is refused, naming the file and the column."""
    df = pd.read_parquet(copy / "imu.parquet")
    df.loc[3, "ax"] = np.nan
    _replace_table(copy, "imu.parquet", df)
    with pytest.raises(RecordingError, match=r"imu\.parquet: imu: non-finite values \(NaN or inf\) in columns \['ax'\]"):
        read_recording(copy)


def _edit(rel: str, fn):
    def damage(root):
        p = root / rel
        p.write_text(fn(p.read_text()))
        if rel != "manifest.json":
            _rehash(root, rel)
    return damage


def _edit_json(rel: str, fn):
    def change(text):
        obj = json.loads(text)
        obj = fn(obj)
        return json.dumps(obj)
    return _edit(rel, change)


def _edit_table(rel: str, fn):
    def damage(root):
        _replace_table(root, rel, fn(pd.read_parquet(root / rel)))
    return damage


@pytest.mark.parametrize(
    "damage, problem",
    [
        # found by the suite above; the old behaviour is in the comment
        (_edit("calibration/top.xml", lambda t: t[:300]), r"calibration/top\.xml: not readable as OpenCV"),  # SystemError
        (_edit("calibration/obl.xml", lambda t: re.sub(r"<position .*?</position>", "", t, flags=re.S)),
         r"calibration/obl\.xml: missing position"),  # AttributeError: 'NoneType' has no 'ravel'
        (_edit("calibration/obl.xml", lambda t: t.replace("<kind>oblique</kind>", "")),
         r"obl\.xml: missing kind"),  # accepted: a camera of kind ""
        (_edit("calibration/sensors.json", lambda t: t[:20]), r"sensors\.json: not valid JSON"),  # JSONDecodeError
        (lambda root: (root / "calibration" / "sensors.json").unlink() or _rehash(root, "calibration/sensors.json"),
         r"sensors\.json: missing"),  # FileNotFoundError
        (_edit_json("floorplan.json", lambda d: {k: v for k, v in d.items() if k != "outline"}),
         r"floorplan\.json: outline: expected a list"),  # KeyError: 'outline'
        (_edit_json("floorplan.json", lambda d: {**d, "outline": [[0, 0], [1, {}], [1, 1]]}),
         r"floorplan\.json: outline\[1\]"),  # TypeError in Floorplan.from_dict
        (_edit_json("manifest.json", lambda d: "a string"), r"manifest\.json: expected a JSON object"),  # AttributeError
        (_edit_json("manifest.json", lambda d: {**d, "observations": 5}), r"manifest\.json: observations: expected list"),  # TypeError
        (_edit_json("manifest.json", lambda d: {k: v for k, v in d.items() if k != "duration"}),
         r"manifest\.json: missing key 'duration'"),  # KeyError
        (_edit_table("truth.parquet", lambda df: df.iloc[::-1]), r"truth\.parquet: people: rows are not sorted"),  # accepted
        (_edit_table("truth_visibility.parquet", lambda df: df.drop(columns=["visible"])),
         r"truth_visibility\.parquet: visibility: missing columns \['visible'\]"),  # accepted
        (_edit_table("bearings.parquet", lambda df: df.assign(label=None)), r"bearings\.parquet: bearings: column 'label'"),  # accepted
        (_edit_table("bearings.parquet", lambda df: df.assign(camera=7)), r"bearings\.parquet: bearings: column 'camera'"),  # accepted
        (_edit_table("boxes.parquet", lambda df: df.assign(camera="nowhere")), r"boxes\.parquet: cameras \['nowhere'\]"),  # accepted
        (_edit_table("floor_detections.parquet", lambda df: df.iloc[::-1]),
         r"floor_detections\.parquet: floor_detections: rows are not sorted"),  # the message named no file
    ],
)
def test_regression_recording_defects(copy, damage, problem):
    damage(copy)
    with pytest.raises(RecordingError, match=problem) as e:
        read_recording(copy)
    assert "\n" not in str(e.value)
