"""scripts/trace_tp_track.py: the frame trace of one target_planes track."""
from __future__ import annotations

import pytest

from scripts import trace_tp_track as tt
from trackroom.dataset import write_recording
from trackroom.estimators import tp_joint
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate


@pytest.fixture(scope="module")
def rec_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("trace") / "rec"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 6.0, "analytic"), out)
    return str(out)


def test_a_trace_has_every_frame_in_range_and_puts_the_tracker_back(rec_dir):
    before = (tp_joint.JointTracker.step, tp_joint.JointTracker.explain_camera)
    lines = tt.trace(rec_dir, 0, 2.0, 2.3)
    assert (tp_joint.JointTracker.step, tp_joint.JointTracker.explain_camera) == before
    heads = [ln for ln in lines if ln.startswith("t ")]
    assert [h.split()[1] for h in heads] == ["2.00", "2.10", "2.20", "2.30"]  # 10 fps, both ends included
    afters = [ln for ln in lines if ln.lstrip().startswith("after:")]
    truths = [ln for ln in lines if ln.lstrip().startswith("truth:")]
    assert len(afters) == len(truths) == 4 and all("target" in ln for ln in truths)
    assert any(ln.startswith("    obl_") and "projection u" in ln and "explained" in ln for ln in lines)
    # a frame starts from where the previous one ended: the state printed after frame k is the
    # state printed before frame k + 1 (the same track, nothing in between)
    for a, h in zip(afters[:-1], heads[1:]):
        assert a.split("after:")[1].split(" mode ")[0].strip() == h.split("before:")[1].strip()


def test_a_track_that_does_not_exist_says_so(rec_dir, capsys):
    assert tt.main([rec_dir, "--from", "1", "--to", "2", "--track", "999"]) == 1
    assert "track 999 does not exist between 1 and 2 s" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="must not be before"):
        tt.trace(rec_dir, 0, 2.0, 1.0)
