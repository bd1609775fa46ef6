"""Lazy tracker (Teixeira eq. 9 track hypotheses) on hand-made detections."""
from __future__ import annotations

import numpy as np
import pytest

from trackroom.estimators.lazy_tracker import TrackerConfig, track_segments, window_velocity

FPS = 20.0


def run(paths, cfg=TrackerConfig(sigma_m=0.02), duration=None, drop=lambda i, k: False):
    """paths: list of functions frame index -> (x, y) (or None when not detected)."""
    n = int((duration or 6.0) * FPS)
    fr, xs, ys = [], [], []
    for k in range(n):
        for i, p in enumerate(paths):
            xy = p(k)
            if xy is None or drop(i, k):
                continue
            fr.append(k); xs.append(xy[0]); ys.append(xy[1])
    return track_segments(np.arange(n) / FPS, np.array(fr), np.array(xs, float), np.array(ys, float), cfg)


def line(x0, y0, vx, vy):
    return lambda k: (x0 + vx * k / FPS, y0 + vy * k / FPS)


def test_separate_walkers_give_one_segment_each():
    segs = run([line(1, 1, 1, 0), line(1, 5, 1, 0)])
    assert segs.n_segments == 2
    assert sorted(segs.rows.groupby("segment").size()) == [120, 120]
    # the filtered velocity converges to the true one
    last = segs.rows[segs.rows["frame"] == 119]
    np.testing.assert_allclose(last[["vx", "vy"]].to_numpy(), [[1, 0], [1, 0]], atol=0.05)
    np.testing.assert_allclose(last[["svx", "svy"]].to_numpy(), [[1, 0], [1, 0]], atol=1e-9)


def test_crossing_breaks_segments_on_entry_and_exit():
    # head-on along y = 5 and y = 5.3: closest 0.3 m at t = 2.5 s
    segs = run([line(2, 5, 1, 0), line(7, 5.3, -1, 0)])
    reasons = segs.info["end_reason"].tolist()
    assert segs.n_segments == 6, segs.info
    assert reasons.count("proximity") == 4
    # the segments after the ambiguity may continue either segment from before it
    last = segs.info.index[segs.info["start_frame"] == segs.info["start_frame"].max()]
    for n in last:
        assert len(segs.predecessors[int(n)]) == 2


def test_hysteresis_keeps_noise_around_the_radius_from_shattering_tracks():
    # two people walking side by side 0.55-0.7 m apart (r_enter 0.6, r_exit 0.8): one break only
    wobble = lambda k: (1 + 0.5 * k / FPS, 5.625 + 0.075 * np.sin(k))
    segs = run([line(1, 5, 0.5, 0), wobble])
    # one ambiguity event at the first approach: both tracks cut once, then never again
    assert segs.n_segments == 4 and (segs.info["end_reason"] == "proximity").sum() == 2
    no_hyst = run([line(1, 5, 0.5, 0), wobble], TrackerConfig(sigma_m=0.02, r_enter=0.6, r_exit=0.6))
    assert no_hyst.n_segments > 10


def test_short_dropout_is_bridged_long_dropout_starts_a_linked_segment():
    short = run([line(1, 1, 1, 0)], drop=lambda i, k: k in (40, 41))
    assert short.n_segments == 1
    long = run([line(1, 1, 1, 0)], drop=lambda i, k: 40 <= k < 60)
    assert long.n_segments == 2
    assert long.info["end_reason"][0] == "missed"
    (pred, w), = long.predecessors[1]
    # constant-velocity extrapolation lands on the new start: the density is near its peak
    gap = 1.0  # s between the last detection before and the first after
    sd = TrackerConfig().sigma_birth + TrackerConfig().speed_max * gap
    assert pred == 0 and w == pytest.approx(1 / (2 * np.pi * sd**2), rel=0.1)


def test_static_ambiguity_cuts_the_partner():
    # A and B walk together; B stops (a privacy camera loses B); A goes on
    a = line(1, 5, 1, 0)
    b = lambda k: (1 + k / FPS, 5.4) if k < 40 else None
    segs = run([a, b])
    assert "missed" in segs.info["end_reason"].tolist()
    assert (segs.info["end_reason"] == "proximity").sum() >= 1  # A's segment cut when B vanished


def test_window_velocity_by_hand():
    t = np.arange(5) * 0.1
    x = 1.0 + 0.5 * t
    vx, vy, var = window_velocity(np.zeros(5, int), t, x, np.full(5, 2.0), 0.25, 0.1, 1.0)
    # window (t - 0.25, t]: 1, 2, 3, 3, 3 samples
    np.testing.assert_allclose(vx[1:], 0.5)
    assert vx[0] == 0 and var[0] == 1.0
    # 3 samples 0.1 s apart: D = n S_tt - S_t^2 = 3 * 0.02 - 0.09 ... relative to the window: 0.06 - ... = 0.02
    tt = t[2:5] - t[0]
    D = 3 * (tt**2).sum() - tt.sum() ** 2
    assert var[4] == pytest.approx(0.1**2 * 3 / D)
    np.testing.assert_allclose(vy, 0.0, atol=1e-12)


def test_bad_radii_rejected():
    with pytest.raises(ValueError, match="r_exit"):
        TrackerConfig(r_enter=1.0, r_exit=0.5)


def test_cut_keeps_the_filtered_track_and_prices_a_swap_by_the_closest_approach():
    # head-on along y = 5 and y = 5.3 (closest 0.3 m), noise floor sigma = 0.1 m
    segs = run([line(2, 5, 1, 0), line(7, 5.3, -1, 0)], cfg=TrackerConfig(sigma_m=0.1))
    rows = segs.rows
    assert rows["track"].nunique() == 2 and rows["segment"].nunique() == 6
    # after the exit cut each new segment continues the same filtered track's linked segment
    last = segs.info.index[segs.info["start_frame"] == segs.info["start_frame"].max()]
    for n in last:
        old, p_swap = segs.continues[int(n)]
        assert rows.loc[rows["segment"] == old, "track"].iloc[0] == rows.loc[rows["segment"] == n, "track"].iloc[0]
        # Phi(-0.3 / 0.2) = 0.067: the filtered tracks come a little closer or farther than 0.3 m
        assert 0.02 < p_swap < 0.2, p_swap
        # the track it may have been swapped with is the other one, cut in the same frame
        assert segs.partner[int(n)] == (set(rows["track"]) - {rows.loc[rows["segment"] == n, "track"].iloc[0]}).pop()
    # on entry nobody was closer than r_enter yet: a swap is all but impossible
    first_cut = segs.info.index[segs.info["start_frame"] == sorted(set(segs.info["start_frame"]))[1]]
    assert all(segs.continues[int(n)][1] < 0.01 for n in first_cut)
    # the evidence velocity does not restart at a cut
    np.testing.assert_allclose(rows.groupby("frame").filter(lambda g: g["frame"].iloc[0] > 30)["svx"].abs(), 1.0, atol=0.3)
