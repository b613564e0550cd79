"""The scenario model: obstacles, swarm spawn region, goal; loading and validation of scene files.

A scene file is TOML (format in ``docs/scenarios.md``). Every key is checked: unknown keys,
wrong types, non-finite numbers, impossible geometry all raise :class:`ScenarioError` whose
message names the file and the offending key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world.obstacles import Box, Circle, Geometry, Obstacle, Polygon, polygon_is_simple

#: Smallest distance [m] a spawned agent keeps from any obstacle (our choice: a UAV body of
#: ~0.3 m radius plus margin; the papers spawn in open space and do not state a value).
DEFAULT_SPAWN_CLEARANCE = 0.5
#: Smallest distance [m] between two spawned agents (our choice: two bodies of 0.3 m radius).
DEFAULT_MIN_SPACING = 0.6


@dataclass(frozen=True, slots=True)
class Swarm:
    """Swarm size and its uniform random spawn rectangle ``[xmin, ymin, xmax, ymax]`` [m].

    With ``density`` [1/m^2] set, agents spawn instead in the square of side
    ``sqrt(n / density)`` centred on the spawn rectangle, so resizing the swarm keeps its
    initial density (HWVEM Section 3.2 starts every swarm at rho = 3.265 /m^2).
    """

    n: int
    spawn: tuple[float, float, float, float]
    min_spacing: float = DEFAULT_MIN_SPACING
    clearance: float = DEFAULT_SPAWN_CLEARANCE
    density: float | None = None

    @property
    def region(self) -> tuple[float, float, float, float]:
        """The rectangle agents are drawn from [m]."""
        if self.density is None:
            return self.spawn
        x0, y0, x1, y1 = self.spawn
        cx, cy, h = (x0 + x1) / 2, (y0 + y1) / 2, math.sqrt(self.n / self.density) / 2
        return (cx - h, cy - h, cx + h, cy + h)


@dataclass(frozen=True, slots=True, eq=False)
class Scenario:
    """A world (obstacles, bounds) with a swarm to place in it and a goal to reach.

    Attributes:
        name: scene name.
        bounds: drawing/validity extent ``(xmin, ymin, xmax, ymax)`` [m]; not an obstacle.
        swarm: size and spawn region.
        goal: goal position [m].
        obstacles: the obstacles; walls are obstacles too.
        periodic: True for a periodic (toroidal) box; then ``bounds`` is the period cell.
        path: optional predetermined polyline [m] from start to goal (information UAV of the
            Vicsek family); empty if not given.
        description: free text.
        geometry: the obstacles flattened for the kernels (derived).
    """

    name: str
    bounds: tuple[float, float, float, float]
    swarm: Swarm
    goal: tuple[float, float]
    obstacles: tuple[Obstacle, ...] = ()
    periodic: bool = False
    path: tuple[tuple[float, float], ...] = ()
    description: str = ""
    source: str = "<dict>"
    geometry: Geometry = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "geometry", Geometry.from_obstacles(self.obstacles))

    @property
    def n(self) -> int:
        return self.swarm.n

    @property
    def goal_array(self) -> np.ndarray:
        return np.asarray(self.goal, dtype=np.float64)

    def with_n(self, n: int) -> Scenario:
        """Same scene with a swarm of ``n`` agents (the spawn region is re-validated)."""
        return validate(replace(self, swarm=replace(self.swarm, n=int(n))))

    def spawn_positions(self, rng: np.random.Generator) -> np.ndarray:
        """Draw (N, 2) start positions [m], uniform in the spawn rectangle, rejecting points
        closer than ``swarm.clearance`` to an obstacle or ``swarm.min_spacing`` to an agent."""
        pos = _sample_spawn(self, rng)
        if pos is None:
            raise ScenarioError(
                f"{self.source}: swarm.spawn cannot hold n={self.n} agents "
                f"{self.swarm.min_spacing} m apart and {self.swarm.clearance} m clear of obstacles"
            )
        return pos

    def to_dict(self) -> dict:
        """The scene as a dictionary in scene-file form (round-trips through :func:`from_dict`)."""
        d: dict[str, Any] = {
            "name": self.name,
            "world": {"bounds": list(self.bounds), "periodic": self.periodic},
            "swarm": {
                "n": self.n,
                "spawn": list(self.swarm.spawn),
                "min_spacing": self.swarm.min_spacing,
                "clearance": self.swarm.clearance,
                **({"density": self.swarm.density} if self.swarm.density is not None else {}),
            },
            "goal": {"position": list(self.goal)},
            "obstacles": [o.to_dict() for o in self.obstacles],
        }
        if self.description:
            d["description"] = self.description
        if self.path:
            d["goal"]["path"] = [list(p) for p in self.path]
        return d


# --------------------------------------------------------------------------- parsing

_TOP_KEYS = {"name", "description", "world", "swarm", "goal", "obstacles"}
_WORLD_KEYS = {"bounds", "periodic"}
_SWARM_KEYS = {"n", "spawn", "min_spacing", "clearance", "density"}
_GOAL_KEYS = {"position", "path"}
_OBSTACLE_KEYS = {"box": {"type", "min", "max"}, "circle": {"type", "center", "radius"},
                  "polygon": {"type", "points"}}


def from_dict(data: dict, source: str = "<dict>") -> Scenario:
    """Build and validate a :class:`Scenario` from a scene-file dictionary."""
    ctx = _Ctx(source)
    if not isinstance(data, dict):
        raise ctx.err("", "a scene must be a table")
    ctx.keys(data, _TOP_KEYS, "")
    name = data.get("name", Path(source).stem if source != "<dict>" else "scene")
    if not isinstance(name, str) or not name:
        raise ctx.err("name", "must be a non-empty string")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ctx.err("description", "must be a string")

    world = ctx.table(data, "world", required=False)
    ctx.keys(world, _WORLD_KEYS, "world")
    periodic = world.get("periodic", False)
    if not isinstance(periodic, bool):
        raise ctx.err("world.periodic", "must be true or false")

    swarm_t = ctx.table(data, "swarm", required=True)
    ctx.keys(swarm_t, _SWARM_KEYS, "swarm")
    if "n" not in swarm_t:
        raise ctx.err("swarm.n", "is required")
    n = swarm_t["n"]
    if isinstance(n, bool) or not isinstance(n, int):
        raise ctx.err("swarm.n", f"must be an integer, got {n!r}")
    if n < 1:
        raise ctx.err("swarm.n", f"must be >= 1, got {n}")
    if "spawn" not in swarm_t:
        raise ctx.err("swarm.spawn", "is required ([xmin, ymin, xmax, ymax])")
    spawn = ctx.rect(swarm_t["spawn"], "swarm.spawn", allow_degenerate=True)
    min_spacing = ctx.nonneg(swarm_t.get("min_spacing", DEFAULT_MIN_SPACING), "swarm.min_spacing")
    clearance = ctx.nonneg(swarm_t.get("clearance", DEFAULT_SPAWN_CLEARANCE), "swarm.clearance")
    density = None
    if "density" in swarm_t:
        density = ctx.number(swarm_t["density"], "swarm.density")
        if density <= 0:
            raise ctx.err("swarm.density", f"must be > 0, got {density}")

    goal_t = ctx.table(data, "goal", required=True)
    ctx.keys(goal_t, _GOAL_KEYS, "goal")
    if "position" not in goal_t:
        raise ctx.err("goal.position", "is required ([x, y])")
    goal = ctx.point(goal_t["position"], "goal.position")
    path: tuple = ()
    if "path" in goal_t:
        pts = goal_t["path"]
        if not isinstance(pts, list) or len(pts) < 2:
            raise ctx.err("goal.path", "must be a list of at least two [x, y] points")
        path = tuple(ctx.point(p, f"goal.path[{k}]") for k, p in enumerate(pts))

    obstacles_raw = data.get("obstacles", [])
    if not isinstance(obstacles_raw, list):
        raise ctx.err("obstacles", "must be an array of tables ([[obstacles]])")
    obstacles = tuple(ctx.obstacle(o, k) for k, o in enumerate(obstacles_raw))

    if "bounds" in world:
        bounds = ctx.rect(world["bounds"], "world.bounds")
    else:
        bounds = _default_bounds(spawn, goal, obstacles)

    scn = Scenario(
        name=name,
        bounds=bounds,
        swarm=Swarm(n=n, spawn=spawn, min_spacing=min_spacing, clearance=clearance, density=density),
        goal=goal,
        obstacles=obstacles,
        periodic=periodic,
        path=path,
        description=description,
        source=source,
    )
    return validate(scn)


def validate(scn: Scenario) -> Scenario:
    """Check the physical consistency of a scene; return it unchanged or raise ScenarioError."""
    from swarmnav.sensing import points_inside  # local: sensing depends on world

    src = scn.source
    if scn.periodic:
        x0, y0, x1, y1 = scn.bounds
        if scn.obstacles:
            raise ScenarioError(f"{src}: a periodic world cannot have obstacles")
        if not math.isclose(x1 - x0, y1 - y0):
            raise ScenarioError(f"{src}: world.bounds of a periodic world must be a square")
    geom = scn.geometry
    goal = scn.goal_array[None, :]
    if not geom.is_empty and bool(points_inside(geom, goal)[0]):
        raise ScenarioError(f"{src}: goal.position {list(scn.goal)} lies inside an obstacle")
    if _sample_spawn(scn, np.random.default_rng(0)) is None:
        raise ScenarioError(
            f"{src}: swarm.spawn {list(scn.swarm.spawn)} cannot hold n={scn.n} agents "
            f"{scn.swarm.min_spacing} m apart and {scn.swarm.clearance} m clear of obstacles"
        )
    return scn


def _sample_spawn(scn: Scenario, rng: np.random.Generator, max_rounds: int = 60) -> np.ndarray | None:
    """Rejection sampling in batches (vectorised); None if the region cannot hold the swarm."""
    from swarmnav.sensing import signed_distance

    x0, y0, x1, y1 = scn.swarm.region
    n, spacing, clear = scn.n, scn.swarm.min_spacing, scn.swarm.clearance
    geom = scn.geometry
    kept = np.zeros((0, 2))
    batch = max(64, 4 * n)
    for _ in range(max_rounds):
        cand = np.column_stack([rng.uniform(x0, x1, batch), rng.uniform(y0, y1, batch)])
        if not geom.is_empty:
            cand = cand[signed_distance(geom, cand) >= clear]
        for p in cand:  # sequential acceptance keeps the spacing rule exact; n is small here
            if len(kept) == n:
                break
            if spacing <= 0 or len(kept) == 0 or np.min(np.sum((kept - p) ** 2, axis=1)) >= spacing**2:
                kept = np.vstack([kept, p])
        if len(kept) == n:
            return kept
    return None


def _default_bounds(spawn, goal, obstacles, pad: float = 2.0) -> tuple[float, float, float, float]:
    pts = [np.array(spawn[:2]), np.array(spawn[2:]), np.array(goal)]
    g = Geometry.from_obstacles(obstacles)
    if len(g.bbox_lo):
        pts += [g.bbox_lo.min(axis=0), g.bbox_hi.max(axis=0)]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - pad, allp.max(axis=0) + pad
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


class _Ctx:
    """Validation helpers that know the source name for error messages."""

    def __init__(self, source: str):
        self.source = source

    def err(self, key: str, msg: str) -> ScenarioError:
        where = f"{self.source}: {key} " if key else f"{self.source}: "
        return ScenarioError(f"{where}{msg}")

    def keys(self, table: dict, allowed: set[str], prefix: str) -> None:
        for k in table:
            if k not in allowed:
                full = f"{prefix}.{k}" if prefix else k
                raise self.err("", f"unknown key '{full}' (allowed: {', '.join(sorted(allowed))})")

    def table(self, data: dict, key: str, required: bool) -> dict:
        if key not in data:
            if required:
                raise self.err(f"[{key}]", "table is required")
            return {}
        t = data[key]
        if not isinstance(t, dict):
            raise self.err(key, "must be a table")
        return t

    def number(self, v: Any, key: str) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(key, f"must be a number, got {v!r}")
        if not math.isfinite(v):
            raise self.err(key, f"must be finite, got {v!r}")
        return float(v)

    def nonneg(self, v: Any, key: str) -> float:
        x = self.number(v, key)
        if x < 0:
            raise self.err(key, f"must be >= 0, got {x}")
        return x

    def point(self, v: Any, key: str) -> tuple[float, float]:
        if not isinstance(v, list) or len(v) != 2:
            raise self.err(key, f"must be [x, y], got {v!r}")
        return (self.number(v[0], key), self.number(v[1], key))

    def rect(self, v: Any, key: str, allow_degenerate: bool = False) -> tuple[float, float, float, float]:
        if not isinstance(v, list) or len(v) != 4:
            raise self.err(key, f"must be [xmin, ymin, xmax, ymax], got {v!r}")
        x0, y0, x1, y1 = (self.number(c, key) for c in v)
        if (x1 < x0 or y1 < y0) if allow_degenerate else (x1 <= x0 or y1 <= y0):
            raise self.err(key, f"must have xmax > xmin and ymax > ymin, got {v!r}")
        return (x0, y0, x1, y1)

    def obstacle(self, o: Any, k: int) -> Obstacle:
        key = f"obstacles[{k}]"
        if not isinstance(o, dict):
            raise self.err(key, "must be a table")
        kind = o.get("type")
        if kind not in _OBSTACLE_KEYS:
            raise self.err(f"{key}.type", f"unknown obstacle type {kind!r} (box, circle, polygon)")
        self.keys(o, _OBSTACLE_KEYS[kind], key)
        for req in _OBSTACLE_KEYS[kind]:
            if req not in o:
                raise self.err(f"{key}.{req}", "is required")
        if kind == "box":
            lo, hi = self.point(o["min"], f"{key}.min"), self.point(o["max"], f"{key}.max")
            if hi[0] <= lo[0] or hi[1] <= lo[1]:
                raise self.err(key, f"box needs max > min in x and y (size must be positive), got min={list(lo)} max={list(hi)}")
            return Box(lo, hi)
        if kind == "circle":
            c = self.point(o["center"], f"{key}.center")
            r = self.number(o["radius"], f"{key}.radius")
            if r <= 0:
                raise self.err(f"{key}.radius", f"must be > 0, got {r}")
            return Circle(c, r)
        pts = o["points"]
        if not isinstance(pts, list) or len(pts) < 3:
            raise self.err(f"{key}.points", "needs at least 3 [x, y] vertices")
        poly = tuple(self.point(p, f"{key}.points[{j}]") for j, p in enumerate(pts))
        if not polygon_is_simple(np.asarray(poly)):
            raise self.err(f"{key}.points", "must form a simple polygon (no self-intersection, non-zero area)")
        return Polygon(poly)


# --------------------------------------------------------------------------- loading

def builtin_names() -> list[str]:
    """Names of the scenes shipped with the package (files in ``swarmnav/world/scenes``)."""
    files = resources.files("swarmnav.world").joinpath("scenes").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def load_file(path: str | Path) -> Scenario:
    """Load and validate a scene file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{p}: no such scene file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(f"{p}: cannot read: {e}") from None
    return loads(text, source=str(p))


def loads(text: str, source: str = "<string>") -> Scenario:
    """Parse and validate scene-file text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"{source}: malformed TOML: {e}") from None
    return from_dict(data, source=source)


def load_scenario(name_or_path: str | Path, **overrides: Any) -> Scenario:
    """Load a scene by built-in name, generator spec or file path.

    Args:
        name_or_path: a built-in scene name (``swarmnav scenarios``), a generator spec
            ``GEN:key=value,...`` (``random_forest:density=0.25,seed=3``,
            ``periodic_box:n=100,rho=4.102``), or a path to a ``.toml`` scene file.
        **overrides: ``n=`` resizes the swarm.
    """
    from swarmnav.world import generators

    s = str(name_or_path)
    if isinstance(name_or_path, Path) or s.endswith(".toml") or "/" in s:
        scn = load_file(s)
    elif ":" in s or s in generators.GENERATORS:
        scn = generators.from_spec(s, n=overrides.get("n"))
    elif s in builtin_names():
        text = resources.files("swarmnav.world").joinpath("scenes", f"{s}.toml").read_text("utf-8")
        scn = loads(text, source=f"{s}.toml")
    else:
        raise ScenarioError(
            f"{s}: unknown scene (built-in: {', '.join(builtin_names())}; "
            f"generators: {', '.join(generators.GENERATORS)}; or a path to a .toml file)"
        )
    unknown = set(overrides) - {"n"}
    if unknown:
        raise ScenarioError(f"{s}: unknown scene override(s) {sorted(unknown)}")
    if "n" in overrides and overrides["n"] is not None:
        n = overrides["n"]
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ScenarioError(f"{s}: n must be an integer >= 1, got {n!r}")
        scn = scn.with_n(int(n))
    return scn
