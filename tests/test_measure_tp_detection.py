"""scripts/measure_tp_detection.py: the flow windows' detection of movers, and (``--slowing``) how
it fades as a mover comes to a stop."""
import numpy as np
import pandas as pd

from scripts.measure_tp_detection import BORDER_COLUMNS, COLUMNS, border_rows, border_table, main, recording_rows, slowing_table


def _rows(gs, dgs, det, hid=False, near=False):
    n = len(gs)
    return pd.DataFrame({"rec": "r", "t": np.arange(n) / 10.0, "cam": "c", "pid": "target", "speed": 10.0, "hid": hid,
                         "near": near, "det": det, "overlap": det, "cover": 0.0, "walking": True, "gs": gs, "dgs": dgs},
                        columns=COLUMNS)


def test_the_slowing_table_splits_by_motion_and_speed_and_leaves_hidden_movers_out():
    df = pd.concat([_rows([0.05] * 4, [-0.1] * 4, [True, False, False, True]),   # slowing, under 0.1 m/s: 2 of 4
                    _rows([0.05] * 5, [0.0] * 5, [False] * 5),                     # steady (standing): none
                    _rows([1.0] * 3, [0.0] * 3, [True] * 3),                       # steady walking: all
                    _rows([0.05] * 6, [-0.1] * 6, [True] * 6, hid=True)])          # hidden: not counted
    tab = slowing_table(df)
    slow = tab.loc[("slowing", pd.Interval(0.0, 0.1))]
    assert slow["n"] == 4 and slow["p_window"] == 0.5
    assert tab.loc[("steady", pd.Interval(0.0, 0.1)), "p_window"] == 0.0
    assert tab.loc[("steady", pd.Interval(0.8, 2.0)), "p_window"] == 1.0
    assert tab["n"].sum() == 12


def test_a_short_analytic_recording_counts_standing_frames_only_when_asked(tmp_path, capsys):
    """On a short analytic occlusion_lab recording: the walking rows are a subset of ``--slowing``'s
    rows (which add the movers' frames standing or not yet walking), the script prints its
    detection rate and, asked, the table by ground speed."""
    from trackroom.dataset import write_recording
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    out = tmp_path / "rec"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 6.0, "analytic"), out)
    walk = pd.DataFrame(recording_rows(out), columns=COLUMNS)
    every = pd.DataFrame(recording_rows(out, slowing=True), columns=COLUMNS)
    assert len(walk) and walk.walking.all()
    assert len(every) > len(walk) and (~every.walking).any()
    assert main([str(out), "--slowing"]) == 0
    text = capsys.readouterr().out
    assert "P(window on axis)" in text and "by ground speed" in text


def test_the_border_table_bins_by_the_columns_inside_the_image():
    """``--border``: rows binned by the mover's cylinder columns inside the image; a sliver of
    0.5 px and one of 2.5 px fall in different bands, a walker seen whole in the last."""
    df = pd.DataFrame([("r", "c", "target", 0.1 * i, px, det) for i, (px, det) in
                       enumerate([(0.5, False), (0.5, False), (2.5, True), (2.5, False), (30.0, True)])], columns=BORDER_COLUMNS)
    tab = border_table(df)
    assert tab.loc[pd.Interval(0.0, 1.0), "p_window"] == 0.0 and tab.loc[pd.Interval(0.0, 1.0), "n"] == 2
    assert tab.loc[pd.Interval(2.0, 3.0), "p_window"] == 0.5
    assert tab.loc[pd.Interval(12.0, np.inf), "p_window"] == 1.0
    assert tab["n"].sum() == 5


def test_border_rows_of_a_short_recording_are_movers_partly_or_wholly_in_the_image(tmp_path, capsys):
    """On a short analytic occlusion_lab recording every border row has a positive span inside
    the image, no wider than an image, and ``--border`` prints the table by that span."""
    from trackroom.dataset import write_recording
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    out = tmp_path / "rec"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 6.0, "analytic"), out)
    df = pd.DataFrame(border_rows(out), columns=BORDER_COLUMNS)
    assert len(df) and (df.inside_px > 0).all() and (df.inside_px <= 640).all()
    assert set(df.pid) <= {"target", "distractor"}
    assert main([str(out), "--border"]) == 0
    assert "by its columns inside the image" in capsys.readouterr().out
