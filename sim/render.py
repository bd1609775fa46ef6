"""Headless MuJoCo rendering of the scene's cameras: RGB, person segmentation, empty backgrounds.

One RGB ``mujoco.Renderer`` per resolution, reused for every camera of that size (FACTS.md:
cycling one renderer through cameras costs the same as one each), and one segmentation renderer
per resolution on a context without multisampling (same ids, ~35 % cheaper; ``seg_renderer``).
Shadows are off unless the scene asks for them (the shadow pass costs ~40 ms a frame on the CPU).
``MUJOCO_GL=egl`` is set before MuJoCo is imported, so rendering runs headless on Mesa's CPU
rasteriser (llvmpipe, which spreads a render over the cores: ``LP_NUM_THREADS`` unset is the
fastest end to end, measured by ``scripts/bench_render.py``).

Every GL call runs in one thread (the caller's). An earlier design drew the segmentation renders
in a second thread on a context of its own, overlapping the RGB renders; CI crashed once with a
segmentation fault inside that thread's ``mjr_render`` (Mesa 22.3 llvmpipe, two contexts drawing
at once), which could not be reproduced on demand, so the overlap (a wall-time gain only: the CPU
time per frame is the same) was given up for a renderer that never draws from two threads.

Where a frame's render time goes (overhead_lab, 320x240, measured): the RGB render is ~4 ms, of
which ~60 % is the model's 4x multisampling (``vis.quality.offsamples``; 2.2 ms without, but
the anti-aliased pixels are what perception is built on, so it stays); segmentation ~2.2 ms.

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
        self._seg_renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._seg_buffers: dict[tuple[int, int], np.ndarray] = {}

    def renderer(self, width: int, height: int) -> mujoco.Renderer:
        """The RGB renderer of this size (the model's multisampling, ``vis.quality.offsamples``)."""
        return self._make(self._renderers, width, height, None)

    def seg_renderer(self, width: int, height: int) -> mujoco.Renderer:
        """The segmentation renderer of this size: a context without multisampling.

        MuJoCo draws segmentation with multisampling disabled, so a 4x multisampled buffer gives
        the same ids at a higher cost (the resolve blit and 4x the buffer): measured on
        overhead_lab, 2.2-2.4 ms instead of 3.7 ms a frame at 320x240, identical pixels
        (``tests/test_render.py`` checks the equality)."""
        return self._make(self._seg_renderers, width, height, 0)

    def _make(self, cache: dict, width: int, height: int, offsamples: int | None) -> mujoco.Renderer:
        key = (int(width), int(height))
        r = cache.get(key)
        if r is None:
            # the offscreen buffer caps the renderer size (default 640x480): grow it if needed
            g = self.model.vis.global_
            g.offwidth = max(int(g.offwidth), key[0])
            g.offheight = max(int(g.offheight), key[1])
            q = self.model.vis.quality
            saved = int(q.offsamples)
            if offsamples is not None:
                q.offsamples = offsamples  # read when the GL context is made
            try:
                r = mujoco.Renderer(self.model, height=key[1], width=key[0])
            finally:
                q.offsamples = saved
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.shadows
            cache[key] = r
        return r

    def rgb(self, data: mujoco.MjData, camera_id: int, width: int, height: int, out=None) -> np.ndarray:
        """(H, W, 3) uint8 RGB image of camera ``camera_id`` for the current ``data``."""
        r = self.renderer(width, height)
        r.update_scene(data, camera=int(camera_id))
        return r.render(out=out)

    def rgb_and_segment(self, data: mujoco.MjData, camera_id: int, width: int, height: int):
        """RGB image and (H, W) int16 person-index image of the current ``data``."""
        return self.rgb(data, camera_id, width, height), self.segment(data, camera_id, width, height)

    def segment(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> np.ndarray:
        """(H, W) int16 person-index image (-1: no person) from the segmentation renderer."""
        r = self.seg_renderer(width, height)
        r.update_scene(data, camera=int(camera_id))
        return self.segment_current(r)

    def segment_current(self, r: mujoco.Renderer) -> np.ndarray:
        """(H, W) int16 person-index image of the scene last given to ``r.update_scene``.

        The same pixels as ``Renderer.enable_segmentation_rendering()`` + ``render()`` followed by
        ``person_index`` (checked equal in ``tests/test_render.py``), in about half the time: the
        segmentation pass draws each visible scene geom s in the flat colour s + 1 (byte-encoded:
        R = (s + 1) mod 256, G = (s + 1) div 256 mod 256, ...; 0 is background), and one table
        lookup maps that id straight to the person index, instead of MuJoCo's wrapper building an
        (H, W, 2) int32 [object id, type] image (uint32 widening, 3-channel arithmetic, a copy to
        flip rows) that ``person_index`` then reduces again. Rows are flipped by a view.
        Uses the Renderer's GL context and rectangle (``_gl_context``, ``_rect``,
        ``_mjr_context``: MuJoCo 4's ``mujoco.Renderer`` internals).
        """
        scn = r.scene
        ngeom = scn.ngeom
        lut = np.full(ngeom + 1, -1, np.int16)  # segment id + 1 -> person index
        for g in scn.geoms[:ngeom]:
            if g.segid != -1 and g.objtype == GEOM:
                lut[g.segid + 1] = self.person_of_geom[g.objid]
        H, W = r.height, r.width
        buf = self._seg_buffers.get((W, H))
        if buf is None:
            buf = self._seg_buffers[(W, H)] = np.empty((H, W, 3), np.uint8)
        flags = scn.flags
        saved = flags.copy()
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            if r._gl_context:
                r._gl_context.make_current()
            mujoco.mjr_render(r._rect, scn, r._mjr_context)
            mujoco.mjr_readPixels(buf, None, r._rect, r._mjr_context)
        finally:
            np.copyto(flags, saved)
        ids = buf[::-1, :, 0].astype(np.intp)
        if ngeom + 1 > 255:  # ids need the second (and third) byte
            ids += buf[::-1, :, 1].astype(np.intp) << 8
            ids += buf[::-1, :, 2].astype(np.intp) << 16
        return lut[np.minimum(ids, ngeom)]

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

    def close(self, segmentation_only: bool = False) -> None:
        for cache in (self._seg_renderers,) if segmentation_only else (self._renderers, self._seg_renderers):
            for r in cache.values():
                r.close()
            cache.clear()

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
