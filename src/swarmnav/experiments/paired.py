"""Paired-seed comparison of two variants (HES paper Figure 5): per metric and per seed, the
percent change of variant B relative to variant A,

    Δ%_s = 100 (B_s − A_s) / |A_s|,

over the seeds both variants have finished. Pairing by seed removes the spread that the seed
(initial positions, a generated scene) puts into both variants alike.

Where A_s = 0 the percent is undefined: such a seed is left out of the percentages and its
absolute difference B_s − A_s is reported instead; equal values are a 0 % change, also when
both are 0 (an R_unsafe of 0 in both variants is no change). A seed where either value is
missing or not finite (``k_con = inf`` of a run that never converges) is skipped and counted.
Functions of stored rows; ``report.paired_changes`` reads them from a results directory.
"""

from __future__ import annotations

import csv
import difflib
import io
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmnav.errors import ConfigError

#: Columns of the per-seed table (``Paired.rows``, ``report_files/paired.csv``).
ROW_KEYS = ("metric", "seed", "a", "b", "change_pct", "b_minus_a")


@dataclass(frozen=True, slots=True)
class Paired:
    """Variant ``b`` against variant ``a`` of one experiment, seed by seed.

    ``rows`` is the per-seed table, one dict per (metric, paired seed) with keys
    :data:`ROW_KEYS`: the two values, ``change_pct`` (None where A = 0 and B ≠ 0, or where a value
    is missing or not finite) and ``b_minus_a`` (None where a value is missing or not finite).
    """

    experiment: str
    a: str
    b: str
    metrics: tuple[str, ...]
    seeds: tuple[int, ...]   # seeds both variants finished (status done), ascending
    only_a: tuple[int, ...]  # seeds finished by a but not by b: not compared
    only_b: tuple[int, ...]
    rows: tuple[dict[str, Any], ...]

    def changes(self, metric: str) -> np.ndarray:
        """The defined percent changes of ``metric`` [%], in seed order."""
        return np.array([r["change_pct"] for r in self.rows if r["metric"] == metric
                         and r["change_pct"] is not None], dtype=float)

    def summary(self) -> list[dict[str, Any]]:
        """One dict per metric: ``n`` percentages, their ``median``/``mean``/``min``/``max`` [%]
        (nan when n = 0), ``zero_a`` (seeds with A = 0, B ≠ 0) with ``zero_a_diff_median`` (the
        median of B − A there, in the metric's unit) and ``skipped`` (missing or not finite)."""
        out = []
        for m in self.metrics:
            mine = [r for r in self.rows if r["metric"] == m]
            pct = self.changes(m)
            zero = [r["b_minus_a"] for r in mine if r["change_pct"] is None and r["b_minus_a"] is not None]
            stat = (lambda f: float(f(pct))) if len(pct) else (lambda f: math.nan)
            out.append({"metric": m, "n": len(pct), "median": stat(np.median), "mean": stat(np.mean),
                        "min": stat(np.min), "max": stat(np.max), "zero_a": len(zero),
                        "zero_a_diff_median": float(np.median(zero)) if zero else math.nan,
                        "skipped": sum(r["b_minus_a"] is None for r in mine)})
        return out

    def to_csv(self) -> str:
        """The per-seed table as CSV text (empty cells where undefined)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(ROW_KEYS)
        for r in self.rows:
            w.writerow(["" if r[k] is None else repr(r[k]) if isinstance(r[k], float) else r[k] for k in ROW_KEYS])
        return buf.getvalue()


def change(a: float, b: float) -> tuple[float | None, float | None]:
    """``(Δ% , B − A)`` of one seed by the rules of the module docstring."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return None, None
    if a == 0.0:
        return (0.0 if b == 0.0 else None), b - a
    return 100.0 * (b - a) / abs(a), b - a


def check_variants(pair: tuple[str, str] | list[str], known: list[str], where: str = "--compare") -> tuple[str, str]:
    """``pair`` as a tuple if it names two different known variants; a one-line ConfigError
    with the closest names otherwise."""
    if len(pair) != 2:
        raise ConfigError(f"{where}: expected two variant names, got {list(pair)}")
    for name in pair:
        if name not in known:
            raise ConfigError(f"{where}: unknown variant '{name}'{unknown_hint(name, known)}")
    if pair[0] == pair[1]:
        raise ConfigError(f"{where}: compare two different variants, got '{pair[0]}' twice")
    return pair[0], pair[1]


def unknown_hint(name: str, known: list[str]) -> str:
    """What a one-line error about an unknown variant ``name`` adds: the closest known names, then
    the known ones (the first 12)."""
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
    hint = f" (did you mean {', '.join(close)}?)" if close else ""
    shown = ", ".join(known[:12]) + (f", … ({len(known)} in all)" if len(known) > 12 else "")
    return f"{hint}; variants: {shown}"


def pair_rows(rows: list[dict], experiment: str, a: str, b: str, metrics: list[str]) -> Paired:
    """The comparison from an experiment's stored rows (``runner.job_rows``)."""
    done = {v: {r["seed"]: r["metrics"] for r in rows if r["variant"] == v and r["status"] == "done"} for v in (a, b)}
    seeds = sorted(set(done[a]) & set(done[b]))
    out = []
    for m in metrics:
        for s in seeds:
            va, vb = (_number(done[v][s].get(m)) for v in (a, b))
            pct, diff = change(va, vb)
            out.append({"metric": m, "seed": s, "a": va, "b": vb, "change_pct": pct, "b_minus_a": diff})
    return Paired(experiment=experiment, a=a, b=b, metrics=tuple(metrics), seeds=tuple(seeds),
                  only_a=tuple(sorted(set(done[a]) - set(done[b]))),
                  only_b=tuple(sorted(set(done[b]) - set(done[a]))), rows=tuple(out))


def _number(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def seed_ranges(seeds: tuple[int, ...] | list[int]) -> str:
    """``[1, 2, 3, 7]`` -> ``"1-3, 7"``."""
    out, s = [], sorted(seeds)
    i = 0
    while i < len(s):
        j = i
        while j + 1 < len(s) and s[j + 1] == s[j] + 1:
            j += 1
        out.append(str(s[i]) if i == j else f"{s[i]}-{s[j]}")
        i = j + 1
    return ", ".join(out)


def pct(x: float) -> str:
    """A signed percent cell: ``+1234``, ``+12.3``, ``-0.0412``, ``0``; ``–`` for nan."""
    if not math.isfinite(x):
        return "–"
    return "0" if x == 0 else f"{x:+.0f}" if abs(x) >= 100 else f"{x:+.3g}"


def table(p: Paired, units: dict[str, str]) -> dict[str, Any]:
    """The report table (``{"title", "columns", "rows"}``, as ``report.tables``): per metric the
    seeds with a percentage, the median, mean and range of Δ%, and what was not a percentage."""
    cols = [("metric", "name"), ("seeds with Δ %", "num"), ("median Δ %", "num"), ("mean Δ %", "num"),
            ("min Δ %", "num"), ("max Δ %", "num"), ("not a percentage", "name")]
    rows = []
    for s in p.summary():
        u = units.get(s["metric"])
        notes = []
        if s["zero_a"]:
            notes.append(f"{s['zero_a']} with A = 0: median B − A = {s['zero_a_diff_median']:+.3g}"
                         + (f" {u}" if u else ""))
        if s["skipped"]:
            notes.append(f"{s['skipped']} skipped (missing or not finite)")
        rows.append([s["metric"] + (f" [{u}]" if u else ""), f"{s['n']}/{len(p.seeds)}", pct(s["median"]),
                     pct(s["mean"]), pct(s["min"]), pct(s["max"]), "; ".join(notes) or "–"])
    return {"title": f"Paired by seed: {p.b} vs {p.a}", "note": note(p),
            "columns": [{"label": c, "metric": None, "kind": k} for c, k in cols], "rows": rows}


def note(p: Paired) -> str:
    """What the paired table and figure compare, in one paragraph (markdown)."""
    text = (f"Percent change of B = `{p.b}` relative to A = `{p.a}`, 100 (B − A) / |A| per seed, over the "
            f"{len(p.seeds)} seeds both finished ({seed_ranges(p.seeds) or 'none'}).")
    for name, only in ((p.a, p.only_a), (p.b, p.only_b)):
        if only:
            text += f" Seeds only `{name}` finished, not compared: {seed_ranges(only)}."
    return text + (" Where A = 0 the percent is undefined: that seed is left out of the percentages and "
                   "its B − A is given instead (equal values count as 0 %). Per-seed values: "
                   "`report_files/paired.csv`.")


def figure(p: Paired, title: str):
    """HES Figure 5 for any two variants: one panel per metric (SVG group ``paired-<metric>``),
    a box of the per-seed Δ% with the seeds as dots (``seeds-<metric>``) and the median as a red
    line (``median-<metric>``) labelled with its value; 0 % dashed. A box and dots rather than
    the paper's one bar per metric, so the spread over seeds shows; panels have their own scale
    because the changes of different metrics differ by orders of magnitude."""
    from matplotlib.figure import Figure

    metrics = list(p.metrics)
    ncol = min(4, max(1, len(metrics)))
    nrow = int(np.ceil(len(metrics) / ncol))
    fig = Figure(figsize=(3.2 * ncol, 3.0 * nrow), layout="constrained")
    rng = np.random.default_rng(0)  # fixed jitter: the figure is reproducible
    for k, (m, s) in enumerate(zip(metrics, p.summary())):
        ax = fig.add_subplot(nrow, ncol, k + 1)
        ax.set_gid(f"paired-{m}")
        ax.axhline(0.0, color="0.5", lw=0.8, ls="--")
        d = p.changes(m)
        if len(d):
            box = ax.boxplot([d], widths=0.5, showfliers=False, medianprops={"color": "C3", "lw": 2})
            box["medians"][0].set_gid(f"median-{m}")
            shown = d if len(d) <= 200 else rng.choice(d, 200, replace=False)
            ax.plot(1 + rng.uniform(-0.12, 0.12, len(shown)), shown, ".", ms=4, alpha=0.7, color="k",
                    gid=f"seeds-{m}")
            ax.annotate(f"median {pct(s['median'])} %", (1.3, s["median"]), fontsize=7, color="C3", va="center")
        else:
            ax.text(0.5, 0.5, "no percentage (A = 0\nor not finite): see the table", transform=ax.transAxes,
                    ha="center", va="center", fontsize=8)
        ax.set_xticks([])
        ax.set_xlim(0.5, 1.9)
        left = f", {s['zero_a']} with A = 0" if s["zero_a"] else ""
        ax.set_title(f"{m}\n{s['n']} seed{'' if s['n'] == 1 else 's'}{left}", fontsize=8)
        if k % ncol == 0:
            ax.set_ylabel("Δ % vs " + p.a, fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{title}: {p.b} vs {p.a}, % change paired by seed (line: median)", fontsize=10)
    return fig
