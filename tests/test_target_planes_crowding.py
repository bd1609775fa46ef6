"""target_planes rules added for rendered windows: crowded views, the jump gate, noise from the
calibration (synthetic windows and hand-made states)."""
from __future__ import annotations

import numpy as np
import pytest

from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_tracker import TRACKING, UNRELIABLE, CameraState, CameraView, Target, TargetUpdater, _focal
from trackroom.recording import Observations
from tests.test_target_planes import calib, four_cameras, line_path, synth_boxes


def view(u_left, u_right) -> CameraView:
    return CameraView(np.array([u_left, u_right, 50.0, 150.0]), np.array([u_left, u_right, 50.0, 150.0]), None)


def test_crowded_views_are_those_where_estimated_windows_overlap():
    tp = TargetPlanes(initial_xy=[0, 0])
    a = Target(0, np.array([1.0, 1.0]), {}, confirmed=True)
    b = Target(1, np.array([1.6, 1.0]), {}, confirmed=True)
    preds = {0: a.xy, 1: b.xy}
    views = {0: {"c1": view(100, 120), "c2": view(200, 220)}, 1: {"c1": view(110, 130), "c2": view(240, 260)}}
    assert tp._crowded([a, b], preds, views) == ({0: {"c1"}, 1: {"c1"}}, {0: {"c1": [1]}, 1: {"c1": [0]}})
    # crowded in every view that sees both: no camera separates them, the rule stays out (they
    # are still each other's neighbours for splitting merged windows)
    views[1]["c2"] = view(205, 225)
    assert tp._crowded([a, b], preds, views) == ({0: set(), 1: set()}, {0: {"c1": [1], "c2": [1]}, 1: {"c1": [0], "c2": [0]}})
    # nearer than a body width on the floor: one person seen twice, not a crowd
    preds[1] = np.array([1.2, 1.0])
    views[1]["c2"] = view(240, 260)
    assert tp._crowded([a, b], preds, views) == ({0: set(), 1: set()}, {0: {}, 1: {}})


def test_a_merged_window_is_split_at_the_targets_outer_edge():
    """Two people side by side in one window: the target's part is the merged window's edge on
    its side plus its estimated width; no split where they are in line, where a centre is
    outside the window or where the target's edge is cut by the image border."""
    upd = TargetUpdater(TargetPlanes.Config(), {})
    merged = np.array([100.0, 150.0, 40.0, 160.0])
    left, right = view(100, 130), view(118, 150)  # target on the left, neighbour on the right
    assert np.allclose(upd.split_window(left, right, merged, 320.0), [100, 130, 50, 150])
    assert np.allclose(upd.split_window(right, left, merged, 320.0), [118, 150, 50, 150])
    assert upd.split_window(view(101, 131), view(103, 133), merged, 320.0) is None  # in line
    assert upd.split_window(left, view(190, 220), merged, 320.0) is None  # neighbour not in the window
    assert upd.split_window(right, left, merged, 150.0) is None  # right edge at the image border
    assert upd.split_window(view(0, 30), view(18, 50), np.array([0.0, 50.0, 40.0, 160.0]), 320.0) is None  # left edge at the border
    assert upd.split_window(left, right, np.array([100.0, 180.0, 40.0, 160.0]), 320.0) is None  # wider than the two: not them
    # rows: the target's estimated rows inside the merged window's
    assert np.allclose(upd.split_window(CameraView(np.array([100, 130, 30.0, 150]), None, None), right, merged, 320.0), [100, 130, 40, 150])


def test_merged_windows_beside_a_tracked_look_alike_are_split_or_left_out():
    """A look-alike 0.7 m beside the target, the same velocity; where their windows overlap the
    camera reports one merged window. The target is held; where the windows merge, the target's
    part of the window is split off (or, with ``split_merged=False``, the camera is left out as
    crowded)."""
    cams = four_cameras()
    times = np.round(np.arange(0, 8.0, 0.1), 6)
    tgt = line_path([1.0, 2.0], [7.0, 2.5], times)
    other = line_path([1.0, 2.7], [7.0, 3.2], times)
    for merge in (True, False):
        boxes = synth_boxes(cams, {"target": tgt, "other": other}, times, merge=merge, sigma=0.3, seed=1)
        res = TargetPlanes(initial_xy=list(tgt[0])).run(Observations({"boxes": boxes}, 8.0), calib(cams))
        k = np.round(res.tracks.t.to_numpy() * 10).astype(int)
        err = np.hypot(res.tracks.x - tgt[k, 0], res.tracks.y - tgt[k, 1])
        assert np.sqrt(np.mean(err**2)) < 0.05
        crowded = (res.status.reason == "crowded").sum()
        split = (res.status.reason == "split").sum()
        assert (crowded + split > 10) if merge else (crowded + split == 0)
        if merge:  # the merged windows' target parts are used: more cameras per frame than without splitting
            plain = TargetPlanes(initial_xy=list(tgt[0]), split_merged=False).run(Observations({"boxes": boxes}, 8.0), calib(cams))
            assert split > 10 and (plain.status.reason == "crowded").sum() > 10
            assert res.tracks.n_cameras.mean() > plain.tracks.n_cameras.mean() + 0.2


class _StubUpdater:
    """Estimates far from the prediction while camera "b" is used."""

    def __init__(self):
        self.calls = []

    def estimate(self, tg, xy_pred, used, frame, held):
        self.calls.append(sorted(used))
        far = "b" in used
        return (xy_pred + (np.array([1.5, 0.0]) if far else np.array([0.05, 0.0])), None, "planes" if used else "predicted", [])

    def search_radius(self, tg):
        return 0.5

    def stray(self, c, boxes, j, xy_pred):
        return {"a": 0.1, "b": 2.0, "c": 0.2}[c]

    def search_sigma(self, xy, cams):
        return 0.3

    def velocity(self, tg, xy, used, frame):
        pass


def test_an_estimate_beyond_the_search_radius_leaves_out_the_straying_camera():
    tp = TargetPlanes(initial_xy=[0, 0])
    tg = Target(0, np.array([2.0, 2.0]), {c: CameraState(TRACKING, 1) for c in "abc"})
    used = {"a": 0, "b": 0, "c": 0}
    upd = _StubUpdater()
    frame = {c: None for c in "abc"}
    tp._update(tg, np.array([2.0, 2.0]), used, [], frame, upd, 0.1)
    assert upd.calls == [["a", "b", "c"], ["a", "c"]]
    np.testing.assert_allclose(tg.xy, [2.05, 2.0])
    assert tg.cams["b"].status == UNRELIABLE and tg.cams["b"].reason == "jump"
    assert sorted(used) == ["a", "c"]
    # without the gate the jump is taken
    tg2 = Target(0, np.array([2.0, 2.0]), {c: CameraState(TRACKING, 1) for c in "abc"})
    TargetPlanes(initial_xy=[0, 0], jump_gate=False)._update(tg2, np.array([2.0, 2.0]), {"a": 0, "b": 0, "c": 0}, [], frame, _StubUpdater(), 0.1)
    np.testing.assert_allclose(tg2.xy, [3.5, 2.0])


def test_search_radius_grows_with_the_calibrated_centroid_noise():
    cams = four_cameras()
    Ps = {c.name: c.P for c in cams}
    for c in cams:
        assert _focal(c.P) == pytest.approx(c.focal, rel=1e-9)
    cfg = TargetPlanes.Config()
    xy = np.array([4.0, 3.5])
    assert TargetUpdater(cfg, Ps, centroid_sigma_px=0.0).search_sigma(xy, ["sw"]) == pytest.approx(cfg.sigma_planes)
    # sigma_planes + 3 sigma_u d / f, d the depth of the body centre in the camera
    sw = next(c for c in cams if c.name == "sw")
    d = float(sw.to_camera(np.array([4.0, 3.5, cfg.flow_height_fraction * cfg.height]))[2])
    got = TargetUpdater(cfg, Ps, centroid_sigma_px=3.5).search_sigma(xy, ["sw"])
    assert got == pytest.approx(cfg.sigma_planes + 3 * 3.5 * d / sw.focal, rel=1e-9)


def test_config_noise_overrides_the_calibration():
    cams = four_cameras()
    times = np.round(np.arange(0, 2.0, 0.1), 6)
    tgt = line_path([1.0, 2.0], [2.5, 2.0], times)
    obs = Observations({"boxes": synth_boxes(cams, {"target": tgt}, times)}, 2.0)
    seen = {}
    orig = TargetUpdater.__init__

    def spy(self, cfg, Ps, flow_sigma=None, window_sigma_px=0.0, centroid_sigma_px=None):
        seen.update(window=window_sigma_px, centroid=centroid_sigma_px, flow=dict(flow_sigma))
        orig(self, cfg, Ps, flow_sigma, window_sigma_px, centroid_sigma_px)

    TargetUpdater.__init__ = spy
    try:
        cal = calib(cams)
        cal.noise = {"box_sigma_px": 1.0, "bearing_sigma_px": 1.0, "flow_sigma_px_s": 5.0}
        TargetPlanes(initial_xy=list(tgt[0]), box_sigma_px=1.5, box_u_sigma_px=3.5).run(obs, cal)
    finally:
        TargetUpdater.__init__ = orig
    assert seen["window"] == 1.5 and seen["centroid"] == 3.5
    assert all(v == pytest.approx(5.0 / np.sqrt(TargetPlanes.Config().flow_window)) for v in seen["flow"].values())
