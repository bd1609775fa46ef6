"""scripts/trace_tp_track.py: the frame trace of one target_planes track."""
from __future__ import annotations

import pytest

from scripts import trace_tp_track as tt
from trackroom.estimators import tp_joint


@pytest.fixture(scope="module")
def rec_dir(occlusion_lab_6s):
    return occlusion_lab_6s


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


def test_the_truth_lines_give_each_persons_columns_in_the_cameras_that_see_them(rec_dir):
    """Each frame's truth is followed by the people's cylinder columns in every oblique camera
    whose image holds part of them: the person model's projection at the true position, the same
    numbers as ``tp_geometry.cylinder_window``."""
    import numpy as np

    from scripts import experiment_tsutsui as ts
    from trackroom.dataset import read_recording
    from trackroom.estimators import tp_geometry as geo

    lines = tt.trace(rec_dir, 0, 2.0, 2.0)
    cols = [ln.strip() for ln in lines if ln.lstrip().startswith("truth in ")]
    assert cols and all(ln.split(":")[0].split()[-1].startswith("obl_") for ln in cols)
    rec = read_recording(rec_dir)
    now = ts.people_at(rec.truth.people, np.array([2.0]))
    target = now[now.person_id == "target"].iloc[0]
    for ln in cols:
        cam = ln.split(":")[0].split()[-1]
        P = np.asarray(rec.calibration.cameras[cam].P, float)
        w = geo.cylinder_window(P, (target.x, target.y), 1.8, 0.2)
        if "target" in ln:
            assert f"target {w[0]:.0f}-{w[1]:.0f}" in ln


def test_updates_are_traced_and_add_up_to_the_frames_change(rec_dir):
    """``--updates``: each Kalman update of the track is a line with how far it moved the state;
    over a frame the position changes of the update lines add up to the step from the predicted
    state (before plus dt times the velocity) to the state after, up to the caps and the mode
    mixing the prediction applies (a few mm here); the tracker's methods are put back after."""
    import numpy as np

    before = {name: getattr(tp_joint.JointTracker, name) for name in tt.UPDATES}
    lines = tt.trace(rec_dir, 0, 2.0, 2.3, updates=True)
    assert {name: getattr(tp_joint.JointTracker, name) for name in tt.UPDATES} == before
    ups = [ln for ln in lines if ln.startswith("      obl_")]
    assert ups and all(any(f" {name}" in ln for name in tt.UPDATES) and " dx " in ln and " dv " in ln for ln in ups)
    assert any("update_plane own share 1.00" in ln for ln in ups)
    assert tt.trace(rec_dir, 0, 2.0, 2.3) == [ln for ln in lines if not ln.startswith("      obl_")]  # the same run otherwise
    # one frame: before + 0.1 v (the prediction) + the updates' dx = after
    frame, blocks = [], []
    for ln in lines:
        if ln.startswith("t ") and frame:
            blocks.append(frame)
            frame = []
        frame.append(ln)
    blocks.append(frame)
    nums = lambda s, key: np.array([float(v) for v in s.split(key)[1].split()[0].split(",")])
    for b in blocks:
        dx = sum((nums(ln, " dx ") for ln in b if ln.startswith("      obl_")), np.zeros(2))
        x0, v0 = nums(b[0], " x "), nums(b[0], " v ")
        x1 = nums(next(ln for ln in b if ln.lstrip().startswith("after:")), " x ")
        if dx.any():
            np.testing.assert_allclose(x0 + 0.1 * v0 + dx, x1, atol=0.02)


def test_an_update_made_inside_another_is_traced_once(rec_dir):
    """``update_own_edge`` makes its plane update through ``update_plane``: the trace shows the
    own-edge update once, not also the plane inside it with the same change."""
    lines = tt.trace(rec_dir, 0, 0.0, 6.0, multi=True, updates=True)
    edges = [k for k, ln in enumerate(lines) if "update_own_edge" in ln]
    assert edges  # this recording's track 0 has a window too wide for it at least once
    for k in edges:
        change = lines[k].split(":", 1)[1]
        assert not ("update_plane" in lines[k - 1] and lines[k - 1].split(":", 1)[1] == change)


def test_costs_give_each_cameras_weighing_and_leave_the_run_alone(rec_dir):
    """``--costs``: after every camera line of the track, its miss cost, P(slow), standing
    probability, its cost alone in each window it gates, and the best explanation's extra cost
    with the track forced to each option. The chosen explanation is one of them (+0.00, every
    other one no cheaper); the run is the same as without the option, and the tracker's methods
    are put back."""
    import re

    before = (tp_joint.JointTracker.step, tp_joint.JointTracker.explain_camera)
    lines = tt.trace(rec_dir, 0, 2.0, 2.3, costs=True)
    assert (tp_joint.JointTracker.step, tp_joint.JointTracker.explain_camera) == before
    cams = [ln for ln in lines if ln.startswith("    obl_")]
    costs = [ln for ln in lines if " costs: miss " in ln]
    assert cams and len(costs) == len(cams)
    for cam, cost in zip(cams, costs):
        assert cost.split()[0] == cam.split(":")[0].strip()  # the same camera, right after its line
        extra = [float(x) for x in re.findall(r"(?:none|\d+) ([+-]\d+\.\d+)", cost.split("forced to window")[1])]
        assert len(extra) >= 1 and min(extra) == 0.0 and all(x >= 0.0 for x in extra)
        assert "none" in cost.split("forced to window")[1]
    assert tt.trace(rec_dir, 0, 2.0, 2.3) == [ln for ln in lines if " costs: miss " not in ln]


def test_the_trace_marks_who_the_cameras_could_not_see(rec_dir, monkeypatch):
    """A person the recording's truth says a camera could not see (``truth_visibility``) is
    marked "(unseen)" in that camera's truth line, and only they; a track the tracker's floor
    plan (``Occluders``) hides from a camera is marked "hidden by the floor plan" on that
    camera's line."""
    import numpy as np

    from trackroom.dataset import read_recording

    lines = tt.trace(rec_dir, 0, 2.0, 4.0)
    vis = read_recording(rec_dir).truth.visibility
    t, marked = None, 0
    for ln in lines:
        if ln.startswith("t "):
            t = float(ln.split()[1])
        elif ln.lstrip().startswith("truth in "):
            cam = ln.split(":")[0].split()[-1]
            now = vis[np.isclose(vis.t, t) & (vis.camera == cam)].set_index("person_id").visible
            words = ln.split(":", 1)[1].split()
            for k, w in enumerate(words):
                if w in now.index:
                    unseen = k + 2 < len(words) and words[k + 2] == "(unseen)"
                    assert unseen == (not now[w]), (t, cam, w)
                    marked += unseen
    assert marked > 0  # the seed-3 recording has people behind the shelf and the desk then
    assert not any("hidden by the floor plan" in ln for ln in lines if ln.startswith("    obl_nw"))
    monkeypatch.setattr(tp_joint.Occluders, "visible", lambda self, c, xy: c != "obl_nw")
    lines = tt.trace(rec_dir, 0, 2.0, 2.3)
    cams = [ln for ln in lines if ln.startswith("    obl_") and "projection u" in ln]
    assert any(ln.startswith("    obl_nw") for ln in cams)
    assert all(("hidden by the floor plan" in ln) == ln.startswith("    obl_nw") for ln in cams)


def _pull_rows(lines: list[str]) -> dict[tuple[str, str], tuple[int, float, float]]:
    """``--pulls``' table: (camera, update) -> (n, position pull, velocity pull)."""
    k = next(i for i, ln in enumerate(lines) if ln.startswith("pulls towards "))
    rows = {}
    for ln in lines[k + 2:]:
        w = ln.split()
        rows[(w[0], " ".join(w[1:-3]))] = (int(w[-3]), float(w[-2]), float(w[-1]))
    return rows


def test_pulls_add_up_each_updates_move_towards_the_person_and_leave_the_run_alone(rec_dir):
    """``--pulls target``: after the frames, one row per (camera, update) with how many updates
    it made and how far they moved the track towards the target, each frame along the unit
    vector from the track (before the frame) to the target; the position pulls are recomputed
    here from the printed update lines and states. The trace before the table is the run
    without the option, and the tracker's methods are put back."""
    import numpy as np

    before = {name: getattr(tp_joint.JointTracker, name) for name in tt.UPDATES}
    lines = tt.trace(rec_dir, 0, 2.0, 2.3, updates=True, pulls="target")
    assert {name: getattr(tp_joint.JointTracker, name) for name in tt.UPDATES} == before
    k = next(i for i, ln in enumerate(lines) if ln.startswith("pulls towards target, 2.00-2.30 s (4 frames)"))
    body = lines[:k]
    assert body == tt.trace(rec_dir, 0, 2.0, 2.3, updates=True)
    rows = _pull_rows(lines)
    assert rows[("-", "motion")][0] == 4
    nums = lambda s, key: np.array([float(v) for v in s.split(key)[1].split()[0].split(",")])
    counts: dict = {}
    pos = 0.0
    u = None
    for i, ln in enumerate(body):
        if ln.startswith("t "):
            # the unit vector from the track before the frame to the target (the frame's truth line)
            x0 = nums(ln, " x ")
            truth = next(x for x in body[i:] if x.lstrip().startswith("truth:"))
            xy = np.array([float(v) for v in truth.split("target ")[1].split()[0].split(",")])
            u = (xy - x0) / np.linalg.norm(xy - x0)
        elif ln.startswith("      obl_"):
            cam, name = ln.split()[0], ln.split()[1].rstrip(":")
            if name == "update_plane":
                name += " " + ln.split()[2]
            counts[(cam, name)] = counts.get((cam, name), 0) + 1
            if u is None:
                raise AssertionError("an update line before its frame's start")
            pos += float(nums(ln, " dx ") @ u)
    assert counts and {key: n for key, (n, _, _) in rows.items() if key != ("-", "motion")} == counts
    table = sum(p for key, (_, p, _) in rows.items() if key != ("-", "motion"))
    assert abs(table - pos) <= 0.002 * len(counts) + 0.01  # printed to 3 and 2 decimals


def test_one_frames_pulls_add_up_to_its_step_towards_the_person(rec_dir):
    """Over one frame the rows (the motion row too: the person's own step counts from the
    second frame) add up to the track's step along the unit vector to the person, read from the
    printed states; an unknown person is refused by name."""
    import numpy as np

    lines = tt.trace(rec_dir, 0, 2.2, 2.2, pulls="target")
    nums = lambda s, key: np.array([float(v) for v in s.split(key)[1].split()[0].split(",")])
    x0 = nums(lines[0], " x ")
    x1 = nums(next(ln for ln in lines if ln.lstrip().startswith("after:")), " x ")
    truth = next(ln for ln in lines if ln.lstrip().startswith("truth:"))
    xy = np.array([float(v) for v in truth.split("target ")[1].split()[0].split(",")])
    u = (xy - x0) / np.linalg.norm(xy - x0)
    total = sum(p for _, p, _ in _pull_rows(lines).values())
    assert abs(total - (x1 - x0) @ u) <= 0.012
    with pytest.raises(SystemExit, match="no true person 'nobody'"):
        tt.trace(rec_dir, 0, 2.2, 2.2, pulls="nobody")


def test_course_axes_rows_add_up_to_the_gaps_change_along_and_across(rec_dir):
    """``--axes course``: the updates' changes summed as vectors and read along the target's
    course over the frames and across it; with the motion row (the track's change outside the
    updates less the target's own step) the rows add up, on each axis, to how much the gap
    closed from the first frame's start to after the last frame, both printed in the header.
    The per-frame table of the same frames need not add up so; the update counts are the same.
    A person who does not move has no course and is refused by name."""
    import numpy as np

    lines = tt.trace(rec_dir, 0, 1.5, 2.5, pulls="target", axes="course")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("pulls along target's course ("))
    head = lines[k]
    nums = [float(w.rstrip(",;m/s")) for w in head.split("):", 1)[1].replace(",", " ").split() if w[0] in "+-"]
    g0, g1 = np.array(nums[:4]), np.array(nums[4:8])  # along, across, velocity along, across
    rows = {}
    for ln in lines[k + 2:]:
        w = ln.split()
        rows[(w[0], " ".join(w[1:-5]))] = (int(w[-5]), np.array([float(v) for v in w[-4:]]))
    assert rows[("-", "motion")][0] == 11 and len(rows) > 1
    total = sum(v for _, v in rows.values())
    assert np.allclose(total, g0 - g1, atol=0.0005 * len(rows) + 0.011)  # rows to 3 decimals, header to 2
    assert abs(total[0]) > 0.001 or abs(total[1]) > 0.001
    per_frame = _pull_rows(tt.trace(rec_dir, 0, 1.5, 2.5, pulls="target"))
    assert {key: n for key, (n, _) in rows.items()} == {key: n for key, (n, _, _) in per_frame.items()}
    still = tt.Tracer(0, moves=True)
    still.close()
    still.states = {0: (np.zeros(4), np.zeros(4)), 1: (np.zeros(4), np.zeros(4))}
    with pytest.raises(SystemExit, match="still did not move"):
        tt.course_table(still, np.array([0.0, 0.1]), _standing(), "still", 0.0, 0.1)


def _standing():
    import pandas as pd

    return pd.DataFrame({"t": [0.0, 0.1], "person_id": ["still"] * 2, "x": [1.0] * 2, "y": [2.0] * 2, "vx": [0.0] * 2, "vy": [0.0] * 2})


def test_course_rows_count_a_move_between_frames_and_add_up_exactly():
    """Hand-made states of three frames, the track moved once between two of them (as the prune
    holds a track inside the walls) and once by an update: the course table has the row
    "between frames" with that move, and its rows add up, along and across, to the gap closed
    (the person walks along +x at 1 m/s; the track starts 0.5 m behind and 0.2 m to the right)."""
    import numpy as np
    import pandas as pd

    tr = tt.Tracer(0, moves=True)
    tr.close()
    s = lambda x, y, vx=1.0, vy=0.0: np.array([x, y, vx, vy])
    tr.states = {0: (s(-0.5, -0.2), s(-0.4, -0.2)), 1: (s(-0.4, -0.1), s(-0.2, -0.1)), 2: (s(-0.2, -0.1), s(-0.1, -0.1))}
    tr.moves = [(1, "obl_ne", "update_plane own", np.array([0.1, 0.0, 0.0, 0.0]))]
    times = np.array([0.0, 0.1, 0.2])
    truth = pd.DataFrame({"t": times, "person_id": "p", "x": times, "y": 0.0, "vx": 1.0, "vy": 0.0})
    lines = tt.course_table(tr, times, truth, "p", 0.0, 0.2)
    assert lines[0].startswith("pulls along p's course (+1.00,+0.00), 0.00-0.20 s (3 frames): gap along +0.50 m, across +0.20 m")
    rows = {}
    for ln in lines[2:]:
        w = ln.split()
        rows[(w[0], " ".join(w[1:-5]))] = np.array([float(v) for v in w[-4:]])
    assert np.allclose(rows[("-", "between frames")], [0.0, 0.1, 0.0, 0.0])  # +0.1 m in y: towards the person's left
    assert np.allclose(rows[("obl_ne", "update_plane own")], [0.1, 0.0, 0.0, 0.0])
    total = sum(rows.values())
    # gap after the last frame: person at (0.2, 0), track at (-0.1, -0.1): along 0.3, across 0.1
    assert np.allclose(total, [0.5 - 0.3, 0.2 - 0.1, 0.0, 0.0], atol=1e-9)
