"""The reference docs stay true: docs/api.md's examples run, docs/scenes.md lists every scene key.

- ``test_api_examples_run``: every ```python block of docs/api.md, in order, in one namespace, in
  a fresh temporary folder, in a child process (so the estimator it registers and the files it
  writes stay out of this test session); a failure names the block and shows its traceback.
- ``test_scenes_doc_lists_every_key``: every key the scene loader accepts
  (``trackroom.scenes.loader.KEYS``, the sets the validator checks against) appears in the table
  of its section of docs/scenes.md, and every key documented there is one the loader accepts.
- ``test_format_doc_lists_every_column``: every column of every table in the recording contract
  (``trackroom.recording``) and of the tracks table appears in docs/format.md.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

# Runs in the child: exec each block in one namespace; on failure print the block number and
# its traceback, exit 1.
RUNNER = r"""
import json, sys, traceback
blocks = json.load(sys.stdin)
ns = {"__name__": "__main__"}
for i, src in enumerate(blocks, 1):
    try:
        exec(compile(src, f"docs/api.md block {i}", "exec"), ns)
    except BaseException:
        print(f"\n*** docs/api.md: python block {i} of {len(blocks)} failed:", file=sys.stderr)
        traceback.print_exc()
        sys.exit(1)
print(f"ran {len(blocks)} blocks")
"""


def python_blocks(text: str) -> list[str]:
    """The bodies of the fenced ```python blocks of a Markdown text, in order."""
    return re.findall(r"^```python[^\n]*\n(.*?)^```", text, flags=re.S | re.M)


def test_python_blocks_are_found():
    text = "a\n```python\nx = 1\n```\ntext\n```bash\nls\n```\n```python\ny = x + 1\n```\n"
    assert python_blocks(text) == ["x = 1\n", "y = x + 1\n"]


def test_api_examples_run(tmp_path):
    import json

    blocks = python_blocks((DOCS / "api.md").read_text())
    assert len(blocks) >= 6, "docs/api.md should hold the runnable examples"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MUJOCO_GL="egl")
    proc = subprocess.run(
        [sys.executable, "-c", RUNNER], input=json.dumps(blocks), cwd=tmp_path, env=env,
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    assert f"ran {len(blocks)} blocks" in proc.stdout


def test_api_example_failure_names_the_block(tmp_path):
    """The runner reports which block broke (so a broken example is easy to find)."""
    import json

    proc = subprocess.run(
        [sys.executable, "-c", RUNNER], input=json.dumps(["x = 1\n", "y = x / 0\n"]), cwd=tmp_path,
        capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 1
    assert "python block 2 of 2 failed" in proc.stderr and "ZeroDivisionError" in proc.stderr


def doc_sections(text: str) -> dict[str, str]:
    """Sections of docs/scenes.md by the TOML table named in their ``## `[...]` `` heading."""
    out = {}
    for m in re.finditer(r"^## `\[\[?([a-z_.]+)\]\]?`.*?$(.*?)(?=^## |\Z)", text, flags=re.S | re.M):
        out[m.group(1)] = m.group(2)
    return out


def table_keys(section: str) -> set[str]:
    """Keys in the first column of the section's Markdown tables: rows starting ``| `key` |``."""
    return set(re.findall(r"^\| `([a-z_]+)` \|", section, flags=re.M))


def scenes_doc_problems(text: str, keys_by_table: dict[str, frozenset[str]]) -> list[str]:
    """What docs/scenes.md (``text``) misses or invents against the loader's key sets."""
    sections = doc_sections(text)
    problems = []
    for table, keys in keys_by_table.items():
        if table == "":  # the top-level keys are the tables themselves
            problems += [f"no section for [{k}]" for k in sorted(keys) if k not in sections]
            continue
        if table not in sections:
            problems.append(f"no section for [{table}]")
            continue
        documented = table_keys(sections[table])
        problems += [f"[{table}] {k}: accepted by the loader, not documented" for k in sorted(keys - documented)]
        problems += [f"[{table}] {k}: documented, not accepted by the loader" for k in sorted(documented - keys)]
    problems += [f"section [{s}] is not a table of the scene language" for s in sorted(set(sections) - set(keys_by_table))]
    return problems


def test_scenes_doc_lists_every_key():
    from trackroom.scenes.loader import KEYS

    problems = scenes_doc_problems((DOCS / "scenes.md").read_text(), KEYS)
    assert not problems, "\n".join(problems)


def test_scenes_doc_check_catches_missing_and_invented_keys():
    keys = {"": frozenset({"room"}), "room": frozenset({"outline", "wall_height"})}
    good = "## `[room]`\n\n| key | type |\n| --- | --- |\n| `outline` | points |\n| `wall_height` | float |\n"
    assert scenes_doc_problems(good, keys) == []
    missing = good.replace("| `wall_height` | float |\n", "")
    assert scenes_doc_problems(missing, keys) == ["[room] wall_height: accepted by the loader, not documented"]
    invented = good + "| `colour` | string |\n"
    assert scenes_doc_problems(invented, keys) == ["[room] colour: documented, not accepted by the loader"]
    assert scenes_doc_problems("", keys) == ["no section for [room]", "no section for [room]"]


def test_scenes_doc_examples_load():
    """The first ```toml block of docs/scenes.md is a whole scene; every later one is a fragment
    that, added to it (in a larger room), still loads."""
    import tomllib

    from trackroom.scenes.loader import parse_scene

    blocks = re.findall(r"^```toml\n(.*?)^```", (DOCS / "scenes.md").read_text(), flags=re.S | re.M)
    assert len(blocks) >= 5
    base = tomllib.loads(blocks[0])
    parse_scene(base, "docs/scenes.md block 1")
    base["room"]["outline"] = [[0, 0], [20, 0], [20, 10], [0, 10]]
    for i, block in enumerate(blocks[1:], 2):
        raw = {k: (list(v) if isinstance(v, list) else dict(v)) for k, v in base.items()}
        for k, v in tomllib.loads(block).items():
            if isinstance(v, list):
                raw[k] = raw.get(k, []) + v
            else:
                raw[k] = {**raw.get(k, {}), **v}
        parse_scene(raw, f"docs/scenes.md block {i}")


def test_format_doc_lists_every_column():
    from trackroom.estimators.base import OPTIONAL_TRACK_COLUMNS, TRACK_COLUMNS
    from trackroom.recording import OBSERVATION_COLUMNS, TRUTH_COLUMNS

    text = (DOCS / "format.md").read_text()
    documented = set(re.findall(r"^\| `([a-z_0-9]+)` \|", text, flags=re.M))
    wanted = {c for cols in (*OBSERVATION_COLUMNS.values(), *TRUTH_COLUMNS.values()) for c in cols}
    wanted |= set(TRACK_COLUMNS) | set(OPTIONAL_TRACK_COLUMNS) | {"width"}  # width: rendered bearings
    assert not sorted(wanted - documented), f"columns not documented in docs/format.md: {sorted(wanted - documented)}"


def format_doc_tables(text: str) -> dict[str, dict[str, str]]:
    """docs/format.md's tables by the file named in their ``### `...` `` heading: {name: {column:
    dtype or type}} (rows ``| `name` | dtype | ...``)."""
    out = {}
    for m in re.finditer(r"^##+ `([a-z_./<>]+)`.*?$(.*?)(?=^##|\Z)", text, flags=re.S | re.M):
        out[m.group(1)] = dict(re.findall(r"^\| `([A-Za-z_0-9]+)` \|\s*([^|]*?)\s*\|", m.group(2), flags=re.M))
    return out


def _doc_dtype(series) -> str:
    import pandas as pd

    if pd.api.types.is_bool_dtype(series):
        return "bool"
    if pd.api.types.is_integer_dtype(series):
        return "int64"
    if pd.api.types.is_float_dtype(series):
        return "float64"
    return "string"


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Short recordings of every observation kind: analytic overhead_lab (with a phoneless
    walker), occlusion_lab and bearing_hall, and a rendered occlusion_lab (boxes, labels)."""
    from trackroom.dataset import write_recording
    from trackroom.scenes import load_scene
    from trackroom.sim.simulate import simulate

    root = tmp_path_factory.mktemp("format")
    runs = [("overhead_lab", ["walkers.count=2", "walkers.phoneless=1"], "analytic"),
            ("occlusion_lab", [], "analytic"), ("bearing_hall", [], "analytic"), ("occlusion_lab", [], "rendered")]
    out = []
    for name, overrides, sensing in runs:
        rec = simulate(load_scene(name, overrides), seed=0, duration=1.0, sensing=sensing)
        out.append(write_recording(rec, root / f"{name}_{sensing}"))
    return out


def test_format_doc_matches_real_recordings(recordings):
    """Every file, column (with its dtype), XML node, sensors.json key and manifest key of real
    recordings is in docs/format.md, and nothing documented there is missing from them (columns
    marked "rendered only" need only appear in rendered recordings)."""
    import json

    import cv2
    import pandas as pd

    text = (DOCS / "format.md").read_text()
    tables = format_doc_tables(text)
    problems, seen = [], {}
    for folder in recordings:
        manifest = json.loads((folder / "manifest.json").read_text())
        rendered = manifest["sensing"] == "rendered"
        for path in sorted(folder.rglob("*")):
            rel = str(path.relative_to(folder))
            if path.is_dir():
                continue
            generic = "calibration/<camera>.xml" if rel.endswith(".xml") else rel
            if f"`{generic}`" not in text:
                problems.append(f"{folder.name}: file {rel} is not documented")
            if path.suffix == ".parquet":
                df = pd.read_parquet(path)
                doc = tables.get(rel, {})
                for c in df.columns:
                    if c not in doc:
                        problems.append(f"{rel}: column {c} not documented")
                    elif len(df) and doc[c] != _doc_dtype(df[c]):
                        problems.append(f"{rel}: column {c} is {_doc_dtype(df[c])}, documented {doc[c]}")
                for c in doc:
                    seen.setdefault(rel, set()).add(c) if c in df.columns else None
        for xml in sorted((folder / "calibration").glob("*.xml")):
            fs = cv2.FileStorage(str(xml), cv2.FILE_STORAGE_READ)
            nodes = set(fs.root().keys())
            fs.release()
            doc = set(tables["calibration/<camera>.xml"])
            problems += [f"{xml.name}: node {n} not documented" for n in sorted(nodes - doc)]
            problems += [f"{xml.name}: documented node {n} not written" for n in sorted(doc - nodes)]
        noise = json.loads((folder / "calibration" / "sensors.json").read_text())
        problems += [f"sensors.json: key {k} not documented" for k in sorted(set(noise) - set(tables["calibration/sensors.json"]))]
        seen.setdefault("calibration/sensors.json", set()).update(noise)
        doc_manifest = set(tables["manifest.json"])
        problems += [f"manifest.json: key {k} not documented" for k in sorted(set(manifest) - doc_manifest)]
        problems += [f"manifest.json: documented key {k} not written" for k in sorted(doc_manifest - set(manifest))]
        problems += [f"manifest.json meta: key {k} not documented" for k in sorted(manifest["meta"])
                     if k not in tables["meta"] and f"`meta.{k}`" not in text]
        gt = pd.read_csv(folder / "gt_world.csv")
        if list(gt.columns) != list(tables["gt_world.csv"]):
            problems.append(f"gt_world.csv columns {list(gt.columns)}, documented {list(tables['gt_world.csv'])}")
    never = sorted(set(tables["calibration/sensors.json"]) - seen.get("calibration/sensors.json", set()))
    problems += [f"sensors.json: documented key {k} written by no recording" for k in never]
    for rel, doc in tables.items():
        if rel.endswith(".parquet"):
            never = sorted(set(doc) - seen.get(rel, set()))
            problems += [f"{rel}: documented column {c} appears in no recording" for c in never]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("doc", ["format.md", "scenes.md", "api.md"])
def test_readme_links_reference_docs(doc):
    assert f"](docs/{doc})" in (ROOT / "README.md").read_text()
