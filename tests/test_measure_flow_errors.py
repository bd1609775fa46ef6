"""scripts/measure_flow_errors.py: how the flow and centroid errors persist, on synthetic tables."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from scripts.measure_flow_errors import (FRAGMENT_BINS, autocorrelation, corr_time, cut_excess, errors, gain, over_speed_share, persistent_fit, share_table,
                                         short_runs, width_tail)


def _table(values: np.ndarray, speed: float = 50.0) -> pd.DataFrame:
    """One camera track per column of ``values`` (frames down), as ``errors`` returns them."""
    F, P = values.shape
    f, p = np.meshgrid(np.arange(F), np.arange(P), indexing="ij")
    return pd.DataFrame({"rec": "r", "t": f.ravel() / 10.0, "frame": f.ravel(), "camera": "c", "track": p.ravel(), "pid": "target",
                         "speed": speed, "along": values.ravel(), "across": 0.0, "du": values.ravel()})


def test_an_ar1_error_has_its_autocorrelation_and_integrated_time():
    rng = np.random.default_rng(0)
    a = 0.8
    x = np.zeros((3000, 8))
    x[0] = rng.standard_normal(8)
    for k in range(1, len(x)):
        x[k] = a * x[k - 1] + np.sqrt(1 - a * a) * rng.standard_normal(8)
    rho = autocorrelation(_table(x), "along", 20)
    np.testing.assert_allclose(rho[[1, 2, 5]], a ** np.array([1, 2, 5]), atol=0.03)
    assert corr_time(rho) == pytest.approx((1 + a) / (1 - a), rel=0.15)  # 1 + 2 sum a^L
    w, a_fit = persistent_fit(rho)
    assert w == pytest.approx(1.0, abs=0.1) and a_fit == pytest.approx(a, abs=0.03)


def test_runs_of_flows_far_short_of_the_motion_are_counted():
    along = np.zeros((40, 1))
    along[5:12, 0] = -40.0  # a run of 7 frames short by 40 of 50 px/s
    along[20, 0] = -30.0  # a run of one
    along[30, 0] = -10.0  # short, not by more than half
    n, share, run, long_runs = short_runs(_table(along))
    assert (n, long_runs) == (40, 1)
    assert share == pytest.approx(8 / 40) and run == pytest.approx(4.0)


def test_the_flow_error_is_split_by_the_window_share_of_the_person_and_border_cuts_are_left_out():
    rng = np.random.default_rng(1)
    n = 4000
    share = rng.uniform(0.3, 1.2, n)
    e_u = rng.standard_normal(n) * np.where(share < 0.5, 40.0, 2.0)  # fragments: large horizontal errors
    border = rng.uniform(size=n) < 0.2
    e_u[border] = 1000.0  # a border-cut window's error must not reach any bin
    df = pd.DataFrame({"speed": 50.0, "e_u": e_u, "e_v": rng.standard_normal(n), "share": share, "border": border})
    tab = share_table(df).set_index("share")
    assert list(tab.index) == ["0.3-0.5", "0.5-0.7", "0.7-0.85", "0.85-1.15", "1.15-1.5"]
    assert tab["n"].sum() == (~border).sum()
    assert tab.loc["0.3-0.5", "flow_u rsd"] == pytest.approx(40.0, rel=0.15)
    assert tab.loc["0.85-1.15", "flow_u rsd"] == pytest.approx(2.0, rel=0.15)
    assert tab["flow_v rsd"].between(0.8, 1.2).all()
    assert tab.loc["0.3-0.5", "flow_u q90 / speed"] == pytest.approx(1.645 * 40.0 / 50.0, rel=0.15)


def test_the_consistency_probe_reads_the_target_track_and_puts_the_tracker_back(tmp_path, capsys):
    """scripts/measure_tp_consistency.py on a short analytic occlusion_lab recording: it prints
    the target track's error, spread and NEES, the update kinds it saw, and leaves
    ``tp_joint.JointTracker`` as it found it."""
    from scripts import measure_tp_consistency as mc
    from trackroom.dataset import write_recording
    from trackroom.estimators import tp_joint
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    out = tmp_path / "rec"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 10.0, "analytic"), out)
    before = (tp_joint.JointTracker.step, tp_joint.JointTracker.update_plane, tp_joint.JointTracker.update_flow)
    assert mc.main([str(out)]) == 0
    text = capsys.readouterr().out
    assert "NEES position mean" in text and "centroid plane updates" in text and "flow updates" in text
    assert "own centroid-plane innovations" in text and "along-track offset (least squares)" in text
    assert "along-track velocity error median" in text
    assert (tp_joint.JointTracker.step, tp_joint.JointTracker.update_plane, tp_joint.JointTracker.update_flow) == before


def test_innovations_whiteness_pairs_one_camera_frame_by_frame():
    """``measure_tp_consistency.whiteness``: innovations that persist (an AR(1) of coefficient 0.8)
    give a lag-one correlation near 0.8, white ones near 0; a frame missing breaks a pair, and
    another camera's or recording's innovation in the next frame is no pair."""
    from scripts.measure_tp_consistency import whiteness

    rng = np.random.default_rng(3)
    n = 5000
    ar = np.empty(n)
    ar[0] = rng.normal()
    for k in range(1, n):
        ar[k] = 0.8 * ar[k - 1] + 0.6 * rng.normal()
    persistent = [(0, "obl_ne", k, float(v)) for k, v in enumerate(ar)]
    white = [(1, "obl_ne", k, float(v)) for k, v in enumerate(rng.normal(size=n))]
    count, ms, rho, pairs = whiteness(persistent)
    assert count == n and pairs == n - 1 and abs(ms - 1.0) < 0.1 and abs(rho - 0.8) < 0.03
    count, ms, rho, pairs = whiteness(white)
    assert abs(rho) < 0.04
    gaps = [(0, "obl_ne", 0, 1.0), (0, "obl_ne", 2, 1.0), (0, "obl_se", 1, 1.0), (1, "obl_ne", 1, 1.0)]
    assert whiteness(gaps)[3] == 0
    assert whiteness([])[0] == 0


def test_along_offset_recovers_a_lag_from_displacements_along_the_plane_normals():
    """``measure_tp_consistency.along_offset``: planes displaced by (a . m) L plus noise, at every
    angle to the motion, give L back; planes that lag by 0.06 m against states on the truth tell
    the two apart; planes parallel to the motion (a . m = 0) say nothing."""
    from scripts.measure_tp_consistency import along_offset

    rng = np.random.default_rng(5)
    c = np.cos(rng.uniform(0.0, np.pi, 4000))
    planes = -0.06 * c + rng.normal(0.0, 0.03, c.size)
    states = rng.normal(0.0, 0.01, c.size)
    n, lw, ls = along_offset(list(zip(c, planes, states)))
    assert n == 4000 and lw == pytest.approx(-0.06, abs=0.003) and abs(ls) < 0.002
    assert np.isnan(along_offset([(0.0, 0.1, 0.2)])[1])
    assert along_offset([])[0] == 0


def test_gain_is_the_median_flow_over_the_motion_within_the_speed_band():
    """Windows whose flow is 0.9 of the motion (along error -0.1 speed) with a tail of flows far
    short, and windows outside 10-120 px/s that say otherwise: the gain is the median ratio
    within the band."""
    rng = np.random.default_rng(1)
    speed = rng.uniform(12.0, 110.0, 1000)
    along = -0.1 * speed
    along[:150] = -0.7 * speed[:150]  # a tail of flows far short: moves the mean, not the median
    df = pd.DataFrame({"speed": np.r_[speed, 5.0, 200.0], "along": np.r_[along, 4.0, -150.0]})
    assert gain(df) == pytest.approx(0.9, abs=1e-9)
    assert np.isnan(gain(df.iloc[-2:]))


def test_width_tail_recovers_the_gross_width_errors_of_synthetic_windows():
    """Widths drawn from target_planes' width model (a Gaussian core of a tenth of the width; with
    probability 0.03 one edge moved out by a half-normal of 0.34 of the width): the fit at 1.33,
    1.5 and 1.75 gives them back; with no gross errors there is no tail to fit (NaN)."""
    rng = np.random.default_rng(7)
    n = 400_000
    share = 1.0 + 0.1 * rng.standard_normal(n)
    gross = rng.random(n) < 0.03
    share[gross] += np.abs(0.34 * rng.standard_normal(gross.sum()))
    e, sigma = width_tail(pd.Series(share))
    assert abs(e - 0.03) < 0.006 and abs(sigma - 0.34) < 0.04
    e0, s0 = width_tail(pd.Series(1.0 + 0.05 * rng.standard_normal(n)))
    assert np.isnan(e0) and np.isnan(s0)


def test_fragments_are_counted_in_finer_share_bins_with_their_rms_and_big_errors():
    """``--fragments``: the share table from 0 in finer bins, each with its rms horizontal flow
    error (``fragment_flow_sigma`` is sqrt(rms(< 0.5)^2 - rms(0.85-1.15)^2)) and the share of
    errors over 25 px/s."""
    rng = np.random.default_rng(2)
    n = 6000
    share = rng.uniform(0.05, 1.1, n)
    e_u = rng.standard_normal(n) * np.where(share < 0.5, 30.0, 10.0)
    df = pd.DataFrame({"speed": 50.0, "e_u": e_u, "e_v": np.zeros(n), "share": share, "border": False})
    tab = share_table(df, FRAGMENT_BINS).set_index("share")
    assert list(tab.index)[:3] == ["0-0.15", "0.15-0.3", "0.3-0.5"]
    for b in ("0-0.15", "0.15-0.3", "0.3-0.5"):
        assert tab.loc[b, "flow_u rms"] == pytest.approx(30.0, rel=0.1)
        assert tab.loc[b, "|e| > 25"] == pytest.approx(2 * (1 - 0.7977), abs=0.05)  # P(|N(0, 30)| > 25)
    assert tab.loc["0.85-1.15", "flow_u rms"] == pytest.approx(10.0, rel=0.1)


def test_with_fragments_narrow_windows_are_counted_and_the_rest_unchanged(occlusion_lab_6s):
    """``errors(..., fragments=True)`` admits windows that cover 30 % of the narrower of window and
    person: it counts windows under 30 % of their person's width, which the plain count cannot;
    a window counted both ways has the same error (a window that now also lies on a second person
    is left out: it no longer holds exactly one)."""
    key = ["t", "camera", "track"]
    plain = errors(occlusion_lab_6s, 5)
    wide = errors(occlusion_lab_6s, 5, fragments=True)
    assert len(plain) > 0 and (plain["share"] > 0.3).all()
    assert (wide["share"] <= 0.3).any()
    both = plain.merge(wide, on=key, suffixes=("", "_f"))
    assert len(both) >= 0.9 * len(plain)
    np.testing.assert_allclose(both["e_u"], both["e_u_f"])
    np.testing.assert_allclose(both["share"], both["share_f"])


def test_the_share_of_flow_errors_larger_than_the_image_speed_counts_the_size_of_the_error():
    """``--border``'s measure: a window whose flow error (both axes) is larger than the true image
    speed counts, whatever its direction; an empty table has none to count."""
    df = pd.DataFrame({"speed": [50.0, 50.0, 50.0, 20.0, 20.0], "e_u": [60.0, 0.0, 30.0, 0.0, -15.0],
                       "e_v": [0.0, -55.0, 30.0, 10.0, -15.0]})
    assert over_speed_share(df) == pytest.approx(3 / 5)  # 60, 55 > 50 and hypot(15, 15) > 20; hypot(30, 30) < 50, 10 < 20
    assert np.isnan(over_speed_share(df.iloc[:0]))


def test_a_cut_windows_excess_error_counts_its_spread_and_its_shortfall_over_the_speed():
    """``cut_excess`` (the forty-fourth session's measured noise for border-cut windows): uncut
    windows err N(0, (0.1 v)^2) along and across; cut ones N(-0.2 v, (0.3 v)^2) along and
    N(0, (0.1 v)^2) across. The excess along is
    sqrt(0.3^2 - 0.1^2 + 0.2^2) = 0.35 of the speed, across 0; windows slower than 20 px/s are
    left out, and a table without cut windows has no excess."""
    rng = np.random.default_rng(3)
    n = 20000
    speed = rng.uniform(20.0, 100.0, n)
    cut = np.arange(n) < n // 2
    along = speed * np.where(cut, -0.2 + 0.3 * rng.standard_normal(n), 0.1 * rng.standard_normal(n))
    across = speed * 0.1 * rng.standard_normal(n)
    slow = pd.DataFrame({"speed": 5.0, "along": 1e3, "across": 1e3, "border": [True, False]})  # off any scale, too slow to count
    df = pd.concat([pd.DataFrame({"speed": speed, "along": along, "across": across, "border": cut}), slow])
    a, c = cut_excess(df)
    assert a == pytest.approx(np.sqrt(0.3**2 - 0.1**2 + 0.2**2), abs=0.02)
    assert c < 0.03
    assert all(np.isnan(cut_excess(df[~df.border.astype(bool)])))
    # the same excess read from another column (``--below``: the feet below the image)
    below = df.rename(columns={"border": "below"})
    assert cut_excess(below, col="below") == (a, c)


def test_the_visible_parts_centre_is_half_way_up_the_axis_inside_the_image():
    """The test cameras (corners, 2.6 m up, 320 x 240): a person in the room's middle is seen
    whole (half the height); 1.4 m from the south-west camera the feet are below its image, and
    the reference is half-way between where the axis enters the bottom row and the head, whose
    image row is then near the middle of the axis's rows inside the image."""
    from scripts.measure_flow_errors import HEIGHT, visible_centre_z
    from tests.test_target_planes import four_cameras
    from trackroom.estimators import tp_geometry as geo

    sw = next(c for c in four_cameras() if c.name == "sw")
    P = np.asarray(sw.P, float)
    assert visible_centre_z(P, (4.0, 3.5), sw.height) == pytest.approx(0.5 * HEIGHT)
    z = visible_centre_z(P, (0.7, 1.4), sw.height)
    assert 0.5 * HEIGHT < z < HEIGHT
    head_row = geo.project(P, np.array([0.7, 1.4, HEIGHT]))[0][1]
    assert geo.project(P, np.array([0.7, 1.4, 0.0]))[0][1] > sw.height > head_row
    assert geo.project(P, np.array([0.7, 1.4, z]))[0][1] == pytest.approx(0.5 * (sw.height + head_row), abs=2.0)


def test_the_centroid_table_compares_both_references_by_whether_the_feet_are_below():
    """Windows with feet in the image err 1 px from both references; those with the feet below
    err 6 px from the body centre's and 1 px from the visible part's; cut and narrow windows are
    left out."""
    from scripts.measure_flow_errors import centroid_table

    n = 10
    df = pd.DataFrame({"du": [1.0] * n + [6.0] * n + [30.0], "du_vis": [1.0] * n + [1.0] * n + [30.0],
                       "below": [False] * n + [True] * n + [True], "border": [False] * (2 * n) + [True],
                       "share": [1.0] * (2 * n + 1)})
    T = centroid_table(df).set_index("windows")
    assert T.loc["feet in the image", "n"] == n and T.loc["feet below the image", "n"] == n
    assert T.loc["feet below the image", "rms_body_centre"] == pytest.approx(6.0)
    assert T.loc["feet below the image", "rms_visible_centre"] == pytest.approx(1.0)
    assert T.loc["the two 5+ px apart", "n"] == 0  # 5 px apart exactly: not more than 5


def test_walkers_shares_of_their_windows_are_split_by_who_else_is_in_them():
    """``--merged-widths``: a walker alone, a walker beside a standing extra, a walker beside a
    mover below walking speed, two walkers merged (a share each); a window of no walker and a
    walker cut by the border give nothing."""
    from trackroom.estimators import tp_geometry as geo
    from scripts.measure_flow_errors import HEIGHT, RADIUS, merged_width_lines, walker_shares
    from tests.test_measure_window_rows import P_ALONG_Y as P
    span = lambda x: geo.cylinder_window(P, np.array([x, 5.0]), HEIGHT, RADIUS)[:2]  # noqa: E731
    people, windows = [], []
    cases = [  # (t, [(id, x, speed)], window's people)
        (0.0, [("target", 0.0, 1.0)], [0]),
        (0.1, [("target", 0.0, 1.0), ("standing1", 0.3, 0.0)], [0, 1]),
        (0.2, [("target", 0.0, 1.0), ("distractor", 0.3, 0.2)], [0, 1]),
        (0.3, [("target", 0.0, 1.0), ("distractor", 0.3, 1.0)], [0, 1]),
        (0.4, [("standing1", 0.0, 0.0)], [0]),
        (0.5, [("target", -2.5, 1.0)], [0]),  # cut by the image's left border
    ]
    for t, who, held in cases:
        for pid, x, v in who:
            people.append({"t": t, "person_id": pid, "x": x, "y": 5.0, "vx": v, "vy": 0.0})
        lo = min(span(who[k][1])[0] for k in held)
        hi = max(span(who[k][1])[1] for k in held)
        windows.append({"t": t, "camera": "obl_a", "u_left": max(lo, 0.0), "u_right": hi})
    df = walker_shares(pd.DataFrame(people), pd.DataFrame(windows), {"obl_a": P}, {"obl_a": 320.0})
    one_wide = (span(0.3)[1] - span(0.0)[0]) / (span(0.0)[1] - span(0.0)[0])
    assert len(df) == 5  # one, one, one, two (a share each)
    assert df.share.iloc[0] == pytest.approx(1.0)
    assert df.share.iloc[1] == pytest.approx(one_wide) and bool(df.standers.iloc[1]) and not df.slow.iloc[1]
    assert bool(df.slow.iloc[2]) and not df.standers.iloc[2]
    assert list(df.walkers) == [1, 1, 1, 2, 2]
    lines = merged_width_lines(df)
    assert lines[0].startswith("one walker alone (1 shares)") and lines[1].startswith("one walker, alone or with people who never walk (2 shares)")
    assert lines[2].startswith("one walker with a mover below walking speed (1 shares)")
    assert lines[3].startswith("one walker or two merged (each walker's share), no one else (3 shares)")
