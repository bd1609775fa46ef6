"""Property-based tests of the scene loader: random scene files from the schema, valid and mutated.

Every case ends in a ``Scene`` that holds only finite numbers, re-parses from its own ``raw`` and
compiles into a MuJoCo world, or in one ``SceneError`` whose one-line message starts with the file
and names the problem; never another exception. Valid scenes keep walls and obstacles in the right
half of the room and people in the left half, so a generated valid scene is valid by construction.
Case counts come from tests/props.py (profile ``ci`` or ``slow``, env TRACKROOM_HYPOTHESIS).
"""
from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trackroom.scenes import SceneError, load_scene, parse_scene
from trackroom.scenes.loader import PALETTE
from trackroom.scenes.spec import MOTION_MODELS, Scene
from trackroom.sim.world import build_world

from .props import examples

# ----------------------------------------------------------------------------- TOML text
_BARE = set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")


def _key(k: str) -> str:
    return k if k and set(k) <= _BARE else _string(k)


def _string(s: str) -> str:
    out = []
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _inline(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_inline(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def _is_aot(v) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def to_toml(d: dict, prefix: tuple = ()) -> str:
    """TOML text for a dict: sections ``[a.b]`` and arrays of tables ``[[a.b]]`` like the bundled scenes."""
    lines = [f"{_key(k)} = {_inline(v)}" for k, v in d.items() if not isinstance(v, dict) and not _is_aot(v)]
    for k, v in d.items():
        header = ".".join(_key(p) for p in prefix + (k,))
        if isinstance(v, dict):
            lines += ["", f"[{header}]", to_toml(v, prefix + (k,))]
        elif _is_aot(v):
            for item in v:
                lines += ["", f"[[{header}]]", to_toml(item, prefix + (k,))]
    return "\n".join(lines)


# ----------------------------------------------------------------------------- valid scenes
def _r(x: float) -> float:
    return round(x, 3)


def _num(lo, hi):
    return st.floats(lo, hi, allow_nan=False).map(_r)


NAME = st.from_regex(r"[a-z][a-z0-9_]{0,7}", fullmatch=True)


@st.composite
def valid_scenes(draw) -> dict:
    """A raw scene dict (as parsed TOML) that the loader must accept."""
    W, D = draw(_num(4, 20)), draw(_num(4, 20))
    wh = draw(_num(2.0, 4.0))
    corners = [[0, 0], [W, 0], [W, D], [0, D]]
    k = draw(st.integers(0, 3))
    corners = corners[k:] + corners[:k]
    if draw(st.booleans()):
        corners = corners[::-1]
    raw: dict = {"scene": {"name": draw(NAME)}, "room": {"outline": corners}}
    if draw(st.booleans()):
        raw["scene"]["description"] = draw(st.text(max_size=20))
    if draw(st.booleans()):
        raw["room"]["wall_height"] = wh
    else:
        wh = 2.5  # the default
    if draw(st.booleans()):
        raw["room"]["wall_thickness"] = draw(_num(0.02, 0.3))
    # walls and obstacles in the right half, x >= W/2 + 0.8
    right = st.tuples(_num(W / 2 + 0.8, W - 0.8), _num(0.8, D - 0.8)).map(list)
    walls = []
    for _ in range(draw(st.integers(0, 2))):
        a, b = draw(right), draw(right)
        if math.hypot(a[0] - b[0], a[1] - b[1]) < 0.1:
            continue
        w = {"start": a, "end": b}
        if draw(st.booleans()):
            w["thickness"] = draw(_num(0.02, 0.3))
        if draw(st.booleans()):
            w["height"] = draw(_num(0.5, 3.0))
        walls.append(w)
    if walls:
        raw["walls"] = walls
    obstacles = []
    for j in range(draw(st.integers(0, 2))):
        o = {"center": draw(right), "size": [draw(_num(0.1, 1.0)), draw(_num(0.1, 1.0)), draw(_num(0.1, 2.0))]}
        if draw(st.booleans()):
            o["yaw_deg"] = draw(_num(-360, 360))
        if draw(st.booleans()):
            o["name"] = f"box{j}"
        obstacles.append(o)
    if obstacles:
        raw["obstacles"] = obstacles
    # sensors
    sim_rate = draw(st.sampled_from([50, 100, 200]))
    sensors = {"sim_rate": sim_rate}
    for f in ("bearing_sigma_px", "box_sigma_px", "floor_sigma_m", "privacy_quantum_m", "still_speed",
              "accel_sigma", "gyro_sigma", "mag_sigma", "flow_sigma_px_s", "flow_min_px_s"):
        if draw(st.booleans()):
            sensors[f] = draw(_num(0, 10))
    if sim_rate == 50 or draw(st.booleans()):  # the default 100 Hz does not divide 50 Hz
        sensors["imu_rate"] = sim_rate / draw(st.integers(1, 10))
    if draw(st.booleans()):
        sensors["magnetic_field"] = [draw(_num(-1, 1)) for _ in range(3)]
    if draw(st.booleans()):
        sensors["perception"] = draw(st.sampled_from(["fitted", "ideal", "my_model.json"]))
    raw["sensors"] = sensors
    if draw(st.booleans()):
        raw["render"] = {"shadows": draw(st.booleans())}
    # cameras of each kind
    inside = lambda z_lo, z_hi: st.tuples(_num(0.06, W - 0.06), _num(0.06, D - 0.06), _num(z_lo, z_hi)).map(list)  # noqa: E731
    cams = []
    for name in draw(st.lists(NAME, max_size=4, unique=True)):
        kind = draw(st.sampled_from(["horizontal", "overhead", "oblique"]))
        c = {"name": name, "kind": kind, "fovy_deg": draw(_num(1, 169)),
             "resolution": [draw(st.integers(8, 1920)), draw(st.integers(8, 1080))],
             "fps": sim_rate / draw(st.integers(1, 25))}
        if kind == "horizontal":
            c["position"] = draw(inside(0.1, wh))
            c["yaw_deg"] = draw(_num(-360, 360))
            if draw(st.booleans()):
                c["pitch_deg"] = 0
        elif kind == "overhead":
            c["position"] = draw(inside(wh / 2, wh))
            c["yaw_deg"] = draw(_num(-180, 180))
            if draw(st.booleans()):
                c["pitch_deg"] = draw(_num(-90, -60))
            if draw(st.booleans()):
                c["privacy"] = draw(st.booleans())
            if draw(st.booleans()):
                x0, y0 = draw(_num(0, W / 2)), draw(_num(0, D / 2))
                c["region"] = [x0, y0, _r(x0 + draw(_num(0.5, W / 2))), _r(y0 + draw(_num(0.5, D / 2)))]
        else:
            c["position"] = draw(inside(0.1, wh))
            if draw(st.booleans()):
                c["look_at"] = [draw(_num(0, W)), draw(_num(0, D)), draw(_num(0, 2))]
            else:
                c["yaw_deg"], c["pitch_deg"] = draw(_num(-180, 180)), draw(_num(-89, 89))
        cams.append(c)
    if cams:
        raw["cameras"] = cams
    # walkers: people (each motion model) in the left half, x <= W/2 - 0.6, clear by >= 0.6 m
    left = st.tuples(_num(0.6, W / 2 - 0.6), _num(0.6, D - 0.6)).map(list)
    people = []
    names = draw(st.lists(st.from_regex(r"[A-Z][a-z0-9_]{0,7}", fullmatch=True), max_size=4, unique=True))
    for name in names:
        motion = draw(st.sampled_from(MOTION_MODELS))
        p = {"motion": motion}
        if draw(st.booleans()):
            p["name"] = name
        if motion == "waypoints":
            p["waypoints"] = draw(st.lists(left, min_size=2, max_size=5))
            if draw(st.booleans()):
                p["loop"] = draw(st.booleans())
        if motion != "waypoints" and draw(st.booleans()):  # a waypoints walker starts at its first waypoint
            p["start"] = draw(left)
        if draw(st.booleans()):
            lo = draw(_num(0, 1.5))
            p["speed"] = [lo, _r(lo + draw(_num(0.1, 1.0)))]
        if draw(st.booleans()):
            lo = draw(_num(0, 5))
            p["pause"] = [lo, _r(lo + draw(_num(0, 5)))]
        for key, strat in (("pause_probability", _num(0, 1)), ("phone", st.booleans()), ("height", _num(1.0, 2.0)),
                           ("radius", _num(0.1, 0.4)), ("bob_amplitude", _num(0, 0.1)),
                           ("process_noise", st.tuples(_num(0, 1e-3), _num(0, 1e-3)).map(list))):
            if draw(st.booleans()):
                p[key] = draw(strat)
        people.append(p)
    walkers: dict = {}
    count = draw(st.integers(len(people), 6)) if people else draw(st.integers(0, 6))
    if draw(st.booleans()) or not people:
        walkers["count"] = count
    else:
        count = len(people)
    if count > len(people):  # template walkers: not "waypoints" (the template has no waypoints)
        if draw(st.booleans()):
            walkers["motion"] = draw(st.sampled_from([m for m in MOTION_MODELS if m != "waypoints"]))
        if draw(st.booleans()):
            walkers["speed"] = draw(_num(0.2, 2.0))
        if draw(st.booleans()):
            walkers["radius"] = draw(_num(0.1, 0.4))
    elif people and draw(st.booleans()):
        for p, colour in zip(people, draw(st.permutations([c for c, _ in PALETTE]))):
            p["color"] = colour
    if count and draw(st.booleans()):
        walkers["phoneless"] = draw(st.integers(0, count))
    if people:
        walkers["people"] = people
    if walkers or draw(st.booleans()):
        raw["walkers"] = walkers
    return raw


# ----------------------------------------------------------------------------- mutations
def _paths(node, prefix=()):
    """Every (path, value) under a parsed TOML node; a path is a tuple of keys and indices."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _set(raw, path, value):
    node = raw
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _get(raw, path):
    for p in path:
        raw = raw[p]
    return raw


BAD_NUMBERS = st.sampled_from([math.nan, math.inf, -math.inf, -1, -1e-9, 0, 1e-310, 1e308, -1e308, 10**30, 10**400, 2**63 - 1])
BAD_VALUES = st.one_of(
    BAD_NUMBERS,
    st.sampled_from(["", "3", "fast", [], [1], [[]], {}, {"a": 1}, True, False, [math.nan, 1], [1, 2, 3, 4, 5]]),
    st.text(max_size=5),
    st.lists(st.floats(), max_size=3),
    st.integers(),
)


def _bad_value(draw):
    """A drawn bad value, copied: ``BAD_VALUES`` samples shared lists and dicts, and a later
    mutation of the scene (a key added, an item removed) would change the shared object, so the
    same draws gave other scenes later (hypothesis: FlakyStrategyDefinition)."""
    return copy.deepcopy(draw(BAD_VALUES))


@st.composite
def mutated_scenes(draw) -> dict:
    """A valid scene with one to three things broken."""
    raw = draw(valid_scenes())
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(raw) if p]
        kind = draw(st.sampled_from(["remove", "unknown", "replace", "number", "empty", "outside", "in_wall", "duplicate"]))
        if kind == "remove":
            p = draw(st.sampled_from(paths))
            parent = _get(raw, p[:-1])
            del parent[p[-1]]  # a key of a table or an item of a list
        elif kind == "unknown":
            tables = [p for p, v in _paths(raw) if isinstance(v, dict)]
            _set_key = draw(st.sampled_from(tables))
            _get(raw, _set_key)[draw(st.text(min_size=1, max_size=8))] = _bad_value(draw)
        elif kind == "replace":
            _set(raw, draw(st.sampled_from(paths)), _bad_value(draw))
        elif kind == "number":
            nums = [p for p, v in _paths(raw) if p and isinstance(v, (int, float)) and not isinstance(v, bool)]
            if nums:
                _set(raw, draw(st.sampled_from(nums)), draw(BAD_NUMBERS))
        elif kind == "empty":
            lists = [p for p, v in _paths(raw) if p and isinstance(v, list)]
            if lists:
                _set(raw, draw(st.sampled_from(lists)), [])
        elif kind == "outside" and isinstance(raw.get("cameras"), list) and raw["cameras"]:
            c = draw(st.sampled_from(raw["cameras"]))
            if isinstance(c, dict):
                c["position"] = [draw(st.sampled_from([-3.0, 1e6])), 1.0, draw(st.sampled_from([1.0, -1.0, 100.0]))]
        elif kind == "in_wall":
            people = raw.get("walkers", {}).get("people") if isinstance(raw.get("walkers"), dict) else None
            target = None
            if isinstance(raw.get("obstacles"), list) and raw["obstacles"] and isinstance(raw["obstacles"][0], dict):
                target = raw["obstacles"][0].get("center")
            elif isinstance(raw.get("walls"), list) and raw["walls"] and isinstance(raw["walls"][0], dict):
                target = raw["walls"][0].get("start")
            if isinstance(people, list) and people and isinstance(people[0], dict) and target is not None:
                if people[0].get("motion") == "waypoints" and isinstance(people[0].get("waypoints"), list) and people[0]["waypoints"]:
                    people[0]["waypoints"][0] = copy.deepcopy(target)
                else:
                    people[0]["start"] = copy.deepcopy(target)
        elif kind == "duplicate":
            for section in ("cameras", "obstacles"):
                items = raw.get(section)
                if isinstance(items, list) and len(items) >= 1 and all(isinstance(c, dict) for c in items):
                    items.append(copy.deepcopy(items[0]))
            people = raw.get("walkers", {}).get("people") if isinstance(raw.get("walkers"), dict) else None
            if isinstance(people, list) and len(people) >= 2 and all(isinstance(p, dict) for p in people):
                people[1]["name"] = people[0].get("name", "p0")
                raw["walkers"].pop("count", None)
    return raw


@st.composite
def text_mutations(draw, text: str) -> str:
    """Malformed TOML: cut, a character inserted or deleted, an '=' replaced, a header broken."""
    kind = draw(st.sampled_from(["cut", "insert", "delete", "equals", "header", "bytes"]))
    i = draw(st.integers(0, max(len(text) - 1, 0)))
    if kind == "cut":
        return text[:i]
    if kind == "insert":
        return text[:i] + draw(st.one_of(st.sampled_from(list("[]{}=\"',.#\n\\")), st.characters())) + text[i:]
    if kind == "delete":
        return text[:i] + text[i + 1:]
    if kind == "equals":
        return text.replace("=", draw(st.sampled_from([":", "==", ""])), 1)
    if kind == "header":
        return text.replace("[", "", 1)
    return text[:i] + "\udcff" + text[i:]  # written with surrogateescape: a byte that is not UTF-8


OVERRIDE_VALUES = st.one_of(
    st.sampled_from(["1", "-1", "0", "nan", "inf", "-inf", "1e400", "true", "maybe", "\"x\"", "[1, 2]", "[", "{a = 1}",
                     "[[0, 0], [1, 0]]", "", "1\nx = 2", "99999999999999999999999999", "0.0000001"]),
    st.text(max_size=8),
)


@st.composite
def overrides_for(draw, raw: dict) -> list[str]:
    """``--set`` strings: real paths (tables, list indices, ``*``) and made-up ones, odd values."""
    real = [".".join(str(p) for p in path) for path, _ in _paths(raw) if path]
    real += [r.replace(".0.", ".*.") for r in real if ".0." in r]
    path = st.one_of(st.sampled_from(real), st.text(max_size=12),
                     st.sampled_from(["", ".", "..", "cameras.9.fps", "cameras.x", "walkers.people.-1.name",
                                      "scene.name.x", "walls.0", "room.outline.*.*", "sensors", "walkers.*"]))
    out = []
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.integers(0, 9)) == 0:
            out.append(draw(st.text(max_size=10)))  # maybe no '=' at all
        else:
            out.append(f"{draw(path)}={draw(OVERRIDE_VALUES)}")
    return out


# ----------------------------------------------------------------------------- checks
def _finite(*xs) -> bool:
    return all(np.all(np.isfinite(np.asarray(x, float))) for x in xs)


def summary(scene: Scene) -> dict:
    """What a Scene holds, as plain data (Scene itself holds arrays, so == does not apply)."""
    return {
        "name": scene.name,
        "floorplan": json.dumps(scene.floorplan.to_dict(), sort_keys=True),
        "cameras": [(c.name, c.kind, np.round(c.P, 9).tolist(), c.width, c.height, c.fps, c.privacy, c.region) for c in scene.cameras],
        "walkers": [repr(w) for w in scene.walkers],
        "sensors": repr(scene.sensors),
        "render": repr(scene.render),
    }


def check_scene(scene: Scene, source: str) -> None:
    """Invariants of an accepted scene."""
    fp = scene.floorplan
    assert _finite(fp.outline, fp.wall_height, fp.wall_thickness)
    for w in fp.walls:
        assert _finite(w.start, w.end, w.thickness, w.height)
    for o in fp.obstacles:
        assert _finite(o.center, o.size, o.yaw) and isinstance(o.name, str)
    for c in scene.cameras:
        assert isinstance(c.name, str) and _finite(c.position, c.yaw, c.pitch, c.fovy, c.fps, c.P)
    for w in scene.walkers:
        assert isinstance(w.name, str)
        assert _finite(w.speed, w.pause, w.height, w.radius, w.pause_probability, w.bob_amplitude, list(w.waypoints) or 0.0)
        assert 0 <= w.pause_probability <= 1 and w.speed[0] <= w.speed[1] and w.pause[0] <= w.pause[1]
    assert len({c.name for c in scene.cameras}) == len(scene.cameras)
    assert len({w.name for w in scene.walkers}) == len(scene.walkers)
    s = scene.sensors
    assert _finite(*[getattr(s, f) for f in s.__dataclass_fields__ if f != "perception"])
    assert isinstance(s.perception, str) and s.perception.strip()
    # the resolved raw scene reproduces the scene, also through TOML text (provenance stores it so)
    assert summary(parse_scene(scene.raw, source=source)) == summary(scene)
    assert summary(parse_scene(tomllib.loads(to_toml(scene.raw)), source=source)) == summary(scene)
    build_world(scene)  # compiles in MuJoCo (about 2 ms)


def outcome(path, overrides=None):
    """Load; return the Scene or None after checking the SceneError's message."""
    try:
        scene = load_scene(path, overrides)
    except SceneError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), msg
        assert "\n" not in msg and len(msg) > len(f"{path}: ") + 5, msg
        return None
    check_scene(scene, str(path))
    return scene


def _write(tmp_path, text: str):
    path = tmp_path / "scene.toml"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    return path


# ----------------------------------------------------------------------------- properties
@settings(max_examples=examples(150))
@given(raw=valid_scenes())
def test_valid_scenes_load_and_round_trip(tmp_path_factory, raw):
    text = to_toml(raw)
    assert tomllib.loads(text) == raw  # the writer itself
    path = _write(tmp_path_factory.mktemp("s"), text)
    scene = load_scene(path)  # a valid scene is accepted: a SceneError here fails the test
    check_scene(scene, str(path))
    assert scene.raw == raw
    n = raw.get("walkers", {}).get("count", len(raw.get("walkers", {}).get("people", [])) or 1)
    assert len(scene.walkers) == n and len(scene.cameras) == len(raw.get("cameras", []))


@settings(max_examples=examples(300))
@given(raw=mutated_scenes())
def test_mutated_scenes_load_or_fail_clearly(tmp_path_factory, raw):
    outcome(_write(tmp_path_factory.mktemp("s"), to_toml(raw)))


@settings(max_examples=examples(150))
@given(data=st.data())
def test_malformed_toml_text_fails_clearly(tmp_path_factory, data):
    text = data.draw(text_mutations(to_toml(data.draw(valid_scenes()))))
    outcome(_write(tmp_path_factory.mktemp("s"), text))


@settings(max_examples=examples(200))
@given(data=st.data())
def test_overrides_apply_or_fail_clearly(tmp_path_factory, data):
    raw = data.draw(valid_scenes())
    overrides = data.draw(overrides_for(raw))
    outcome(_write(tmp_path_factory.mktemp("s"), to_toml(raw)), overrides)


@settings(max_examples=examples(100))
@given(data=st.data())
def test_overrides_that_restate_values_change_nothing(tmp_path_factory, data):
    """``--set path=<the value already there>`` (dotted paths, list indices) gives the same scene."""
    raw = data.draw(valid_scenes())
    leaves = [(p, v) for p, v in _paths(raw) if p and not isinstance(v, (dict, list)) or (p and isinstance(v, list) and not _is_aot(v))]
    picked = data.draw(st.lists(st.sampled_from(leaves), min_size=1, max_size=4))
    path = _write(tmp_path_factory.mktemp("s"), to_toml(raw))
    scene = load_scene(path, [f"{'.'.join(map(str, p))}={_inline(v)}" for p, v in picked])
    assert summary(scene) == summary(load_scene(path)) and scene.raw == raw


# ----------------------------------------------------------------------------- regressions
def test_regression_malformed_scene_file(tmp_path):
    """Issue 16: a malformed scene file ends in one SceneError naming the file."""
    path = _write(tmp_path, '[scene]\nname = "x"\n[room\noutline = [[0, 0], [1, 0], [1, 1]]\n')
    with pytest.raises(SceneError, match=r"scene\.toml: not valid TOML"):
        load_scene(path)
    # and on the command line: one line, exit status 2
    r = subprocess.run([sys.executable, "-m", "trackroom", "show", str(path), "--out", str(tmp_path / "s.png")],
                       cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert lines[0].startswith(f"trackroom show: error: {path}: not valid TOML")


BASE = {
    "scene": {"name": "reg"},
    "room": {"outline": [[0, 0], [8, 0], [8, 6], [0, 6]]},
    "obstacles": [{"name": "desk", "center": [6.0, 3.0], "size": [0.8, 0.8, 0.8]}],
    "cameras": [{"name": "c0", "kind": "overhead", "position": [4.0, 3.0, 2.4], "fovy_deg": 90,
                 "resolution": [320, 240], "fps": 10}],
    "walkers": {"count": 1, "people": [{"name": "a", "start": [2.0, 3.0]}]},
}


@pytest.mark.parametrize(
    "path, value, problem",
    [
        # each was found by the suites above; the old behaviour is in the comment
        (("walkers", "people", 0, "height"), 10**400, "finite number"),  # OverflowError
        (("walls",), -1, "array of tables"),  # TypeError: 'int' object is not iterable
        (("room", "outline", 1, 0), math.nan, r"expected \[x, y\]"),  # accepted: a NaN room
        (("room", "outline", 1, 0), 1e300, r"expected \[x, y\]"),  # accepted: overflow, inf in P
        (("cameras", 0, "resolution"), [2**31, 240], r"resolution"),  # TypeError in build_world (int32)
        (("cameras", 0, "fps"), 1e-310, "must divide"),  # OverflowError: round(inf)
        (("cameras", 0, "fovy_deg"), 1e-300, "fovy_deg"),  # accepted: focal length inf
        (("walkers", "people", 0, "pause"), [5, 1], "pause: min 5.0 exceeds max 1.0"),  # accepted
        (("walkers", "people", 0, "pause_probability"), 3.0, "from 0 to 1"),  # accepted
        (("walkers", "phoneless"), 0.5, "whole number"),  # accepted as 0
        (("walkers", "people", 0, "name"), "world", "a name is"),  # MuJoCo: repeated name 'world'
        (("cameras", 0, "name"), "../c", "a name is"),  # accepted: a file outside calibration/
        (("obstacles", 0, "name"), 7, "expected a string"),  # accepted: an int name
        (("room", "a\nb"), 1, r"room\.'a\\nb': unknown key"),  # a two-line message
    ],
)
def test_regression_scene_defects(tmp_path, path, value, problem):
    raw = copy.deepcopy(BASE)
    _set(raw, path, value)
    with pytest.raises(SceneError, match=problem) as e:
        load_scene(_write(tmp_path, to_toml(raw)))
    assert "\n" not in str(e.value)


def test_regression_duplicate_obstacle_names_and_reserved_geom_names(tmp_path):
    """Two obstacles named alike were accepted, then MuJoCo refused the world (repeated name);
    an obstacle named "floor" collided with the floor geom."""
    raw = copy.deepcopy(BASE)
    raw["obstacles"].append({"name": "desk", "center": [6.0, 1.0], "size": [0.5, 0.5, 0.5]})
    with pytest.raises(SceneError, match=r"obstacles\[1\]\.name: 'desk'.*distinct"):
        load_scene(_write(tmp_path, to_toml(raw)))
    raw["obstacles"][1]["name"] = "floor"
    build_world(load_scene(_write(tmp_path, to_toml(raw))))


def test_regression_scene_file_not_utf8_or_a_folder(tmp_path):
    """Bytes that are not UTF-8 ended in UnicodeDecodeError, a folder in IsADirectoryError."""
    path = _write(tmp_path, to_toml(BASE).replace('"reg"', '"r\udcffg"'))
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(path)
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(SceneError, match="cannot be read"):
        load_scene(tmp_path / "dir.toml")


def test_regression_deeply_nested_toml_and_override(tmp_path):
    """Arrays nested 100000 deep ended in RecursionError (a file) or a traceback (a --set value)."""
    deep = "[" * 100000 + "]" * 100000
    with pytest.raises(SceneError, match="nested too deeply"):
        load_scene(_write(tmp_path, to_toml(BASE) + f"\nx = {deep}\n"))
    with pytest.raises(SceneError, match="unknown key"):  # the value is kept as a bare string
        load_scene(_write(tmp_path, to_toml(BASE)), [f"x={deep}"])


def test_regression_override_value_with_a_second_key(tmp_path):
    """--set 'walkers.count=1\\nx = 2' applied the 1 and dropped the rest silently."""
    with pytest.raises(SceneError, match="more than one TOML value"):
        load_scene(_write(tmp_path, to_toml(BASE)), ["walkers.count=1\nx = 2"])


# ----------------------------------------------------------------------------- bundled scenes
@settings(max_examples=examples(20), deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_bearing_corridor_is_rahimi_fig_1b_on_every_seed(seed):
    """bearing_corridor's premise (issue 13), whatever the seed: after its start (2 s) the walker
    keeps one speed (within 1 %, inside 1.2 m/s x the pace range 0.85-1.15) on a straight line
    along the corridor (heading within 1 deg), stays clear of the far end for 20 s, and passes
    every camera's view, never two at once (Rahimi Fig. 1b: a constant speed past
    non-overlapping cameras). A change to the walkers that breaks it makes the corridor
    experiment (docs/qp_smoother.md) meaningless."""
    from trackroom.sim.walkers import plan_trajectories

    scene = load_scene("bearing_corridor")
    tr = plan_trajectories(scene, 20.0, np.random.default_rng(seed))
    v, xy = tr.vel[0, :, :2], tr.pos[0, :, :2]
    walking = tr.t >= 2.0
    speed = np.hypot(v[walking, 0], v[walking, 1])
    mid = float(np.median(speed))
    assert 1.2 * 0.85 - 1e-6 <= mid <= 1.2 * 1.15 + 1e-6
    assert np.abs(speed / mid - 1).max() < 0.01
    heading = np.degrees(np.arctan2(v[walking, 1], v[walking, 0]))
    assert np.ptp(heading) < 1.0 and np.abs(heading).max() < 5.0
    assert xy[:, 0].max() < 28.5
    seen = np.stack([c.in_horizontal_fov(xy) for c in scene.cameras])
    assert seen.any(axis=1).all() and seen.sum(axis=0).max() == 1
