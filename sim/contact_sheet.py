"""Contact sheets: a grid of saved frames per camera with labels and detections drawn over them.

For ``trackroom show DIR --frames``. Frames come from ``DIR/frames/<camera>.mp4`` (frame j at
t = j / fps). Drawn on each tile: ground-truth label boxes (white, person id and visible
fraction), and the camera's observations at that time: bearings (a vertical line at u, colour
label), tracking windows (yellow rectangle, track id), floor detections (a cross at the floor
point lifted to head height, where a downward camera sees a person).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from trackroom.sim.render import read_video

TILES = 12
COLUMNS = 4


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
    img = np.ascontiguousarray(frame.copy())
    font, white, yellow = cv2.FONT_HERSHEY_PLAIN, (255, 255, 255), (255, 230, 0)
    lab = _at(labels, name, t)
    if lab is not None:
        for _, r in lab.iterrows():
            cv2.rectangle(img, (int(r.x0), int(r.y0)), (int(r.x1) - 1, int(r.y1) - 1), white, 1)
            cv2.putText(img, f"{r.person_id} {r.visible_fraction:.2f}", (int(r.x0), max(8, int(r.y0) - 2)), font, 0.7, white, 1)
    b = _at(obs["bearings"], name, t)
    for _, r in b.iterrows():
        u = int(round(r.u - 0.5))
        cv2.line(img, (u, 0), (u, img.shape[0] - 1), (0, 255, 255), 1)
        cv2.putText(img, str(r.label), (u + 2, img.shape[0] - 4), font, 0.7, (0, 255, 255), 1)
    w = _at(obs["boxes"], name, t)
    for _, r in w.iterrows():
        cv2.rectangle(img, (int(r.u_left), int(r.v_top)), (int(r.u_right) - 1, int(r.v_bottom) - 1), yellow, 1)
        cv2.putText(img, f"#{int(r.track)}", (int(r.u_left), int(r.v_bottom) + 9), font, 0.7, yellow, 1)
    f = _at(obs["floor_detections"], name, t)
    for _, r in f.iterrows():
        (u, v), depth = cam.project(np.array([r.x, r.y, head_height]))
        if depth > 0 and np.isfinite(u) and np.isfinite(v):
            cv2.drawMarker(img, (int(u), int(v)), (255, 0, 255), cv2.MARKER_CROSS, 10, 2)
    cv2.putText(img, f"{name} t={t:.2f}s", (3, 11), font, 0.8, white, 1)
    return img


def _grid(images, cols):
    h, w = images[0].shape[:2]
    rows = -(-len(images) // cols)
    sheet = np.zeros((rows * h, min(cols, len(images)) * w, 3), np.uint8)
    for i, im in enumerate(images):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = im
    return sheet
