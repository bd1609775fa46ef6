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


@pytest.mark.parametrize("doc", ["format.md", "scenes.md", "api.md"])
def test_readme_links_reference_docs(doc):
    assert f"](docs/{doc})" in (ROOT / "README.md").read_text()
