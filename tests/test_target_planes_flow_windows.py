"""The oblique cameras' flow windows (``sim/perception_flow.py``) on hand-made frames.

A "person" is the person cylinder projected by a calibrated ``occlusion_lab`` camera and filled
with one colour (as MuJoCo renders a walker: no texture, so flow appears only near its edges),
moving sideways over a smooth background. Checks: one window per person even when a static
occluder cuts it in two, the same id across frames, the window on the current silhouette (the
flow field lives on the previous frame), two people side by side stay two windows, and the box
algebra of ``current_box``.
"""
from __future__ import annotations

import numpy as np
import pytest

from trackroom.scenes.loader import load_scene
from trackroom.sim.perception_flow import FlowTracker, current_box, expected_person_window

W, H = 320, 240


@pytest.fixture(scope="module")
def cam():
    return next(c for c in load_scene("occlusion_lab").cameras if c.name == "obl_sw")


def background() -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W]
    g = (90 + 0.15 * xx + 0.1 * yy).astype(np.uint8)
    return np.dstack([g, g, g])


def person_box(cam, xy) -> np.ndarray:
    """Integer pixel box [x0, y0, x1, y1) of the person cylinder (1.75 m x 0.2 m) at floor xy."""
    X = cam.backproject_to_plane(cam.project(np.array([xy[0], xy[1], 1.75]))[0], 1.75)
    e = expected_person_window(cam, *cam.project(X)[0], 1.75, 0.2)
    return np.round(e).astype(int)


def frames(cam, starts, step_px=3, n=6, occluder=None):
    """RGB frames with people (boxes from ``starts``) moving ``step_px`` per frame to the right,
    and an optional static occluder band (rows y0:y1) drawn in front of them."""
    boxes = [person_box(cam, xy) for xy in starts]
    out, truth = [], []
    for k in range(n):
        img = background()
        now = []
        for b, colour in zip(boxes, [(200, 30, 30), (30, 30, 200)]):
            x0, y0, x1, y1 = b + np.array([k * step_px, 0, k * step_px, 0])
            img[y0:y1, x0:x1] = colour
            now.append(np.array([x0, y0, x1, y1], float))
        if occluder is not None:
            img[occluder[0] : occluder[1]] = (60, 50, 40)
        out.append(img)
        truth.append(now)
    return out, truth


def test_current_box_moves_the_region_to_the_current_frame():
    # silhouette [a, b] = [100, 120] in frame k-1, moving +3 px: changed pixels [100, 103] and
    # [120, 123], grown by d = 4 -> region [96, 127]; the current silhouette is [103, 123]
    np.testing.assert_allclose(current_box(np.array([96.0, 50, 127, 90]), np.array([3.0, 0.0]), 4.0), [103, 54, 123, 86])
    # moving -3 px: changed [97, 100] and [117, 120], region [93, 124]; current [97, 117]
    np.testing.assert_allclose(current_box(np.array([93.0, 50, 124, 90]), np.array([-3.0, 0.0]), 4.0), [97, 54, 117, 86])
    # an edge on the image border stays there; the box stays inside the image
    b = current_box(np.array([0.0, 50, 20, 90]), np.array([-3.0, 0.0]), 4.0, (W, H))
    assert b[0] == 0 and b[2] == pytest.approx(13) and (b >= 0).all()


def test_one_window_per_person_across_an_occluder_with_a_stable_id(cam):
    box = person_box(cam, (3.0, 4.0))
    mid = (box[1] + box[3]) // 2
    imgs, truth = frames(cam, [(3.0, 4.0)], occluder=(mid - 6, mid + 6))
    tr = FlowTracker(W, H, camera=cam)
    ids = []
    for img, tru in zip(imgs, truth):
        ws = tr(img)
        if not ids and not ws:
            continue  # the first frame has no flow yet
        assert len(ws) == 1, [w.box for w in ws]
        ids.append(ws[0].track)
        np.testing.assert_allclose(ws[0].box, tru[0], atol=3.0)  # the current silhouette, both fragments
        assert abs(ws[0].u - 0.5 * (tru[0][0] + tru[0][2])) <= 2.0
        assert ws[0].flow[0] == pytest.approx(3.0, abs=1.0)  # px/frame
    assert len(ids) >= 4 and len(set(ids)) == 1


def test_two_people_side_by_side_stay_two_windows(cam):
    a = person_box(cam, (3.0, 4.0))
    w = a[2] - a[0]
    # the second person one width to the right of the first (a gap of one width between them)
    imgs, truth = frames(cam, [(3.0, 4.0)], n=5)
    second = [img.copy() for img in imgs]
    for k, img in enumerate(second):
        img[a[1] : a[3], a[0] + 2 * w + 3 * k : a[2] + 2 * w + 3 * k] = (30, 30, 200)
    tr = FlowTracker(W, H, camera=cam)
    for img in second:
        ws = tr(img)
    assert len(ws) == 2
    centres = sorted(0.5 * (x.box[0] + x.box[2]) for x in ws)
    assert centres[1] - centres[0] == pytest.approx(2 * w, abs=3.0)


def test_without_a_calibration_fragments_still_make_windows(cam):
    imgs, truth = frames(cam, [(3.0, 4.0)], n=4)
    tr = FlowTracker(W, H)
    for img in imgs:
        ws = tr(img)
    assert ws and all(w.box[0] <= w.u <= w.box[2] for w in ws)
