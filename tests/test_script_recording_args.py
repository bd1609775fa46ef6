"""Every measurement script that reads recording folders checks them all before anything runs
(``trackroom.dataset.recording_folders``): a missing folder ends the command with one line naming
it, nothing printed for the folders before it, and no traceback."""
from __future__ import annotations

import importlib
import runpy
import sys

import pytest

from trackroom.dataset import expand_recordings, recording_folders, write_recording

WITH_MAIN = ["measure_encounters", "measure_own_windows", "measure_window_widths", "explain_tp_mota", "explain_tp_ends",
             "explain_tp_losses", "measure_tp_identity", "measure_flow_errors", "measure_ghost_crossings",
             "measure_tp_detection", "measure_tp_duplicates", "measure_person_detections", "measure_tp_consistency",
             "measure_tp_lag", "explain_tp_errors", "measure_hidden_rows", "measure_edge_heights", "check_rendered"]
AS_MAIN = ["measure_stop_lengths", "measure_window_stops"]  # run as scripts only (no main())


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    d = tmp_path_factory.mktemp("rec") / "seed_3"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 2.0, "analytic"), d)
    return d


def test_globs_expand_sorted_and_a_missing_folder_is_named(good, tmp_path):
    assert expand_recordings([str(good.parent / "seed_*")]) == [str(good)]
    assert expand_recordings([str(tmp_path / "nothing_*")]) == [str(tmp_path / "nothing_*")]
    assert recording_folders([str(good)], "prog") == [str(good)]
    with pytest.raises(SystemExit, match=r"^prog: .*missing: no such recording folder"):
        recording_folders([str(good), str(tmp_path / "missing")], "prog")
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit, match=r"^prog: .*empty: not a trackroom recording \(no manifest.json\)"):
        recording_folders([str(tmp_path / "empty")], "prog")


@pytest.mark.parametrize("name", WITH_MAIN + AS_MAIN)
def test_a_missing_recording_stops_the_script_before_anything_runs(name, good, tmp_path, capsys, monkeypatch):
    missing = str(tmp_path / "missing")
    with pytest.raises(SystemExit) as e:
        if name in AS_MAIN:
            monkeypatch.setattr(sys, "argv", [name, str(good), missing])
            runpy.run_module(f"scripts.{name}", run_name="__main__")
        else:
            importlib.import_module(f"scripts.{name}").main([str(good), missing])
    assert f"{missing}: no such recording folder" in str(e.value.code)
    assert capsys.readouterr().out == ""


@pytest.mark.parametrize("name", ["bench_target_planes", "fig_tsutsui"])
def test_a_missing_recording_given_by_option_is_named(name, tmp_path, capsys):
    missing = str(tmp_path / "missing")
    with pytest.raises(SystemExit) as e:
        importlib.import_module(f"scripts.{name}").main(["--recording", missing])
    assert f"{missing}: no such recording folder" in str(e.value.code)
    assert capsys.readouterr().out == ""
