"""A metric against a sweep variable, one line per value of another (SPH paper Fig. 6).

A spec's ``[report.lines]`` table::

    [report.lines]
    x = "n"                                   # numeric: a [matrix] key, a scenario variable or a --set key
    series = "density"                        # optional: one line per value (one line if absent)
    metrics = ["sph_success", "coordination_time"]
    title = "..."                             # optional

Each variant records the variables that place it in the sweep (``Variant.variables``: its
``[matrix]`` values, the scenario variables and the ``--set`` values, kept in the store's record
of the experiment), so the figure reads x and the series from that record, not from variant
names. Every other variable the variants differ by (a second ``--set`` sweep, say ``preset``)
splits the lines further: one line per combination, labelled ``density = 0.15, preset = queue``.

A point is the mean over the seeds of one variant with its 95 % interval: Wilson's score interval
for a 0/1 outcome (:data:`BINARY_METRICS`, e.g. ``sph_success``), the Student-t interval of the
mean otherwise (:mod:`swarmnav.experiments.differences`); non-finite values (a run that
never got there) are left out of the point and counted.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.experiments import differences

KEYS = ("x", "series", "metrics", "title")
#: Per-run 0/1 outcomes, drawn as rates with Wilson intervals. Named, not guessed from the values:
#: a fraction (``Y``, ``R_goal``) or a count (``N_swarm``, ``collisions``) may be all 0 or 1 in a sweep.
BINARY_METRICS = ("sph_success", "sph_swarm_success", "converged", "success_rate")


class Line(NamedTuple):
    """One line of a panel, points in increasing x: the mean over seeds with its 95 % interval
    (``low``, ``high``: nan where undefined, e.g. one seed of a continuous metric), ``runs`` the
    finite values behind each point and ``dropped`` the non-finite ones left out."""

    x: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    runs: np.ndarray
    dropped: np.ndarray


def check(table: Any, variants: list[tuple[str, dict[str, Any]]], names: set[str], where: str) -> None:
    """Validate a ``[report.lines]`` table against the variants ``(name, variables)`` it will draw;
    ``names`` are the variables the variants can differ by (``[matrix]`` keys, scenario variables,
    ``--set`` keys). A one-line ConfigError for anything wrong. Variants that fall on one point
    (``--set n=30`` over a matrix of n) are the report's to note, not an error: the sweep is valid."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table with {list(KEYS)}, got {table!r}")
    bad = set(table) - set(KEYS)
    if bad:
        raise ConfigError(f"{where} unknown key(s) {sorted(bad)} (allowed: {list(KEYS)})")
    known = sorted(names)
    for key in ("x", "series"):
        if key not in table and key == "series":
            continue
        value = table.get(key)
        if not isinstance(value, str) or value not in names:
            raise ConfigError(f"{where} {key} must be a variable the variants differ by (a [matrix] key, a scenario "
                              f"variable or a --set key: {known or 'none in this spec'}), got {value!r}")
    if table.get("series") == table["x"]:
        raise ConfigError(f"{where} series must differ from x ('{table['x']}')")
    metrics = table.get("metrics")
    if not isinstance(metrics, list) or not metrics or not all(isinstance(m, str) and m for m in metrics):
        raise ConfigError(f"{where} metrics must be a non-empty list of metric names, got {metrics!r}")
    if len(set(metrics)) != len(metrics):
        raise ConfigError(f"{where} metrics lists a metric twice: {metrics!r}")
    if "title" in table and not isinstance(table["title"], str):
        raise ConfigError(f"{where} title must be a string, got {table['title']!r}")
    for name, values in variants:
        if table["x"] in values and not math.isfinite(_float(values[table["x"]])):
            raise ConfigError(f"{where} x '{table['x']}' must take numbers (variant {name}: "
                              f"{values[table['x']]!r})")


def lines(variants: list[tuple[str, dict[str, Any]]], x: str, series: str | None) -> list[tuple[str, list[tuple[float, str]]]]:
    """The figure's lines: ``(label, [(x value, variant name), ...] by increasing x)``, ordered by the
    series value (numerically where every value is a number), then by the other variables that
    differ between the variants. Variants without ``x`` (a spec's ``[[variants]]`` beside its
    matrix) are not drawn. Two variants at the same point of one line: ValueError."""
    drawn = [(name, vals) for name, vals in variants if x in vals]
    keys: list[str] = []
    for _, vals in drawn:
        keys.extend(k for k in vals if k not in keys)
    others = [k for k in keys if k not in (x, series) and len({_text(v.get(k)) for _, v in drawn}) > 1]
    split = ([series] if series else []) + others
    order = {k: _order([v.get(k) for _, v in drawn]) for k in split}
    out: dict[tuple, list[tuple[float, str]]] = {}
    for name, vals in drawn:
        line = tuple(_text(vals.get(k)) for k in split)
        points = out.setdefault(line, [])
        at = _float(vals[x])
        clash = [n for xx, n in points if xx == at]
        if clash:
            where = ", ".join(f"{k}={vals.get(k)}" for k in [x, *split])
            raise ValueError(f"variants '{clash[0]}' and '{name}' are the same point ({where}) of the figure: they "
                             f"differ by something that is not a variable (name it as series, or sweep it with --set)")
        points.append((at, name))
    ranked = sorted(out, key=lambda line: tuple(order[k][v] for k, v in zip(split, line)))
    return [(", ".join(f"{k} = {v}" for k, v in zip(split, line)), sorted(out[line])) for line in ranked]


def series_of(lines_: list[tuple[str, list[tuple[float, str]]]], values: dict[str, np.ndarray],
              binary: bool) -> dict[str, Line]:
    """Each line's points from ``values`` (variant name -> the metric's per-seed values):
    means with Wilson intervals if ``binary``, else Student-t intervals of the mean."""
    out = {}
    for label, points in lines_:
        cols: list[list[float]] = [[], [], [], [], [], []]
        for at, name in points:
            v = np.asarray(values.get(name, []), dtype=float)
            finite = v[np.isfinite(v)]
            mean, low, high = interval(finite, binary)
            for col, val in zip(cols, (at, mean, low, high, len(finite), len(v) - len(finite))):
                col.append(val)
        out[label] = Line(*(np.array(c, dtype=float) for c in cols[:4]), *(np.array(c, dtype=int) for c in cols[4:]))
    return out


def interval(vals: np.ndarray, binary: bool) -> tuple[float, float, float]:
    """Mean of finite per-seed values and its 95 % interval: Wilson's for 0/1 values (``binary``),
    the one-sample Student-t one otherwise (the paired interval of the values against 0); nan where
    undefined (no value; one value of a continuous metric)."""
    n = len(vals)
    if n == 0:
        return math.nan, math.nan, math.nan
    if binary:
        k = int(np.sum(vals == 1.0))
        lo, hi = differences.wilson(k, n)
        return k / n, lo, hi
    iv = differences.mean_difference(np.zeros(n), vals)
    return iv.estimate, iv.low, iv.high


def is_binary(metric: str, per_variant: list[np.ndarray]) -> bool:
    """A 0/1 outcome: one of :data:`BINARY_METRICS`, and every finite value of every variant is 0
    or 1 (and there is one)."""
    if metric not in BINARY_METRICS:
        return False
    vals = np.concatenate([np.asarray(v, dtype=float) for v in per_variant] or [np.zeros(0)])
    vals = vals[np.isfinite(vals)]
    return len(vals) > 0 and bool(np.all((vals == 0.0) | (vals == 1.0)))


def figure(panels: dict[str, dict[str, Line]], binary: dict[str, bool], x: str, title: str, labels: dict[str, str]):
    """One panel per metric (``labels``: its axis label with unit), one line with markers and 95 %
    interval bars per series; points of one x are spread by 1.5 % of the x span so that their
    bars do not hide each other. Returns a matplotlib Figure."""
    from matplotlib.figure import Figure

    metrics = list(panels)
    ncol = min(3, len(metrics))
    nrow = math.ceil(len(metrics) / ncol)
    fig = Figure(figsize=(4.2 * ncol, 3.3 * nrow + 0.6), layout="constrained")
    handles = []
    for k, m in enumerate(metrics):
        ax = fig.add_subplot(nrow, ncol, k + 1)
        every = sorted({float(v) for line in panels[m].values() for v in line.x})
        span = (every[-1] - every[0]) if len(every) > 1 else 1.0
        nl = len(panels[m])
        handles = []
        for i, (label, line) in enumerate(panels[m].items()):
            dx = 0.015 * span * (i - (nl - 1) / 2)
            xs = line.x + dx
            (h,) = ax.plot(xs, line.mean, "-o", ms=4, lw=1.4, color=f"C{i % 10}", label=label or m)
            ok = np.isfinite(line.low) & np.isfinite(line.high) & np.isfinite(line.mean)
            if ok.any():
                err = np.vstack([line.mean[ok] - line.low[ok], line.high[ok] - line.mean[ok]])
                ax.errorbar(xs[ok], line.mean[ok], yerr=np.maximum(err, 0.0), fmt="none", capsize=3, lw=1.0,
                            color=f"C{i % 10}")
            handles.append(h)
        ax.set_xticks(every, [_tick(v) for v in every])
        ax.set_xlabel(labels.get(x, x), fontsize=9)
        ax.set_ylabel(labels.get(m, m), fontsize=9)
        if binary[m]:
            ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
    fig.suptitle(f"{title}: mean over seeds with its 95 % interval (Wilson's for a 0/1 outcome, "
                 f"Student-t otherwise)", fontsize=10)
    if len(handles) > 1 or (handles and handles[0].get_label() not in metrics):
        fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 4), fontsize=8, frameon=False)
    return fig


def _float(v: Any) -> float:
    if isinstance(v, bool):
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _text(v: Any) -> str:
    return "" if v is None else str(v)


def _order(values: list[Any]) -> dict[str, tuple]:
    """Sort rank of each value's text: numerically if every value is a number, else by first appearance."""
    texts = list(dict.fromkeys(_text(v) for v in values))
    if all(math.isfinite(_float(t)) for t in texts):
        return {t: (_float(t),) for t in texts}
    return {t: (i,) for i, t in enumerate(texts)}


def _tick(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else f"{v:g}"
