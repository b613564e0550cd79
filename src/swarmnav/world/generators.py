"""Scene generators: random 2-D and 3-D forests (SPH paper, Table II and Fig. 3 (D)), periodic
boxes and the mission-scene family (HWVEM).

Generators are addressable by a spec string ``NAME:key=value,...`` so the CLI and experiment
specs can name a generated scene exactly like a built-in one; the same spec and seed always
give the same scene.
"""

from __future__ import annotations

import contextlib
import math
from typing import Any, Callable

import numpy as np
from scipy import ndimage

from swarmnav.errors import ScenarioError
from swarmnav.params import Range
from swarmnav.world.obstacles import Box, Circle, Cylinder
from swarmnav.world.scenario import MAX_AGENTS, Scenario, Swarm, from_dict, validate


def random_forest(
    density: float = 0.25,
    seed: int = 0,
    n: int = 15,
    length: float = 40.0,
    width: float = 20.0,
    r_min: float = 0.5,
    r_max: float = 1.2,
    min_gap: float = 0.0,
    max_tries: int = 200_000,
    min_passage: float = 0.0,
    max_forests: int = 200,
    spawn_length: float = 6.0,
    height: float = 0.0,
    altitude: float = 1.5,
) -> Scenario:
    """A planar forest of non-overlapping discs filling ``density`` of a rectangle.

    The forest occupies ``x in [0, length]``, ``y in [-width/2, width/2]`` [m]; solid walls run
    along both long sides so the swarm must cross the forest rather than fly round it. The
    swarm spawns in a ``spawn_length`` x 8 m area (6 m; at most 8 m, for swarms of up to 100
    robots) ending 2 m before the forest, and the goal lies 6 m beyond it.

    Density is the obstacle area fraction of the forest rectangle, ``d_obs = A_obs / A``
    (the SPH paper's ``V_obs / V_total`` for vertical trunks). Discs are placed by random
    sequential addition with radii uniform in ``[r_min, r_max]`` [m] and at least ``min_gap``
    [m] between discs; this stays feasible up to ~0.5 area fraction (the jamming limit of
    random sequential addition is ~0.547 for equal discs).

    ``min_passage`` [m] > 0 keeps only crossable forests: a forest is redrawn (the same ``rng``
    continues, so a forest that passes on the first draw is the one ``min_passage = 0`` gives)
    until a corridor at least ``min_passage`` wide joins the two ends of the strip, checked on
    a 0.1 m grid of the exact distance to discs and walls; ``max_forests`` draws at most.

    ``height`` [m] > 0 builds the same forest in 3-D: every disc a trunk from the ground to a
    ceiling at ``height``, the side walls as tall, a ground slab under z = 0 and a ceiling slab
    over z = ``height`` (each 0.5 m thick), the swarm spawning in the same area in a 1 m layer
    centred at ``altitude`` [m] and the goal at that altitude. Full-height trunks cover ``density``
    of the floor at every altitude, so ``V_obs / V_total`` is ``density`` exactly, and a forest
    crossable in 2-D is crossable at every altitude. 0 (the default): the planar scene.
    """
    _check_options("random_forest", locals())
    if not (0 < r_min <= r_max):
        raise ScenarioError(f"random_forest: need 0 < r_min <= r_max, got {r_min}, {r_max}")
    if not 2.0 * r_max <= min(length, width):
        raise ScenarioError(f"random_forest: need 2 r_max <= length and width (a disc fits in the forest), "
                            f"got r_max={r_max}, length={length}, width={width}")
    if not min_passage < width:
        raise ScenarioError(f"random_forest: min_passage must be < width (a corridor inside the forest), "
                            f"got min_passage={min_passage}, width={width}")
    if height and not 1.0 <= altitude <= height - 1.0:
        raise ScenarioError(f"random_forest: with a height, altitude must be in [1, height - 1] m (the 1 m spawn "
                            f"layer keeps 0.5 m from ground and ceiling), got altitude={altitude}, height={height}")
    rng = np.random.default_rng(seed)
    for _ in range(max(1, int(max_forests))):
        centers, radii = _place_discs(rng, density, length, width, r_min, r_max, min_gap, max_tries)
        if min_passage <= 0.0 or _crossable(centers, radii, length, width, min_passage):
            break
    else:
        raise ScenarioError(
            f"random_forest: no forest of {max_forests} draws at density {density} has a "
            f"{min_passage} m passage; lower density or min_passage"
        )
    spawn, goal = (-2.0 - spawn_length, -4.0, -2.0, 4.0), (length + 6.0, 0.0)  # [m]: ends 2 m before, 6 m past
    if height:
        return _extruded_forest(centers, radii, density, seed, n, length, width, spawn, goal, height, altitude)
    wall = 1.0
    obstacles: list = [
        Box((-10.0, width / 2), (length + 10.0, width / 2 + wall)),
        Box((-10.0, -width / 2 - wall), (length + 10.0, -width / 2)),
    ]
    obstacles += [Circle((float(c[0]), float(c[1])), float(r)) for c, r in zip(centers, radii)]
    scn = Scenario(
        name=f"random_forest:density={density:g},seed={seed}",
        bounds=(-10.0, -width / 2 - wall - 1.0, length + 10.0, width / 2 + wall + 1.0),
        swarm=Swarm(n=n, spawn=spawn),
        goal=goal,
        obstacles=tuple(obstacles),
        description=f"Random forest, obstacle area density {density:g}, seed {seed}",
        source=f"random_forest(density={density:g}, seed={seed})",
    )
    return validate(scn)


_SLAB = 0.5  # [m] thickness of the side walls, ground and ceiling of a 3-D forest


def _closed_world(x0: float, x1: float, width: float, height: float) -> list:
    """Side walls at y = +-width/2, a ground slab under z = 0 and a ceiling slab over z = height,
    from x0 to x1: a 3-D forest's swarm must cross it, not fly round or over it."""
    yw = width / 2 + _SLAB
    return [
        Box((x0, width / 2, -_SLAB), (x1, yw, height + _SLAB)),  # side walls
        Box((x0, -yw, -_SLAB), (x1, -width / 2, height + _SLAB)),
        Box((x0, -yw, -_SLAB), (x1, yw, 0.0)),  # ground
        Box((x0, -yw, height), (x1, yw, height + _SLAB)),  # ceiling
    ]


def _extruded_forest(centers, radii, density, seed, n, length, width, spawn, goal, height, altitude) -> Scenario:
    """The planar forest ``random_forest`` drew, as full-height trunks in a closed 3-D world; the
    planar ``spawn`` rectangle and ``goal`` lifted to a 1 m layer and a point at ``altitude``."""
    height, altitude = float(height), float(altitude)
    x0, x1 = -10.0, length + 10.0
    yw = width / 2 + _SLAB
    obstacles = _closed_world(x0, x1, width, height)
    obstacles += [Cylinder((float(c[0]), float(c[1])), float(r), (0.0, height)) for c, r in zip(centers, radii)]
    scn = Scenario(
        name=f"random_forest:density={density:g},seed={seed},height={height:g}",
        bounds=(x0, -yw, 0.0, x1, yw, height),
        swarm=Swarm(n=n, spawn=(*spawn[:2], altitude - 0.5, *spawn[2:], altitude + 0.5)),
        goal=(*goal, altitude),
        obstacles=tuple(obstacles),
        description=f"Random forest of full-height trunks, obstacle volume density {density:g}, seed {seed}",
        source=f"random_forest(density={density:g}, seed={seed}, height={height:g})",
    )
    return validate(scn)


def _place_discs(rng, density, length, width, r_min, r_max, min_gap, max_tries):
    """Random sequential addition of non-overlapping discs up to the area fraction ``density``."""
    target = density * length * width
    centers = np.zeros((0, 2))
    radii = np.zeros(0)
    area, tries = 0.0, 0
    while area < target:
        if tries >= max_tries:
            raise ScenarioError(
                f"random_forest: could not reach density {density} ({area / (length * width):.3f} "
                f"placed after {max_tries} tries); lower density or r_max"
            )
        # draw a batch; accept sequentially so accepted discs never overlap
        cand_r = rng.uniform(r_min, r_max, 256)
        cand_c = np.column_stack(
            [rng.uniform(0.0 + cand_r, length - cand_r), rng.uniform(-width / 2 + cand_r, width / 2 - cand_r)]
        )
        tries += 256
        for c, r in zip(cand_c, cand_r):
            if len(radii):
                d = np.sqrt(np.sum((centers - c) ** 2, axis=1))
                if np.any(d < radii + r + min_gap):
                    continue
            centers = np.vstack([centers, c])
            radii = np.append(radii, r)
            area += math.pi * r * r
            if area >= target:
                break
    return centers, radii


def _crossable(centers: np.ndarray, radii: np.ndarray, length: float, width: float, passage: float,
               resolution: float = 0.1) -> bool:
    """Whether free space at least ``passage`` [m] wide joins x < 0 to x > length between
    the walls: grid nodes with clearance >= passage / 2 from every disc and both walls,
    4-connected, from the column at x = -1 m to the one at x = length + 1 m."""
    xs = np.arange(-1.0, length + 1.0 + 1e-9, resolution)
    ys = np.arange(-width / 2, width / 2 + 1e-9, resolution)
    gx, gy = np.meshgrid(xs, ys)  # (ny, nx)
    clear = width / 2 - np.abs(gy)
    for c, r in zip(centers, radii):
        clear = np.minimum(clear, np.hypot(gx - c[0], gy - c[1]) - r)
    labels, _ = ndimage.label(clear >= passage / 2)
    left = set(labels[:, 0][labels[:, 0] > 0].tolist())
    return any(lab in left for lab in labels[:, -1][labels[:, -1] > 0].tolist())


def random_forest_3d(
    density: float = 0.15,
    seed: int = 0,
    n: int = 30,
    length: float = 26.0,
    width: float = 18.0,
    height: float = 6.0,
    d_min: float = 0.6,
    d_max: float = 1.5,
    h_min: float = 0.1,
    box_share: float = 0.0,
    min_gap: float = 0.0,
    altitude: float = 1.5,
    max_tries: int = 200_000,
    overlap: bool = False,
) -> Scenario:
    """A 3-D forest of vertical trunks filling the volume fraction ``density`` of a box (SPH Fig. 3 (D)).

    The forest fills ``x in [0, length]``, ``y in [-width/2, width/2]``, ``z in [0, height]`` [m]
    and ``density`` is the SPH paper's ``d_obs = V_obs / V_total`` of that box. The world is
    closed (side walls, a ground slab under ``z = 0`` and a ceiling slab over ``z = height``) so
    the swarm must cross the forest, not fly round or over it. ``n`` robots (the paper's
    M = 30) spawn in a 4 m x 6 m x 1 m box centred at ``altitude`` [m], 3-7 m before the forest;
    the goal lies 4 m beyond it at the same altitude.

    Trunks follow the authors' released random map (mockamap, ``randomMapGenerate``) where the
    paper is silent: width (diameter) uniform in ``[d_min, d_max]`` = [0.6, 1.5] m, height
    uniform from the ground up to the map height (``[h_min, height]``; ``h_min`` = 0.1 m, one
    voxel of that map, the shortest post it draws). A trunk is a vertical cylinder (a forest),
    or with probability ``box_share`` the released generator's square post of side ``w``.
    Unlike the released generator trunks never overlap (footprints at least ``min_gap`` [m]
    apart, a square post counted by its circumscribed disc), so ``V_obs`` is the plain sum of
    trunk volumes; trunks are added by random sequential addition until ``V_obs`` reaches the
    target, and the last trunk is shortened to meet it (never below ``h_min``), so the density
    is exact up to ``d_max^2 h_min / V_total`` (8e-5 at the defaults).

    ``overlap = True`` places trunks as the released generator does: uniformly at random, free to
    overlap, until the volume of their union (measured on a 0.05 m floor grid: each cell counts
    the tallest trunk over it) reaches the target; the last trunk is shortened to meet it. Free
    space then clusters in the gaps the random draw leaves, instead of spreading into the even
    gaps of the non-overlapping packing, and densities up to ~(h_min + height) / (2 height) fit.
    """
    _check_options("random_forest_3d", locals())
    if not (0 < d_min <= d_max < min(length, width)):
        raise ScenarioError(f"random_forest_3d: need 0 < d_min <= d_max < the forest's length and width, "
                            f"got {d_min}, {d_max}")
    if not (0 < h_min <= height):
        raise ScenarioError(f"random_forest_3d: need 0 < h_min <= height, got h_min={h_min}, height={height}")
    if not 1.0 <= altitude <= height - 1.0:
        raise ScenarioError(f"random_forest_3d: altitude must be in [1, height - 1] = [1, {height - 1:g}] m "
                            f"(the 1 m spawn box keeps 0.5 m from ground and ceiling), got {altitude}")
    # random sequential addition of footprints fills at most ~0.55 of the floor (overlapping
    # trunks: ~0.95 before the draws become mostly redundant); trunks reach on average (h_min + height) / 2
    limit = (0.95 if overlap else 0.5) * (h_min + height) / (2 * height)
    if not 0.0 <= density <= limit:
        raise ScenarioError(f"random_forest_3d: density must be in [0, {limit:.3g}] with trunks "
                            f"{h_min:g}-{height:g} m tall (raise h_min for more), got {density}")
    rng = np.random.default_rng(seed)
    place = _overlap_trunks if overlap else _place_trunks
    trunks = place(rng, density, length, width, height, d_min, d_max, h_min, box_share, min_gap, max_tries)
    x0, x1 = -8.0, length + 6.0
    yw = width / 2 + _SLAB
    obstacles = _closed_world(x0, x1, width, height)
    for x, y, w, h, square in trunks:
        if square:
            obstacles.append(Box((x - w / 2, y - w / 2, 0.0), (x + w / 2, y + w / 2, h)))
        else:
            obstacles.append(Cylinder((x, y), w / 2, (0.0, h)))
    z0, z1 = altitude - 0.5, altitude + 0.5
    scn = Scenario(
        name=f"random_forest_3d:density={density:g},seed={seed}",
        bounds=(x0, -yw, 0.0, x1, yw, height),
        swarm=Swarm(n=n, spawn=(-7.0, -3.0, z0, -3.0, 3.0, z1)),
        goal=(length + 4.0, 0.0, altitude),
        obstacles=tuple(obstacles),
        description=f"Random 3-D forest, obstacle volume density {density:g}, seed {seed}",
        source=f"random_forest_3d(density={density:g}, seed={seed})",
    )
    return validate(scn)


def _place_trunks(rng, density, length, width, height, d_min, d_max, h_min, box_share, min_gap, max_tries):
    """Random sequential addition of non-overlapping trunks up to the volume fraction ``density``.

    Returns a list of ``(x, y, w, h, square)``: footprint centre [m], width [m], height [m] and
    whether the trunk is a square post.
    """
    target = density * length * width * height
    xy = np.zeros((0, 2))
    reach = np.zeros(0)  # footprint radius used by the overlap test [m]
    trunks: list[tuple[float, float, float, float, bool]] = []
    volume, tries = 0.0, 0
    while volume < target:
        if tries >= max_tries:
            raise _unreached(density, volume / target * density, f"{max_tries} tries", "lower density or d_max, or raise h_min")
        w = rng.uniform(d_min, d_max, 256)
        h = rng.uniform(h_min, height, 256)
        square = rng.uniform(0.0, 1.0, 256) < box_share
        x = rng.uniform(w / 2, length - w / 2)
        y = rng.uniform(-width / 2 + w / 2, width / 2 - w / 2)
        tries += 256
        for k in range(256):
            r = w[k] / math.sqrt(2.0) if square[k] else w[k] / 2
            c = np.array([x[k], y[k]])
            if len(reach) and np.any(np.sqrt(np.sum((xy - c) ** 2, axis=1)) < reach + r + min_gap):
                continue
            area = w[k] ** 2 if square[k] else math.pi * (w[k] / 2) ** 2
            hk = float(h[k])
            if volume + area * hk >= target:  # the last trunk: shortened to meet the target
                hk = max(h_min, (target - volume) / area)
            xy = np.vstack([xy, c])
            reach = np.append(reach, r)
            trunks.append((float(x[k]), float(y[k]), float(w[k]), hk, bool(square[k])))
            volume += area * hk
            if volume >= target:
                break
    return trunks


def _unreached(density: float, reached: float, spent: str, hint: str) -> ScenarioError:
    return ScenarioError(f"random_forest_3d: could not reach density {density} ({reached:.3f} placed after "
                         f"{spent}); {hint}")


def _overlap_trunks(rng, density, length, width, height, d_min, d_max, h_min, box_share, min_gap, max_tries,
                    cell: float = 0.05):
    """Trunks drawn uniformly at random, free to overlap (``min_gap`` unused), until the volume of
    their union on a ``cell`` [m] floor grid reaches the fraction ``density``; same return as
    :func:`_place_trunks`."""
    target = density * length * width * height
    nx, ny = int(math.ceil(length / cell)), int(math.ceil(width / cell))
    cx = (np.arange(nx) + 0.5) * cell  # cell centres
    cy = (np.arange(ny) + 0.5) * cell - width / 2
    top = np.zeros((nx, ny))  # tallest trunk over each cell [m]
    trunks: list[tuple[float, float, float, float, bool]] = []
    volume, tries = 0.0, 0
    while volume < target:
        if tries >= max_tries:
            raise _unreached(density, volume / target * density, f"{max_tries} trunks", "lower density or raise h_min")
        w = rng.uniform(d_min, d_max)
        h = rng.uniform(h_min, height)
        square = bool(rng.uniform(0.0, 1.0) < box_share)
        x = rng.uniform(w / 2, length - w / 2)
        y = rng.uniform(-width / 2 + w / 2, width / 2 - w / 2)
        tries += 1
        i0, i1 = np.searchsorted(cx, x - w / 2), np.searchsorted(cx, x + w / 2)
        j0, j1 = np.searchsorted(cy, y - w / 2), np.searchsorted(cy, y + w / 2)
        if square:
            foot = np.ones((i1 - i0, j1 - j0), dtype=bool)
        else:
            foot = (cx[i0:i1, None] - x) ** 2 + (cy[None, j0:j1] - y) ** 2 <= (w / 2) ** 2
        patch = top[i0:i1, j0:j1]
        under = patch[foot]  # the tallest trunk over each cell of the footprint so far [m]

        def gain_at(hk: float) -> float:  # union volume the trunk adds at height hk [m^3]
            return float(np.sum(np.maximum(under, hk) - under)) * cell * cell

        gain = gain_at(h)
        if gain <= 0.0:
            continue
        if volume + gain > target:  # the last trunk: shortened (bisection) to meet the target
            lo, hi = h_min, h
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if volume + gain_at(mid) < target else (lo, mid)
            h = hi
            gain = gain_at(h)
        patch[foot] = np.maximum(under, h)
        trunks.append((float(x), float(y), float(w), float(h), square))
        volume += gain
    return trunks


def periodic_box(n: int = 100, rho: float = 4.102, seed: int = 0) -> Scenario:
    """An obstacle-free periodic square of side ``D = sqrt(n / rho)`` [m] (HWVEM Section 3.1).

    ``rho`` is the agent density [1/m^2]. Agents spawn uniformly over the whole box (no spacing
    rule: Vicsek agents are points). The goal is unused by the alignment experiments and sits
    at the box centre. ``seed`` is accepted for a uniform spec grammar; the box has no random
    geometry.
    """
    _check_options("periodic_box", locals())
    side = math.sqrt(n / rho)
    scn = Scenario(
        name=f"periodic_box:n={n},rho={rho:g}",
        bounds=(0.0, 0.0, side, side),
        swarm=Swarm(n=n, spawn=(0.0, 0.0, side, side), min_spacing=0.0, clearance=0.0),
        goal=(side / 2, side / 2),
        periodic=True,
        description=f"Periodic box, {n} agents at density {rho:g} /m^2 (D = {side:.4g} m)",
        source=f"periodic_box(n={n}, rho={rho:g})",
    )
    return validate(scn)


def hwvem_mission_family(tiny_offset: float = 1.45, rect_offset: float = 1.3, passage_width: float = 2.4,
                         turn_scale: float = 1.0, n: int = 20) -> Scenario:
    """The HWVEM Section 3.2 mission scene as a family of our layouts (Figure 7 gives no coordinates).

    One layout, four free numbers (the defaults are ``hwvem_mission``, laid out from the paper's
    figure and text; ``hwvem_mission_fitted`` is the option ``rect_offset = 0.6``, fitted to the
    paper's baselines, see docs/history/vicsek.md). Along a 70 m path (at ``turn_scale = 1``) the swarm meets two tiny
    circles (r = 0.25 m), a 6 m passage with funnel entrance faces, a huge circle (r = 3 m) and
    a diamond either side of the high leg, a triangle above the descending leg, a rectangle
    (2 m x 1 m) and a small circle either side of the low leg, and a triangle-diamond passage
    on the last leg. The swarm starts at rho = 3.265 /m^2 centred on the path start.

    Args:
        tiny_offset: [m] lateral offset of the tiny circles from the path (+y at x = 7, -y at x = 10).
        rect_offset: [m] gap between the low leg and the rectangle's near face.
        passage_width: [m] width of the first passage; the second passage's gap is 0.2 m wider.
        turn_scale: [-] multiplies the y of every path waypoint (steeper turns); the obstacles
            beside a leg move with it, so their distance to that leg is kept.
        n: swarm size.
    """
    _check_options("hwvem_mission_family", locals())
    s, h, g = turn_scale, passage_width / 2, (passage_width + 0.2) / 2
    hi, lo = 3.0 * s, -3.5 * s  # [m] y of the high and the low leg
    dy = -2.1875 * (s - 1.0)  # [m] shift of the descending leg at x = 45 (the triangle moves with it)

    def poly(*pts):
        return {"type": "polygon", "points": [list(p) for p in pts]}

    obstacles = [
        {"type": "circle", "center": [7.0, tiny_offset], "radius": 0.25},
        {"type": "circle", "center": [10.0, -tiny_offset], "radius": 0.25},
        poly((12, 7), (16, h), (22, h), (22, 7)),  # passage 1, upper wall (funnel face)
        poly((12, -7), (22, -7), (22, -h), (16, -h)),  # passage 1, lower wall
        {"type": "circle", "center": [32.0, hi - 4.5], "radius": 3.0},  # huge circle under the high leg
        poly((32, hi + 1.5), (34, hi + 3.5), (32, hi + 5.5), (30, hi + 3.5)),  # diamond over it (3 m gap)
        poly((43, 0.5 + dy), (47, 0.5 + dy), (45, 3 + dy)),  # triangle above the descending leg
        {"type": "box", "min": [51.0, round(lo + rect_offset, 9)], "max": [53.0, round(lo + rect_offset + 1.0, 9)]},
        {"type": "circle", "center": [53.5, lo - 2.1], "radius": 0.6},  # small circle below the low leg
        poly((61, -3.5), (65, -3.5), (63, -g)),  # passage 2, triangle below the last leg
        poly((63, g), (64.2, g + 1.2), (63, g + 2.4), (61.8, g + 1.2)),  # passage 2, diamond above it
    ]
    spec = (f"hwvem_mission_family:tiny_offset={tiny_offset:g},rect_offset={rect_offset:g},"
            f"passage_width={passage_width:g},turn_scale={turn_scale:g}")
    data = {
        "name": spec,
        "description": "HWVEM Sec. 3.2 mission family: narrow passages, tiny and huge circles, rectangles, "
                       "diamonds, triangles.",
        # the paper's open plane of point agents: no walls, contacts counted (hwvem_mission.toml says why)
        "world": {"bounds": [-6.0, min(-10.0, lo - 4.0), 70.0, max(12.0, hi + 7.0)], "boundary": "open"},
        "rules": {"contact": "count"},
        "swarm": {"n": n, "spawn": [0.0, 0.0, 0.0, 0.0], "density": 3.265, "min_spacing": 0.0, "clearance": 0.3},
        "goal": {"position": [66.0, 0.0], "path": [[0.0, 0.0], [24.0, 0.0], [28.0, hi], [36.0, hi], [40.0, 0.0],
                                                   [48.0, lo], [56.0, lo], [60.0, 0.0], [66.0, 0.0]]},
        "obstacles": obstacles,
    }
    return from_dict(data, source=spec)


def mockamap(
    type: int = 1,
    seed: int = 511,
    resolution: float = 0.1,
    x_length: float = 20.0,
    y_length: float = 20.0,
    z_length: float = 4.0,
    complexity: float = 0.03,
    fill: float = 0.15,
    fractal: int = 1,
    attenuation: float = 0.1,
    width_min: float = 0.6,
    width_max: float = 1.5,
    obstacle_number: int = 10,
    road_width: float = 1.0,
    add_wall_x: int = 0,
    add_wall_y: int = 0,
    maze_type: int = 1,
    numNodes: int = 10,
    connectivity: float = 0.5,
    roadRad: int = 2,
    n: int = 15,
    dim: int = 3,
    altitude: float = 1.5,
    min_passage: float = 0.0,
) -> Scenario:
    """A mockamap world (the released simulators of SPH and EGO-Swarm) for the swarm to cross.

    The map (:func:`swarmnav.world.mockamap.generate`; mockamap's parameter names, SPH's launch
    file's values as defaults: type 1 Perlin noise, 20 m x 20 m x 4 m at 0.1 m, seed 511,
    complexity 0.03, fill 0.15, fractal 1, attenuation 0.1) fills ``x in [-X/2, X/2]``,
    ``y in [-Y/2, Y/2]``, ``z in [0, Z]``; its voxels are merged exactly into boxes. The world
    extends 8 m before and 6 m past the map along x and is walled at the map's sides (and floor
    and ceiling in 3-D), so the swarm crosses the map: ``n`` robots spawn in a free 6 m x 6 m
    area 1-7 m before it (in 3-D a 1 m layer centred at ``altitude``) and fly to the goal 4 m
    past it at ``altitude``. ``dim = 2`` reads the voxel layer that holds ``altitude`` as a
    planar map (the 2-D maze's every layer is the maze). A map whose free voxels (those at least
    ``min_passage / 2`` m from every occupied voxel) join no way from the spawn side to the goal
    side is refused (another seed, or a lower fill).
    """
    from swarmnav.world import mockamap as mk
    from swarmnav.world.maps import OccupancyGrid

    _check_options("mockamap", locals())
    if width_min > width_max:
        raise ScenarioError(f"mockamap: need width_min <= width_max, got {width_min:g}, {width_max:g}")
    if not 1.0 <= altitude <= z_length - 1.0:
        raise ScenarioError(f"mockamap: altitude must be in [1, z_length - 1] = [1, {z_length - 1:g}] m (the 1 m "
                            f"spawn layer keeps 0.5 m from floor and ceiling), got {altitude:g}")
    grid = mk.generate(type=type, seed=seed, resolution=resolution, x_length=x_length, y_length=y_length,
                       z_length=z_length, complexity=complexity, fill=fill, fractal=fractal,
                       attenuation=attenuation, width_min=width_min, width_max=width_max,
                       obstacle_number=obstacle_number, road_width=road_width, add_wall_x=add_wall_x,
                       add_wall_y=add_wall_y, numNodes=numNodes, connectivity=connectivity, roadRad=roadRad)
    occ = grid.occupied
    if dim == 2:
        layer = min(int(math.floor(altitude / resolution + 1e-9)), occ.shape[0] - 1)
        occ = np.ascontiguousarray(occ[layer])
        occ.setflags(write=False)
        grid = OccupancyGrid(occ, grid.origin[:2], grid.cell, grid.source)
    spec = f"mockamap:type={type},seed={seed}"
    if not _crosses(occ, resolution, min_passage):
        raise ScenarioError(f"{spec}: no way across the map for free space {min_passage:g} m wide "
                            "(another seed, a lower fill or a smaller min_passage)")
    x_lo, y_lo = grid.origin[:2]
    x_hi, y_hi = grid.bounds[dim], grid.bounds[dim + 1]
    spawn_xy = (x_lo - 7.0, -3.0, x_lo - 1.0, 3.0)  # [m]: 6 m x 6 m, 1-7 m before the map
    if dim == 3:
        bounds = (x_lo - 8.0, y_lo, 0.0, x_hi + 6.0, y_hi, grid.bounds[5])
        spawn = (spawn_xy[0], spawn_xy[1], altitude - 0.5, spawn_xy[2], spawn_xy[3], altitude + 0.5)
        goal: tuple[float, ...] = (x_hi + 4.0, 0.0, altitude)
    else:
        bounds = (x_lo - 8.0, y_lo, x_hi + 6.0, y_hi)
        spawn, goal = spawn_xy, (x_hi + 4.0, 0.0)
    kind = mk.TYPES[type]
    scn = Scenario(
        name=spec,
        bounds=bounds,
        swarm=Swarm(n=n, spawn=spawn),
        goal=goal,
        obstacles=grid.boxes(),
        description=f"mockamap {kind} map (type {type}), seed {seed}, "
                    f"{int(occ.sum())} of {occ.size} {'voxels' if dim == 3 else 'cells'} occupied"
                    + ("" if dim == 3 else f" (the layer at {altitude:g} m)"),
        source=spec,
    )
    return validate(scn)


def _crosses(occ: np.ndarray, cell: float, passage: float) -> bool:
    """Whether free cells (at least ``passage / 2`` [m] from every occupied cell: the distance
    between centres less half a cell diagonal) join the map's x = min face to its x = max face,
    face-connected; the approach areas beyond both faces are free."""
    free = ~occ
    if passage > 0.0 and occ.any():
        dist = ndimage.distance_transform_edt(free) * cell - cell * math.sqrt(occ.ndim) / 2
        free = dist >= passage / 2
    pad = [(0, 0)] * (occ.ndim - 1) + [(1, 1)]
    labels, _ = ndimage.label(np.pad(free, pad, constant_values=True))
    return bool(labels[..., 0].flat[0] == labels[..., -1].flat[0])


GENERATORS: dict[str, Callable[..., Scenario]] = {
    "random_forest": random_forest,
    "random_forest_3d": random_forest_3d,
    "periodic_box": periodic_box,
    "hwvem_mission_family": hwvem_mission_family,
    "mockamap": mockamap,
}


#: Every option of every generator, as ``(type, valid values, unit, why those values)``: ``from_spec`` reads a spec's
#: values with these types, and each generator checks its arguments against them on entry, so a
#: spec and a Python call are refused alike, with the generator, the option and its valid values.
#: Relations between options (``r_min <= r_max``, an altitude under the ceiling) are checked by the
#: generator itself. Upper bounds that are ours: forest sides up to 200 m (five times the SPH
#: paper's 40 m forest; random sequential addition is quadratic in the number of discs, and a
#: 200 m x 200 m forest at density 0.5 already takes ~30 s), heights up to 100 m, up to 10 000
#: redraws for ``min_passage``.
OPTIONS: dict[str, dict[str, tuple[type, Range | None, str, str]]] = {
    "random_forest": {
        "density": (float, Range.parse("[0, 0.55)"), "", "random sequential addition jams at ~0.547"),
        "seed": (int, Range.parse("[0, inf)"), "", ""),
        "n": (int, Range.parse(f"[1, {MAX_AGENTS}]"), "", ""),
        "length": (float, Range.parse("(0, 200]"), "m", ""),
        "width": (float, Range.parse("[8, 200]"), "m", "the 8 m wide spawn area lies between the side walls"),
        "r_min": (float, Range.parse("(0, inf)"), "m", ""),
        "r_max": (float, Range.parse("(0, inf)"), "m", ""),
        "min_gap": (float, Range.parse("[0, inf)"), "m", ""),
        "min_passage": (float, Range.parse("[0, inf)"), "m", ""),
        "max_forests": (int, Range.parse("[1, 10000]"), "", ""),
        "spawn_length": (float, Range.parse("(0, 8]"), "m", "at most 8 m, for swarms of up to 100 robots"),
        "height": (float, Range.parse("[0, 100]"), "m", "0: the planar forest"),
        "altitude": (float, Range.parse("[1, 99]"), "m", "the 1 m spawn layer keeps 0.5 m from ground and ceiling"),
    },
    "random_forest_3d": {
        "density": (float, Range.parse("[0, 1)"), "", ""),  # what is reachable depends on h_min and overlap
        "seed": (int, Range.parse("[0, inf)"), "", ""),
        "n": (int, Range.parse(f"[1, {MAX_AGENTS}]"), "", ""),
        "length": (float, Range.parse("(0, 200]"), "m", ""),
        "width": (float, Range.parse("[6, 200]"), "m", "the 6 m wide spawn box lies between the side walls"),
        "height": (float, Range.parse("[2, 100]"), "m", "the 1 m spawn layer keeps 0.5 m from ground and ceiling"),
        "d_min": (float, Range.parse("(0, inf)"), "m", ""),
        "d_max": (float, Range.parse("(0, inf)"), "m", ""),
        "h_min": (float, Range.parse("(0, inf)"), "m", ""),
        "box_share": (float, Range.parse("[0, 1]"), "", "a probability"),
        "min_gap": (float, Range.parse("[0, inf)"), "m", ""),
        "altitude": (float, Range.parse("[1, 99]"), "m", "the 1 m spawn layer keeps 0.5 m from ground and ceiling"),
        "overlap": (bool, None, "", ""),
    },
    "periodic_box": {
        "n": (int, Range.parse(f"[1, {MAX_AGENTS}]"), "", ""),
        "rho": (float, Range.parse("(0, inf)"), "1/m^2", ""),
        "seed": (int, Range.parse("[0, inf)"), "", ""),
    },
    "hwvem_mission_family": {
        "tiny_offset": (float, Range.parse("[0, 9.75]"), "m", "the r = 0.25 m circles stay inside y >= -10 m"),
        "rect_offset": (float, Range.parse("[0, 10]"), "m", ""),
        "passage_width": (float, Range.parse("(0, 6.8)"), "m",
                          "the second passage's triangle keeps its apex, y = -(w + 0.2) / 2, above its base at -3.5 m"),
        "turn_scale": (float, Range.parse("[0, 10]"), "", ""),
        "n": (int, Range.parse(f"[1, {MAX_AGENTS}]"), "", ""),
    },
    "mockamap": {  # mockamap's parameters (docs/maps-generators.md), then ours (n, dim, altitude, min_passage)
        "type": (int, Range.parse("[1, 4]"), "", "1 Perlin 3-D, 2 random posts, 3 2-D maze, 4 3-D maze"),
        "seed": (int, Range.parse("[0, inf)"), "", ""),
        "resolution": (float, Range.parse("[0.02, 2]"), "m", "the voxel side"),
        "x_length": (float, Range.parse("(0, 100]"), "m", ""),
        "y_length": (float, Range.parse("[6, 100]"), "m", "the 6 m wide spawn area lies between the side walls"),
        "z_length": (float, Range.parse("[2, 40]"), "m", "the 1 m spawn layer keeps 0.5 m from floor and ceiling"),
        "complexity": (float, Range.parse("(0, 10]"), "1/voxel", "noise frequency per voxel index"),
        "fill": (float, Range.parse("(0, 1)"), "", "the occupied fraction of the Perlin map"),
        "fractal": (int, Range.parse("[1, 8]"), "", "noise octaves"),
        "attenuation": (float, Range.parse("(0, inf)"), "", ""),
        "width_min": (float, Range.parse("(0, 100]"), "m", ""),
        "width_max": (float, Range.parse("(0, 100]"), "m", ""),
        "obstacle_number": (int, Range.parse("[0, 100000]"), "", ""),
        "road_width": (float, Range.parse("(0, 100]"), "m", "a whole number of voxels"),
        "add_wall_x": (int, Range.parse("[0, 1]"), "", "1: walls along the maze's y edges"),
        "add_wall_y": (int, Range.parse("[0, 1]"), "", "1: walls along the maze's x edges"),
        "maze_type": (int, Range.parse("[1, 1]"), "", "mockamap has one: recursive division"),
        "numNodes": (int, Range.parse("[2, 1000]"), "", "cores of the 3-D maze"),
        "connectivity": (float, Range.parse("[0, 1]"), "", ""),
        "roadRad": (int, Range.parse("[0, 1000]"), "voxel/3", "hole radius of the 3-D maze's walls"),
        "n": (int, Range.parse(f"[1, {MAX_AGENTS}]"), "", ""),
        "dim": (int, Range.parse("[2, 3]"), "", "2: the voxel layer at altitude as a planar map"),
        "altitude": (float, Range.parse("[1, 39]"), "m", "the 1 m spawn layer keeps 0.5 m from floor and ceiling"),
        "min_passage": (float, Range.parse("[0, 100]"), "m", ""),
    },
}


def _check_options(name: str, values: dict[str, Any]) -> None:
    """Raise ScenarioError unless every option of generator ``name`` in ``values`` (its arguments)
    has the type and lies in the range ``OPTIONS`` declares."""
    for key, option in OPTIONS[name].items():
        if key in values:
            _option(name, key, values[key], *option)


def _option(name: str, key: str, value: Any, kind: type, valid: Range | None, unit: str, why: str) -> Any:
    """``value`` (a Python value) as option ``key`` of generator ``name``, or ScenarioError."""
    if kind is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise ScenarioError(f"{name}: {key} must be true or false, got {value!r}")
    if kind is int:
        lo, hi = (f"{v:.0f}" if math.isfinite(v) else "inf" for v in (valid.lo, valid.hi))
        shown = f"{'[' if valid.lo_closed else '('}{lo}, {hi}{']' if valid.hi_closed else ')'}"
    else:
        shown = f"{valid}{' ' + unit if unit else ''}"
    why = f" ({why})" if why else ""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or (kind is int and not isinstance(value, (int, np.integer))):
        raise ScenarioError(f"{name}: {key} must be {'an integer' if kind is int else 'a number'} in {shown}{why}, "
                            f"got {value!r}")
    try:
        x = int(value) if kind is int else float(value)
    except OverflowError:  # an integer beyond the float range
        x = math.inf
    if x not in valid:  # NaN and infinities lie in no range
        raise ScenarioError(f"{name}: {key} must be in {shown}{why}, got {x!r}")
    return x


def _read(name: str, key: str, text: str) -> Any:
    """The text of option ``key`` in a spec as the option's type (an integer may be written as a
    float: ``1e3``, ``15.0``), checked by :func:`_option`."""
    kind = OPTIONS[name][key][0]
    value: Any = text
    if kind is bool:
        value = {"true": True, "false": False}.get(text.lower(), text)
    else:
        try:
            value = int(text) if kind is int else float(text)
        except ValueError:
            with contextlib.suppress(ValueError):
                x = float(text)
                value = int(x) if kind is int and x.is_integer() else text
    return _option(name, key, value, *OPTIONS[name][key])


def from_spec(spec: str, n: int | None = None) -> Scenario:
    """Build a generated scene from ``NAME:key=value,...``, each value read as its option's type
    (``OPTIONS``: integer, number or true/false) and checked against its range.

    ``n`` (if given) overrides the generator's swarm size, so a generator that sizes its world
    by ``n`` (``periodic_box``: side ``sqrt(n / rho)``) keeps its density when resized.
    """
    name, _, rest = spec.partition(":")
    where = spec if spec.isprintable() else repr(spec)[1:-1]  # the message stays one line
    if name not in GENERATORS:
        raise ScenarioError(f"{where}: unknown generator {name!r} (known: {', '.join(GENERATORS)})")
    fn, options = GENERATORS[name], OPTIONS[name]
    kwargs: dict[str, Any] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, val = item.partition("=")
        key = key.strip()
        if not eq:
            raise ScenarioError(f"{where}: expected key=value, got {item!r}")
        if key not in options:
            raise ScenarioError(f"{where}: unknown parameter {key!r} for {name} (allowed: {', '.join(options)})")
        if key in kwargs:
            raise ScenarioError(f"{where}: {name} option {key!r} is given twice")
        kwargs[key] = _read(name, key, val.strip())
    if n is not None and "n" in options:
        kwargs["n"] = n
    return fn(**kwargs)
