"""Any scene by name: a built-in scene, a generator spec or a scene file.

The one place that knows every source of scenes, so the scenario model (``scenario``) and
the generators (which build scenarios) need not import each other.
"""

from __future__ import annotations

import math
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world import generators, maps
from swarmnav.world.scenario import Scenario, builtin_names, load_file, loads


def load_scenario(name_or_path: str | Path, **overrides: Any) -> Scenario:
    """Load a scene by built-in name, generator spec or file path.

    Args:
        name_or_path: a built-in scene name (``swarmnav scenarios``), a generator spec
            ``GEN:key=value,...`` (``random_forest:density=0.25,seed=3``,
            ``periodic_box:n=100,rho=4.102``), a path to a ``.toml`` scene file, or a map file
            with its options (:func:`map_scene`: ``arena.map.scen#12``, ``office.yaml#start=...``).
        **overrides: ``n=`` resizes the swarm.
    """
    s = str(name_or_path)
    if maps.map_kind(s.partition("#")[0]) is not None:
        return map_scene(s, n=overrides.pop("n", None), **overrides)
    if isinstance(name_or_path, Path) or s.endswith(".toml") or "/" in s:
        scn = load_file(s)
    elif ":" in s or s in generators.GENERATORS:
        scn = generators.from_spec(s, n=overrides.get("n"))
        scn = replace(scn, name=_label(scn.name, s, overrides.get("n")))
    elif s in builtin_names():
        text = resources.files("swarmnav.world").joinpath("scenes", f"{s}.toml").read_text("utf-8")
        scn = loads(text, source=f"{s}.toml")
    else:
        import difflib

        close = difflib.get_close_matches(s, builtin_names() + list(generators.GENERATORS), n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise ScenarioError(
            f"{s}: unknown scene{hint} (built-in: {', '.join(builtin_names())}; "
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


def _label(name: str, spec: str, n: Any) -> str:
    """The generated scene's name with every option of ``spec`` it leaves out appended, so the
    label rebuilds the same scene (``random_forest:density=0.45,seed=1,length=12,...``).

    The generator's own name comes first (it spells the options that define the family, e.g.
    density and seed, defaults included); then the spec's other options as written; then the
    swarm size when ``n`` overrides it."""
    head, _, rest = name.partition(":")
    have = {item.partition("=")[0].strip() for item in rest.split(",") if item.strip()}
    extra = []
    for item in (x.strip() for x in spec.partition(":")[2].split(",")):
        key, _, val = item.partition("=")
        key = key.strip()
        if key and key not in have and not (key == "n" and n is not None):
            extra.append(f"{key}={val.strip()}")
            have.add(key)
    if n is not None and "n" not in have:
        extra.append(f"n={int(n)}")
    return ",".join([name, *extra]) if rest or not extra else f"{head}:{','.join(extra)}"


#: Options of a map file loaded as a scene (``PATH#key=value,...``).
MAP_OPTIONS = ("row", "n", "cell", "spread", "unknown", "start", "goal")
#: Agents of a scene made from a map file when ``n`` is not given (our choice: a small swarm
#: that fits the spawn square of a 1 m grid's open areas).
MAP_DEFAULT_N = 4


def map_scene(spec: str, n: int | None = None, **unknown_overrides: Any) -> Scenario:
    """A scene made from a map file: its obstacles, a spawn square around a start, a goal.

    ``spec`` is ``PATH`` or ``PATH#key=value,...`` (``PATH#12`` is ``PATH#row=12``):

    * ``X.map.scen`` (a MovingAI scenario): row ``row`` (default 0) gives the start and goal
      cells of the map ``X.map`` (beside the scenario, else the row's map name, relative to the
      scenario file or by its base name there); the swarm spawns around the start cell's centre
      and flies to the goal cell's centre.
    * ``X.map``, ``X.yaml``/``X.yml`` (ROS), ``X.3dmap``, ``X.ply``/``X.pcd`` (point clouds):
      ``start=x:y`` and ``goal=x:y`` [m] (``x:y:z`` for a voxel map or point cloud) are required.

    Other options: ``n`` agents (default :data:`MAP_DEFAULT_N`), ``cell`` [m] (MovingAI grids and
    voxel maps, default 1 m; point clouds' voxel, default ``maps.CLOUD_CELL``), ``spread`` [m] the half side of the spawn square (default
    ``max(sqrt(n) m, cell)``; clipped to the map), ``unknown`` (ROS maps: ``occupied`` or
    ``free``). The scene is walled at the map's extent.
    """
    from swarmnav.world.scenario import from_dict

    path_s, _, opt_s = str(spec).partition("#")
    path = Path(path_s)
    if unknown_overrides:
        raise ScenarioError(f"{spec}: unknown scene override(s) {sorted(unknown_overrides)}")
    opts: dict[str, str] = {}
    items = [x.strip() for x in opt_s.split(",") if x.strip()] if opt_s else []
    if len(items) == 1 and "=" not in items[0]:
        items = [f"row={items[0]}"]
    for item in items:
        key, eq, val = item.partition("=")
        key = key.strip()
        if not eq or key not in MAP_OPTIONS:
            raise ScenarioError(f"{spec}: unknown map option {item!r} (options: {', '.join(MAP_OPTIONS)}; "
                                "PATH#12 chooses a .scen row)")
        if key in opts:
            raise ScenarioError(f"{spec}: map option {key!r} given twice")
        opts[key] = val.strip()
    kind = maps.map_kind(path)

    def number(key: str, cast=float, default=None):
        if key not in opts:
            return default
        try:
            v = cast(opts[key])
        except ValueError:
            raise ScenarioError(f"{spec}: map option {key} must be {'an integer' if cast is int else 'a number'}, "
                                f"got {opts[key]!r}") from None
        if not math.isfinite(v) or v < (0 if key == "row" else 1 if key == "n" else 0) or (v == 0 and key != "row"):
            raise ScenarioError(f"{spec}: map option {key} must be {'>= 0' if key == 'row' else '> 0'}, "
                                f"got {opts[key]!r}")
        return v

    if n is not None:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ScenarioError(f"{spec}: n must be an integer >= 1, got {n!r}")
        n = int(n)
    else:
        n = number("n", int, MAP_DEFAULT_N)
    cell = number("cell")
    spread_opt = number("spread")
    for key, allowed in (("row", kind == "scen"), ("start", kind != "scen"), ("goal", kind != "scen")):
        if key in opts and not allowed:
            raise ScenarioError(f"{spec}: map option {key} is for "
                                f"{'a .scen file' if key == 'row' else 'a map without a .scen (its row gives them)'}")
    map_t: dict[str, Any] = {}
    if kind == "scen":
        rows = maps.read_movingai_scen(path)
        row_i = number("row", int, 0)
        if row_i >= len(rows):
            raise ScenarioError(f"{spec}: row {row_i} does not exist ({path} has rows 0-{len(rows) - 1})")
        row = rows[row_i]
        map_path = _scen_map(path, row)
        grid = maps.load_grid(map_path, cell=cell)
        w, h = grid.shape_xyz
        if (row.width, row.height) != (w, h):
            raise ScenarioError(f"{spec}: row {row_i} is for a {row.width} x {row.height} map but {map_path} is "
                                f"{w} x {h}")
        pts = []
        for what, (cx, cy) in (("start", row.start), ("goal", row.goal)):
            if not (cx < w and cy < h):
                raise ScenarioError(f"{spec}: row {row_i} {what} cell ({cx}, {cy}) lies outside the {w} x {h} map")
            iy = h - 1 - cy  # the file counts rows from the top
            if grid.occupied[iy, cx]:
                raise ScenarioError(f"{spec}: row {row_i} {what} cell ({cx}, {cy}) is an obstacle of {map_path}")
            pts.append(grid.center((cx, iy)))
        start, goal = pts
        desc = (f"MovingAI scenario {path.name} row {row_i}: start cell {row.start}, goal cell {row.goal}, "
                f"optimal grid path {row.optimal_length * grid.cell:g} m")
        map_t = {"file": str(map_path.resolve()), **({"cell": cell} if cell is not None else {})}
    else:
        map_t = {"file": str(path.resolve()), **({"cell": cell} if cell is not None else {}),
                 **({"unknown": opts["unknown"]} if "unknown" in opts else {})}
        if "unknown" in opts and kind != "ros":
            raise ScenarioError(f"{spec}: map option unknown is for ROS maps")
        grid = maps.load_grid(path, cell=cell, unknown=opts.get("unknown", "occupied"))
        if "start" not in opts or "goal" not in opts:
            raise ScenarioError(f"{spec}: a map gives obstacles only: give {path.name}#start=x:y,goal=x:y [m], "
                                "a .scen row, or a TOML scene with [map] (docs/maps.md)")
        start, goal = (_coords(spec, k, opts[k], grid.dim) for k in ("start", "goal"))
        desc = f"map {path.name}"
    d = grid.dim
    lo, hi = grid.bounds[:d], grid.bounds[d:]
    for what, p in (("start", start), ("goal", goal)):
        if any(not lo[a] <= p[a] <= hi[a] for a in range(d)):
            raise ScenarioError(f"{spec}: {what} {list(p)} lies outside the map {list(grid.bounds)}")
    spread = spread_opt if spread_opt is not None else max(math.sqrt(n), grid.cell)
    spawn = [max(start[a] - spread, lo[a]) for a in range(d)] + [min(start[a] + spread, hi[a]) for a in range(d)]
    data = {
        "name": _map_label(path, opts, n),
        "description": desc,
        "map": map_t,
        "swarm": {"n": n, "spawn": spawn},
        "goal": {"position": list(goal)},
    }
    return from_dict(data, source=str(path))


def _coords(spec: str, key: str, val: str, dim: int) -> tuple[float, ...]:
    try:
        p = tuple(float(v) for v in val.split(":"))
    except ValueError:
        p = ()
    if len(p) != dim or not all(math.isfinite(v) for v in p):
        raise ScenarioError(f"{spec}: map option {key} must be {'x:y' if dim == 2 else 'x:y:z'} [m], got {val!r}")
    return p


def _scen_map(scen: Path, row: maps.ScenRow) -> Path:
    """The map a scenario row is for: ``X.map`` beside ``X.map.scen``, else the row's map name
    relative to the scenario's folder, else that name's base name there."""
    beside = scen.with_suffix("")
    for cand in (beside, scen.parent / row.map, scen.parent / Path(row.map).name):
        if maps.map_kind(cand) == "movingai" and cand.is_file():
            return cand
    raise ScenarioError(f"{scen}: cannot find the map of row ({row.map!r}): looked for {beside.name}, "
                        f"{row.map} and {Path(row.map).name} beside the scenario")


def _map_label(path: Path, opts: dict[str, str], n: int) -> str:
    """The scene's name: the map file with every option that rebuilds it."""
    o = dict(opts)
    o["n"] = str(n)
    if maps.map_kind(path) == "scen":
        o.setdefault("row", "0")
    return f"{path.name}#" + ",".join(f"{k}={o[k]}" for k in MAP_OPTIONS if k in o)
