"""Contact sheets: a grid of saved frames per camera with labels and detections drawn over them.

For ``trackroom show DIR --frames``. Frames come from ``DIR/frames/<camera>.mp4`` (frame j at
t = j / fps). Drawn on each tile: ground-truth label boxes (white, person id and visible
fraction), and the camera's observations at that time: bearings (a vertical line at u, colour
label), tracking windows (yellow rectangle, track id), floor detections (a cross at the floor
point lifted to head height, where a downward camera sees a person).

Tiles narrower than ``MIN_TILE_WIDTH`` are enlarged (whole-number factor) before drawing, so the
text is drawn at the sheet's own resolution; labels are outlined for contrast and placed where they
overlap no label already drawn on the tile and stay inside it (``Labels``).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from trackroom.sim.render import read_video

TILES = 12
COLUMNS = 4
MIN_TILE_WIDTH = 480  # px: smaller frames are enlarged so labels are legible
FONT = cv2.FONT_HERSHEY_SIMPLEX
FONT_SCALE = 0.42


class Labels:
    """Text on one tile without overlaps: each label goes to the first candidate position (moving
    away from its anchor one line at a time) where it overlaps no earlier label, shifted to stay
    inside the image."""

    def __init__(self, img: np.ndarray):
        self.img = img
        self.boxes: list[tuple[int, int, int, int]] = []  # x0, y0, x1, y1 of placed labels

    def put(self, text: str, x: int, y: int, colour, direction: int = -1) -> tuple[int, int, int, int]:
        """Draw ``text`` with its baseline near (x, y); ``direction`` -1 moves up, +1 down to avoid others."""
        h_img, w_img = self.img.shape[:2]
        (w, h), base = cv2.getTextSize(text, FONT, FONT_SCALE, 1)
        step = h + base + 2
        x = int(np.clip(x, 1, max(1, w_img - w - 1)))
        box = None
        for k in range(12):
            yy = int(np.clip(y + direction * k * step, h + 1, h_img - base - 1))
            cand = (x, yy - h - 1, x + w, yy + base)
            if not any(_overlap(cand, b) for b in self.boxes):
                box = cand
                break
        if box is None:  # crowded: the anchor itself (still inside the tile)
            yy = int(np.clip(y, h + 1, h_img - base - 1))
            box = (x, yy - h - 1, x + w, yy + base)
        self.boxes.append(box)
        org = (box[0], box[3] - base)
        cv2.putText(self.img, text, org, FONT, FONT_SCALE, (0, 0, 0), 3, cv2.LINE_AA)  # outline
        cv2.putText(self.img, text, org, FONT, FONT_SCALE, colour, 1, cv2.LINE_AA)
        return box


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def contact_sheets(recording_dir, out_dir, tiles: int = TILES) -> list[Path]:
    """Write ``<out_dir>/frames_<camera>.png`` for every camera with a saved video."""
    from trackroom.dataset import read_recording

    recording_dir, out_dir = Path(recording_dir), Path(out_dir)
    rec = read_recording(recording_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    labels = rec.truth.tables.get("labels")
    heights = [w.get("height", 1.75) for w in rec.meta.get("walkers", [])] or [1.75]
    head = float(np.mean(heights)) - 0.2
    paths = []
    for name, cam in rec.calibration.cameras.items():
        video = recording_dir / "frames" / f"{name}.mp4"
        if not video.exists():
            continue
        n = int(cv2.VideoCapture(str(video)).get(cv2.CAP_PROP_FRAME_COUNT))
        if n <= 0:
            continue
        idx = np.unique(np.linspace(0, n - 1, min(tiles, n)).round().astype(int))
        frames = read_video(video, list(idx))
        drawn = [_draw(f, j / cam.fps, name, cam, rec.observations, labels, head) for j, f in zip(idx, frames)]
        sheet = _grid(drawn, COLUMNS)
        path = out_dir / f"frames_{name}.png"
        cv2.imwrite(str(path), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
        paths.append(path)
    return paths


def _at(df, name, t):
    if df is None or len(df) == 0:
        return df
    return df[(df["camera"] == name) & np.isclose(df["t"].to_numpy(float), t, atol=1e-6)]


def _draw(frame, t, name, cam, obs, labels, head_height):
    s = max(1, -(-MIN_TILE_WIDTH // frame.shape[1]))  # enlargement factor: pixel coordinates x s
    img = np.ascontiguousarray(cv2.resize(frame, None, fx=s, fy=s, interpolation=cv2.INTER_NEAREST) if s > 1 else frame.copy())
    white, yellow, cyan = (255, 255, 255), (255, 230, 0), (0, 255, 255)
    text = Labels(img)
    text.put(f"{name}  t = {t:.2f} s", 3, 14, white, direction=+1)
    lab = _at(labels, name, t)
    if lab is not None:
        for _, r in lab.sort_values("y0").iterrows():
            cv2.rectangle(img, (int(s * r.x0), int(s * r.y0)), (int(s * r.x1) - 1, int(s * r.y1) - 1), white, 1)
            text.put(f"{r.person_id} {r.visible_fraction:.2f}", int(s * r.x0), int(s * r.y0) - 3, white)
    b = _at(obs["bearings"], name, t)
    for _, r in b.iterrows():
        u = int(round(s * r.u - 0.5))
        cv2.line(img, (u, 0), (u, img.shape[0] - 1), cyan, 1)
        text.put(str(r.label), u + 2, img.shape[0] - 4, cyan)
    w = _at(obs["boxes"], name, t)
    for _, r in w.iterrows():
        cv2.rectangle(img, (int(s * r.u_left), int(s * r.v_top)), (int(s * r.u_right) - 1, int(s * r.v_bottom) - 1), yellow, 1)
        text.put(f"#{int(r.track)}", int(s * r.u_left), int(s * r.v_bottom) + 14, yellow, direction=+1)
    f = _at(obs["floor_detections"], name, t)
    for _, r in f.iterrows():
        (u, v), depth = cam.project(np.array([r.x, r.y, head_height]))
        if depth > 0 and np.isfinite(u) and np.isfinite(v):
            cv2.drawMarker(img, (int(s * u), int(s * v)), (255, 0, 255), cv2.MARKER_CROSS, 10 * s, 2)
    return img


def _grid(images, cols):
    h, w = images[0].shape[:2]
    rows = -(-len(images) // cols)
    sheet = np.zeros((rows * h, min(cols, len(images)) * w, 3), np.uint8)
    for i, im in enumerate(images):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = im
    return sheet
