"""Drawing pieces shared by every figure and animation: the scene, sub-swarm colours,
trajectory segments and the positions of structural events.

Everything here works on a given :class:`matplotlib.axes.Axes` or on arrays; nothing creates
figures, so plots and animations draw a scene the same way.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib import patches as mpatches
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.collections import PatchCollection
from matplotlib.lines import Line2D

from swarmnav.errors import SwarmnavError
from swarmnav.viz.draw3d import draw_scene_3d
from swarmnav.viz.style import EVENT_MARKERS, GOAL_FACE, OBSTACLE_EDGE, OBSTACLE_FACE, PATH_COLOR, SPAWN_COLOR
from swarmnav.world.obstacles import Circle
from swarmnav.world.scenario import Scenario, from_dict


def draw_scene(
    ax: Axes,
    scenario: Scenario,
    *,
    show_spawn: bool = True,
    show_goal: bool = True,
    show_path: bool = True,
) -> list[Artist]:
    """Draw a scene on ``ax``: obstacles, goal, spawn rectangle and path; set equal-aspect
    limits to ``scenario.bounds`` and the axis labels.

    Obstacles are one PatchCollection (light-blue fill, darker edge), so scenes with thousands
    of obstacles draw in one call.

    A 3-D scene is drawn by :func:`swarmnav.viz.draw3d.draw_scene_3d` on a 3-D ``ax``.

    Returns:
        Legend handles of what was drawn (obstacle, periodic cell, spawn, path, goal).
    """
    if scenario.dim == 3:
        return draw_scene_3d(ax, scenario, show_spawn=show_spawn, show_goal=show_goal, show_path=show_path)
    handles: list[Artist] = []
    shapes = [
        mpatches.Circle(o.center, o.radius) if isinstance(o, Circle) else mpatches.Polygon(o.vertices(), closed=True)
        for o in scenario.obstacles
    ]
    if shapes:
        ax.add_collection(PatchCollection(
            shapes, facecolor=OBSTACLE_FACE, edgecolor=OBSTACLE_EDGE, linewidth=0.8, zorder=1))
        handles.append(mpatches.Patch(facecolor=OBSTACLE_FACE, edgecolor=OBSTACLE_EDGE, label="obstacle"))
    x0, y0, x1, y1 = scenario.bounds
    if scenario.boundary == "wall":  # the closed world's walls: a solid frame on the bounds
        handles.append(ax.add_patch(mpatches.Rectangle(
            (x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor=OBSTACLE_EDGE, linewidth=2.5,
            zorder=1, label="world wall")))
    if scenario.periodic:
        handles.append(ax.add_patch(mpatches.Rectangle(
            (x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="0.4", linestyle=":", linewidth=1.0,
            zorder=1, label="periodic cell")))
    if show_spawn:
        sx0, sy0, sx1, sy1 = scenario.swarm.region  # the rectangle agents are drawn from
        handles.append(ax.add_patch(mpatches.Rectangle(
            (sx0, sy0), sx1 - sx0, sy1 - sy0, fill=False, edgecolor=SPAWN_COLOR, linestyle="--",
            linewidth=1.2, zorder=2, label="spawn region")))
    if show_path and scenario.path:
        p = np.asarray(scenario.path)
        handles += ax.plot(p[:, 0], p[:, 1], linestyle="-.", color=PATH_COLOR, linewidth=1.2, zorder=2,
                           label="path")
    if show_goal:
        handles += ax.plot([scenario.goal[0]], [scenario.goal[1]], linestyle="none", marker="*",
                           markersize=16, markerfacecolor=GOAL_FACE, markeredgecolor="black",
                           markeredgewidth=1.0, zorder=6, label="goal")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return handles


def scenario_of(result) -> Scenario:
    """The scene a run was made on, rebuilt from ``result.config["scenario"]``."""
    scene = result.config.get("scenario")
    if not isinstance(scene, dict):
        raise SwarmnavError("run config has no 'scenario' table; cannot draw the scene")
    return from_dict(scene, source="run config scenario")


def label_colors(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Qualitative colours for sub-swarm ids.

    Distinct ids seen in the run get distinct colours in order of id (tab10, or tab20 beyond
    ten ids, cycling beyond twenty), so one id keeps its colour for the whole run.

    Returns:
        ``(index, palette)``: int array shaped like ``labels`` and (M, 4) RGBA palette;
        the colour of entry ``j`` is ``palette[index[j]]``.
    """
    ids, inv = np.unique(np.asarray(labels), return_inverse=True)
    cmap = matplotlib.colormaps["tab10" if len(ids) <= 10 else "tab20"]
    palette = cmap(np.arange(len(ids)) % cmap.N)
    return inv.reshape(np.shape(labels)), palette


def trajectory_segments(positions: np.ndarray, period: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Consecutive-position segments of every agent.

    Args:
        positions: (T, N, 2) positions [m].
        period: side of a periodic cell [m]; a step longer than half of it is a wrap-around,
            not motion, and is masked out.

    Returns:
        ``(segments, valid)``: (T - 1, N, 2, 2) segment end points and (T - 1, N) bool mask.
    """
    segs = np.stack([positions[:-1], positions[1:]], axis=2)
    valid = np.ones(segs.shape[:2], dtype=bool)
    if period is not None:
        valid = np.all(np.abs(positions[1:] - positions[:-1]) < 0.5 * period, axis=2)
    return segs, valid


def period_of(scenario: Scenario) -> float | None:
    """Side of the periodic cell [m], or None for a bounded world."""
    return (scenario.bounds[2] - scenario.bounds[0]) if scenario.periodic else None


def event_points(positions: np.ndarray, labels: np.ndarray, events: list[dict]) -> list[tuple[int, str, np.ndarray]]:
    """Where each split / merge happened: ``(step, action, centroid [m])``.

    An event logged at step ``k`` changes the labels from ``labels[k]`` to ``labels[k + 1]``.
    The affected agents are those of every sub-swarm (before or after) that contains an agent
    whose label changed, i.e. the whole parent of a split or all parts of a merge; an event
    dict may name them explicitly with an ``agents`` list. If no label changed at that step
    the centroid of the whole swarm is used.
    """
    K = len(positions) - 1
    out = []
    for ev in events:
        action = ev.get("action")
        if action not in EVENT_MARKERS:
            continue
        k = int(np.clip(int(ev.get("step", 0)), 0, K))
        k1 = min(k + 1, K)
        if "agents" in ev:
            members = np.zeros(positions.shape[1], dtype=bool)
            members[np.asarray(ev["agents"], dtype=np.int64)] = True
        else:
            before, after = labels[k], labels[k1]
            changed = before != after
            members = (np.isin(before, before[changed]) | np.isin(after, after[changed])) if changed.any() \
                else np.ones(positions.shape[1], dtype=bool)
        if members.any():
            out.append((k, action, positions[k1][members].mean(axis=0)))
    return out


def event_handles() -> list[Artist]:
    """Legend proxies of the split / merge markers."""
    return [Line2D([], [], linestyle="none", marker=m, markersize=7, markerfacecolor=c, markeredgecolor="black",
                   markeredgewidth=0.6, label=a) for a, (m, c) in EVENT_MARKERS.items()]


def dot_size(n: int) -> float:
    """Scatter marker area [pt^2] for ``n`` agents: large for a few, small for thousands."""
    return float(np.clip(600.0 / max(n, 1), 2.0, 30.0))


def fig_size(
    bounds: tuple[float, float, float, float],
    map_width: float,
    extra_width: float = 0.0,
    extra_height: float = 0.0,
    max_map_height: float = 6.5,
) -> tuple[float, float]:
    """Figure size [in] for a map panel with the aspect of ``bounds``, plus room around it.

    The panel is ``map_width`` inches wide, narrowed so it is at most ``max_map_height``
    tall; ``extra_width`` / ``extra_height`` hold legends, titles and other panels.
    """
    x0, y0, x1, y1 = bounds
    aspect = (y1 - y0) / (x1 - x0)
    w = min(map_width, max_map_height / aspect)
    return w + extra_width, w * aspect + extra_height


def fmt_metric(metrics: dict, key: str, spec: str, unit: str = "") -> str:
    """``metrics[key]`` formatted with ``spec`` plus ``unit``, or ``n/a`` when missing or not
    a finite number."""
    v = metrics.get(key)
    try:
        v = float(v)
    except (TypeError, ValueError):
        return "n/a"
    return f"{format(v, spec)}{unit}" if math.isfinite(v) else "n/a"


def output_path(out: str | Path) -> Path:
    """``out`` as a Path whose folder exists (figures may be written into a new directory)."""
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    return p
