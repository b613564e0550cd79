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
from operator import add
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world.obstacles import (
    Box,
    Circle,
    Cylinder,
    Geometry,
    Obstacle,
    Polygon,
    Sphere,
    polygon_is_simple,
    slice_at,
)

#: Smallest distance [m] a spawned agent keeps from any obstacle (our choice: a UAV body of
#: ~0.3 m radius plus margin; the papers spawn in open space and do not state a value).
DEFAULT_SPAWN_CLEARANCE = 0.5
#: Smallest distance [m] between two spawned agents (our choice: two bodies of 0.3 m radius).
DEFAULT_MIN_SPACING = 0.6
#: What a world's bounds are (``world.boundary``): walls every method senses and crashes into, an
#: open edge, or the period cell of a torus.
BOUNDARIES = ("wall", "open", "periodic")
#: What touching an obstacle, a wall or another agent does (``rules.contact``): the agent crashes
#: (stops where it hit and has failed), or the contact is only counted and the agent flies on.
CONTACT_RULES = ("crash", "count")
#: Thickness [m] of the walls a closed world (``boundary = "wall"``) puts just outside its bounds
#: (our choice: thicker than any step an agent takes, so no agent steps across one unseen).
WALL_THICKNESS = 1.0


@dataclass(frozen=True, slots=True)
class Rules:
    """The referee's settings of a scene (``[rules]`` in a scene file; ``--set`` overrides them).

    Attributes:
        goal_radius: [m] an agent has reached the goal when it ends within this distance of it,
            in line of sight of it, not crashed (HES Section 5.1: r_succ = 8 m).
        d_safe: [m] clearance below which a step counts as unsafe (HES Table A1: 1.5 m).
        body_radius: [m] an agent touches an obstacle or wall when its clearance is below this,
            and another agent when they are nearer than twice this (our choice: 0.2 m, a
            Crazyflie-class UAV with guards; the papers give none).
        contact: ``"crash"`` or ``"count"`` (:data:`CONTACT_RULES`); None: ``"crash"`` in a
            walled or open world, ``"count"`` in a periodic box (Vicsek agents are points).
    """

    goal_radius: float = 8.0
    d_safe: float = 1.5
    body_radius: float = 0.2
    contact: str | None = None

    def __post_init__(self) -> None:
        for k in ("goal_radius", "d_safe", "body_radius"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 \
                    or (k == "goal_radius" and v == 0):
                raise ScenarioError(f"rules.{k} must be a finite number {'> 0' if k == 'goal_radius' else '>= 0'} "
                                    f"[m], got {v!r}")
        if self.contact is not None and self.contact not in CONTACT_RULES:
            raise ScenarioError(f"rules.contact must be one of {', '.join(CONTACT_RULES)}, got {self.contact!r}")


@dataclass(frozen=True, slots=True)
class Swarm:
    """Swarm size and its uniform random spawn rectangle ``[xmin, ymin, xmax, ymax]`` [m]
    (in a 3-D world the box ``[xmin, ymin, zmin, xmax, ymax, zmax]``).

    With ``density`` [1/m^2] set, agents spawn instead in the square of side
    ``sqrt(n / density)`` centred on the spawn rectangle, so resizing the swarm keeps its
    initial density (HWVEM Section 3.2 starts every swarm at rho = 3.265 /m^2).
    """

    n: int
    spawn: tuple[float, ...]
    min_spacing: float = DEFAULT_MIN_SPACING
    clearance: float = DEFAULT_SPAWN_CLEARANCE
    density: float | None = None

    @property
    def region(self) -> tuple[float, ...]:
        """The rectangle (3-D: box) agents are drawn from [m]."""
        if self.density is None or len(self.spawn) == 6:
            return self.spawn
        x0, y0, x1, y1 = self.spawn
        cx, cy, h = (x0 + x1) / 2, (y0 + y1) / 2, math.sqrt(self.n / self.density) / 2
        return (cx - h, cy - h, cx + h, cy + h)


@dataclass(frozen=True, slots=True, eq=False)
class Scenario:
    """A world (obstacles, bounds) with a swarm to place in it and a goal to reach.

    Attributes:
        name: scene name.
        bounds: drawing/validity extent ``(xmin, ymin, xmax, ymax)`` [m], or
            ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in a 3-D world; not an obstacle.
        swarm: size and spawn region.
        goal: goal position [m] (two or three numbers: the world's dimension).
        obstacles: the obstacles; walls are obstacles too.
        periodic: True for a periodic (toroidal) box; then ``bounds`` is the period cell.
        boundary: what the bounds are (:data:`BOUNDARIES`): ``"wall"`` (the default: walls
            :data:`WALL_THICKNESS` thick just outside the bounds, in :attr:`geometry`, so every
            method senses them and the contact rule sees them), ``"open"`` or ``"periodic"``
            (the same as ``periodic = True``).
        rules: the referee's settings (goal radius, d_safe, body radius, contact rule).
        path: optional predetermined polyline [m] from start to goal (information UAV of the
            Vicsek family); empty if not given.
        description: free text.
        geometry: the obstacles and the boundary walls flattened for the kernels (derived).
    """

    name: str
    bounds: tuple[float, ...]
    swarm: Swarm
    goal: tuple[float, ...]
    obstacles: tuple[Obstacle, ...] = ()
    periodic: bool = False
    path: tuple[tuple[float, ...], ...] = ()
    description: str = ""
    source: str = "<dict>"
    boundary: str = "wall"
    rules: Rules = Rules()
    geometry: Geometry = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.boundary not in BOUNDARIES:
            raise ScenarioError(f"{self.source}: world.boundary must be one of {', '.join(BOUNDARIES)}, "
                                f"got {self.boundary!r}")
        if self.periodic or self.boundary == "periodic":
            object.__setattr__(self, "periodic", True)
            object.__setattr__(self, "boundary", "periodic")
        object.__setattr__(self, "geometry", Geometry.from_obstacles(self.solid_obstacles, dim=len(self.goal)))

    @property
    def walls(self) -> tuple[Obstacle, ...]:
        """The boundary walls of a closed world: slabs :data:`WALL_THICKNESS` thick just outside
        ``bounds`` (four in the plane, six in 3-D: the floor and the ceiling too), overlapping at
        the corners; none in an open or periodic world."""
        if self.boundary != "wall":
            return ()
        d, t = len(self.goal), WALL_THICKNESS
        lo, hi = list(self.bounds[:d]), list(self.bounds[d:])
        out = []
        for a in range(d):
            olo, ohi = [v - t for v in lo], [v + t for v in hi]
            below = Box(tuple(olo), tuple(lo[a] if b == a else ohi[b] for b in range(d)))
            above = Box(tuple(hi[a] if b == a else olo[b] for b in range(d)), tuple(ohi))
            out += [below, above]
        return tuple(out)

    @property
    def solid_obstacles(self) -> tuple[Obstacle, ...]:
        """Everything an agent can hit: the obstacles, then the boundary walls."""
        return self.obstacles + self.walls

    @property
    def contact(self) -> str:
        """The contact rule in force: ``rules.contact``, else ``"count"`` in a periodic box and
        ``"crash"`` elsewhere."""
        return self.rules.contact or ("count" if self.periodic else "crash")

    @property
    def has_goal(self) -> bool:
        """Whether the scene's goal means anything: not in a periodic box, whose goal is a
        placeholder (no goal metrics are reported there)."""
        return not self.periodic

    @property
    def n(self) -> int:
        return self.swarm.n

    @property
    def dim(self) -> int:
        """2 for a planar world, 3 for a 3-D one (the length of ``goal``)."""
        return len(self.goal)

    @property
    def lower(self) -> np.ndarray:
        """(dim,) lower corner of ``bounds`` [m]."""
        return np.asarray(self.bounds[: self.dim], dtype=np.float64)

    @property
    def upper(self) -> np.ndarray:
        """(dim,) upper corner of ``bounds`` [m]."""
        return np.asarray(self.bounds[self.dim :], dtype=np.float64)

    def default_altitude(self) -> float:
        """The middle of the spawn box's z range [m] (3-D only): where planar methods fly."""
        if self.dim != 3:
            raise ScenarioError(f"{self.source}: a planar scene has no altitude")
        return 0.5 * (self.swarm.spawn[2] + self.swarm.spawn[5])

    def planar_slice(self, z: float) -> Scenario:
        """The horizontal slice of a 3-D scene at altitude ``z`` [m], as a planar scene.

        Obstacles become what the plane cuts from them (:func:`swarmnav.world.obstacles.slice_at`);
        bounds, spawn, goal and path keep their x and y. Planar methods (HES, the Vicsek family)
        fly 3-D scenes in this slice.
        """
        if self.dim != 3:
            raise ScenarioError(f"{self.source}: planar_slice needs a 3-D scene")
        z = float(z)
        x0, y0, z0, x1, y1, z1 = self.bounds
        if not (math.isfinite(z) and z0 <= z <= z1):
            raise ScenarioError(f"{self.source}: z_fly = {z} m lies outside world.bounds z [{z0}, {z1}]")
        sx0, sy0, _, sx1, sy1, _ = self.swarm.spawn
        scn = Scenario(
            name=f"{self.name}@z={z:g}",
            bounds=(x0, y0, x1, y1),
            swarm=replace(self.swarm, spawn=(sx0, sy0, sx1, sy1)),
            goal=tuple(self.goal[:2]),
            obstacles=slice_at(self.obstacles, z),
            periodic=self.periodic,
            boundary=self.boundary,
            rules=self.rules,
            path=tuple(tuple(p[:2]) for p in self.path),
            description=f"{self.description} (horizontal slice at z = {z:g} m)".strip(),
            source=f"{self.source}@z={z:g}",
        )
        return validate(scn)

    @property
    def goal_array(self) -> np.ndarray:
        return np.asarray(self.goal, dtype=np.float64)

    def with_n(self, n: int) -> Scenario:
        """Same scene with a swarm of ``n`` agents (the spawn region is re-validated)."""
        return validate(replace(self, swarm=replace(self.swarm, n=int(n))))

    def spawn_positions(self, rng: np.random.Generator) -> np.ndarray:
        """Draw (N, dim) start positions [m], uniform in the spawn region, rejecting points
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
            "world": {"bounds": list(self.bounds), "boundary": self.boundary},
            "swarm": {
                "n": self.n,
                "spawn": list(self.swarm.spawn),
                "min_spacing": self.swarm.min_spacing,
                "clearance": self.swarm.clearance,
                **({"density": self.swarm.density} if self.swarm.density is not None else {}),
            },
            "goal": {"position": list(self.goal)},
            "rules": {"goal_radius": self.rules.goal_radius, "d_safe": self.rules.d_safe,
                      "body_radius": self.rules.body_radius, "contact": self.contact},
            "obstacles": [o.to_dict() for o in self.obstacles],
        }
        if self.description:
            d["description"] = self.description
        if self.path:
            d["goal"]["path"] = [list(p) for p in self.path]
        return d

    def to_toml(self) -> str:
        """The scene as scene-file text: ``load_file`` / ``--scenario-file`` read it back as it is."""
        import tomlkit  # a writer (the standard library's tomllib only reads)

        d = self.to_dict()
        head = {k: d.pop(k) for k in ("name", "description") if k in d}
        return "# swarmnav scene file (docs/scenarios.md); run it with --scenario-file\n" + tomlkit.dumps({**head, **d})


# --------------------------------------------------------------------------- parsing

_TOP_KEYS = {"name", "description", "world", "swarm", "goal", "rules", "obstacles", "map"}
_MAP_KEYS = {"file", "cell", "unknown"}
_WORLD_KEYS = {"bounds", "periodic", "boundary"}
_RULES_KEYS = {"goal_radius", "d_safe", "body_radius", "contact"}
_SWARM_KEYS = {"n", "spawn", "min_spacing", "clearance", "density"}
_GOAL_KEYS = {"position", "path"}
_OBSTACLE_KEYS = {"box": {"type", "min", "max"}, "circle": {"type", "center", "radius"},
                  "polygon": {"type", "points"}, "cylinder": {"type", "center", "radius", "z"},
                  "sphere": {"type", "center", "radius"}}
#: Obstacle types of each world dimension.
_TYPES = {2: ("box", "circle", "polygon"), 3: ("box", "cylinder", "sphere", "polygon")}
#: Largest swarm a scene may ask for (our choice: far above any experiment, small enough that
#: a typo such as n = 10**12 fails at once instead of exhausting memory in the spawn sampler).
MAX_AGENTS = 1_000_000


def from_dict(data: dict, source: str = "<dict>") -> Scenario:
    """Build and validate a :class:`Scenario` from a scene-file dictionary.

    The world's dimension is read from ``world.bounds`` (four numbers: planar, six: 3-D) or,
    without bounds, from ``swarm.spawn``; every other coordinate must then have that dimension.
    """
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
    grid = _map_grid(ctx, data) if "map" in data else None
    # a scene that declares its world is closed by default (a map declares its world: its
    # extent); without bounds there is no declared world to close (its bounds are only the
    # padded extent of what it holds): open
    declared = "bounds" in world or grid is not None
    boundary = world.get("boundary", "periodic" if periodic else "wall" if declared else "open")
    if not isinstance(boundary, str) or boundary not in BOUNDARIES:
        raise ctx.err("world.boundary", f"must be one of {', '.join(repr(b) for b in BOUNDARIES)}, got {boundary!r}")
    if periodic and boundary != "periodic":
        raise ctx.err("world.periodic", f"= true contradicts world.boundary = {boundary!r}")
    periodic = boundary == "periodic"

    swarm_t = ctx.table(data, "swarm", required=True)
    ctx.keys(swarm_t, _SWARM_KEYS, "swarm")
    if "n" not in swarm_t:
        raise ctx.err("swarm.n", "is required")
    n = swarm_t["n"]
    if isinstance(n, bool) or not isinstance(n, int):
        raise ctx.err("swarm.n", f"must be an integer, got {n!r}")
    if n < 1:
        raise ctx.err("swarm.n", f"must be >= 1, got {n}")
    if n > MAX_AGENTS:
        raise ctx.err("swarm.n", f"must be <= {MAX_AGENTS}, got {n}")
    if "spawn" not in swarm_t:
        raise ctx.err("swarm.spawn", "is required ([xmin, ymin, xmax, ymax])")
    dim = ctx.dimension(world, swarm_t)
    if periodic and dim == 3:
        raise ctx.err("world.periodic", "is planar only (a 3-D world cannot be periodic)")
    spawn = ctx.rect(swarm_t["spawn"], "swarm.spawn", dim, allow_degenerate=True)
    min_spacing = ctx.nonneg(swarm_t.get("min_spacing", DEFAULT_MIN_SPACING), "swarm.min_spacing")
    clearance = ctx.nonneg(swarm_t.get("clearance", DEFAULT_SPAWN_CLEARANCE), "swarm.clearance")
    density = None
    if "density" in swarm_t:
        if dim == 3:
            raise ctx.err("swarm.density", "is planar only (agents per m^2)")
        density = ctx.number(swarm_t["density"], "swarm.density")
        if density <= 0:
            raise ctx.err("swarm.density", f"must be > 0, got {density}")

    goal_t = ctx.table(data, "goal", required=True)
    ctx.keys(goal_t, _GOAL_KEYS, "goal")
    if "position" not in goal_t:
        raise ctx.err("goal.position", "is required ([x, y])" if dim == 2 else "is required ([x, y, z])")
    goal = ctx.point(goal_t["position"], "goal.position", dim)
    path: tuple = ()
    if "path" in goal_t:
        pts = goal_t["path"]
        if not isinstance(pts, list) or len(pts) < 2:
            raise ctx.err("goal.path", f"must be a list of at least two {_POINT[dim]} points")
        path = tuple(ctx.point(p, f"goal.path[{k}]", dim) for k, p in enumerate(pts))

    rules_t = ctx.table(data, "rules", required=False)
    ctx.keys(rules_t, _RULES_KEYS, "rules")
    rv: dict[str, Any] = {}
    for k in ("goal_radius", "d_safe", "body_radius"):
        if k in rules_t:
            rv[k] = (ctx.positive if k == "goal_radius" else ctx.nonneg)(rules_t[k], f"rules.{k}")
    if "contact" in rules_t:
        c = rules_t["contact"]
        if not isinstance(c, str) or c not in CONTACT_RULES:
            raise ctx.err("rules.contact", f"must be one of {', '.join(repr(r) for r in CONTACT_RULES)}, got {c!r}")
        rv["contact"] = c
    rules = Rules(**rv)

    obstacles_raw = data.get("obstacles", [])
    if not isinstance(obstacles_raw, list):
        raise ctx.err("obstacles", "must be an array of tables ([[obstacles]])")
    obstacles = tuple(ctx.obstacle(o, k, dim) for k, o in enumerate(obstacles_raw))
    if grid is not None:
        if grid.dim != dim:
            raise ctx.err("map.file", f"is a {grid.dim}-D map but {_WORLD[dim]}")
        obstacles = grid.boxes() + obstacles

    if "bounds" in world:
        bounds = ctx.rect(world["bounds"], "world.bounds", dim)
    elif grid is not None:
        bounds = grid.bounds
    else:
        bounds = _default_bounds(Swarm(n=n, spawn=spawn, density=density).region, goal, obstacles)

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
        boundary=boundary,
        rules=rules,
    )
    return validate(scn)


def _map_grid(ctx: _Ctx, data: dict):
    """The ``[map]`` table's occupancy grid: ``file`` relative to the scene file, ``cell`` [m] for
    the formats without a resolution, ``unknown`` for ROS maps (docs/maps.md)."""
    from swarmnav.world import maps

    t = ctx.table(data, "map", required=False)
    ctx.keys(t, _MAP_KEYS, "map")
    f = t.get("file")
    if not isinstance(f, str) or not f:
        raise ctx.err("map.file", f"must be the map file's path, got {f!r}" if "file" in t else "is required")
    kind = maps.map_kind(f)
    if kind is None or kind == "scen":
        raise ctx.err("map.file", f"must be a .map, .yaml/.yml (ROS), .3dmap, .ply or .pcd file, got {f!r}")
    cell = ctx.positive(t["cell"], "map.cell") if "cell" in t else None
    if cell is not None and kind == "ros":
        raise ctx.err("map.cell", "is for MovingAI grids, voxel maps and point clouds: a ROS map has its own resolution")
    unknown = t.get("unknown", "occupied")
    if unknown not in maps.UNKNOWN_AS or kind != "ros" and "unknown" in t:
        raise ctx.err("map.unknown", f"must be one of {', '.join(maps.UNKNOWN_AS)} (ROS maps only), got {unknown!r}")
    base = Path(ctx.source).parent if not ctx.source.startswith("<") else Path.cwd()
    path = Path(f) if Path(f).is_absolute() else base / f
    return maps.load_grid(path, cell=cell, unknown=unknown)


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
    if scn.n > MAX_AGENTS:
        raise ScenarioError(f"{src}: swarm.n must be <= {MAX_AGENTS}, got {scn.n}")
    if scn.n < 1:
        raise ScenarioError(f"{src}: swarm.n must be >= 1, got {scn.n}")
    _check_placement(scn)
    geom = scn.geometry
    goal = scn.goal_array[None, :]
    if not geom.is_empty and bool(points_inside(geom, goal)[0]):
        in_obstacle = bool(points_inside(Geometry.from_obstacles(scn.obstacles, dim=scn.dim), goal)[0]) \
            if scn.obstacles else False
        where = "an obstacle" if in_obstacle else "the world's boundary wall (world.boundary = \"wall\")"
        raise ScenarioError(f"{src}: goal.position {list(scn.goal)} lies inside {where}")
    if not _may_hold(scn) or _sample_spawn(scn, np.random.default_rng(0)) is None:
        raise ScenarioError(
            f"{src}: swarm.spawn {list(scn.swarm.spawn)} cannot hold n={scn.n} agents "
            f"{scn.swarm.min_spacing} m apart and {scn.swarm.clearance} m clear of obstacles"
        )
    return scn


def _check_placement(scn: Scenario) -> None:
    """The spawn region has extent on every axis, and it and the goal lie in ``world.bounds``.

    A spawn point (or line) is allowed only with ``swarm.density``, where it is the centre of
    the square the agents spawn in (the HWVEM mission scenes); that square must lie in bounds.
    """
    src, d = scn.source, scn.dim
    spawn = scn.swarm.spawn
    if scn.swarm.density is None and any(spawn[d + a] <= spawn[a] for a in range(d)):
        axes = "xmax > xmin and ymax > ymin" + (" and zmax > zmin" if d == 3 else "")
        raise ScenarioError(f"{src}: swarm.spawn {list(spawn)} has no extent: a spawn region needs {axes} "
                            "(a point is a spawn region only with swarm.density, as the centre of its square)")
    lo, hi = scn.bounds[:d], scn.bounds[d:]
    region = scn.swarm.region
    if any(region[a] < lo[a] or region[d + a] > hi[a] for a in range(d)):
        what = (f"{list(spawn)}" if region == spawn else
                f"{list(spawn)} (the square of n={scn.n} agents at density {scn.swarm.density:g} /m^2, "
                f"[{', '.join(f'{c:.4g}' for c in region)}])")
        raise ScenarioError(f"{src}: swarm.spawn {what} reaches outside world.bounds {list(scn.bounds)}")
    if any(not lo[a] <= scn.goal[a] <= hi[a] for a in range(d)):
        raise ScenarioError(f"{src}: goal.position {list(scn.goal)} lies outside world.bounds {list(scn.bounds)}")


def _may_hold(scn: Scenario) -> bool:
    """A necessary condition for the spawn region to hold the swarm: balls of diameter
    ``min_spacing`` around the agents are disjoint and lie in the region grown by half a
    spacing, so their total volume cannot exceed that region's. Rejects a hopeless ``n`` at
    once instead of after the sampler's rounds."""
    s = scn.swarm.min_spacing
    if s <= 0:
        return True
    d = scn.dim
    region = np.asarray(scn.swarm.region, dtype=float)
    extent = np.prod(region[d:] - region[:d] + s)
    ball = math.pi * (s / 2) ** 2 if d == 2 else 4.0 / 3.0 * math.pi * (s / 2) ** 3
    return scn.n * ball <= extent


def _sample_spawn(scn: Scenario, rng: np.random.Generator, max_rounds: int = 60) -> np.ndarray | None:
    """Rejection sampling in batches (vectorised); None if the region cannot hold the swarm."""
    from swarmnav.sensing import signed_distance

    region = scn.swarm.region
    d = scn.dim
    n, spacing, clear = scn.n, scn.swarm.min_spacing, scn.swarm.clearance
    geom = scn.geometry
    kept = np.empty((n, d))
    k = 0
    # Accepted agents hashed in cells of side 2 * spacing: an agent three or more cells away
    # (along any axis) is more than 2 * spacing away, so checking the 3^d cells around a
    # candidate accepts exactly the candidates a check against every agent accepts, in O(n)
    # instead of O(n^2) (n up to MAX_AGENTS must not hang the load).
    cells: dict[tuple[float, ...], list[int]] = {}
    near = [tuple(float(v) for v in o) for o in np.ndindex(*(3,) * d)]
    one = (1.0,) * d
    lo = np.asarray(region[:d], dtype=float)
    batch = max(64, 4 * n)
    for _ in range(max_rounds):
        # one uniform draw per axis, x then y (then z): the planar draw order is unchanged
        cand = np.column_stack([rng.uniform(region[a], region[d + a], batch) for a in range(d)])
        if not geom.is_empty:
            cand = cand[signed_distance(geom, cand) >= clear]
        if spacing <= 0:
            take = cand[: n - k]
            kept[k : k + len(take)] = take
            k += len(take)
        else:
            key = (np.floor((cand - lo) / (2.0 * spacing)) - 1.0).tolist()  # cell keys as Python floats
            for p, c in zip(cand, key):  # sequential acceptance keeps the spacing rule exact
                if k == n:
                    break
                idx = [i for o in near for i in cells.get(tuple(map(add, c, o)), ())]
                if not idx or np.min(np.sum((kept[idx] - p) ** 2, axis=1)) >= spacing**2:
                    kept[k] = p
                    cells.setdefault(tuple(map(add, c, one)), []).append(k)
                    k += 1
        if k == n:
            return kept
    return None


def _default_bounds(spawn, goal, obstacles, pad: float = 2.0) -> tuple[float, ...]:
    d = len(goal)
    pts = [np.array(spawn[:d]), np.array(spawn[d:]), np.array(goal)]
    g = Geometry.from_obstacles(obstacles, dim=d)
    if len(g.bbox_lo):
        pts += [g.bbox_lo.min(axis=0), g.bbox_hi.max(axis=0)]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - pad, allp.max(axis=0) + pad
    return tuple(float(c) for c in lo) + tuple(float(c) for c in hi)


_POINT = {2: "[x, y]", 3: "[x, y, z]"}
_RECT = {2: "[xmin, ymin, xmax, ymax]", 3: "[xmin, ymin, zmin, xmax, ymax, zmax]"}
_WORLD = {2: "the world is planar (world.bounds has four numbers)",
          3: "the world is 3-D (world.bounds has six numbers)"}


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
                full = f"{prefix}.{k}" if prefix else str(k)
                if not full.isprintable():  # a quoted TOML key may hold a newline: keep one line
                    full = repr(full)[1:-1]
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

    def dimension(self, world: dict, swarm: dict) -> int:
        """2 or 3: the length of ``world.bounds`` (4 or 6), else of ``swarm.spawn``."""
        key, v = ("world.bounds", world["bounds"]) if "bounds" in world else ("swarm.spawn", swarm["spawn"])
        if isinstance(v, list) and len(v) in (4, 6):
            return 2 if len(v) == 4 else 3
        raise self.err(key, f"must be {_RECT[2]} (planar) or {_RECT[3]} (3-D), got {v!r}")

    def number(self, v: Any, key: str) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(key, f"must be a number, got {v!r}")
        try:
            x = float(v)
        except OverflowError:  # an integer beyond the float range (TOML integers are unbounded)
            raise self.err(key, "must be finite, got an integer too large for a float") from None
        if not math.isfinite(x):
            raise self.err(key, f"must be finite, got {v!r}")
        return x

    def nonneg(self, v: Any, key: str) -> float:
        x = self.number(v, key)
        if x < 0:
            raise self.err(key, f"must be >= 0, got {x}")
        return x

    def positive(self, v: Any, key: str) -> float:
        x = self.number(v, key)
        if x <= 0:
            raise self.err(key, f"must be > 0, got {x}")
        return x

    def point(self, v: Any, key: str, dim: int = 2, why: str | None = None) -> tuple[float, ...]:
        if not isinstance(v, list) or len(v) != dim:
            if isinstance(v, list) and len(v) in (2, 3):
                raise self.err(key, f"must be {_POINT[dim]} because {why or _WORLD[dim]}, got {v!r}")
            raise self.err(key, f"must be {_POINT[dim]}, got {v!r}")
        return tuple(self.number(c, key) for c in v)

    def rect(self, v: Any, key: str, dim: int = 2, allow_degenerate: bool = False) -> tuple[float, ...]:
        if not isinstance(v, list) or len(v) != 2 * dim:
            if isinstance(v, list) and len(v) in (4, 6):
                raise self.err(key, f"must be {_RECT[dim]} because {_WORLD[dim]}, got {v!r}")
            raise self.err(key, f"must be {_RECT[dim]}, got {v!r}")
        c = tuple(self.number(x, key) for x in v)
        lo, hi = c[:dim], c[dim:]
        if not all(math.isfinite(b - a) for a, b in zip(lo, hi)):  # e.g. [-1e308, ..., 1e308, ...]
            raise self.err(key, f"has an extent too large for a float, got {v!r}")
        bad = any((b < a) if allow_degenerate else (b <= a) for a, b in zip(lo, hi))
        if bad:
            axes = "xmax > xmin and ymax > ymin" + (" and zmax > zmin" if dim == 3 else "")
            raise self.err(key, f"must have {axes}, got {v!r}")
        return c

    def zrange(self, v: Any, key: str) -> tuple[float, float]:
        if not isinstance(v, list) or len(v) != 2:
            raise self.err(key, f"must be [z0, z1], got {v!r}")
        z0, z1 = self.number(v[0], key), self.number(v[1], key)
        if z1 <= z0:
            raise self.err(key, f"must have z1 > z0, got {v!r}")
        return (z0, z1)

    def obstacle(self, o: Any, k: int, dim: int = 2) -> Obstacle:
        key = f"obstacles[{k}]"
        if not isinstance(o, dict):
            raise self.err(key, "must be a table")
        kind = o.get("type")
        if not isinstance(kind, str) or kind not in _OBSTACLE_KEYS:
            raise self.err(f"{key}.type", f"unknown obstacle type {kind!r} ({', '.join(_TYPES[dim])})")
        if kind not in _TYPES[dim]:
            hint = " (use cylinder)" if kind == "circle" else ""
            raise self.err(f"{key}.type", f"{kind!r} is not an obstacle of this world: {_WORLD[dim]}; "
                                          f"types here: {', '.join(_TYPES[dim])}{hint}")
        allowed = _OBSTACLE_KEYS[kind] | ({"z"} if kind == "polygon" and dim == 3 else set())
        self.keys(o, allowed, key)
        for req in sorted(allowed):
            if req not in o:
                raise self.err(f"{key}.{req}", "is required")
        if kind == "box":
            lo, hi = self.point(o["min"], f"{key}.min", dim), self.point(o["max"], f"{key}.max", dim)
            if any(b <= a for a, b in zip(lo, hi)):
                axes = "x and y" if dim == 2 else "x, y and z"
                raise self.err(key, f"box needs max > min in {axes} (size must be positive), got min={list(lo)} max={list(hi)}")
            return Box(lo, hi)
        if kind in ("circle", "cylinder", "sphere"):
            c = self.point(o["center"], f"{key}.center", 3 if kind == "sphere" else 2,
                           why="a cylinder is vertical: its height is z = [z0, z1]" if kind == "cylinder" else None)
            r = self.positive(o["radius"], f"{key}.radius")
            if kind == "circle":
                return Circle(c, r)
            if kind == "sphere":
                return Sphere(c, r)
            return Cylinder(c, r, self.zrange(o["z"], f"{key}.z"))
        pts = o["points"]
        if not isinstance(pts, list) or len(pts) < 3:
            raise self.err(f"{key}.points", "needs at least 3 [x, y] vertices")
        why = "a 3-D polygon is a vertical prism: its height is z = [z0, z1]" if dim == 3 else None
        poly = tuple(self.point(p, f"{key}.points[{j}]", 2, why) for j, p in enumerate(pts))
        if not polygon_is_simple(np.asarray(poly)):
            raise self.err(f"{key}.points", "must form a simple polygon (no self-intersection, non-zero area)")
        return Polygon(poly, self.zrange(o["z"], f"{key}.z") if dim == 3 else None)


# --------------------------------------------------------------------------- loading

def builtin_names() -> list[str]:
    """Names of the scenes shipped with the package (files in ``swarmnav/world/scenes``)."""
    files = resources.files("swarmnav.world").joinpath("scenes").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def load_file(path: str | Path) -> Scenario:
    """Load and validate a scene file."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        raise ScenarioError(f"{p}: scene files are TOML (.toml), not JSON; "
                            "'swarmnav scenarios show NAME' prints one to start from")
    if p.suffix.lower() in (".map", ".scen", ".yaml", ".yml", ".3dmap", ".ply", ".pcd"):
        raise ScenarioError(f"{p}: a map file, not a scene file: load_scenario (--scenario-file) reads it "
                            "(docs/maps.md), or a scene's [map] table names it")
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
