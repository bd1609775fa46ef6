"""scripts/check_rendered.py: a re-made recording is compared with the recorded digests of its
tables (same, differs naming the tables and, where recorded, their columns and the numpy SIMD
targets; not recorded), and a folder whose files do not match its
own manifest is one line naming the file."""
from __future__ import annotations

import pytest

from scripts.check_rendered import main
from trackroom.dataset import write_recording
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    root = tmp_path_factory.mktemp("rec")
    scene = load_scene("occlusion_lab")
    for name, draw in (("a", 0), ("again", 0), ("redrawn", 1)):
        write_recording(simulate(scene, 3, 2.0, "analytic", perception_draw=draw), root / name)
    rec = simulate(scene, 3, 2.0, "analytic")
    rec.truth.tables["people"]["yaw"] += 1e-15  # as another CPU's arctan2 may give it
    write_recording(rec, root / "other_cpu")
    return root


def test_a_differing_table_names_its_columns_and_the_simd_targets(recordings, tmp_path, capsys):
    import json

    record = tmp_path / "digests.json"
    assert main([str(recordings / "a"), "--digests", str(record), "--record"]) == 0
    entry = next(iter(json.loads(record.read_text()).values()))
    assert set(entry["columns"]["truth.parquet"]) >= {"x", "y", "yaw", "person_id"}
    assert main([str(recordings / "other_cpu"), "--digests", str(record)]) == 1
    line = capsys.readouterr().out.splitlines()[-1]
    assert line.endswith("differs in truth.parquet (yaw)"), line
    data = json.loads(record.read_text())
    next(iter(data.values()))["simd"] = ["ELSEWHERE"]
    record.write_text(json.dumps(data))
    assert main([str(recordings / "other_cpu"), "--digests", str(record)]) == 1
    line = capsys.readouterr().out.splitlines()[-1]
    assert "differs in truth.parquet (yaw) (recorded -> now: {'numpy SIMD': ('ELSEWHERE', " in line, line


def test_a_remade_recording_is_the_same_and_a_redrawn_one_differs(recordings, tmp_path, capsys):
    record = tmp_path / "digests.json"
    assert main([str(recordings / "a"), "--digests", str(record), "--record"]) == 0
    assert main([str(recordings / "again"), "--digests", str(record)]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith("occlusion_lab seed 3 2 s analytic: same")
    assert main([str(recordings / "redrawn"), "--digests", str(record)]) == 1
    line = capsys.readouterr().out.splitlines()[-1]
    assert ": differs in " in line and "boxes.parquet" in line and "truth.parquet" not in line
    assert main([str(recordings / "a"), "--digests", str(tmp_path / "none.json")]) == 0
    assert capsys.readouterr().out.strip().endswith("not recorded")


def test_a_file_that_does_not_match_its_manifest_is_named(recordings, tmp_path):
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(recordings / "a", bad)
    (bad / "boxes.parquet").write_bytes(b"not a table")
    with pytest.raises(SystemExit, match=r"^check_rendered: .*bad: file boxes.parquet does not match its hash in the manifest"):
        main([str(bad), "--digests", str(tmp_path / "digests.json")])
