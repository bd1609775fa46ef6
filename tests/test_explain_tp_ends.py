"""scripts/explain_tp_ends.py: target_planes' dropped tracks read against the truth."""
import numpy as np
import pytest
import pandas as pd

from scripts.explain_tp_ends import ends_against_truth, matched_cover

T = np.round(np.arange(0, 6.0, 0.1), 1)


def people(**paths) -> pd.DataFrame:
    """The truth: name -> (len(T), 2) positions."""
    return pd.concat([pd.DataFrame({"t": T, "person_id": n, "x": p[:, 0], "y": p[:, 1]}) for n, p in paths.items()], ignore_index=True)


def tracks(**paths) -> pd.DataFrame:
    """The tracker's internal tracks: 'tN' -> (positions, last frame index)."""
    rows = []
    for name, (p, last) in paths.items():
        rows += [(T[k], int(name[1:]), p[k, 0], p[k, 1]) for k in range(last + 1)]
    return pd.DataFrame(rows, columns=["t", "track_id", "x", "y"])


def end(track: int, k: int, where, reason="duplicate") -> pd.DataFrame:
    return pd.DataFrame([(T[k], track, where[0], where[1], reason, 0)], columns=["t", "track_id", "x", "y", "reason", "other"])


def walk(a, v):
    return np.asarray(a, float) + np.outer(T, v)


def still(a):
    return np.tile(np.asarray(a, float), (len(T), 1))


def test_people_and_tracks_are_matched_one_to_one_within_half_a_metre():
    p = pd.DataFrame({"x": [0.0, 0.4, 5.0], "y": [0.0, 0.0, 5.0]}, index=["a", "b", "c"])
    o = pd.DataFrame({"x": [0.2], "y": [0.0]}, index=[7])
    cov = matched_cover(p, o)
    assert sorted(k for k, v in cov.items() if np.isfinite(v)) in (["a"], ["b"])  # one track, one person
    assert np.isinf(cov["c"])
    assert all(np.isinf(v) for v in matched_cover(p, o.iloc[:0]).values())


def test_a_track_on_no_one_is_a_ghost():
    truth = people(target=walk([1.0, 1.0], [0.5, 0.0]))
    ghost = still([4.0, 4.0])
    rows = ends_against_truth(truth, tracks(t0=(walk([1.0, 1.0], [0.5, 0.0]), 59), t3=(ghost, 30)), end(3, 30, ghost[30], "existence"))
    assert [r["class"] for r in rows] == ["ghost"]


def test_a_second_track_on_a_person_still_followed_is_no_loss():
    """Tracks 0 and 2 follow the target, 2 is dropped as a duplicate: the target stays tracked. A
    person standing 1 m off, whom no track ever followed, does not count as left untracked."""
    tgt = walk([1.0, 1.0], [0.5, 0.0])
    truth = people(target=tgt, standing=still([2.5, 2.0]))
    rows = ends_against_truth(truth, tracks(t0=(tgt, 59), t2=(tgt + [0.05, 0.0], 30)), end(2, 30, tgt[30]))
    assert [(r["class"], r["who"]) for r in rows] == [("second track", "target")]
    assert rows[0]["apart"] == round(float(np.hypot(2.5 - tgt[30, 0], 2.0 - tgt[30, 1])), 2)
    assert rows[0]["cover_1s"] < 0.01


def test_two_tracks_drawn_onto_one_person_leave_the_other_untracked():
    """The pattern of fresh analytic 903: the look-alike stands 0.6 m from the target; the
    target's track 0 is drawn onto it and the look-alike's own track 1 dropped as its duplicate:
    the target is left untracked, and the end is counted against it."""
    tgt = walk([1.0, 1.0], [0.2, 0.0])
    look = still([2.0, 1.6])  # 0.6 m from the target at 3 s (k = 30)
    drawn = tgt.copy()
    drawn[25:] = look[25:] + [0.05, 0.0]  # track 0 leaves the target for the look-alike at 2.5 s
    truth = people(target=tgt, distractor=look)
    rows = ends_against_truth(truth, tracks(t0=(drawn, 59), t1=(look, 30)), end(1, 30, look[30]))
    assert [(r["class"], r["who"], r["other"]) for r in rows] == [("person untracked", "target", 0)]  # a duplicate of track 0
    assert np.isinf(rows[0]["cover_1s"])
    assert rows[0]["apart"] == 0.72  # the people 0.72 m apart at 3 s: a track drawn over, not one person seen twice
    # the same with track 0 staying on the target: the look-alike is left untracked instead
    rows = ends_against_truth(truth, tracks(t0=(tgt, 59), t1=(look, 30)), end(1, 30, look[30], "existence"))
    assert [(r["class"], r["who"], r["speed"], r["other"]) for r in rows] == [("person untracked", "distractor", 0.0, None)]


def test_the_command_on_a_recording_without_dropped_tracks(occlusion_lab_6s, capsys):
    """End to end on a short analytic recording (conftest: 6 s, in which the tracker drops no
    confirmed track)."""
    from scripts.explain_tp_ends import main

    assert main([occlusion_lab_6s]) == 0
    assert "1 recordings: no confirmed track dropped" in capsys.readouterr().out


def test_the_command_counts_and_lists_the_people_left_untracked(monkeypatch, tmp_path, capsys):
    """The command's summary and CSV for a run with the 903 pattern (the tracker's record given
    by hand): one duplicate end, a person left untracked, listed with where it happened."""
    from types import SimpleNamespace

    import scripts.explain_tp_ends as cmd

    tgt = walk([1.0, 1.0], [0.2, 0.0])
    look = still([2.0, 1.6])
    drawn = tgt.copy()
    drawn[25:] = look[25:] + [0.05, 0.0]
    # the truth's visibility: the target seen by ne at the end (3.0 s), by no oblique camera 1 s later
    vis = pd.DataFrame([(3.0, "ne", "target", True, True), (3.0, "sw", "target", True, False), (4.0, "ne", "target", False, False),
                        (4.0, "sw", "target", True, False), (4.0, "top", "target", True, True)],
                       columns=["t", "camera", "person_id", "in_fov", "visible"])
    rec = SimpleNamespace(seed=903, truth=SimpleNamespace(people=people(target=tgt, distractor=look), visibility=vis),
                          calibration=SimpleNamespace(cameras_of_kind=lambda *kinds: {"ne": None, "sw": None}))
    res = SimpleNamespace(internal=tracks(t0=(drawn, 59), t1=(look, 30)), ends=end(1, 30, look[30]), times=np.arange(60) * 0.1)
    monkeypatch.setattr(cmd, "read_recording", lambda d: rec)
    monkeypatch.setattr(cmd, "run_target", lambda r, params=None: res)
    monkeypatch.setattr("trackroom.dataset.read_manifest", lambda d: {})  # the folder check: "somewhere" stands for a recording
    out = tmp_path / "ends.csv"
    assert cmd.main(["somewhere", "--csv", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "1 recordings, 1 confirmed tracks dropped" in printed
    assert "seed  903 t   3.0 s  track 1 (duplicate of track 0) at (2.00, 1.60)  target" in printed
    assert "seen by 1 cameras, 1 s later 0" in printed  # the overhead camera "top" is not the tracker's
    df = pd.read_csv(out)
    assert df[["seed", "reason", "other", "who", "class"]].values.tolist() == [[903, "duplicate", 0, "target", "person untracked"]]


def test_views_count_the_cameras_that_saw_the_person_by_the_truth():
    """``views_at``: the tracker's cameras whose truth says they saw the person in the frame
    nearest t; someone below one camera's image and hidden in the other counts 0; without the
    truth's visibility there is no count."""
    from scripts.explain_tp_ends import views_at

    vis = pd.DataFrame([(2.0, "ne", "a", True, True), (2.0, "sw", "a", True, True), (2.0, "ne", "b", True, False),
                        (2.1, "ne", "a", True, False), (2.1, "sw", "a", False, False)],
                       columns=["t", "camera", "person_id", "in_fov", "visible"])
    assert views_at(vis, ["ne", "sw"], "a", 2.0) == 2
    assert views_at(vis, ["ne"], "a", 2.02) == 1
    assert views_at(vis, ["ne", "sw"], "a", 2.1) == 0
    assert views_at(vis, ["ne", "sw"], "b", 2.0) == 0
    assert views_at(vis.iloc[:0], ["ne"], "a", 2.0) is None
    assert views_at(None, ["ne"], "a", 2.0) is None
    assert views_at(vis, ["ne"], "a", 5.0) is None  # no frame of the truth then


def test_the_existence_log_counts_the_frames_from_the_accept_bound_to_a_drop(occlusion_lab_6s):
    """``ExistenceLog`` keeps each track's existence after each frame's update, one frame index
    a ``step``; ``fall`` is the frames from the last frame at the accept bound to the drop's frame
    (None: never at the bound by then); the tracker's methods are put back."""
    import numpy as np

    from scripts import experiment_tsutsui as ts
    from scripts.explain_tp_ends import ExistenceLog, fall_bin
    from trackroom.dataset import read_recording
    from trackroom.estimators import tp_joint

    JT = tp_joint.JointTracker
    before = (JT.step, JT.__dict__["existence"], JT.walk_evidence)
    log = ExistenceLog()
    try:
        res = ts.run_target(read_recording(occlusion_lab_6s))
    finally:
        log.close()
    assert (JT.step, JT.__dict__["existence"], JT.walk_evidence) == before
    assert log.k + 1 == len(res.times)  # one step a frame
    target = log.exist[0]
    assert target and all(e <= tp_joint.EXIST_ACCEPT + 1e-9 for e in target.values())
    assert max(target.values()) == tp_joint.EXIST_ACCEPT  # the target's track reaches the bound
    k_first = min(k for k, e in target.items() if e >= tp_joint.EXIST_ACCEPT)
    assert log.fall(0, k_first) == 0 and log.fall(0, k_first - 1) is None and log.fall(999, 10) is None
    # the standing probability and the cameras its projection fell in, every frame it has an existence
    assert log.mu.keys() == log.in_image.keys() == log.exist.keys()
    assert all(log.mu[t].keys() == log.in_image[t].keys() == log.exist[t].keys() for t in log.exist)
    assert all(0.0 <= m <= 1.0 for t in log.mu for m in log.mu[t].values())
    n_cams = len(read_recording(occlusion_lab_6s).calibration.cameras_of_kind("oblique"))
    assert all(0 <= n <= n_cams for t in log.in_image for n in log.in_image[t].values())
    assert max(log.in_image[0].values()) >= 2  # the target's track: seen by two cameras or more
    # each camera's share of the evidence, in the frames the track's existence was updated: a
    # camera the track's projection falls in has one (the cameras out of view: none)
    assert set(log.evidence[0]) <= set(log.exist[0]) and len(log.evidence[0]) >= 0.9 * len(log.exist[0])
    assert all(len(ev) <= log.in_image[0][k] for k, ev in log.evidence[0].items())
    assert any(v > 0 for ev in log.evidence[0].values() for v in ev.values())  # its own windows speak for it
    log.exist[7] = {10: 4.0, 11: tp_joint.EXIST_ACCEPT, 12: 0.2, 13: -2.7, 14: -7.0}  # 4115's track: three frames
    log.mu[7] = {10: 0.9, 11: 0.0, 12: 0.0, 13: 0.4, 14: 0.1}
    log.in_image[7] = {10: 0, 11: 3, 12: 2, 13: 1, 14: 2}
    assert log.fall(7, 14) == 3 and log.fall(7, 11) == 0 and log.fall(7, 10) is None
    assert log.during_fall(7, 14) == (0.4, 1)  # frames 12-14, not 10-11
    assert log.during_fall(7, 11) is None and log.during_fall(7, 10) is None
    log.evidence[7] = {11: {"ne": -3.0}, 12: {"ne": -1.0, "sw": 0.5}, 13: {"sw": -2.0}, 14: {}}
    assert log.fall_misses(7, 14) == [(12, "ne", -1.0), (13, "sw", -2.0)]  # frame 11 (at the bound) not counted
    assert log.fall_misses(7, 11) == [] and log.fall_misses(7, 10) == []
    assert [fall_bin(x) for x in (3, 4, 10, 11, None, np.nan)] == ["1-3", "4-10", "4-10", "11+", "never at the bound", "never at the bound"]


def test_the_command_counts_the_falls_by_the_trackers_own_standing_and_views(monkeypatch, tmp_path, capsys):
    """For each existence drop the CSV has the fall's highest standing probability and fewest
    cameras (the log's ``during_fall``, by the drop's frame index) and its cameras' evidence
    against it split by the truth's visibility of the person, and the summary counts the falls by
    them: a standing look-alike's track dropped (person untracked) and a ghost."""
    from types import SimpleNamespace

    import scripts.explain_tp_ends as cmd

    tgt = walk([1.0, 1.0], [0.2, 0.0])
    look = still([2.0, 1.6])
    ghost = still([5.0, 5.0])
    # the look-alike seen by ne at frame 28, in sw's image but hidden there, out of sw's image at 29;
    # no row for ne at 30 (out of its image)
    vis = pd.DataFrame([(T[28], "ne", "distractor", True, True), (T[28], "sw", "distractor", True, False),
                        (T[29], "ne", "distractor", True, True), (T[29], "sw", "distractor", False, False),
                        (T[28], "ne", "target", True, False)], columns=["t", "camera", "person_id", "in_fov", "visible"])
    rec = SimpleNamespace(seed=4115, truth=SimpleNamespace(people=people(target=tgt, distractor=look), visibility=vis),
                          calibration=SimpleNamespace(cameras_of_kind=lambda *kinds: {"ne": None, "sw": None}))
    ends = pd.concat([end(1, 30, look[30], "existence"), end(2, 40, ghost[40], "existence")], ignore_index=True)
    res = SimpleNamespace(internal=tracks(t0=(tgt, 59), t1=(look, 30), t2=(ghost, 40)), ends=ends, times=np.arange(60) * 0.1)
    asked = []

    class Log:  # the existence log's record of the two falls
        def fall(self, tid, k_end):
            asked.append((tid, k_end))
            return 3

        def during_fall(self, tid, k_end):
            return {1: (0.8, 1), 2: (0.0, 3)}[tid]

        def fall_misses(self, tid, k_end):
            return {1: [(28, "ne", -1.5), (28, "sw", -1.0), (29, "sw", -2.0), (30, "ne", -0.5)], 2: []}[tid]

        def close(self):
            pass

    monkeypatch.setattr(cmd, "ExistenceLog", Log)
    monkeypatch.setattr(cmd, "read_recording", lambda d: rec)
    monkeypatch.setattr(cmd, "run_target", lambda r, params=None: res)
    monkeypatch.setattr("trackroom.dataset.read_manifest", lambda d: {})
    out = tmp_path / "ends.csv"
    assert cmd.main(["somewhere", "--csv", str(out)]) == 0
    assert sorted(asked) == [(1, 30), (2, 40)]
    df = pd.read_csv(out).set_index("track")
    cols = ["class", "fall", "mu_fall", "in_image", "miss_seen", "miss_hidden", "miss_out"]
    assert df.loc[1, cols].tolist() == ["person untracked", 3, 0.8, 1, -1.5, -1.0, -2.5]
    assert df.loc[2, cols].tolist() == ["ghost", 3, 0.0, 3, 0.0, 0.0, 0.0]
    printed = capsys.readouterr().out
    table = printed.split("the fewest cameras' images its projection fell in):")[1].split("\n\n")[0]
    lines = [ln.split() for ln in table.strip().splitlines()]
    assert lines[0] == ["class", "ghost", "person", "untracked"]
    assert ["likelier", "standing", "1", "0", "1"] in lines and ["likelier", "walking", "2+", "1", "0"] in lines
    assert "seen; in its image but hidden; out of its image:" in printed


def test_a_miss_is_told_by_the_truth_and_set_beside_the_persons_projected_cylinder(occlusion_lab_6s):
    """``truth_view``: seen, hidden (in the image, not visible) or out (not in it, or no row);
    ``miss_rows``: one row per miss of a fall, the track's projected cylinder as the log kept it
    and the person model's at the true position (the tracker's height and radius), so a person
    below the image with the track inside its rows shows as lower than the track."""
    from types import SimpleNamespace

    from scripts.explain_tp_ends import miss_rows, truth_view
    from trackroom.dataset import read_recording
    from trackroom.estimators import tp_geometry as geo

    vis = pd.DataFrame([(2.0, "ne", "a", True, True), (2.0, "sw", "a", True, False), (2.0, "se", "a", False, False)],
                       columns=["t", "camera", "person_id", "in_fov", "visible"])
    assert [truth_view(vis, 2.0, "a", c) for c in ("ne", "sw", "se", "nw")] == ["seen", "hidden", "out", "out"]
    assert truth_view(vis, 2.3, "a", "ne") == "out"  # no frame of the truth then

    cal = read_recording(occlusion_lab_6s).calibration
    c = next(iter(cal.cameras_of_kind("oblique")))
    P = np.asarray(cal.cameras[c].P, float)
    cfg = SimpleNamespace(height=1.7, radius=0.2)
    who = still([2.0, 1.6])
    track_win = geo.cylinder_window(P, np.array([2.5, 2.0]), cfg.height, cfg.radius)
    log = SimpleNamespace(jt=SimpleNamespace(Ps={c: P}, cfg=cfg, widths={c: 320.0}), windows={3: {20: {c: track_win}}})
    vis = pd.DataFrame([(T[20], c, "distractor", False, False)], columns=["t", "camera", "person_id", "in_fov", "visible"])
    rows = miss_rows(log, 3, [(20, c, -1.25)], T, people(distractor=who), vis, "distractor")
    assert len(rows) == 1
    r = rows[0]
    assert (r["t"], r["camera"], r["evidence"], r["truth"], r["image_width"]) == (2.0, c, -1.25, "out", 320.0)
    assert [r[f"track_{n}"] for n in ("left", "right", "top", "bottom")] == pytest.approx(track_win, abs=0.051)
    person_win = geo.cylinder_window(P, np.array([2.0, 1.6]), cfg.height, cfg.radius)
    assert [r[f"person_{n}"] for n in ("left", "right", "top", "bottom")] == pytest.approx(person_win, abs=0.051)
    assert r["person_top"] != r["track_top"]  # two positions, two cylinders
