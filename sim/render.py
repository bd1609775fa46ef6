"""Headless MuJoCo rendering of the scene's cameras: RGB, person segmentation, empty backgrounds.

One ``mujoco.Renderer`` per resolution, reused for every camera of that size (FACTS.md: cycling
one renderer through cameras costs the same as one each). Shadows are off unless the scene asks
for them (the shadow pass costs ~40 ms a frame on the CPU). ``MUJOCO_GL=egl`` is set before
MuJoCo is imported, so rendering runs headless on Mesa's CPU rasteriser.

Image convention: row 0 at the top, pixel (row j, column i) covers u in [i, i+1) and v in
[j, j+1), so a pixel's centre is at (i + 0.5, j + 0.5) in the ``scenes.camera.Camera`` model.
"""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


class SceneRenderer:
    """Renders MuJoCo cameras at their own resolution; RGB and person-index segmentation.

    ``person_of_geom`` (ngeom,) maps a geom id to the index of the person it belongs to, or -1.
    ``segment`` returns an (H, W) int16 image of person indices (-1: no person), which is what
    the ground-truth labels need; the RGB image is what perception sees.
    """

    def __init__(self, model: mujoco.MjModel, person_of_geom: np.ndarray, shadows: bool = False):
        self.model = model
        self.shadows = bool(shadows)
        self.person_of_geom = np.asarray(person_of_geom, np.int16)
        if self.person_of_geom.shape != (model.ngeom,):
            raise ValueError(f"person_of_geom has shape {self.person_of_geom.shape}, expected ({model.ngeom},)")
        # segid lookup: object id -> person index, with one slot for "not a geom" (index -1)
        self._lut = np.concatenate([self.person_of_geom, np.array([-1], np.int16)])
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}

    def renderer(self, width: int, height: int) -> mujoco.Renderer:
        key = (int(width), int(height))
        r = self._renderers.get(key)
        if r is None:
            # the offscreen buffer caps the renderer size (default 640x480): grow it if needed
            g = self.model.vis.global_
            g.offwidth = max(int(g.offwidth), key[0])
            g.offheight = max(int(g.offheight), key[1])
            r = mujoco.Renderer(self.model, height=key[1], width=key[0])
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows
            self._renderers[key] = r
        return r

    def rgb(self, data: mujoco.MjData, camera_id: int, width: int, height: int, out=None) -> np.ndarray:
        """(H, W, 3) uint8 RGB image of camera ``camera_id`` for the current ``data``."""
        r = self.renderer(width, height)
        r.update_scene(data, camera=int(camera_id))
        return r.render(out=out)

    def rgb_and_segment(self, data: mujoco.MjData, camera_id: int, width: int, height: int):
        """RGB image and (H, W) int16 person-index image from one scene update."""
        r = self.renderer(width, height)
        r.update_scene(data, camera=int(camera_id))
        rgb = r.render()
        r.enable_segmentation_rendering()
        try:
            seg = r.render()
        finally:
            r.disable_segmentation_rendering()
        return rgb, self.person_index(seg)

    def segment(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> np.ndarray:
        r = self.renderer(width, height)
        r.update_scene(data, camera=int(camera_id))
        r.enable_segmentation_rendering()
        try:
            seg = r.render()
        finally:
            r.disable_segmentation_rendering()
        return self.person_index(seg)

    def person_index(self, seg: np.ndarray) -> np.ndarray:
        objid = np.where(seg[..., 1] == GEOM, seg[..., 0], -1)
        return self._lut[objid]  # index -1 picks the trailing "not a person" slot

    def background(self, data: mujoco.MjData, camera_id: int, width: int, height: int,
                   hidden_geoms: np.ndarray) -> np.ndarray:
        """The empty-scene image: the camera's view with the given geoms made invisible.

        MuJoCo skips geoms with alpha 0 when it builds the scene, so setting their alpha to 0
        for one render removes them (and their reflections) exactly; the model is restored.
        """
        hidden_geoms = np.asarray(hidden_geoms, int)
        saved = self.model.geom_rgba[hidden_geoms, 3].copy()
        self.model.geom_rgba[hidden_geoms, 3] = 0.0
        try:
            return self.rgb(data, camera_id, width, height).copy()
        finally:
            self.model.geom_rgba[hidden_geoms, 3] = saved

    def close(self) -> None:
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class VideoSink:
    """Writes one MP4 per camera with OpenCV's ``VideoWriter`` (codec ``mp4v``)."""

    def __init__(self, out_dir: str | Path):
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self._writers: dict[str, cv2.VideoWriter] = {}

    def path(self, camera: str) -> Path:
        return self.out_dir / f"{camera}.mp4"

    def write(self, camera: str, rgb: np.ndarray, fps: float) -> None:
        w = self._writers.get(camera)
        if w is None:
            h, wd = rgb.shape[:2]
            w = cv2.VideoWriter(str(self.path(camera)), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (wd, h))
            if not w.isOpened():
                raise RuntimeError(f"OpenCV cannot open an MP4 writer for {self.path(camera)}")
            self._writers[camera] = w
        w.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))

    def close(self) -> None:
        for w in self._writers.values():
            w.release()
        self._writers.clear()


def read_video(path: str | Path, frames: list[int] | None = None) -> list[np.ndarray]:
    """RGB frames of an MP4 (all, or those with the given indices, in order)."""
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise FileNotFoundError(2, "cannot open video", str(path))
    wanted = None if frames is None else set(int(i) for i in frames)
    out, i = [], 0
    try:
        while True:
            ok, bgr = cap.read()
            if not ok:
                break
            if wanted is None or i in wanted:
                out.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            i += 1
    finally:
        cap.release()
    return out
