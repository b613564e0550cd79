"""A run in perspective at one step, as a PNG (``swarmnav plot --perspective``): the still
form of the replay viewer's perspective view.

A planar run is drawn as in HES Appendix A, Figure A1: the UAVs as arrows along their heading
at the fixed altitude z = 10 m, the goal as a yellow star, walls and obstacles as light-grey
slabs. A 3-D run is drawn in its own box with its obstacles as solids
(:mod:`swarmnav.viz.draw3d`), the agents as arrows along their velocity.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.lines import Line2D
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from swarmnav.errors import ConfigError
from swarmnav.viz import draw3d
from swarmnav.viz.draw import label_colors, output_path, period_of, scenario_of
from swarmnav.viz.style import GOAL_FACE
from swarmnav.viz.viewer import PLANAR_ALTITUDE, SLAB_HEIGHT
from swarmnav.world.obstacles import Box, Circle, Cylinder, Polygon

if TYPE_CHECKING:
    from swarmnav.sim.result import RunResult

#: Trail behind each arrow [s] (the viewer's default).
TRAIL_SECONDS = 3.0
#: Camera elevation [deg] of a planar run: higher than the 3-D default, to see between slabs
#: (the viewer's choice too).
PLANAR_ELEVATION = 50.0


def _slabs(obstacles) -> list:
    """A planar scene's obstacles as vertical prisms from the ground to SLAB_HEIGHT."""
    out = []
    for o in obstacles:
        if isinstance(o, Circle):
            out.append(Cylinder(tuple(o.center), o.radius, (0.0, SLAB_HEIGHT)))
        elif isinstance(o, (Box, Polygon)):
            out.append(Polygon(tuple(map(tuple, o.vertices())), (0.0, SLAB_HEIGHT)))
    return out


def headings(velocities: np.ndarray, k: int) -> np.ndarray:
    """(N, d) unit headings at step ``k``: each agent's velocity direction, or its last
    non-zero one before ``k`` (+x for an agent that has not moved yet)."""
    V = velocities[: k + 1]
    speed = np.linalg.norm(V, axis=2)
    moving = speed > 1e-9
    last = np.where(moving.any(axis=0), V.shape[0] - 1 - np.argmax(moving[::-1], axis=0), -1)
    h = np.zeros(V.shape[1:])
    h[:, 0] = 1.0
    ok = last >= 0
    idx = np.flatnonzero(ok)
    h[idx] = V[last[idx], idx] / speed[last[idx], idx][:, None]
    return h


def plot_perspective(result: RunResult, out_png: str | Path, *, step: int | None = None, dpi: int = 150) -> Path:
    """Write a perspective PNG of ``result`` at ``step`` (default: the middle of the run)."""
    out = output_path(out_png)
    scn = scenario_of(result)
    P, V = result.positions, result.velocities
    K, N, d = P.shape[0] - 1, P.shape[1], P.shape[2]
    k = K // 2 if step is None else int(step)
    if not 0 <= k <= K:
        raise ConfigError(f"--step must be between 0 and {K} (the run's steps), got {k}")
    dt = float(result.config.get("dt", 1.0))
    if d == 2:
        lo = np.r_[scn.lower, 0.0]
        hi = np.r_[scn.upper, max(SLAB_HEIGHT, PLANAR_ALTITUDE + 2.0)]
        box = SimpleNamespace(lower=lo, upper=hi)
        fig, ax = draw3d.panel_figure(box, width=10.0, top=0.9, camera=(PLANAR_ELEVATION, draw3d.CAMERA[1]))
        coll = draw3d.solids(_slabs(scn.obstacles))
        if coll is not None:
            ax.add_collection3d(coll, autolim=False)
        xyz = np.concatenate([P, np.full(P.shape[:2] + (1,), PLANAR_ALTITUDE)], axis=2)
        vel = np.concatenate([V, np.zeros(V.shape[:2] + (1,))], axis=2)
        goal = np.r_[np.asarray(scn.goal, dtype=float)[:2], PLANAR_ALTITUDE]
        handles = [Line2D([], [], color=draw3d.SOLID_FACE, linewidth=6, label=f"obstacle (slab, {SLAB_HEIGHT:g} m)")]
    else:
        fig, ax = draw3d.panel_figure(scn, width=10.0, top=0.9)
        handles = draw3d.draw_scene_3d(ax, scn, show_spawn=False, show_goal=False, show_path=False)
        xyz, vel, goal = P, V, np.asarray(scn.goal, dtype=float)
        lo, hi = scn.lower, scn.upper
    extent = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    arrow = max(1.0, 0.025 * extent) if N <= 300 else max(0.35, 0.008 * extent)  # [m] readable at print size
    idx, palette = label_colors(result.labels)
    # fading trails: the last TRAIL_SECONDS, split in four bands of rising opacity
    span = min(k, int(round(TRAIL_SECONDS / dt)))
    if span > 0:
        ks = np.arange(k - span, k + 1)
        seg = np.stack([xyz[ks[:-1]], xyz[ks[1:]]], axis=2)  # (T, N, 2, 3)
        valid = np.ones(seg.shape[:2], dtype=bool)
        period = period_of(scn)
        if period is not None:
            valid = np.all(np.abs(xyz[ks[1:], :, :2] - xyz[ks[:-1], :, :2]) < 0.5 * period, axis=2)
        colors = palette[idx[k]]  # (N, 4): the agent's sub-swarm now
        alpha = 0.1 + 0.65 * (np.arange(1, span + 1) / span)  # oldest faint, newest strong
        rgba = np.repeat(colors[None], span, axis=0)
        rgba[..., 3] = alpha[:, None]
        ax.add_collection(Line3DCollection(seg[valid], colors=rgba[valid], linewidths=0.8, zorder=3), autolim=False)
    h = headings(vel, k)
    for j in np.unique(idx[k]):
        sel = idx[k] == j
        ax.quiver(*xyz[k, sel].T, *h[sel].T, length=arrow, normalize=True, color=palette[j], linewidth=1.6,
                  arrow_length_ratio=0.45, zorder=5)
    ids = np.unique(result.labels)
    present = np.unique(idx[k])
    handles += [Line2D([], [], color=palette[j], marker=r"$\rightarrow$", markersize=10, linestyle="none",
                       label=f"UAV, sub-swarm {ids[j]}") for j in present[:8]]
    ax.scatter([goal[0]], [goal[1]], [goal[2]], marker="*", s=320, color=GOAL_FACE, edgecolors="black",
               linewidths=0.8, depthshade=False, zorder=8)
    handles.append(Line2D([], [], marker="*", markersize=14, color=GOAL_FACE, markeredgecolor="black",
                          linestyle="none", label="goal"))
    w, hgt = fig.get_size_inches()
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 1 - 0.5 / hgt), fontsize=8, frameon=False,
               ncols=min(len(handles), 5))
    cfg = result.config
    where = f"planar run at z = {PLANAR_ALTITUDE:g} m" if d == 2 else "3-D run"
    fig.suptitle(f"{cfg.get('method', '?')} on {scn.name}, seed {cfg.get('seed', '?')}: step {k} of {K} "
                 f"(t = {k * dt:g} s), {where}", fontsize=11, y=1 - 0.08 / hgt, va="top")
    fig.savefig(out, dpi=dpi)
    return out

