"""Static figures: a scene, and a run in the layout of HES Figure 3.

Figures are built as bare :class:`matplotlib.figure.Figure` objects (no pyplot), so they
never touch a GUI backend or pyplot's global figure list and are freed when the function
returns.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from swarmnav.metrics import MetricParams
from swarmnav.viz import draw3d
from swarmnav.viz.draw import (
    dot_size, draw_scene, event_handles, event_points, fig_size, fmt_metric, label_colors, output_path, period_of,
    scenario_of, trajectory_segments,
)
from swarmnav.viz.style import END_COLOR, EVENT_MARKERS, START_COLOR
from swarmnav.world.scenario import Scenario

if TYPE_CHECKING:
    from swarmnav.sim.result import RunResult

#: Most trajectory segments drawn in one figure (our choice: keeps a 2000-agent, 1000-step
#: run under a few seconds); longer runs are subsampled in time.
MAX_SEGMENTS = 200_000


def plot_scene(scenario: Scenario, out_png: str | Path, *, dpi: int = 150) -> Path:
    """Write a PNG of one scene: title = scene name, subtitle = its description."""
    out = output_path(out_png)
    if scenario.dim == 3:
        return _plot_scene_3d(scenario, out, dpi)
    fig = Figure(figsize=fig_size(scenario.bounds, 8.0, extra_width=1.8, extra_height=1.0), layout="constrained")
    ax = fig.add_subplot()
    handles = draw_scene(ax, scenario)
    fig.suptitle(scenario.name, fontsize=13, fontweight="bold")
    ax.set_title(f"{scenario.description}  (N = {scenario.n})".strip(), fontsize=9, color="0.3")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    fig.savefig(out, dpi=dpi)
    return out


def _plot_scene_3d(scenario: Scenario, out: Path, dpi: int) -> Path:
    """The 3-D form of :func:`plot_scene`: the scene box seen from the default camera, titles
    and a one-row legend above it."""
    sub = textwrap.wrap(f"{scenario.description}  (N = {scenario.n})".strip(), 120)
    fig, ax = draw3d.panel_figure(scenario, top=0.75 + 0.2 * len(sub))
    handles = draw_scene(ax, scenario)
    h = fig.get_figheight()
    fig.suptitle(scenario.name, fontsize=13, fontweight="bold", y=1 - 0.08 / h, va="top")
    fig.text(0.5, 1 - 0.42 / h, "\n".join(sub), fontsize=9, color="0.3", ha="center", va="top")
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 1 - (0.45 + 0.2 * len(sub)) / h),
               ncols=len(handles), fontsize=8, frameon=False)
    fig.savefig(out, dpi=dpi)
    return out


def plot_run(result: RunResult, out_png: str | Path, *, dpi: int = 150) -> Path:
    """Write a PNG of a run in the layout of HES Figure 3.

    (a) top-down trajectories (3-D scenes: seen from the default camera of
    :mod:`swarmnav.viz.draw3d`, shadows on the floor): one thin curve per agent, each segment coloured by the agent's
    sub-swarm label at that step, start (green) and end (red) positions, goal (star),
    split / merge events at the centroid of the agents they affected;
    (b) minimum clearance over agents [m] (red) with the d_safe threshold (grey dashed) and
    the sub-swarm count (blue, right axis) against time t = k dt [s].
    The title names method, scene and seed and quotes Y, R_goal, E_mean and R_unsafe.
    """
    out = output_path(out_png)
    scn = scenario_of(result)
    if scn.dim == 3:
        return _plot_run_3d(result, scn, out, dpi)
    map_w, map_h = fig_size(scn.bounds, 8.0, max_map_height=5.0)
    fig = Figure(figsize=(max(map_w, 6.0) + 2.2, map_h + 3.6), layout="constrained")
    ax, ax_t = fig.subplots(2, 1, height_ratios=[map_h, 2.2])
    handles = draw_scene(ax, scn, show_spawn=False) + _trajectories(ax, result, scn)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_title("(a) trajectories", fontsize=10, loc="left")
    _clearance_and_structure(ax_t, result)
    fig.suptitle(_run_title(result, scn), fontsize=11)
    fig.savefig(out, dpi=dpi)
    return out


def _plot_run_3d(result: RunResult, scn: Scenario, out: Path, dpi: int) -> Path:
    """The 3-D form of :func:`plot_run`: (a) the run in the scene box seen from the default
    camera, with each trajectory's shadow on the floor (its altitude is otherwise hard to
    read), its legend above it; (b) the same time series as in 2-D."""
    n_handles = 8 + min(len(np.unique(result.labels)), 8)  # upper bound: the legend's rows
    rows = math.ceil(n_handles / LEGEND_COLUMNS_3D)
    ts_h, ts_margin = 2.0, 0.65  # time-series panel and its x labels [in]
    fig, ax = draw3d.panel_figure(scn, width=10.0, top=0.95 + 0.2 * rows, below=ts_h + ts_margin + 0.3)
    handles = draw_scene(ax, scn, show_spawn=False) + _trajectories(ax, result, scn)
    w, h = fig.get_size_inches()
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 1 - 0.75 / h), fontsize=8,
               frameon=False, ncols=min(len(handles), LEGEND_COLUMNS_3D))
    fig.text(0.01, 1 - (0.8 + 0.2 * rows) / h, "(a) trajectories", fontsize=10, ha="left", va="top")
    ax_t = fig.add_axes([0.7 / w, ts_margin / h, (w - 0.7 - 2.9) / w, ts_h / h])
    _clearance_and_structure(ax_t, result)
    fig.suptitle(_run_title(result, scn), fontsize=11, y=1 - 0.08 / h, va="top")
    fig.savefig(out, dpi=dpi)
    return out


#: Columns of the legend above a 3-D run panel.
LEGEND_COLUMNS_3D = 6
#: Trajectory shadows on the floor of a 3-D run (light grey, translucent).
SHADOW_COLOR = (0.55, 0.55, 0.55, 0.25)


def _trajectories(ax, result: RunResult, scn: Scenario) -> list:
    """Draw a run's trajectories on ``ax`` (2-D or 3-D): one thin curve per agent, each
    segment coloured by the agent's sub-swarm label at that step, start (green) and end (red)
    positions, split / merge events at the centroid of the agents they affected.

    Returns:
        Legend handles of what was drawn.
    """
    P, labels = result.positions, result.labels
    K, N = P.shape[0] - 1, P.shape[1]
    d = P.shape[2]
    # 3-D: colours as given, not dimmed with depth (sub-swarm colours must stay comparable)
    flat = {"depthshade": False} if d == 3 else {}
    # Subsample in time so at most MAX_SEGMENTS segments are drawn (the last state is kept).
    stride = max(1, math.ceil(K * N / MAX_SEGMENTS))
    ks = np.unique(np.r_[np.arange(0, K + 1, stride), K])
    segs, valid = trajectory_segments(P[ks], period_of(scn))
    idx, palette = label_colors(labels)
    colors = palette[idx[ks[:-1]]]
    lc = (Line3DCollection if d == 3 else LineCollection)(
        segs[valid], colors=colors[valid], linewidths=0.8 if N <= 100 else 0.4, alpha=1.0 if N <= 100 else 0.4,
        zorder=3)
    ax.add_collection(lc, autolim=False)
    if d == 3:  # shadows on the floor, under the solids: where each curve is above the ground
        floor = segs[valid].copy()
        floor[..., 2] = scn.lower[2]
        ax.add_collection(Line3DCollection(floor, colors=SHADOW_COLOR, linewidths=0.6, zorder=0.5), autolim=False)
    s = dot_size(N)
    ax.scatter(*P[0].T, s=s, color=START_COLOR, edgecolors="none", zorder=4, **flat)
    ax.scatter(*P[-1].T, s=s, color=END_COLOR, edgecolors="none", zorder=5, **flat)
    handles = [
        Line2D([], [], linestyle="none", marker="o", color=START_COLOR, markersize=5, label="start"),
        Line2D([], [], linestyle="none", marker="o", color=END_COLOR, markersize=5, label="end"),
    ]
    points = event_points(P, labels, result.events)
    for action, (marker, color) in EVENT_MARKERS.items():
        xy = np.array([p for _, a, p in points if a == action]).reshape(-1, d)
        if len(xy):
            ax.scatter(*xy.T, s=45, marker=marker, color=color, edgecolors="black", linewidths=0.6, zorder=7,
                       **flat)
    handles += [h for h in event_handles() if any(a == h.get_label() for _, a, _ in points)]
    crashes = [(e["step"], e["agent"]) for e in result.events if e.get("action") == "crash"]
    if crashes:  # where each crashed agent hit (it stayed there)
        xy = np.array([P[min(k, K), i] for k, i in crashes]).reshape(-1, d)
        ax.scatter(*xy.T, s=60, marker="X", color="black", edgecolors="white", linewidths=0.6, zorder=8, **flat)
        handles.append(Line2D([], [], linestyle="none", marker="X", color="black", markersize=7,
                              label=f"crash ({len(crashes)})"))
    n_ids = len(palette)
    if 1 < n_ids <= 8:  # few sub-swarms: name their colours; many: the colours speak for themselves
        ids = np.unique(labels)
        handles += [Line2D([], [], color=palette[j], linewidth=1.5, label=f"sub-swarm {ids[j]}")
                    for j in range(n_ids)]
    else:
        handles.append(Line2D([], [], color=palette[0], linewidth=1.0, label="trajectory"))
    return handles


def _clearance_and_structure(ax_t, result: RunResult) -> None:
    """Panel (b): minimum clearance over agents [m] (red) with the d_safe threshold (grey
    dashed) and the sub-swarm count (blue, right axis) against time t = k dt [s]."""
    K = result.positions.shape[0] - 1
    dt = float(result.config.get("dt", 1.0))
    t = np.arange(K + 1) * dt
    d_safe = float(result.config.get("rules", {}).get("d_safe", MetricParams().d_safe))
    d_min = np.where(np.isfinite(result.min_clearance), result.min_clearance, np.nan)
    ax_t.plot(t, d_min, color="tab:red", linewidth=1.2, label="min clearance [m]")
    ax_t.axhline(d_safe, color="0.5", linestyle="--", linewidth=1.0, label=f"d_safe = {d_safe:g} m")
    ax_t.set_xlabel("t [s]")
    ax_t.set_ylabel("min clearance [m]", color="tab:red")
    ax_t.set_xlim(t[0], t[-1] if K > 0 else dt)
    if np.isfinite(d_min).any():  # from 0 (or below, after a collision) so d_safe is in context
        ax_t.set_ylim(min(0.0, float(np.nanmin(d_min))), max(2 * d_safe, float(np.nanmax(d_min))) * 1.05)
    else:
        ax_t.text(0.5, 0.8, "no obstacles", transform=ax_t.transAxes, ha="center", va="center", color="0.5")
        ax_t.set_ylim(0, 2 * d_safe)
    ax_n = ax_t.twinx()
    n_sub = result.n_subswarms
    ax_n.plot(t, n_sub, color="tab:blue", linewidth=1.2, drawstyle="steps-post", label="sub-swarm count")
    ax_n.set_ylabel("sub-swarms", color="tab:blue")
    ax_n.set_ylim(0, int(n_sub.max()) + 1)
    ax_n.yaxis.set_major_locator(MaxNLocator(integer=True))
    lines = ax_t.get_legend_handles_labels()[0] + ax_n.get_legend_handles_labels()[0]
    ax_t.legend(handles=lines, loc="upper left", bbox_to_anchor=(1.06, 1.0), fontsize=8, frameon=False)
    ax_t.set_title("(b) clearance and structure", fontsize=10, loc="left")


def _run_title(result: RunResult, scn: Scenario) -> str:
    """Method, scene, seed, N and K; Y, R_goal, E_mean and R_unsafe; collisions and crashes."""
    K, N = result.positions.shape[0] - 1, result.positions.shape[1]
    m, cfg = result.metrics, result.config
    goal = (f"Y = {fmt_metric(m, 'Y', '.0f')}   R_goal = {fmt_metric(m, 'R_goal', '.2f')}   "
            f"E_mean = {fmt_metric(m, 'E_mean', '.2f', ' m')}   " if "Y" in m else "")
    return (
        f"{cfg.get('method', '?')} on {scn.name}, seed {cfg.get('seed', '?')}, N = {N}, K = {K}\n"
        f"{goal}R_unsafe = {fmt_metric(m, 'R_unsafe', '.3f')}   "
        f"collisions = {fmt_metric(m, 'collisions', '.0f')}   crashes = {fmt_metric(m, 'crashes', '.0f')}"
    )
