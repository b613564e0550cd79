"""Drawing a 3-D scene on a matplotlib ``Axes3D``: obstacles as shaded translucent solids,
goal, spawn box and path, true-scale box aspect and the default camera.

Solids are meshed into planar faces (:func:`obstacle_faces`) and drawn as one
``Poly3DCollection``: mplot3d sorts faces by depth only inside a collection, so one collection
for every obstacle keeps a box in front of a cylinder drawn in front of it. Faces are shaded
here from their outward normals (a fixed light above the default viewer's left shoulder)
instead of by mplot3d's ``shade=True``, which depends on vertex order.

Figures draw the scene first and trajectories, agents and marks over it (the axes are made
with ``computed_zorder=False``): mplot3d cannot interleave a line collection with the faces of
solids, and a path hidden behind a pillar is worse than one drawn across it.
"""

from __future__ import annotations

import numpy as np
from matplotlib import patches as mpatches
from matplotlib.artist import Artist
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d import Axes3D, proj3d
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from swarmnav.errors import SwarmnavError
from swarmnav.viz.style import GOAL_FACE, PATH_COLOR, SPAWN_COLOR
from swarmnav.world.obstacles import Box, Cylinder, Polygon, Sphere
from swarmnav.world.scenario import Scenario

SOLID_FACE = "#c5cad3"  # light cool grey: tab10 trajectories stay readable on it
SOLID_EDGE = "#59606b"
SOLID_ALPHA = 0.45  # translucent, so a solid behind another still shows
#: Default camera: elevation and azimuth [deg] (looks down on the swarm from the side of
#: negative y, the start on the left, a +x goal on the right).
CAMERA = (35.0, -60.0)
#: Room [in] around a 3-D panel's box for tick and axis labels: left, right, bottom, top.
MARGINS = (0.35, 0.8, 0.6, 0.15)
#: Direction the light comes from (unit vector, world frame): above the default viewer's left.
LIGHT = np.array([-0.35, -0.55, 0.76]) / np.linalg.norm([-0.35, -0.55, 0.76])
#: Budget of faces for all curved solids of a scene (our choice: a forest of 150 trees still
#: draws in well under a second); each cylinder or sphere gets between MIN_SIDES and
#: MAX_SIDES sides around its axis.
CURVED_FACE_BUDGET = 6000
MIN_SIDES, MAX_SIDES = 8, 32


def new_axes(fig: Figure, *args, **kwargs) -> Axes3D:
    """A 3-D axes on ``fig`` (``fig.add_subplot(*args)``) that draws artists in the order
    they were added (see the module docstring), with the default camera."""
    ax = fig.add_subplot(*args, projection="3d", computed_zorder=False, **kwargs)
    ax.view_init(elev=CAMERA[0], azim=CAMERA[1])
    return ax


def curved_sides(obstacles) -> int:
    """Sides around the axis of every cylinder and sphere of ``obstacles`` within
    ``CURVED_FACE_BUDGET`` faces (a sphere of ``s`` sides has ``s * s / 2`` faces)."""
    n_cyl = sum(isinstance(o, Cylinder) for o in obstacles)
    n_sph = sum(isinstance(o, Sphere) for o in obstacles)
    if n_cyl + n_sph == 0:
        return MAX_SIDES
    # largest s with n_cyl * (s + 2) + n_sph * s^2 / 2 <= budget, clipped
    a, b, c = n_sph / 2, n_cyl, 2 * n_cyl - CURVED_FACE_BUDGET
    s = -c / b if a == 0 else (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)
    return int(np.clip(int(s), MIN_SIDES, MAX_SIDES))


def obstacle_faces(obstacle, sides: int = MAX_SIDES) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Planar faces of one 3-D obstacle's surface.

    Boxes and prisms: one quad per footprint edge plus the bottom and top caps. Cylinders: the
    prism of a regular ``sides``-gon inscribed in the disc. Spheres: ``sides`` meridians by
    ``sides // 2`` parallels of quads (triangles at the poles, as quads with a repeated vertex).

    Returns:
        ``(faces, normals, edged)``: list of (M, 3) vertex arrays [m], (F, 3) outward unit
        normals, (F,) bool: draw the face's outline (true edges of the solid, not the seams of
        a curved surface).
    """
    if isinstance(obstacle, Sphere):
        return _sphere_faces(np.asarray(obstacle.center, dtype=float), obstacle.radius, sides)
    if isinstance(obstacle, Cylinder):
        phi = 2 * np.pi * np.arange(sides) / sides
        ring = np.asarray(obstacle.center, dtype=float) + obstacle.radius * np.column_stack([np.cos(phi), np.sin(phi)])
        return _prism_faces(ring, obstacle.z, edged_sides=False)
    if isinstance(obstacle, (Box, Polygon)) and obstacle.z is not None:
        return _prism_faces(obstacle.vertices(), obstacle.z, edged_sides=True)
    raise SwarmnavError(f"not an obstacle of a 3-D world: {obstacle!r}")


def _prism_faces(v: np.ndarray, z: tuple[float, float], edged_sides: bool):
    z0, z1 = z
    m = len(v)
    if np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]) < 0:
        v = v[::-1]  # counter-clockwise, so the right of each edge is outside
    w = np.roll(v, -1, axis=0)
    lo, hi = np.full((m, 1), z0), np.full((m, 1), z1)
    sides = np.stack([np.hstack([v, lo]), np.hstack([w, lo]), np.hstack([w, hi]), np.hstack([v, hi])], axis=1)
    e = w - v
    out = np.column_stack([e[:, 1], -e[:, 0], np.zeros(m)]) / np.linalg.norm(e, axis=1)[:, None]
    faces = [*sides, np.hstack([v[::-1], lo]), np.hstack([v, hi])]
    normals = np.vstack([out, [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    edged = np.r_[np.full(m, edged_sides), True, True]
    return faces, normals, edged


def _sphere_faces(c: np.ndarray, r: float, sides: int):
    n_lat = max(sides // 2, 2)
    theta = np.linspace(0.0, np.pi, n_lat + 1)  # polar angle
    phi = np.linspace(0.0, 2 * np.pi, sides + 1)
    T, F = np.meshgrid(theta, phi, indexing="ij")
    u = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], axis=-1)  # (n_lat+1, sides+1, 3)
    quads = np.stack([u[:-1, :-1], u[:-1, 1:], u[1:, 1:], u[1:, :-1]], axis=2).reshape(-1, 4, 3)
    mid = quads.mean(axis=1)
    normals = mid / np.linalg.norm(mid, axis=1)[:, None]
    return list(c + r * quads), normals, np.zeros(len(quads), dtype=bool)


def solids(obstacles) -> Poly3DCollection | None:
    """One shaded, translucent ``Poly3DCollection`` of every obstacle's faces, or None when
    there are none."""
    if not obstacles:
        return None
    sides = curved_sides(obstacles)
    faces, normals, edged = [], [], []
    for o in obstacles:
        f, n, e = obstacle_faces(o, sides)
        faces += f
        normals.append(n)
        edged.append(e)
    normals, edged = np.vstack(normals), np.concatenate(edged)
    # Lambertian shade with an ambient floor: faces turned from the light stay light grey.
    light = 0.62 + 0.38 * np.clip(normals @ LIGHT, 0.0, None)
    face = np.asarray(to_rgba(SOLID_FACE))
    facecolors = np.column_stack([face[:3] * light[:, None], np.full(len(light), SOLID_ALPHA)])
    edgecolors = np.tile(to_rgba(SOLID_EDGE, 0.8), (len(light), 1))
    edgecolors[~edged, 3] = 0.0
    return Poly3DCollection(faces, facecolors=facecolors, edgecolors=edgecolors, linewidths=0.5, zorder=1)


def enclosing(obstacle, lo, hi) -> bool:
    """True for a wall, ground or ceiling of the world box ``[lo, hi]``: a box that spans the
    whole box along at least two axes."""
    if not isinstance(obstacle, Box) or obstacle.dim != 3:
        return False
    spans = (np.asarray(obstacle.min) <= lo + 1e-9) & (np.asarray(obstacle.max) >= hi - 1e-9)
    return int(spans.sum()) >= 2


def box_edges(lo, hi) -> np.ndarray:
    """The 12 edges (12, 2, 3) of the axis-aligned box ``[lo, hi]`` [m]."""
    corners = np.array([[hi[i] if (k >> i) & 1 else lo[i] for i in range(3)] for k in range(8)])
    pairs = [(a, a | 1 << i) for a in range(8) for i in range(3) if not (a >> i) & 1]
    return corners[np.array(pairs)]


def draw_scene_3d(
    ax: Axes3D,
    scenario: Scenario,
    *,
    show_spawn: bool = True,
    show_goal: bool = True,
    show_path: bool = True,
) -> list[Artist]:
    """Draw a 3-D scene on ``ax``: solids, goal (star over a dotted drop line to the floor),
    spawn box and path; set the limits to ``scenario.bounds`` with a true-scale box aspect,
    the axis labels and the default camera.

    Returns:
        Legend handles of what was drawn (obstacle, spawn, path, goal).
    """
    if not isinstance(ax, Axes3D):
        raise SwarmnavError(f"{scenario.name}: a 3-D scene is drawn on a 3-D axes (projection='3d')")
    handles: list[Artist] = []
    lo, hi = scenario.lower, scenario.upper
    shell = [enclosing(o, lo, hi) for o in scenario.obstacles]
    coll = solids([o for o, s in zip(scenario.obstacles, shell) if not s])
    if coll is not None:
        ax.add_collection3d(coll, autolim=False)
        handles.append(mpatches.Patch(facecolor=SOLID_FACE, edgecolor=SOLID_EDGE, label="obstacle"))
    if any(shell):
        # Walls, ground and ceiling would hide the whole scene: outlines of their parts inside
        # the bounds only.
        edges = [box_edges(np.maximum(o.min, lo), np.minimum(o.max, hi)) for o, s in zip(scenario.obstacles, shell) if s]
        ax.add_collection3d(Line3DCollection(np.concatenate(edges), colors=SOLID_EDGE, linewidths=0.7, alpha=0.6,
                                             zorder=1), autolim=False)
        handles.append(Line2D([], [], color=SOLID_EDGE, linewidth=0.7, alpha=0.6, label="walls, ground, ceiling"))
    if show_spawn:
        region = np.asarray(scenario.swarm.region, dtype=float)
        ax.add_collection3d(Line3DCollection(box_edges(region[:3], region[3:]), colors=SPAWN_COLOR,
                                             linestyles="--", linewidths=1.0, zorder=2), autolim=False)
        handles.append(Line2D([], [], color=SPAWN_COLOR, linestyle="--", linewidth=1.2, label="spawn region"))
    if show_path and scenario.path:
        p = np.asarray(scenario.path)
        handles += ax.plot(p[:, 0], p[:, 1], p[:, 2], linestyle="-.", color=PATH_COLOR, linewidth=1.2,
                           zorder=2, label="path")
    if show_goal:
        g = scenario.goal
        ax.plot([g[0], g[0]], [g[1], g[1]], [lo[2], g[2]], linestyle=":", color="0.3", linewidth=0.9, zorder=6)
        handles.append(ax.scatter([g[0]], [g[1]], [g[2]], marker="*", s=260, color=GOAL_FACE, edgecolors="black",
                                  linewidths=0.8, depthshade=False, zorder=8, label="goal"))
    set_bounds(ax, lo, hi)
    return handles


def set_bounds(ax: Axes3D, lo, hi) -> None:
    """Limits exactly ``[lo, hi]``, box aspect of the true extents, labels in metres, at most
    a few ticks on a short axis."""
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ext = np.asarray(hi, dtype=float) - np.asarray(lo, dtype=float)
    ax.set_box_aspect(tuple(ext))
    for axis, label, e in ((ax.xaxis, "x [m]", ext[0]), (ax.yaxis, "y [m]", ext[1]), (ax.zaxis, "z [m]", ext[2])):
        axis.set_major_locator(MaxNLocator(nbins=max(2, min(8, int(round(8 * e / ext.max())))), steps=[1, 2, 5, 10]))
        axis.set_label_text(label)
    ax.tick_params(labelsize=7, pad=0)



def panel_figure(scenario: Scenario, width: float = 9.0, top: float = 1.0, below: float = 0.0,
                 max_height: float = 7.0, camera: tuple[float, float] = CAMERA) -> tuple[Figure, Axes3D]:
    """A figure ``width`` [in] wide holding a 3-D panel of ``scenario``'s box: ``top`` [in] above
    it for titles and legends, ``below`` [in] under it for other panels (left to the caller),
    seen from ``camera`` = (elevation, azimuth) [deg].

    The figure's height follows the box's shape on screen, so a long flat world gets a wide
    low panel and a tower a tall one (at most ``max_height`` [in]).
    """
    fig = Figure(figsize=(width, 4.0))  # height set once the panel's shape is known
    ax = new_axes(fig)
    ax.view_init(elev=camera[0], azim=camera[1])
    set_bounds(ax, scenario.lower, scenario.upper)
    left, right, bottom, margin_top = MARGINS
    pw = width - left - right
    ph = min(pw * projected_aspect(ax), max_height)
    fig.set_size_inches(width, below + bottom + ph + margin_top + top)
    place(ax, (left, below + bottom, pw, ph))
    return fig, ax


def projected_aspect(ax: Axes3D) -> float:
    """Height / width of the scene box (the axes limits) as ``ax``'s camera draws it."""
    px = box_on_screen(ax)
    w, h = np.ptp(px, axis=0)
    return float(h / w)


def place(ax: Axes3D, rect: tuple[float, float, float, float]) -> None:
    """Move and scale ``ax`` so its scene box fills ``rect = (left, bottom, width, height)``
    [in] of the figure, centred, keeping its shape.

    mplot3d draws into a square axes and leaves room for any camera angle, so a long, flat
    scene fills a thin band of it; scaling the axes instead (its square may reach beyond the
    figure, where nothing is drawn) gives the scene the whole panel. Tick and axis labels sit
    outside the box: ``rect`` must leave them a margin.
    """
    fig = ax.get_figure()
    px = box_on_screen(ax)
    lo, hi = px.min(axis=0), px.max(axis=0)
    pos = ax.get_position().transformed(fig.transFigure)  # display px, square after apply_aspect
    target = np.asarray(rect, dtype=float) * fig.dpi
    k = min(target[2] / (hi[0] - lo[0]), target[3] / (hi[1] - lo[1]))
    centre = (lo + hi) / 2
    x0 = target[0] + target[2] / 2 - k * (centre[0] - pos.x0)
    y0 = target[1] + target[3] / 2 - k * (centre[1] - pos.y0)
    w, h = fig.bbox.width, fig.bbox.height
    ax.set_position([x0 / w, y0 / h, k * pos.width / w, k * pos.height / h])


def box_on_screen(ax: Axes3D) -> np.ndarray:
    """(8, 2) display coordinates [px] of the corners of the axes' limits box."""
    ax.apply_aspect()
    lo = np.array([ax.get_xlim()[0], ax.get_ylim()[0], ax.get_zlim()[0]])
    hi = np.array([ax.get_xlim()[1], ax.get_ylim()[1], ax.get_zlim()[1]])
    corners = box_edges(lo, hi).reshape(-1, 3)
    x, y, _ = proj3d.proj_transform(*corners.T, ax.get_proj())
    return ax.transData.transform(np.column_stack([x, y]))
