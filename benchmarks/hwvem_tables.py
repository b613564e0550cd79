"""Reproduce HWVEM Tables 1 and 2 (and the data of Figures 5 and 6) and print them beside the paper's.

Runs the shipped experiments ``hwvem-alignment`` (Table 1), ``hwvem-mission`` (Table 2) and
optionally ``hwvem-weights`` / ``hwvem-ablation`` (Figures 5 and 6) into resumable result stores
under ``--out`` (a rerun only runs what is missing), then prints markdown tables with the
published values from the packaged ``paper_results.toml`` and the wall time of each sweep.

    PYTHONPATH=src python benchmarks/hwvem_tables.py --out out/hwvem --workers 2
    PYTHONPATH=src python benchmarks/hwvem_tables.py --out out/hwvem --only table1 --seeds 1-20
    PYTHONPATH=src python benchmarks/hwvem_tables.py --out out/hwvem --print-only

Equivalent CLI runs: ``swarmnav experiment hwvem-alignment --set n=100|200|500 --out DIR``.

Where the mission loses its agents (Table 2 diagnostics: every agent that failed the success
test, tallied by the obstacle nearest to where its decisive separation from the information
UAV began; runs in-process, one core):

    PYTHONPATH=src python benchmarks/hwvem_tables.py --losses 50 --seeds 1-100
    PYTHONPATH=src python benchmarks/hwvem_tables.py --losses 50 --variant HWVEM-II --set trigger_heading=previous

HWVEM-II against HWVEM-I on the same seeds (the paired difference with its CI):

    PYTHONPATH=src python benchmarks/hwvem_tables.py --only table2 --sizes 50 --seeds 1-300 \
        --variant HWVEM-I --variant HWVEM-II --paired HWVEM-I,HWVEM-II --workers 1 --out out/hwvem-pair
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from swarmnav.experiments import load_experiment, run_experiment
from swarmnav.experiments.report import paper_results

TABLES = {
    "table1": ("hwvem-alignment", "100|200|500"),
    "table2": ("hwvem-mission", "5|20|50"),
    "fig5": ("hwvem-weights", "100|200|500"),
    "fig6": ("hwvem-ablation", "100|200|500"),
}


def run(name: str, sizes: str, out: Path, workers: int, seeds: str | None, extra: dict[str, str],
        variants: list[str] | None = None) -> float:
    exp = load_experiment(name, overrides={"n": sizes, **extra}, seeds=seeds)
    if variants:
        exp = replace(exp, variants=tuple(v for v in exp.variants if v.name.split("[")[0] in variants))
    t0 = time.perf_counter()
    run_experiment(exp, out, workers=workers, save_trajectories=False, progress=sys.stderr.isatty())
    return time.perf_counter() - t0


def summary(out: Path) -> dict[str, dict[str, str]]:
    with open(out / "summary.csv", newline="") as f:
        return {r["variant"]: r for r in csv.DictReader(f)}


def num(x: str | float, fmt: str = ".2f") -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return "–"
    return format(v, fmt) if math.isfinite(v) else str(v)


def ci95(xs) -> tuple[float, float]:
    """Mean and the half-width of its 95 % confidence interval (Student t, n - 1 degrees of
    freedom) over the finite values of ``xs``; (nan, nan) if there are none."""
    from scipy.stats import t

    x = np.asarray([v for v in xs if math.isfinite(v)], dtype=float)
    if len(x) == 0:
        return float("nan"), float("nan")
    if len(x) == 1:
        return float(x[0]), float("nan")
    return float(x.mean()), float(t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / math.sqrt(len(x)))


def run_values(out: Path, metric: str) -> dict[str, list[float]]:
    """Per variant: ``metric`` of every finished run (+inf kept)."""
    with open(out / "runs.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "done"]
    vals: dict[str, list[float]] = {}
    for r in rows:
        vals.setdefault(r["variant"], []).append(float(r[metric]))
    return vals


def pm(x: tuple[float, float], fmt: str = ".2f") -> str:
    """``mean ± half-width`` of :func:`ci95`."""
    return f"{num(x[0], fmt)} ± {num(x[1], fmt)}"


def finite_means(out: Path, metric: str) -> dict[str, tuple[float, int, int]]:
    """Per variant: mean of ``metric`` over the runs where it is finite, how many, of how many.

    k_con is +inf for a run that never converged within the step cap; its plain mean is then
    inf, so the tables show the mean over the converged runs and say how many there were.
    """
    with open(out / "runs.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "done"]
    vals: dict[str, list[float]] = {}
    for r in rows:
        vals.setdefault(r["variant"], []).append(float(r[metric]))
    return {v: (sum(x for x in xs if math.isfinite(x)) / max(1, sum(map(math.isfinite, xs))),
                sum(map(math.isfinite, xs)), len(xs)) for v, xs in vals.items()}


def variant_key(rows: dict, model: str, n: int) -> str | None:
    """The store's name of ``model`` at size ``n``: ``model[n=N]`` when the sweep had several
    sizes, plain ``model`` when it had one (``--sizes 100``)."""
    if f"{model}[n={n}]" in rows:
        return f"{model}[n={n}]"
    if model in rows and rows[model].get("n") == str(n):
        return model
    return None


def table1(out: Path, sizes=(100, 200, 500)) -> str:
    ref = paper_results()["hwvem"]["table1"]
    s = summary(out)
    fin = finite_means(out, "k_con")
    ks = run_values(out, "k_con")
    lines = ["| N | model | k_con mean* ± 95 % CI | p25 | p50 | p75 | converged to π/4 | paper mean | ours / paper | "
             "p25 | p50 | p75 | paper converges | runs (reached Deg_con^d) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        for model in ("VEM", "VEM-A", "IVEM", "IVEM-A", "WVEM", "HWVEM"):
            k = variant_key(s, model, n)
            p = ref[f"N{n}"][model]
            if k is None:
                continue
            r = s[k]
            mean, n_fin, n_all = fin[k]
            lines.append(f"| {n} | {model} | {pm(ci95(ks[k]))} | {num(r['k_con_p25'], '.1f')} | "
                         f"{num(r['k_con_p50'], '.1f')} | {num(r['k_con_p75'], '.1f')} | "
                         f"{num(r['converged_fraction'])} | {p['k_con'][0]:.2f} | {mean / p['k_con'][0]:.2f} | "
                         f"{p['k_con'][1]:.1f} | "
                         f"{p['k_con'][2]:.1f} | {p['k_con'][3]:.1f} | {'yes' if p['converges'] else 'no'} | "
                         f"{r['done']}/{r['runs']} ({n_fin}) |")
    return "\n".join(lines)


def table2(out: Path, sizes=(5, 20, 50)) -> str:
    ref = paper_results()["hwvem"]["table2"]
    s = summary(out)
    vals = {m: run_values(out, m) for m in ("P_s", "D_obs", "D_ind")}
    lines = ["| N | model | P_s mean ± 95 % CI | p25 | p50 | p75 | paper P_s | p25 | p50 | p75 | D_obs ± CI | paper D_obs | "
             "D_ind ± CI | paper D_ind | runs |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        for model in ("VEM-A", "IVEM-A", "WVEM", "HWVEM-I", "HWVEM-II"):
            k = variant_key(s, model, n)
            p = ref[f"N{n}"][model]
            if k is None:
                continue
            r = s[k]
            lines.append(f"| {n} | {model} | {pm(ci95(vals['P_s'][k]))} | {num(r['P_s_p25'], '.1f')} | "
                         f"{num(r['P_s_p50'], '.1f')} | {num(r['P_s_p75'], '.1f')} | {p['P_s'][0]:.2f} | "
                         f"{p['P_s'][1]:.1f} | {p['P_s'][2]:.1f} | {p['P_s'][3]:.1f} | "
                         f"{pm(ci95(vals['D_obs'][k]), '.4f')} | {p['D_obs']:.4f} | "
                         f"{pm(ci95(vals['D_ind'][k]), '.4f')} | {p['D_ind']:.4f} | {r['done']}/{r['runs']} |")
    return "\n".join(lines)


def figure_table(out: Path) -> str:
    s = summary(out)
    fin = finite_means(out, "k_con")
    lines = ["| variant | k_con mean* | p25 | p50 | p75 | converged | runs (reached Deg_con^d) |",
             "|---|---|---|---|---|---|---|"]
    for name, r in s.items():
        mean, n_fin, _ = fin[name]
        lines.append(f"| {name} | {num(mean)} | {num(r['k_con_p25'], '.1f')} | {num(r['k_con_p50'], '.1f')} | "
                     f"{num(r['k_con_p75'], '.1f')} | {num(r['converged_fraction'])} | {r['done']}/{r['runs']} ({n_fin}) |")
    return "\n".join(lines)


def obstacle_label(o) -> str:
    d = o.to_dict()
    kind = d.pop("type")
    if kind == "circle":
        return f"circle r={d['radius']:g} at ({d['center'][0]:g}, {d['center'][1]:g})"
    pts = np.asarray(o.vertices() if hasattr(o, "vertices") else d["points"], dtype=float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return f"{kind} x {lo[0]:g}..{hi[0]:g}, y {lo[1]:g}..{hi[1]:g}"


def losses(n: int, seeds: str | None, variants: list[str] | None, extra: dict[str, str]) -> str:
    """Run the hwvem-mission variants at size ``n`` and tally the failed agents (eq. 32) by where
    their decisive separation began: "start" (not with the information UAV at step 0), else the
    obstacle nearest to that point. Returns a markdown table (agents lost per run)."""
    from swarmnav.methods import registry
    from swarmnav.sensing import signed_distance
    from swarmnav.sim.rollout import run as rollout
    from swarmnav.world.catalog import load_scenario
    from swarmnav.world.obstacles import Geometry

    exp = load_experiment("hwvem-mission", overrides={"n": str(n), **extra}, seeds=seeds)
    chosen = [v for v in exp.variants if not variants or v.name.split("[")[0] in variants]
    scn = load_scenario(chosen[0].scenario, n=n)
    labels = [obstacle_label(o) for o in scn.obstacles]
    geoms = [Geometry.from_obstacles([o]) for o in scn.obstacles]
    places = ["start", *labels]
    rows = []
    for v in chosen:
        tally = dict.fromkeys(places, 0)
        never, p_s = 0, []
        for seed in exp.seeds:
            m = registry.make(v.method, **v.params)
            res = rollout(m, scn, seed=seed, steps=v.steps)
            p_s.append(res.metrics["P_s"])
            lost = m.losses()
            never += int(lost["apart_at_end"].sum())
            for step, x, y in zip(lost["step"], lost["x"], lost["y"]):
                if step == 0:
                    tally["start"] += 1
                    continue
                d = [float(signed_distance(g, np.array([[x, y]]))[0]) for g in geoms]
                tally[labels[int(np.argmin(d))]] += 1
        k = len(exp.seeds)
        rows.append((v.name, float(np.mean(p_s)), {p: c / k for p, c in tally.items()}, never / k))
    head = "| where the failing separation began | " + " | ".join(r[0] for r in rows) + " |"
    lines = [f"Agents lost per run (N = {n}, {len(exp.seeds)} seeds), by the obstacle nearest to where "
             "the separation that failed them began", "", head, "|---|" + "---|" * len(rows)]
    for p in places:
        lines.append(f"| {p} | " + " | ".join(f"{r[2][p]:.2f}" for r in rows) + " |")
    lines.append("| total lost (= N (1 - P_s)) | " + " | ".join(f"{sum(r[2].values()):.2f}" for r in rows) + " |")
    lines.append("| of which apart at the end | " + " | ".join(f"{r[3]:.2f}" for r in rows) + " |")
    lines.append("| P_s [%] | " + " | ".join(f"{r[1]:.2f}" for r in rows) + " |")
    return "\n".join(lines)


def paired(out: Path, first: str, second: str) -> str:
    """P_s of ``second`` minus ``first`` on the same seeds, per N: mean with its 95 % CI (Student t),
    the standard deviation of the differences, and how many paired runs would detect the paper's
    difference (two-sided 5 % test, 80 % power) or resolve ours from 0."""
    from scipy.stats import t

    ref = paper_results()["hwvem"]["table2"]
    by: dict[tuple[str, int], dict[int, float]] = {}
    with open(out / "runs.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["status"] == "done":
                by.setdefault((r["variant"].split("[")[0], int(r["n"])), {})[int(r["seed"])] = float(r["P_s"])
    lines = [f"| N | runs | {first} | {second} | {second} − {first} ± 95 % CI | SD of the differences | paper's "
             "difference | paired runs to detect it | to resolve ours from 0 |", "|---|---|---|---|---|---|---|---|---|"]
    for n in sorted({n for _, n in by}):
        a, b = by.get((first, n), {}), by.get((second, n), {})
        seeds = sorted(set(a) & set(b))
        if len(seeds) < 2:
            continue
        d = np.array([b[k] - a[k] for k in seeds])
        sd = d.std(ddof=1)
        half = t.ppf(0.975, len(d) - 1) * sd / math.sqrt(len(d))
        paper = ref[f"N{n}"][second]["P_s"][0] - ref[f"N{n}"][first]["P_s"][0]
        need = (lambda delta: f"{((1.96 + 0.84) * sd / abs(delta)) ** 2:.0f}" if delta and sd else "–")
        lines.append(f"| {n} | {len(d)} | {np.mean([a[k] for k in seeds]):.2f} | {np.mean([b[k] for k in seeds]):.2f} | "
                     f"{d.mean():+.2f} ± {half:.2f} | {sd:.2f} | {paper:+.2f} | {need(paper)} | {need(d.mean())} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/hwvem"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seeds", default=None, help="default: the specs' (1-100)")
    ap.add_argument("--sizes", default=None, help="swarm sizes, e.g. 100 or 20|50 (default: the table's)")
    ap.add_argument("--only", action="append", choices=sorted(TABLES), help="default: table1 and table2")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="extra override for every run")
    ap.add_argument("--print-only", action="store_true", help="do not run, print what the stores hold")
    ap.add_argument("--losses", type=int, metavar="N", help="tally the failed agents of hwvem-mission at size N")
    ap.add_argument("--variant", action="append", help="only these variants (default: all)")
    ap.add_argument("--paired", metavar="A,B", help="table2: P_s of B minus A on the same seeds, with its CI")
    args = ap.parse_args(argv)
    extra = dict(kv.split("=", 1) for kv in args.set)
    if args.losses:
        t0 = time.perf_counter()
        print(losses(args.losses, args.seeds, args.variant, extra))
        print(f"\n({(time.perf_counter() - t0) / 60:.1f} min on one core)")
        return 0
    for key in args.only or ["table1", "table2"]:
        name, sizes = TABLES[key]
        sizes = args.sizes or sizes
        out = args.out / key
        if not args.print_only:
            wall = run(name, sizes, out, args.workers, args.seeds, extra, args.variant)
            print(f"\n{key} ({name}, n = {sizes}): {wall / 60:.1f} min wall on {args.workers} worker(s)")
        if not (out / "summary.csv").exists():
            print(f"{key}: no results in {out}")
            continue
        print(f"\n### {key}: `{name}`\n")
        ns = tuple(int(v) for v in sizes.split("|"))
        print(table1(out, ns) if key == "table1" else table2(out, ns) if key == "table2" else figure_table(out))
        if key == "table2" and args.paired:
            print(f"\nPaired on the same seeds:\n\n{paired(out, *args.paired.split(',', 1))}")
        if key != "table2":
            ci = " and its 95 % confidence interval (Student t)" if key == "table1" else ""
            print(f"\n*mean{ci} over the runs that reached Deg_con^d within the step cap (their number in "
                  "brackets); quartiles over all runs, a run that never converged counting as +inf.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
