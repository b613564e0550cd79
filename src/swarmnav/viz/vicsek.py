"""Figures of the HWVEM paper from stored results: evolution snapshots (Figure 4), Deg_con
convergence curves, k_con against the layer weights (Figure 5), the neighbourhood-weight
ablation (Figure 6) and a mission run (Figures 7-8).

Everything reads run directories (``RunResult.load``) or an experiment's ``runs.csv`` /
``summary.csv``; nothing here simulates. Import this module directly (``swarmnav.viz.vicsek``).

    python -m swarmnav.viz.vicsek snapshots RUN_DIR --out fig4.png
    python -m swarmnav.viz.vicsek convergence RUN_DIR [RUN_DIR ...] --out deg_con.png
    python -m swarmnav.viz.vicsek weights out/hwvem/fig5 --out fig5.png
    python -m swarmnav.viz.vicsek ablation out/hwvem/fig6 --out fig6.png
    python -m swarmnav.viz.vicsek mission RUN_DIR --out fig7.png
"""

from __future__ import annotations

import argparse
import csv
import math
import re
from collections import defaultdict
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from swarmnav.methods.vicsek.measures import circular_mean, deg_con, headings_from_velocities
from swarmnav.sim.result import RunResult
from swarmnav.viz.draw import draw_scene, output_path, period_of, scenario_of, trajectory_segments

INFO_COLOR = "tab:red"
AGENT_COLOR = "tab:blue"


def deg_con_series(result: RunResult, norm: str = "l2") -> np.ndarray:
    """Deg_con(k) of a stored run [-], k = 1..K, from the recorded velocities (exact for the
    constant-speed alignment runs): against the information UAV's heading for the models that
    have one, against the consensus (circular mean) direction for VEM and IVEM; ``norm`` as the
    models' ``deg_con_norm`` (default L2)."""
    th = headings_from_velocities(result.velocities[1:])
    iu = result.metrics.get("info_uav")
    ref = th[:, int(iu)] if iu is not None else circular_mean(th)
    return np.atleast_1d(deg_con(th, ref, norm))


def plot_snapshots(result: RunResult, out_png: str | Path, steps: Sequence[int] | None = None, *,
                   dpi: int = 150) -> Path:
    """Figure 4: positions and headings at a few steps; the information UAV in red.

    Default steps: 1, then a quarter, half and all of k_con, and the last recorded step.
    """
    out = output_path(out_png)
    scn = scenario_of(result)
    P, V = result.positions, result.velocities
    K = P.shape[0] - 1
    if steps is None:
        kc = result.metrics.get("k_con", K)
        kc = int(kc) if np.isfinite(kc) else K
        steps = sorted({1, max(1, kc // 4), max(1, kc // 2), max(1, min(kc, K)), K})
    steps = [k for k in steps if 1 <= k <= K]
    iu = result.metrics.get("info_uav")
    fig = Figure(figsize=(3.0 * len(steps), 3.3), layout="constrained")
    axes = fig.subplots(1, len(steps), squeeze=False)[0]
    x0, y0, x1, y1 = scn.bounds
    span = max(x1 - x0, y1 - y0)
    for ax, k in zip(axes, steps):
        if not scn.periodic:
            draw_scene(ax, scn, show_spawn=False)
        u = V[k] / np.maximum(np.linalg.norm(V[k], axis=1, keepdims=True), 1e-300)
        colors = np.full(P.shape[1], AGENT_COLOR, dtype=object)
        if iu is not None:
            colors[int(iu)] = INFO_COLOR
        ax.quiver(P[k, :, 0], P[k, :, 1], u[:, 0], u[:, 1], color=list(colors), angles="xy", scale_units="xy",
                  scale=1.0 / (0.04 * span), width=0.006, headwidth=3.5)
        if iu is not None:
            ax.plot(*P[k, int(iu)], "o", color=INFO_COLOR, ms=4)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        d = deg_con_series(result)[k - 1]
        ax.set_title(f"k = {k}, Deg_con = {d:.4f}", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.suptitle(f"{result.config.get('method')} on {scn.name}, seed {result.config.get('seed')} "
                 f"(information UAV in red)", fontsize=10)
    fig.savefig(out, dpi=dpi)
    return out


def plot_convergence(groups: dict[str, Sequence[RunResult]], out_png: str | Path, *, threshold: float = 0.9984,
                     dpi: int = 150) -> Path:
    """Deg_con(k) over time: each run thin, the per-step median of each group thick, and
    the desired consistency Deg_con^d dashed. ``1 - Deg_con`` on a log axis shows the approach."""
    out = output_path(out_png)
    fig = Figure(figsize=(9.0, 3.6), layout="constrained")
    ax, ax_log = fig.subplots(1, 2)
    for c, (label, runs) in enumerate(groups.items()):
        series = [deg_con_series(r) for r in runs]
        color = f"C{c % 10}"
        for s in series:
            k = np.arange(1, len(s) + 1)
            ax.plot(k, s, color=color, lw=0.4, alpha=0.35)
            ax_log.plot(k, np.maximum(1 - s, 1e-12), color=color, lw=0.4, alpha=0.35)
        L = max(len(s) for s in series)
        pad = np.array([np.r_[s, np.full(L - len(s), s[-1])] for s in series])  # a stopped run stays converged
        med = np.median(pad, axis=0)
        k = np.arange(1, L + 1)
        ax.plot(k, med, color=color, lw=2.0, label=f"{label} (median of {len(series)})")
        ax_log.plot(k, np.maximum(1 - med, 1e-12), color=color, lw=2.0)
    for a in (ax, ax_log):
        a.set_xlabel("time step k")
        a.grid(alpha=0.3)
    ax.axhline(threshold, color="0.4", ls="--", lw=1.0, label=f"Deg_con^d = {threshold}")
    ax_log.axhline(1 - threshold, color="0.4", ls="--", lw=1.0)
    ax.set_ylabel("Deg_con")
    ax_log.set_ylabel("1 - Deg_con")
    ax_log.set_yscale("log")
    ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("Convergence to the reference state (eq. 28)", fontsize=10)
    fig.savefig(out, dpi=dpi)
    return out


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _split_variant(name: str) -> tuple[str, int | None]:
    """``"p1=0.1[n=200]"`` -> ``("p1=0.1", 200)``."""
    m = re.match(r"^(.*?)(?:\[(?:.*,)?n=(\d+)(?:,.*)?\])?$", name)
    return m.group(1), (int(m.group(2)) if m.group(2) else None)


def plot_weights(result_dir: str | Path, out_png: str | Path, *, dpi: int = 150) -> Path:
    """Figure 5 from the ``hwvem-weights`` summary: mean k_con against (a) p1 with p2 = 5 and
    (b) p2 with p1 = 0.01, one line per swarm size (log-x; p1 = 0 is drawn at the left edge)."""
    out = output_path(out_png)
    rows = _read_csv(Path(result_dir) / "summary.csv")
    curves: dict[tuple[str, int | None], list[tuple[float, float]]] = defaultdict(list)
    for r in rows:
        base, n = _split_variant(r["variant"])
        key, _, val = base.partition("=")
        curves[(key, n)].append((float(val), float(r["k_con_mean"])))
    fig = Figure(figsize=(9.0, 3.6), layout="constrained")
    axes = dict(zip(("p1", "p2"), fig.subplots(1, 2)))
    for (key, n), pts in sorted(curves.items(), key=lambda kv: (kv[0][0], kv[0][1] or 0)):
        pts = sorted(pts)
        x = np.array([p[0] for p in pts])
        if key == "p1":
            x = np.where(x > 0, x, min(x[x > 0], default=1e-3) / 10)
        axes[key].plot(x, [p[1] for p in pts], "o-", label=f"N = {n}" if n else "default N")
    axes["p1"].set_title("(a) k_con against p1 (p2 = 5)", fontsize=9)
    axes["p2"].set_title("(b) k_con against p2 (p1 = 0.01)", fontsize=9)
    for k, a in axes.items():
        a.set_xscale("log")
        a.set_xlabel(k)
        a.set_ylabel("mean k_con [steps]")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.savefig(out, dpi=dpi)
    return out


def plot_ablation(result_dir: str | Path, out_png: str | Path, *, dpi: int = 150) -> Path:
    """Figure 6 from the ``hwvem-ablation`` runs: box plots of k_con with (red) and without
    (blue) the neighbourhood-layer-status weight, per swarm size."""
    out = output_path(out_png)
    rows = [r for r in _read_csv(Path(result_dir) / "runs.csv") if r["status"] == "done"]
    data: dict[tuple[int | None, str], list[float]] = defaultdict(list)
    for r in rows:
        base, n = _split_variant(r["variant"])
        data[(n, base)].append(float(r["k_con"]))
    sizes = sorted({n for n, _ in data}, key=lambda n: n or 0)
    fig = Figure(figsize=(2.4 * len(sizes) + 1.5, 3.6), layout="constrained")
    ax = fig.add_subplot()
    for j, (label, color) in enumerate((("with", "tab:red"), ("without", "tab:blue"))):
        pos = [3 * i + j for i in range(len(sizes))]
        vals = [data.get((n, label), [np.nan]) for n in sizes]
        bp = ax.boxplot(vals, positions=pos, widths=0.8, patch_artist=True, showmeans=True,
                        flierprops=dict(marker="D", markerfacecolor="k", markersize=3))
        for b in bp["boxes"]:
            b.set_facecolor(color)
            b.set_alpha(0.6)
        ax.plot([], [], "s", color=color, alpha=0.6, label=f"{label} neighbourhood-layer weight")
    ax.set_xticks([3 * i + 0.5 for i in range(len(sizes))], [f"N = {n}" for n in sizes])
    ax.set_ylabel("k_con [steps]")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("HWVEM-I with and without the neighbourhood-layer-status weight (eq. 16-17)", fontsize=9)
    fig.savefig(out, dpi=dpi)
    return out


def plot_mission(result: RunResult, out_png: str | Path, snapshots: Sequence[int] | None = None, *,
                 dpi: int = 150) -> Path:
    """Figures 7-8: the mission scene with every trajectory (information UAV in red) and the
    swarm at a few snapshot steps (black dots, the information UAV as a red star)."""
    out = output_path(out_png)
    scn = scenario_of(result)
    P = result.positions
    K, N = P.shape[0] - 1, P.shape[1]
    iu = result.metrics.get("info_uav")
    x0, y0, x1, y1 = scn.bounds
    fig = Figure(figsize=(12.0, 12.0 * (y1 - y0) / (x1 - x0) + 1.0), layout="constrained")
    ax = fig.add_subplot()
    draw_scene(ax, scn, show_spawn=False)
    segs, valid = trajectory_segments(P, period_of(scn))
    lc = LineCollection(segs[valid], colors=AGENT_COLOR, linewidths=0.5, alpha=0.6, zorder=3)
    ax.add_collection(lc, autolim=False)
    if iu is not None:
        ax.plot(P[:, int(iu), 0], P[:, int(iu), 1], color=INFO_COLOR, lw=1.2, zorder=6, label="information UAV")
    snaps = snapshots if snapshots is not None else [k for k in (0, 80, 320, 485, 560, 630) if k <= K]
    for k in snaps:
        ax.scatter(P[k, :, 0], P[k, :, 1], s=6, c="k", zorder=4)
        if iu is not None:
            ax.plot(*P[k, int(iu)], "*", color=INFO_COLOR, ms=9, zorder=5)
            ax.annotate(f"k={k}", P[k, int(iu)], xytext=(0, 8), textcoords="offset points", fontsize=7, ha="center")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    m = result.metrics
    fmt = {k: (f"{m[k]:.3g}" if isinstance(m.get(k), float) and math.isfinite(m[k]) else "–")
           for k in ("P_s", "D_obs", "D_ind")}
    prm = result.config.get("params", {})
    name = str(result.config.get("method"))
    if name == "hwvem":
        name += f" (p1 = {prm.get('p1')}, p2 = {prm.get('p2')})"
    ax.set_title(f"{name} on {scn.name}, "
                 f"N = {N}, seed {result.config.get('seed')}: P_s = {fmt['P_s']} %, D_obs = {fmt['D_obs']} m, "
                 f"D_ind = {fmt['D_ind']} m", fontsize=9)
    fig.savefig(out, dpi=dpi)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m swarmnav.viz.vicsek", description=__doc__.splitlines()[0])
    ap.add_argument("figure", choices=["snapshots", "convergence", "weights", "ablation", "mission"])
    ap.add_argument("inputs", nargs="+", help="run directories, or an experiment results directory")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    if args.figure == "snapshots":
        path = plot_snapshots(RunResult.load(args.inputs[0]), args.out)
    elif args.figure == "mission":
        path = plot_mission(RunResult.load(args.inputs[0]), args.out)
    elif args.figure == "convergence":
        groups: dict[str, list[RunResult]] = defaultdict(list)
        for d in args.inputs:
            r = RunResult.load(d)
            groups[str(r.config.get("method"))].append(r)
        path = plot_convergence(groups, args.out)
    elif args.figure == "weights":
        path = plot_weights(args.inputs[0], args.out)
    else:
        path = plot_ablation(args.inputs[0], args.out)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
