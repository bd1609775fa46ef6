"""Top-down pictures of scenes and recordings (matplotlib, Agg): walls, obstacles, cameras and
their fields of view, true paths, and detections."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.patches  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from trackroom.scenes.camera import Camera  # noqa: E402
from trackroom.scenes.spec import Floorplan  # noqa: E402

KIND_COLOURS = {"horizontal": "tab:blue", "overhead": "tab:purple", "oblique": "tab:green"}


def draw_floorplan(ax, fp: Floorplan) -> None:
    for w in fp.all_walls():
        ax.plot([w.start[0], w.end[0]], [w.start[1], w.end[1]], color="0.15", lw=2.5, solid_capstyle="butt")
    for o in fp.obstacles:
        c = o.corners()
        ax.fill(c[:, 0], c[:, 1], color="0.6", alpha=0.8, zorder=2)
        if o.name:
            ax.text(*o.center, o.name, ha="center", va="center", fontsize=6, zorder=3)


def fov_polygon(cam: Camera, fp: Floorplan, reach: float | None = None) -> np.ndarray:
    """Floor footprint of a camera's field of view, clipped to the room's bounding box."""
    x0, y0, x1, y1 = fp.bounds()
    reach = reach or 1.5 * np.hypot(x1 - x0, y1 - y0)
    if cam.kind == "overhead":
        # image corners back-projected to the floor at person mid-height
        corners = np.array([[0, 0], [cam.width, 0], [cam.width, cam.height], [0, cam.height]], float)
        pts = cam.backproject_to_plane(corners, 0.9)[:, :2]
        return pts if np.isfinite(pts).all() else np.empty((0, 2))
    half = 0.5 * cam.fovx
    angles = cam.yaw + np.linspace(-half, half, 24)
    p = np.asarray(cam.position[:2], float)
    arc = p + reach * np.stack([np.cos(angles), np.sin(angles)], -1)
    return np.vstack([p, arc])


def room_clip(ax, fp: Floorplan):
    """A patch of the room outline that clips views and rays to the inside of the room."""
    patch = matplotlib.patches.Polygon(fp.outline, closed=True, transform=ax.transData, fill=False, lw=0)
    ax.add_patch(patch)
    return patch


def draw_cameras(ax, cams, fp: Floorplan) -> None:
    x0, y0, x1, y1 = fp.bounds()
    clip = room_clip(ax, fp)
    for cam in cams:
        col = KIND_COLOURS.get(cam.kind, "k")
        if cam.kind == "overhead" and cam.region is not None:
            rx0, ry0, rx1, ry1 = cam.region
            poly = np.array([[rx0, ry0], [rx1, ry0], [rx1, ry1], [rx0, ry1]])
            ax.add_patch(matplotlib.patches.Polygon(poly, closed=True, fill=True, color=col, alpha=0.06, lw=1, ls="--", zorder=1))
        else:
            poly = fov_polygon(cam, fp)
            if len(poly):
                for patch in ax.fill(poly[:, 0], poly[:, 1], color=col, alpha=0.10, zorder=1, lw=0):
                    patch.set_clip_path(clip)
        ax.plot(*cam.position[:2], marker="^" if cam.kind != "overhead" else "s", color=col, ms=8, zorder=5)
        ax.annotate(cam.name, cam.position[:2], xytext=(4, 4), textcoords="offset points", fontsize=7, color=col, zorder=6)
    ax.set_xlim(x0 - 0.5, x1 + 0.5)
    ax.set_ylim(y0 - 0.5, y1 + 0.5)


def plot_scene(scene, out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(6, 6))
    draw_floorplan(ax, scene.floorplan)
    draw_cameras(ax, scene.cameras, scene.floorplan)
    for w in scene.walkers:
        pts = list(w.waypoints) or ([w.start] if w.start else [])
        if pts:
            a = np.asarray(pts)
            ax.plot(a[:, 0], a[:, 1], "o--", color=w.color, ms=3, lw=1)
    _finish(ax, fig, f"{scene.name}", out)
    return out


def plot_recording(rec, out: Path, max_bearing_rays: int = 150) -> Path:
    """Walls, cameras, true paths (colour per person) and the observations."""
    fp = rec.calibration.floorplan
    fig, ax = plt.subplots(figsize=(7, 7))
    draw_floorplan(ax, fp)
    draw_cameras(ax, rec.calibration.cameras.values(), fp)
    colours = {w["name"]: w.get("color") for w in rec.meta.get("walkers", [])}
    for pid, g in rec.truth.people.groupby("person_id", sort=False):
        ax.plot(g["x"], g["y"], "-", lw=1.2, color=colours.get(pid) or None, label=str(pid), zorder=4)
        ax.plot(g["x"].iloc[0], g["y"].iloc[0], "o", ms=4, color=colours.get(pid) or "k", zorder=4)
    clip = room_clip(ax, fp)
    obs = rec.observations
    if obs.has("floor_detections"):
        d = obs["floor_detections"]
        ax.plot(d["x"], d["y"], ".", ms=1.5, color="k", alpha=0.35, label="floor detections", zorder=3)
    if obs.has("bearings"):
        b = obs["bearings"]
        step = max(1, len(b) // max_bearing_rays)
        for _, r in b.iloc[::step].iterrows():
            cam = rec.calibration.cameras[r["camera"]]
            ang = _bearing_angle(cam, r["u"])
            p = cam.position[:2]
            (line,) = ax.plot([p[0], p[0] + 30 * np.cos(ang)], [p[1], p[1] + 30 * np.sin(ang)], "-", lw=0.4,
                              color=colours.get(_label_owner(rec, r["label"])) or "tab:red", alpha=0.3, zorder=2)
            line.set_clip_path(clip)
    title = f"{rec.meta.get('scene', '')}  seed {rec.meta.get('seed')}  {rec.duration:g} s  ({rec.meta.get('sensing', '')})"
    ax.legend(loc="upper right", fontsize=6, framealpha=0.7)
    _finish(ax, fig, title, out)
    return out


def _label_owner(rec, label: str) -> str | None:
    """The walker whose appearance class is ``label`` (for colouring rays only)."""
    for w in rec.meta.get("walkers", []):
        if w.get("color") == label:
            return w["name"]
    return None


def _bearing_angle(cam: Camera, u: float) -> float:
    """World heading (radians) of the ray through image column u (horizontal cameras)."""
    return cam.yaw - np.arctan((u - cam.width / 2.0) / cam.focal)


def _finish(ax, fig, title: str, out: Path) -> None:
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.2)
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
