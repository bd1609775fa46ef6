"""Privacy-preserving (motion-only) overhead cameras: report only people who move, on a 15 cm grid.

Teixeira et al.'s privacy cameras perceive only moving objects and output the floor position of
each moving person ("motion histogram"); a person standing still is invisible to them. Plain
frame differencing does not give that position well: a slow walker's difference image is a few
moving edges (at 0.2 m/s and 20 fps a person moves 1 cm, ~0.5 px, per frame) that can lie
anywhere along the long head-to-feet streak a 120-degree lens makes of someone near the image
border, so the position wanders and fragments become false detections.

The model here separates *whether* a person is seen from *where*:

1. Person blobs exactly as the regular overhead camera finds them (``sim.perception``):
   background-difference silhouettes, split by walker colour, and, when a blob is split, each
   colour keeps only its largest connected part (a few stray votes of one colour on another
   person's body must not stretch that person's streak).
2. Motion gate. A blob is reported only if it moved *itself* between frames k-1 and k. With
   I_k, I_{k-1} the frames, B the empty-scene image and c the blob's colour, a pixel x of the
   blob is motion evidence when
       max_ch |I_k(x) - I_{k-1}(x)| > ``motion_threshold``           (it changed),
       vote_k(x) = c                                                 (it shows this person now),
       max_ch |I_{k-1}(x) - B(x)| <= ``diff_threshold`` or vote_{k-1}(x) = c
                                                                     (it was floor or this person),
       no pixel within 1 px votes for another colour in I_k or I_{k-1}
                                                                     (not a shared edge).
   The last two conditions reject changes of *ownership*: a walker passing in front of, or
   uncovering, a person who stands still changes that person's pixels (and the anti-aliased
   pixels along their shared edge) although the person did not move. The blob is reported when
   at least ``min_motion_px`` pixels (scaled with the image area) are motion evidence. A blob
   without colour votes counts every changed pixel.
3. Placement uses the whole silhouette (``floor_from_blob``, the regular camera's mapping), and
   the position is quantised to the camera's grid: x_q = q round(x / q), q = ``Camera.quantum``
   (0.15 m in Teixeira's simulations).

So the sensor's *output* is what a motion camera gives (positions of moving people only, coarse
grid, nothing while someone stands still, nothing on the first frame); the silhouette is used only
to place a person the motion has already revealed, which stands in for the motion-histogram
localisation of the paper (a real motion camera accumulates motion over time to the same end).
Someone turning on the spot moves (a rotating body changes pixels) and is reported.
"""
from __future__ import annotations

import cv2
import numpy as np

from trackroom.scenes.camera import Camera
from trackroom.sim.perception import Appearance, PerceptionParams, PersonBlob, foreground

_NEIGHBOURS = np.ones((3, 3), np.uint8)


def own_motion(blob: PersonBlob, rgb: np.ndarray, prev: np.ndarray, background: np.ndarray, moving: np.ndarray,
               votes: np.ndarray, prev_votes: np.ndarray, params: PerceptionParams) -> int:
    """Number of the blob's pixels that are evidence of its own motion (module docstring, step 2).

    moving: (H, W) bool, max_ch |I_k - I_{k-1}| > ``motion_threshold``; votes, prev_votes: (H, W)
    colour votes of frames k and k-1 (-1: none or not a person pixel).
    """
    ys, xs = blob.ys, blob.xs
    mv = moving[ys, xs]
    my, mx = ys[mv], xs[mv]
    if blob.colour < 0 or len(my) == 0:
        return int(len(my))
    c = blob.colour
    was_floor = np.abs(prev[my, mx].astype(np.int16) - background[my, mx]).max(axis=1) <= params.diff_threshold
    ok = (votes[my, mx] == c) & (was_floor | (prev_votes[my, mx] == c))
    if not ok.any():
        return 0
    # pixels next to another colour, now or in the previous frame: a shared edge, not own motion
    H, W = moving.shape
    y0, y1 = max(int(my.min()) - 1, 0), min(int(my.max()) + 2, H)
    x0, x1 = max(int(mx.min()) - 1, 0), min(int(mx.max()) + 2, W)
    other = np.zeros((y1 - y0, x1 - x0), np.uint8)
    for v in (votes[y0:y1, x0:x1], prev_votes[y0:y1, x0:x1]):
        other |= ((v >= 0) & (v != c)).astype(np.uint8)
    other = cv2.dilate(other, _NEIGHBOURS)
    ok &= other[my - y0, mx - x0] == 0
    return int(ok.sum())


class MotionGate:
    """Keeps the previous frame (and its colour votes) of one privacy camera and selects the
    person blobs that moved."""

    def __init__(self, cam: Camera, background: np.ndarray, app: Appearance, params: PerceptionParams):
        self.cam, self.background, self.app, self.params = cam, background, app, params
        self.min_px = params.area(params.min_motion_px, cam.width, cam.height)
        self._prev: tuple[np.ndarray, np.ndarray] | None = None

    def __call__(self, rgb: np.ndarray, votes: np.ndarray, blobs: list[PersonBlob]) -> list[PersonBlob]:
        """The blobs that moved since the previous frame (none on the first frame). ``votes``:
        the frame's colour votes, filled by ``person_blobs``."""
        prev, self._prev = self._prev, (rgb, votes)
        if prev is None:
            return []
        moving = foreground(rgb, prev[0], self.params.motion_threshold)
        p = self.params
        return [b for b in blobs if own_motion(b, rgb, prev[0], self.background, moving, votes, prev[1], p) >= self.min_px]
