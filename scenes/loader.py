"""The scene language: a TOML file parsed into a validated ``Scene``.

File layout (every key is checked; unknown keys are errors; ``KEYS`` below lists them and
docs/scenes.md documents each with its type, default and unit)::

    [scene]      name, description
    [room]       outline = [[x, y], ...], wall_height, wall_thickness
    [[walls]]    start = [x, y], end = [x, y], thickness, height        (interior walls)
    [[obstacles]] name, center = [x, y], size = [sx, sy, sz], yaw_deg
    [[cameras]]  name, kind = "horizontal" | "overhead" | "oblique", position = [x, y, z],
                 yaw_deg, pitch_deg  or  look_at = [x, y, z], fovy_deg, resolution = [w, h],
                 fps, privacy (overhead), region = [xmin, ymin, xmax, ymax] (overhead)
    [sensors]    see ``SensorSpec``
    [render]     shadows
    [walkers]    count, motion, speed = [min, max], pause = [min, max], pause_probability,
                 height, radius, phoneless, process_noise = [q_pos, q_vel], bob_amplitude, vary
    [[walkers.people]]  name, motion, waypoints, loop, start, speed, pause, pause_probability,
                 phone, height, radius, color, process_noise, bob_amplitude, vary

``walkers.count`` walkers are made: the first from ``walkers.people`` (in order), the rest from
the ``[walkers]`` template. The last ``phoneless`` walkers carry no phone.

Overrides (``--set key=value``) are applied to the parsed TOML before validation; the key is
a dotted path, list items by index or ``*`` for all (``cameras.*.privacy=true``).

A loaded ``Scene`` keeps its ``source`` (the bundled scene's name, or the file's path relative to
the working directory), its ``overrides`` and the parsed TOML after them (``raw``):
``scene_toml`` writes that resolved scene back as TOML (it loads back to the same scene) and
``scene_sha256`` hashes it canonically (recordings and the compare cache carry the hash).

Every number must be finite and at most ``LIMIT`` (1e6) in magnitude (larger is a typo, and would
overflow the geometry); image sizes are whole pixels from 8 to ``MAX_PIXELS``. Camera and walker
names become file names, table ids and MuJoCo names, so they match ``NAME_PATTERN``.
"""
from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import math
import os
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .camera import CAMERA_KINDS, Camera, yaw_pitch_towards
from .spec import (
    MOTION_MODELS,
    Floorplan,
    GaussMarkovParams,
    Obstacle,
    RenderSpec,
    Scene,
    SensorSpec,
    Wall,
    WalkerSpec,
    point_in_polygon,
)

# Distinct appearance classes: the colour name is the label a camera may report.
PALETTE: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("red", (0.85, 0.10, 0.10)),
    ("blue", (0.10, 0.25, 0.90)),
    ("green", (0.10, 0.70, 0.15)),
    ("orange", (1.00, 0.55, 0.00)),
    ("purple", (0.55, 0.15, 0.75)),
    ("cyan", (0.00, 0.80, 0.85)),
    ("magenta", (0.95, 0.10, 0.70)),
    ("yellow", (0.95, 0.90, 0.10)),
    ("brown", (0.50, 0.30, 0.10)),
    ("navy", (0.05, 0.05, 0.45)),
    ("lime", (0.60, 1.00, 0.30)),
    ("pink", (1.00, 0.65, 0.75)),
)


# Every key the scene language accepts, by table ("" = the file's top level; ``walls``,
# ``obstacles``, ``cameras`` and ``walkers.people`` are arrays of tables). The validator rejects
# any other key; docs/scenes.md documents each one (tests/test_docs.py checks both directions).
KEYS: dict[str, frozenset[str]] = {
    "": frozenset({"scene", "room", "walls", "obstacles", "cameras", "sensors", "render", "walkers"}),
    "scene": frozenset({"name", "description"}),
    "room": frozenset({"outline", "wall_height", "wall_thickness"}),
    "walls": frozenset({"start", "end", "thickness", "height"}),
    "obstacles": frozenset({"name", "center", "size", "yaw_deg"}),
    "cameras": frozenset(
        {"name", "kind", "position", "yaw_deg", "pitch_deg", "look_at", "fovy_deg", "resolution", "fps", "privacy", "region"}
    ),
    "sensors": frozenset(SensorSpec.__dataclass_fields__),
    "render": frozenset({"shadows"}),
    "walkers": frozenset(
        {"count", "motion", "speed", "pause", "pause_probability", "height", "radius", "phoneless", "process_noise", "bob_amplitude", "vary", "people"}
    ),
    "walkers.people": frozenset(
        {"name", "motion", "waypoints", "loop", "start", "speed", "pause", "pause_probability", "phone", "height", "radius", "color", "process_noise", "bob_amplitude", "vary"}
    ),
}


LIMIT = 1e6  # largest magnitude of any number in a scene file
MAX_PIXELS = 16384  # largest image width or height
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
RESERVED_NAMES = {"world"}  # MuJoCo's world body


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file, the field and the problem."""


def bundled_scenes() -> list[str]:
    """Names of the scenes shipped with trackroom."""
    return sorted(p.name[:-5] for p in resources.files("trackroom.scenes").iterdir() if p.name.endswith(".toml"))


def _names_a_file(p: Path) -> bool:
    """A scene argument names a file when it ends in .toml or a file of that name exists; a
    folder that happens to share a bundled scene's name (a recording written to ``--out
    overhead_lab``) does not hide the bundled scene."""
    return p.suffix == ".toml" or p.is_file()


def resolve_scene_path(name_or_path: str | Path) -> Path:
    """A bundled scene name (``bearing_hall``) or a path to a TOML file."""
    p = Path(name_or_path)
    if _names_a_file(p):
        if not p.exists():
            raise SceneError(f"{p}: no such scene file")
        return p
    candidate = Path(str(resources.files("trackroom.scenes").joinpath(f"{name_or_path}.toml")))
    if not candidate.exists():
        what = "a folder, not a scene file, and not" if p.is_dir() else "not a scene file or"
        raise SceneError(f"{name_or_path}: {what} a bundled scene (bundled: {', '.join(bundled_scenes())})")
    return candidate


def scene_source(name_or_path: str | Path) -> str:
    """How a scene's origin is recorded: a bundled scene by its name, a file by its path relative
    to the working directory (never an absolute path, so records move between machines)."""
    p = Path(name_or_path)
    if _names_a_file(p):
        return os.path.relpath(p)
    return str(name_or_path)


def load_scene(name_or_path: str | Path, overrides: list[str] | dict[str, Any] | None = None) -> Scene:
    """Read, override and validate a scene; raises ``SceneError`` with a clear message."""
    path = resolve_scene_path(name_or_path)
    source = scene_source(name_or_path)
    shown = str(name_or_path)  # messages name the scene as the user gave it; records use ``source``
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{shown}: not valid TOML: {e}") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{shown}: not valid TOML: not UTF-8 text (byte {e.start})") from None
    except RecursionError:
        raise SceneError(f"{shown}: not valid TOML: nested too deeply") from None
    except OSError as e:
        raise SceneError(f"{shown}: cannot be read: {e.strerror or e}") from None
    return parse_scene(raw, source=source, overrides=overrides, shown=shown)


def parse_scene(raw: dict, source: str = "<scene>", overrides=None, shown: str | None = None) -> Scene:
    """Apply ``overrides`` to the parsed TOML ``raw`` and validate it. ``source`` is recorded in the
    Scene; errors name the scene as ``shown`` (default: ``source``)."""
    raw = copy.deepcopy(raw)
    where = shown or source
    texts: list[str] = []
    if overrides:
        if isinstance(overrides, dict):
            items = list(overrides.items())
            texts = [f"{k}={_toml_value(v)}" for k, v in items]
        else:
            texts = [str(o) for o in overrides]
            items = [_split_override(where, o) for o in texts]
        for key, value in items:
            _apply_override(raw, key, value, where)
    scene = _Validator(where).scene(raw)
    return dataclasses.replace(scene, source=source, overrides=tuple(texts))


# ----------------------------------------------------------------------------- resolved scene
def scene_toml(scene: Scene) -> str:
    """The resolved scene (its TOML after overrides) as TOML text; ``load_scene`` on a file holding
    it gives the same scene."""
    import tomli_w

    head = f"# Resolved scene: {scene.source or scene.name}"
    if scene.overrides:
        head += " with --set " + " --set ".join(scene.overrides)
    return head + "\n" + tomli_w.dumps(scene.raw)


def scene_sha256(scene: Scene) -> str:
    """SHA-256 (hex) of the resolved scene in a canonical form: its TOML tables after overrides as
    JSON with sorted keys and no spaces. Comments, key order and formatting of the file do not
    change it; any value does."""
    text = json.dumps(scene.raw, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _toml_value(v: Any) -> str:
    import tomli_w

    return tomli_w.dumps({"v": v}).split("=", 1)[1].strip()


# ----------------------------------------------------------------------------- overrides
def _split_override(source: str, text: str) -> tuple[str, Any]:
    if "=" not in text:
        raise SceneError(f"{source}: --set {text!r}: expected key=value")
    key, value = text.split("=", 1)
    try:
        doc = tomllib.loads(f"v = {value}")
    except (tomllib.TOMLDecodeError, RecursionError):
        return key.strip(), value  # a bare string
    if set(doc) != {"v"}:  # "1\nx = 2" would set x too, silently
        raise SceneError(f"{source}: --set {text!r}: the value is more than one TOML value")
    parsed = doc["v"]
    return key.strip(), parsed


def _apply_override(raw: dict, key: str, value: Any, source: str) -> None:
    parts = key.split(".")

    def walk(node, i):
        part = parts[i]
        last = i == len(parts) - 1
        if isinstance(node, list):
            if part == "*":
                targets = range(len(node))
            elif part.isdigit() and int(part) < len(node):
                targets = [int(part)]
            else:
                raise SceneError(f"{source}: --set {key!r}: {part!r} is not an index of a list of {len(node)}")
            for j in targets:
                if last:
                    node[j] = value
                else:
                    walk(node[j], i + 1)
            return
        if not isinstance(node, dict):
            raise SceneError(f"{source}: --set {key!r}: {'.'.join(parts[:i])!r} is not a table")
        if last:
            node[part] = value
        else:
            walk(node.setdefault(part, {}), i + 1)

    walk(raw, 0)


# ----------------------------------------------------------------------------- validation
class _Validator:
    def __init__(self, source: str):
        self.source = source

    def fail(self, where: str, problem: str):
        raise SceneError(f"{self.source}: {where}: {problem}")

    def table(self, node, where: str, allowed: set[str], required: set[str] = frozenset()) -> dict:
        if not isinstance(node, dict):
            self.fail(where, f"expected a table, got {type(node).__name__}")
        for k in node:
            if k not in allowed:
                label = k if re.fullmatch(r"[\w.-]+", k) else repr(k)  # one line, visible
                self.fail(f"{where}.{label}" if where else label, f"unknown key (allowed: {', '.join(sorted(allowed))})")
        for k in required:
            if k not in node:
                self.fail(f"{where}.{k}" if where else k, "missing")
        return node

    def number(self, node, key, where, default=None, positive=False, nonneg=False) -> float:
        if key not in node:
            if default is None:
                self.fail(f"{where}.{key}", "missing")
            return float(default)
        v = node[key]
        if not _is_number(v):
            self.fail(f"{where}.{key}", f"expected a finite number of magnitude <= {LIMIT:g}, got {_show(v)}")
        if positive and v <= 0:
            self.fail(f"{where}.{key}", f"must be positive, got {v}")
        if nonneg and v < 0:
            self.fail(f"{where}.{key}", f"must not be negative, got {v}")
        return float(v)

    def vector(self, node, key, where, n, default=None, nonneg=False) -> tuple[float, ...]:
        if key not in node:
            if default is None:
                self.fail(f"{where}.{key}", "missing")
            return tuple(default)
        v = node[key]
        if not isinstance(v, list) or len(v) != n or not all(_is_number(x) for x in v):
            self.fail(f"{where}.{key}", f"expected {n} finite numbers of magnitude <= {LIMIT:g}, got {_show(v)}")
        if nonneg and any(x < 0 for x in v):
            self.fail(f"{where}.{key}", f"must not be negative, got {v!r}")
        return tuple(float(x) for x in v)

    def points(self, node, key, where, min_len=1) -> tuple[tuple[float, float], ...]:
        v = node.get(key, [])
        if not isinstance(v, list) or len(v) < min_len:
            self.fail(f"{where}.{key}", f"expected a list of at least {min_len} [x, y] points")
        out = []
        for j, p in enumerate(v):
            if not isinstance(p, list) or len(p) != 2 or not all(_is_number(x) for x in p):
                self.fail(f"{where}.{key}[{j}]", f"expected [x, y] (finite, magnitude <= {LIMIT:g}), got {_show(p)}")
            out.append((float(p[0]), float(p[1])))
        return tuple(out)

    def integer(self, node, key, where, default: int) -> int:
        v = self.number(node, key, where, default, nonneg=True)
        if v != int(v):
            self.fail(f"{where}.{key}", f"must be a whole number, got {v}")
        return int(v)

    def name(self, node, key, where, default=None) -> str:
        v = self.string(node, key, where, default)
        if not NAME_PATTERN.fullmatch(v) or v in RESERVED_NAMES:
            self.fail(f"{where}.{key}", f"{v!r}: a name is 1-64 letters, digits, '_', '.' or '-', starting with a letter or digit, and not {', '.join(sorted(RESERVED_NAMES))}")
        return v

    def array_of_tables(self, raw, key) -> list:
        v = raw.get(key, [])
        if not isinstance(v, list):
            self.fail(key, f"expected an array of tables [[{key}]], got {type(v).__name__}")
        return v

    def boolean(self, node, key, where, default: bool) -> bool:
        v = node.get(key, default)
        if not isinstance(v, bool):
            self.fail(f"{where}.{key}", f"expected true or false, got {v!r}")
        return v

    def string(self, node, key, where, default=None, choices=None) -> str:
        v = node.get(key, default)
        if v is None:
            self.fail(f"{where}.{key}", "missing")
        if not isinstance(v, str):
            self.fail(f"{where}.{key}", f"expected a string, got {v!r}")
        if choices and v not in choices:
            self.fail(f"{where}.{key}", f"{v!r} is not one of {', '.join(choices)}")
        return v

    # -- sections
    def scene(self, raw: dict) -> Scene:
        self.table(raw, "", KEYS[""], {"scene", "room"})
        meta = self.table(raw["scene"], "scene", KEYS["scene"], {"name"})
        floorplan = self.floorplan(raw)
        sensors = self.sensors(raw.get("sensors", {}))
        render = self.table(raw.get("render", {}), "render", KEYS["render"])
        cameras = self.cameras(self.array_of_tables(raw, "cameras"), floorplan, sensors)
        walkers = self.walkers(raw.get("walkers", {}), floorplan)
        return Scene(
            name=self.string(meta, "name", "scene"),
            description=self.string(meta, "description", "scene", default=""),
            floorplan=floorplan,
            cameras=cameras,
            walkers=walkers,
            sensors=sensors,
            render=RenderSpec(shadows=self.boolean(render, "shadows", "render", False)),
            source=self.source,
            raw=raw,
        )

    def floorplan(self, raw: dict) -> Floorplan:
        room = self.table(raw["room"], "room", KEYS["room"], {"outline"})
        outline = np.asarray(self.points(room, "outline", "room", min_len=3))
        area = 0.5 * np.sum(outline[:, 0] * np.roll(outline[:, 1], -1) - np.roll(outline[:, 0], -1) * outline[:, 1])
        if abs(area) < 1e-6:
            self.fail("room.outline", "the outline encloses no area")
        wh = self.number(room, "wall_height", "room", 2.5, positive=True)
        wt = self.number(room, "wall_thickness", "room", 0.1, positive=True)
        walls = []
        for i, w in enumerate(self.array_of_tables(raw, "walls")):
            where = f"walls[{i}]"
            self.table(w, where, KEYS["walls"], {"start", "end"})
            a, b = self.vector(w, "start", where, 2), self.vector(w, "end", where, 2)
            if np.hypot(b[0] - a[0], b[1] - a[1]) < 1e-6:
                self.fail(where, "start and end are the same point")
            walls.append(Wall(a, b, self.number(w, "thickness", where, wt, positive=True), self.number(w, "height", where, wh, positive=True)))
        obstacles = []
        for i, o in enumerate(self.array_of_tables(raw, "obstacles")):
            where = f"obstacles[{i}]"
            self.table(o, where, KEYS["obstacles"], {"center", "size"})
            size = self.vector(o, "size", where, 3)
            if min(size) <= 0:
                self.fail(f"{where}.size", f"every side must be positive, got {list(size)}")
            c = self.vector(o, "center", where, 2)
            name = self.string(o, "name", where, default=f"obstacle{i}")
            if not name or name in {ob.name for ob in obstacles}:
                self.fail(f"{where}.name", f"{name!r}: obstacle names must be non-empty and distinct")
            obstacles.append(Obstacle(c, size, math.radians(self.number(o, "yaw_deg", where, 0.0)), name))
            if not bool(np.all(point_in_polygon(Obstacle(c, size).corners(), outline))):
                self.fail(where, f"obstacle at {list(c)} is not inside the room outline")
        return Floorplan(outline, tuple(walls), tuple(obstacles), wh, wt)

    def sensors(self, node) -> SensorSpec:
        d = SensorSpec()
        allowed = KEYS["sensors"]
        self.table(node, "sensors", allowed)
        kw = {}
        for k in allowed:
            if k not in node:
                continue
            if k == "magnetic_field":
                kw[k] = self.vector(node, k, "sensors", 3)
            elif k == "perception":
                kw[k] = self.string(node, k, "sensors")
                if not kw[k].strip():
                    self.fail("sensors.perception", "expected \"fitted\", \"ideal\" or a perception model file, got an empty string")
            else:
                positive = k.endswith("rate")
                kw[k] = self.number(node, k, "sensors", getattr(d, k), positive=positive, nonneg=True)
        s = SensorSpec(**kw)
        if not _divides(s.imu_rate, s.sim_rate):
            self.fail("sensors.imu_rate", f"{s.imu_rate} Hz must divide sensors.sim_rate = {s.sim_rate} Hz")
        return s

    def cameras(self, nodes, floorplan: Floorplan, sensors: SensorSpec) -> tuple[Camera, ...]:
        if not isinstance(nodes, list):
            self.fail("cameras", "expected an array of tables [[cameras]]")
        out, names = [], set()
        for i, c in enumerate(nodes):
            where = f"cameras[{i}]"
            self.table(c, where, KEYS["cameras"], {"name", "kind", "position", "fovy_deg", "resolution", "fps"})
            name = self.name(c, "name", where)
            where = f"cameras[{i}] ({name})"
            if name in names:
                self.fail(f"{where}.name", f"duplicate camera name {name!r}")
            names.add(name)
            kind = self.string(c, "kind", where, choices=CAMERA_KINDS)
            pos = np.asarray(self.vector(c, "position", where, 3))
            if "look_at" in c:
                if "yaw_deg" in c or "pitch_deg" in c:
                    self.fail(where, "give either look_at or yaw_deg/pitch_deg, not both")
                yaw, pitch = yaw_pitch_towards(pos, self.vector(c, "look_at", where, 3))
            else:
                default_pitch = -90.0 if kind == "overhead" else 0.0
                yaw = math.radians(self.number(c, "yaw_deg", where, 0.0))
                pitch = math.radians(self.number(c, "pitch_deg", where, default_pitch))
            if kind == "horizontal" and abs(pitch) > 1e-6:
                self.fail(f"{where}.pitch_deg", "a horizontal camera's optical axis must be parallel to the floor (pitch 0)")
            if kind == "overhead" and pitch > math.radians(-60):
                self.fail(f"{where}.pitch_deg", "an overhead camera must look down (pitch <= -60 degrees)")
            fovy = self.number(c, "fovy_deg", where, positive=True)
            if not 0.1 <= fovy < 170:
                self.fail(f"{where}.fovy_deg", f"{fovy} degrees: must be from 0.1 and below 170 (pinhole model)")
            res = self.vector(c, "resolution", where, 2)
            if min(res) < 8 or max(res) > MAX_PIXELS or any(r != int(r) for r in res):
                self.fail(f"{where}.resolution", f"expected [width, height] in whole pixels from 8 to {MAX_PIXELS}, got {list(res)}")
            fps = self.number(c, "fps", where, positive=True)
            if not _divides(fps, sensors.sim_rate):
                self.fail(f"{where}.fps", f"{fps} Hz must divide sensors.sim_rate = {sensors.sim_rate} Hz")
            if not (floorplan.inside(pos[:2]) or _near_outline(pos[:2], floorplan)):
                self.fail(f"{where}.position", f"camera at {pos.tolist()} is outside the room")
            if not 0 < pos[2] <= floorplan.wall_height + 1.0:
                self.fail(f"{where}.position", f"height {pos[2]} m is below the floor or above the ceiling")
            privacy = self.boolean(c, "privacy", where, False)
            region = None
            if "region" in c:
                region = self.vector(c, "region", where, 4)
                if not (region[0] < region[2] and region[1] < region[3]):
                    self.fail(f"{where}.region", "expected [xmin, ymin, xmax, ymax] with min < max")
            if kind != "overhead" and (privacy or region is not None):
                self.fail(where, "privacy and region apply to overhead cameras only")
            out.append(
                Camera(
                    name=name, kind=kind, position=pos, yaw=yaw, pitch=pitch, fovy=math.radians(fovy),
                    width=int(res[0]), height=int(res[1]), fps=fps, privacy=privacy,
                    quantum=sensors.privacy_quantum_m if privacy else 0.0, region=region,
                )
            )
        return tuple(out)

    def walkers(self, node, floorplan: Floorplan) -> tuple[WalkerSpec, ...]:
        self.table(node, "walkers", KEYS["walkers"])
        people = node.get("people", [])
        if not isinstance(people, list):
            self.fail("walkers.people", "expected an array of tables [[walkers.people]]")
        count = self.integer(node, "count", "walkers", len(people) if people else 1)
        if count > len(PALETTE):
            self.fail("walkers.count", f"{count} walkers: at most {len(PALETTE)} (one distinct colour each)")
        phoneless = self.integer(node, "phoneless", "walkers", 0)
        if phoneless > count:
            self.fail("walkers.phoneless", f"{phoneless} phoneless walkers but only {count} walkers")
        colours = dict(PALETTE)
        # a walker without a colour of its own takes the first palette colour nobody has (given or
        # taken); two walkers share a colour only where the scene gives both the same one
        given = [people[i].get("color") if i < len(people) and isinstance(people[i], dict) else None for i in range(count)]
        taken = {c for c in given if isinstance(c, str)}
        out = []
        for i in range(count):
            p = people[i] if i < len(people) else {}
            where = f"walkers.people[{i}]" if i < len(people) else f"walkers (walker {i})"
            self.table(p, where, KEYS["walkers.people"])
            merged = {k: v for k, v in node.items() if k not in ("count", "phoneless", "people")}
            merged.update(p)
            default = next((c for c, _ in PALETTE if c not in taken), PALETTE[i][0])
            cname = self.string(merged, "color", where, default=default, choices=list(colours))
            taken.add(cname)
            motion = self.string(merged, "motion", where, default="random_waypoint", choices=MOTION_MODELS)
            speed = self.vector(merged, "speed", where, 2, default=(0.5, 1.5), nonneg=True) if isinstance(merged.get("speed", []), list) else (self.number(merged, "speed", where, nonneg=True),) * 2
            pause = self.vector(merged, "pause", where, 2, default=(0.0, 5.0), nonneg=True)
            pn = self.vector(merged, "process_noise", where, 2, default=(2e-10, 2e-6), nonneg=True)
            waypoints = self.points(merged, "waypoints", where, min_len=2) if motion == "waypoints" else ()
            if motion == "waypoints" and "start" in merged:
                self.fail(f"{where}.start", "a waypoints walker starts at its first waypoint (with vary, up to 2 m along "
                          "its first leg); put the start first in waypoints instead")
            start = self.vector(merged, "start", where, 2) if "start" in merged else None
            height = self.number(merged, "height", where, 1.75, positive=True)
            radius = self.number(merged, "radius", where, 0.2, positive=True)
            if speed[0] > speed[1]:
                self.fail(f"{where}.speed", f"min {speed[0]} exceeds max {speed[1]}")
            if pause[0] > pause[1]:
                self.fail(f"{where}.pause", f"min {pause[0]} exceeds max {pause[1]}")
            if motion in ("random_waypoint", "random_walk", "waypoints") and speed[1] <= 0:
                self.fail(f"{where}.speed", "a walking person needs a positive speed")
            for label, pts in (("start", [start] if start else []), ("waypoints", list(waypoints))):
                for j, q in enumerate(pts):
                    clear = float(floorplan.clearance(np.asarray(q)))
                    if clear < radius:
                        what = "outside the room" if not np.isfinite(clear) else "inside a wall or obstacle"
                        self.fail(f"{where}.{label}" + (f"[{j}]" if label == "waypoints" else ""), f"{list(q)} is {what} (clearance {clear:.2f} m < radius {radius} m)")
            name = self.name(p, "name", where, default=f"p{i}")
            pause_probability = self.number(merged, "pause_probability", where, 0.5, nonneg=True)
            if pause_probability > 1:
                self.fail(f"{where}.pause_probability", f"must be from 0 to 1, got {pause_probability}")
            out.append(
                WalkerSpec(
                    name=name, color=colours[cname], color_name=cname, motion=motion, height=height, radius=radius,
                    speed=speed, pause=pause,
                    pause_probability=pause_probability,
                    waypoints=waypoints, loop=self.boolean(merged, "loop", where, False), start=start,
                    phone=self.boolean(merged, "phone", where, True) and i < count - phoneless,
                    gauss_markov=GaussMarkovParams(*pn),
                    bob_amplitude=self.number(merged, "bob_amplitude", where, 0.03, nonneg=True),
                    vary=self.boolean(merged, "vary", where, True),
                )
            )
        names = [w.name for w in out]
        if len(set(names)) != len(names):
            self.fail("walkers.people", f"duplicate walker names {names}")
        return tuple(out)


def _divides(rate: float, base: float) -> bool:
    k = base / rate
    return math.isfinite(k) and abs(k - round(k)) < 1e-9


def _is_number(v) -> bool:
    """A TOML int or float (not a bool), finite and at most LIMIT in magnitude."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return abs(v) <= LIMIT if isinstance(v, int) else math.isfinite(v) and abs(v) <= LIMIT


def _show(v) -> str:
    """A value for an error message: repr, shortened (a 400-digit integer is not worth a screen)."""
    r = repr(v)
    return r if len(r) <= 60 else r[:57] + "..."


def _near_outline(xy, floorplan: Floorplan) -> bool:
    return any(float(w.distance(xy)) <= w.thickness + 1e-9 for w in floorplan.outline_walls())
