"""Top-down pictures of scenes and recordings (matplotlib, Agg): walls, obstacles, cameras and
their fields of view, true paths, and detections; an estimator's tracks over the truth, with the
identity switches the CLEAR MOT matching (``metrics.mot``) finds."""
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


TRUTH_GREY = "0.55"
MAX_SWITCH_LABELS = 12  # more switch markers than this are drawn unlabelled


def identity_switches(evaluation) -> "pd.DataFrame":
    """The identity switches of a scored run: ``t, person_id, track_id, previous, x, y`` (the
    person's true floor position at that frame, m), from the CLEAR MOT matches of
    ``metrics.score.evaluate`` (a person matched to a track other than its last)."""
    import pandas as pd

    m = evaluation.mot.matches.sort_values("frame", kind="stable")
    m = m.assign(previous=m.groupby("person_id", sort=False)["track_id"].shift())
    sw = m[m["switch"]]
    truth = evaluation.frames.truth[["frame", "person_id", "x", "y"]]
    out = sw.merge(truth, on=["frame", "person_id"], how="left")
    return pd.DataFrame(out[["t", "person_id", "track_id", "previous", "x", "y"]]).reset_index(drop=True)


def draw_tracks(ax, rec, tracks, gate: float = 1.0, legend: bool = True, label_tracks: bool = True) -> int:
    """The truth (grey), each track (a colour per track, its id at its start) and the identity
    switches (red crosses at the person's true position, ``person: old -> new``). Returns the
    number of switches."""
    from trackroom.metrics.score import evaluate

    for pid, g in rec.truth.people.groupby("person_id", sort=False):
        ax.plot(g["x"], g["y"], "-", lw=2.2, color=TRUTH_GREY, alpha=0.6, zorder=3,
                label="truth" if pid == rec.truth.people["person_id"].iloc[0] else None)
        ax.plot(g["x"].iloc[0], g["y"].iloc[0], "o", ms=3.5, color=TRUTH_GREY, zorder=3)  # a person standing still shows too
        ax.annotate(str(pid), (g["x"].iloc[0], g["y"].iloc[0]), xytext=(-3, -9), textcoords="offset points",
                    fontsize=6, color="0.35", zorder=3)
    ids = list(dict.fromkeys(tracks["track_id"]))
    colours = track_colours(len(ids))
    for i, (tid, g) in enumerate(tracks.groupby("track_id", sort=False)):
        g = g.sort_values("t", kind="stable")
        col = colours[i % len(colours)]
        ax.plot(g["x"], g["y"], "-", lw=0.9, color=col, zorder=4, label=f"track {tid}" if len(ids) <= 10 else None)
        if label_tracks:
            ax.annotate(f"#{tid}", (g["x"].iloc[0], g["y"].iloc[0]), xytext=(3, 3), textcoords="offset points",
                        fontsize=6, color=col, zorder=6)
    sw = identity_switches(evaluate(rec, tracks, gate))
    if len(sw):
        ax.plot(sw["x"], sw["y"], "X", color="red", mec="white", mew=0.6, ms=8, zorder=7, label="identity switch")
        _place_labels(ax, [(f"{r.person_id}: {r.previous}\u2192{r.track_id}", (r.x, r.y))
                           for r in sw.head(MAX_SWITCH_LABELS).itertuples()], color="red")
    if legend:  # beside the room, where it hides no camera or path
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return len(sw)


def track_colours(n: int) -> list:
    """Distinct colours for n tracks, none of them grey (grey is the truth's)."""
    cmap = plt.get_cmap("tab20" if n > 9 else "tab10")
    return [cmap(i) for i in range(cmap.N) if not _greyish(cmap(i))]


def _greyish(rgba) -> bool:
    r, g, b = rgba[:3]
    return max(r, g, b) - min(r, g, b) < 0.08


def _place_labels(ax, labels, color, fontsize: int = 6) -> None:
    """Annotate each (text, (x, y)) at the first of a few offsets where it overlaps no text already
    on the axes (camera, obstacle and track labels, earlier ones of these)."""
    ax.set_aspect("equal")
    ax.apply_aspect()  # the final data-to-display scale, so the overlap test holds in the picture
    renderer = ax.figure.canvas.get_renderer()
    offsets = [(5, -10), (5, 5), (-5, -10), (-5, 5), (5, -20), (5, 15), (-5, -20), (-5, 15)]
    placed = [t.get_window_extent(renderer) for t in ax.texts]
    for text, xy in labels:
        for k, (dx, dy) in enumerate(offsets):
            a = ax.annotate(text, xy, xytext=(dx, dy), textcoords="offset points", fontsize=fontsize, color=color,
                            ha="left" if dx > 0 else "right", zorder=8)
            box = a.get_window_extent(renderer).expanded(1.1, 1.3)  # a margin for later layout changes
            if not any(box.overlaps(b) for b in placed) or k == len(offsets) - 1:
                placed.append(box)
                break
            a.remove()


def plot_tracks(rec, tracks, out: Path, gate: float = 1.0, name: str = "tracks") -> Path:
    """Walls, cameras, the truth in grey, the tracks in colour and their identity switches."""
    fig, ax = plt.subplots(figsize=(8.5, 7))
    fig.subplots_adjust(left=0.08, right=0.8, bottom=0.08, top=0.94)  # near the final layout, for label placement
    fp = rec.calibration.floorplan
    draw_floorplan(ax, fp)
    draw_cameras(ax, rec.calibration.cameras.values(), fp)
    n = draw_tracks(ax, rec, tracks, gate)
    title = (f"{rec.meta.get('scene', '')} seed {rec.meta.get('seed')} ({rec.meta.get('sensing', '')}): {name}, "
             f"{tracks['track_id'].nunique()} tracks, {n} identity switch{'es' if n != 1 else ''} (gate {gate:g} m)")
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
