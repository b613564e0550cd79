"""Bad scene input, property-based: valid planar and 3-D scene files are mutated (keys dropped,
wrong types, NaN/inf, negative radii, inverted boxes, 2-D/3-D coordinate mixes, huge n, unknown
keys, obstacle types of the other dimension, corrupted TOML text) and every load must either
give a Scenario or raise the one-line ScenarioError naming a key, never any other exception."""

import copy
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swarmnav.errors import ScenarioError
from swarmnav.world.scenario import MAX_AGENTS, Scenario, from_dict, loads

BASE_2D = {
    "name": "fuzz2d",
    "world": {"bounds": [-6.0, -6.0, 12.0, 6.0]},
    "swarm": {"n": 4, "spawn": [-5.0, -2.0, -3.0, 2.0], "min_spacing": 0.6, "clearance": 0.5},
    "goal": {"position": [10.0, 0.0], "path": [[-4.0, 0.0], [10.0, 0.0]]},
    "obstacles": [
        {"type": "box", "min": [2.0, 1.0], "max": [3.0, 4.0]},
        {"type": "circle", "center": [5.0, -2.0], "radius": 0.8},
        {"type": "polygon", "points": [[6.0, 1.0], [8.0, 1.0], [7.0, 3.0]]},
    ],
}

BASE_3D = {
    "name": "fuzz3d",
    "description": "a small 3-D scene",
    "world": {"bounds": [-6.0, -6.0, 0.0, 12.0, 6.0, 4.0]},
    "swarm": {"n": 4, "spawn": [-5.0, -2.0, 1.0, -3.0, 2.0, 2.0]},
    "goal": {"position": [10.0, 0.0, 1.5]},
    "obstacles": [
        {"type": "box", "min": [2.0, 1.0, 0.0], "max": [3.0, 4.0, 3.0]},
        {"type": "cylinder", "center": [5.0, -2.0], "radius": 0.8, "z": [0.0, 4.0]},
        {"type": "sphere", "center": [4.0, 2.5, 2.0], "radius": 0.7},
        {"type": "polygon", "points": [[6.0, 1.0], [8.0, 1.0], [7.0, 3.0]], "z": [1.0, 3.0]},
    ],
}

#: Values a mutation may put anywhere: wrong types, non-finite and extreme numbers, wrong shapes.
JUNK = st.one_of(
    st.sampled_from([None, True, "", "abc", "3", [], {}, [[]], {"a": 1}, math.nan, math.inf, -math.inf,
                     0, -1, -0.5, 1e308, -1e308, 5e-324, 10**30, -(10**400), 2**63, MAX_AGENTS, MAX_AGENTS + 1,
                     [1.0], [1.0, 2.0], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                     [math.nan, 0.0], [0.0, math.inf, 1.0], ["a", "b"], [True, False, 1.0]]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**20), max_value=10**20),
    st.lists(st.floats(min_value=-50, max_value=50), min_size=0, max_size=7),
)


def _paths(node, prefix=()):
    """Every (path, value) inside a scene dictionary (paths are tuples of keys / indices)."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _get(d, path):
    for k in path:
        d = d[k]
    return d


@st.composite
def mutated_scene(draw):
    scene = copy.deepcopy(draw(st.sampled_from([BASE_2D, BASE_3D])))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(scene) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _get(scene, path[:-1]), path[-1]
        value = parent[key]
        op = draw(st.sampled_from(["drop", "junk", "unknown", "swap", "grow", "shrink", "negate", "type", "huge_n"]))
        if op == "drop":
            del parent[key]
        elif op == "junk":
            parent[key] = draw(JUNK)
        elif op == "unknown" and isinstance(value, dict):
            value[draw(st.sampled_from(["z", "radius", "typo", "bounds", "periodic", "x\ny", "min"]))] = draw(JUNK)
        elif op == "swap" and isinstance(value, list) and len(value) in (4, 6):  # inverted box / bounds
            h = len(value) // 2
            parent[key] = value[h:] + value[:h]
        elif op == "swap" and isinstance(value, dict) and "min" in value and "max" in value:
            value["min"], value["max"] = value["max"], value["min"]
        elif op == "grow" and isinstance(value, list):  # a 2-D coordinate made 3-D, 4 bounds made 6...
            parent[key] = value + ([draw(st.floats(-10, 10))] if len(value) in (2, 3) else value[:2])
        elif op == "shrink" and isinstance(value, list) and value:
            parent[key] = value[: -1 if len(value) in (2, 3) else -2]
        elif op == "negate" and isinstance(value, (int, float)) and not isinstance(value, bool):
            parent[key] = -value
        elif op == "type" and isinstance(value, dict) and "type" in value:  # obstacle type of the other dimension
            value["type"] = draw(st.sampled_from(["box", "circle", "polygon", "cylinder", "sphere", "cone"]))
        elif op == "huge_n" and isinstance(scene.get("swarm"), dict):
            scene["swarm"]["n"] = draw(st.sampled_from([MAX_AGENTS + 1, 10**9, 10**18, 10**30]))
    return scene


def _check(load, *args):
    """``load(*args)`` gives a Scenario or a one-line ScenarioError naming a key."""
    try:
        scn = load(*args)
    except ScenarioError as e:
        msg = str(e)
        assert "\n" not in msg and "\r" not in msg, msg
        rest = msg.split(": ", 1)[1]
        assert re.search(r"\b(name|description|world|swarm|goal|obstacles|malformed TOML)\b", rest), msg
        return None
    assert isinstance(scn, Scenario)
    assert scn.dim in (2, 3) and len(scn.bounds) == 2 * scn.dim and len(scn.swarm.spawn) == 2 * scn.dim
    return scn


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, (int, str)):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def to_toml(scene: dict) -> str:
    """A scene dictionary as TOML text (None values, which TOML cannot hold, are left out)."""
    lines, tables = [], []
    for k, v in scene.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables.append(f"[{json.dumps(k)}]")
            tables += [f"{json.dumps(str(a))} = {_toml_value(b)}" for a, b in v.items() if b is not None
                       and not (isinstance(b, list) and any(x is None for x in b))]
        elif isinstance(v, list) and v and all(isinstance(o, dict) for o in v):
            for o in v:
                tables.append(f"[[{json.dumps(k)}]]")
                tables += [f"{json.dumps(str(a))} = {_toml_value(b)}" for a, b in o.items() if b is not None]
        elif not (isinstance(v, list) and any(x is None for x in v)):
            lines.append(f"{json.dumps(k)} = {_toml_value(v)}")
    return "\n".join(lines + tables) + "\n"


FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.parametrize("base", [BASE_2D, BASE_3D], ids=["2d", "3d"])
def test_base_scenes_are_valid(base):
    scn = from_dict(copy.deepcopy(base))
    assert scn.dim == len(base["goal"]["position"])
    assert loads(to_toml(base)).dim == scn.dim


@FUZZ
@given(mutated_scene())
def test_mutated_scene_dict_loads_or_gives_one_line_error(scene):
    _check(from_dict, scene)


@FUZZ
@given(mutated_scene())
def test_mutated_scene_file_loads_or_gives_one_line_error(scene):
    try:
        text = to_toml(scene)
    except TypeError:  # a value TOML cannot hold (None inside a table): not a file
        return
    _check(loads, text, "fuzz.toml")


@FUZZ
@given(st.sampled_from([BASE_2D, BASE_3D]), st.data())
def test_corrupted_scene_text_loads_or_gives_one_line_error(base, data):
    text = to_toml(base)
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(text)))
        j = data.draw(st.integers(i, min(len(text), i + 12)))
        text = text[:i] + data.draw(st.sampled_from(["", "]", "[", "=", "\n", ",", "-", "9e999", "nan", '"', "0"])) + text[j:]
    _check(loads, text, "fuzz.toml")


# --------------------------------------------------------------------------- named cases

@pytest.mark.parametrize(
    ("mutate", "key"),
    [
        (lambda d: d["swarm"].__setitem__("spawn", [-5.0, -2.0, -3.0, 2.0]), "swarm.spawn"),  # 2-D spawn, 3-D bounds
        (lambda d: d["goal"].__setitem__("position", [10.0, 0.0]), "goal.position"),
        (lambda d: d["obstacles"][0].__setitem__("min", [2.0, 1.0]), "obstacles[0].min"),
        (lambda d: d["obstacles"][1].__setitem__("center", [5.0, -2.0, 1.0]), "obstacles[1].center"),
        (lambda d: d["obstacles"][2].__setitem__("center", [4.0, 2.5]), "obstacles[2].center"),
        (lambda d: d["obstacles"][3]["points"].__setitem__(0, [6.0, 1.0, 0.0]), "obstacles[3].points[0]"),
        (lambda d: d["obstacles"][3].pop("z"), "obstacles[3].z"),
        (lambda d: d["obstacles"][1].__setitem__("type", "circle"), "obstacles[1].type"),
        (lambda d: d["obstacles"][2].__setitem__("radius", -0.7), "obstacles[2].radius"),
        (lambda d: d["obstacles"][1].__setitem__("z", [4.0, 0.0]), "obstacles[1].z"),
        (lambda d: d["obstacles"][0].__setitem__("max", [3.0, 4.0, math.nan]), "obstacles[0].max"),
        (lambda d: d["world"].__setitem__("bounds", [-1e308, -6.0, 0.0, 1e308, 6.0, 4.0]), "world.bounds"),
        (lambda d: d["swarm"].__setitem__("spawn", [-5.0, -2.0, 1.0, 10**400, 2.0, 2.0]), "swarm.spawn"),
        (lambda d: d["swarm"].__setitem__("n", 10**12), "swarm.n"),
        (lambda d: d["world"].__setitem__("periodic", True), "world.periodic"),
    ],
)
def test_3d_mistakes_name_their_key(mutate, key):
    d = copy.deepcopy(BASE_3D)
    mutate(d)
    with pytest.raises(ScenarioError) as e:
        from_dict(d, source="s.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"s.toml: {key} "), msg


def test_cylinder_centre_error_says_why_not_planar():
    d = copy.deepcopy(BASE_3D)
    d["obstacles"][1]["center"] = [5.0, -2.0, 1.0]
    with pytest.raises(ScenarioError, match=r"obstacles\[1\]\.center must be \[x, y\] because a cylinder is vertical"):
        from_dict(d)


def test_unknown_key_with_a_newline_stays_one_line():
    with pytest.raises(ScenarioError) as e:
        loads(to_toml(BASE_3D).replace("[\"world\"]", "[\"world\"]\n\"a\\nb\" = 1"), "s.toml")
    assert "\n" not in str(e.value) and "world.a\\nb" in str(e.value)


# --------------------------------------------------------------------------- the CLI

def _cli(*args):
    import os
    from pathlib import Path

    import swarmnav

    src = str(Path(swarmnav.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-m", "swarmnav.cli", *args], capture_output=True, text=True, env=env)


@pytest.mark.parametrize("command", [["scenarios", "show"], ["run", "--method", "apf", "--steps", "2", "--out", "OUT", "--scenario-file"]])
def test_cli_bad_3d_scene_file_exits_2_with_one_line(tmp_path, command):
    d = copy.deepcopy(BASE_3D)
    d["obstacles"][1]["center"] = [5.0, -2.0, 1.0]  # a cylinder given a 3-D centre
    f = tmp_path / "bad3d.toml"
    f.write_text(to_toml(d))
    r = _cli(*[str(tmp_path / "out") if a == "OUT" else a for a in command], str(f))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"swarmnav: error: {f}: obstacles[1].center ")


# --------------------------------------------------------------------------- spawning a large n

def _spawn_reference(scn, rng):
    """The plain sampler: every candidate checked against every accepted agent (O(n^2))."""
    from swarmnav.sensing import signed_distance

    d, n, s = scn.dim, scn.n, scn.swarm.min_spacing
    region, kept = scn.swarm.region, np.zeros((0, scn.dim))
    while True:
        cand = np.column_stack([rng.uniform(region[a], region[d + a], max(64, 4 * n)) for a in range(d)])
        if not scn.geometry.is_empty:
            cand = cand[signed_distance(scn.geometry, cand) >= scn.swarm.clearance]
        for p in cand:
            if len(kept) == n:
                return kept
            if s <= 0 or len(kept) == 0 or np.min(np.sum((kept - p) ** 2, axis=1)) >= s**2:
                kept = np.vstack([kept, p])
        if len(kept) == n:
            return kept


@pytest.mark.parametrize("base", [BASE_2D, BASE_3D], ids=["2d", "3d"])
@pytest.mark.parametrize(("n", "side"), [(1, 2.0), (30, 6.0), (200, 14.0)])
def test_spawn_sampler_matches_the_plain_reference(base, n, side):
    """The hashed sampler accepts exactly the agents a check against every agent accepts."""
    d = copy.deepcopy(base)
    d["swarm"]["n"] = n
    d["swarm"]["spawn"] = [-1.0 - side, -side / 2, 1.0 - side / 2, -1.0, side / 2, 1.0 + side / 2] \
        if len(d["swarm"]["spawn"]) == 6 else [-1.0 - side, -side / 2, -1.0, side / 2]
    h = side / 2 + 1.0  # bounds that hold the spawn region (and the obstacles and goal)
    d["world"]["bounds"] = [-20.0, -max(h, 6.0), 1.0 - h, 12.0, max(h, 6.0), 1.0 + max(h, 3.0)] \
        if len(d["swarm"]["spawn"]) == 6 else [-20.0, -max(h, 6.0), 12.0, max(h, 6.0)]
    d["goal"].pop("path", None)
    scn = from_dict(d)
    np.testing.assert_array_equal(scn.spawn_positions(np.random.default_rng(3)),
                                  _spawn_reference(scn, np.random.default_rng(3)))


def test_large_swarm_loads_in_seconds_not_hours():
    # 100 000 agents 0.6 m apart in a 1 km square: the O(n^2) sampler took minutes
    import time

    t = time.perf_counter()
    scn = from_dict({"swarm": {"n": 100_000, "spawn": [0.0, 0.0, 1000.0, 1000.0]}, "goal": {"position": [5.0, 5.0]}})
    assert scn.n == 100_000 and time.perf_counter() - t < 30.0
