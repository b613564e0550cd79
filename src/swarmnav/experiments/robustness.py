"""Success and distances against each degradation, one curve per method (issue 37's robustness report).

A spec whose ``[one_at_a_time]`` table sweeps factors (``net.latency``, ``net.loss``) one at a time
places each variant by its variables: the factor it moves (``varied``, "" at the baseline) and the
level of every factor. A ``[report.robustness]`` table draws them::

    [report.robustness]
    success = "Y"                     # a per-run outcome in [0, 1]; 0/1 values get Wilson intervals
    threshold = 0.8                   # the table gives the level at which success first falls below it
    metrics = ["min_inter_robot_distance", "min_robot_obstacle_distance"]
    title = "..."                     # optional
    [report.robustness.groups]        # optional: scenes pooled into one figure (else one per scene)
    "HES scenes" = ["default_corridor", "narrow_alternating_gates"]

For each factor and group: one figure (``robustness-<factor>-<group>.png``), a panel per metric (the
success first), a curve per method (or per whatever else the variants differ by, besides the scene
and the factors), x the factor's level. A point pools the runs of every scene of the group at that
level (the baseline belongs to every factor's curve at its baseline level): the mean with its 95 %
interval, Wilson's for a 0/1 outcome, Student-t otherwise (:func:`swarmnav.experiments.lines.interval`).

The table gives, per group and curve, the lowest level of each factor at which the mean success is
below ``threshold``: "never" if no level is, and where some levels have no finished run yet, "not
below up to L" (L the highest level run); "not run" if no level has a finished run.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.experiments import lines

KEYS = ("success", "threshold", "metrics", "groups", "title")


def check(table: Any, where: str) -> None:
    """Validate a ``[report.robustness]`` table (a one-line ConfigError for anything wrong)."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table with {list(KEYS)}, got {table!r}")
    bad = set(table) - set(KEYS)
    if bad:
        raise ConfigError(f"{where} unknown key(s) {sorted(bad)} (allowed: {list(KEYS)})")
    if not isinstance(table.get("success"), str) or not table["success"]:
        raise ConfigError(f"{where} success must name a per-run outcome in [0, 1] (e.g. \"Y\"), "
                          f"got {table.get('success')!r}")
    th = table.get("threshold", 0.8)
    if isinstance(th, bool) or not isinstance(th, (int, float)) or not 0.0 <= th <= 1.0:
        raise ConfigError(f"{where} threshold must be a number in [0, 1], got {th!r}")
    metrics = table.get("metrics", [])
    if not isinstance(metrics, list) or not all(isinstance(m, str) and m for m in metrics) \
            or table["success"] in metrics or len(set(metrics)) != len(metrics):
        raise ConfigError(f"{where} metrics must be a list of distinct metric names other than the success "
                          f"metric, got {metrics!r}")
    groups = table.get("groups", {})
    if not isinstance(groups, dict) or not all(
            isinstance(v, list) and v and all(isinstance(s, str) for s in v) for v in groups.values()):
        raise ConfigError(f"{where} groups must map a name to a non-empty list of scenes, got {groups!r}")
    if "title" in table and not isinstance(table["title"], str):
        raise ConfigError(f"{where} title must be a string, got {table['title']!r}")


def check_variants(table: dict, variants: list[tuple[str, str, dict[str, Any]]], where: str) -> None:
    """The variants ``(name, scenario, variables)`` can be drawn: some vary a factor (a spec with
    ``[one_at_a_time]``), and every scene a group names is one of theirs."""
    if not any(vals.get("varied") for _, _, vals in variants):
        raise ConfigError(f"{where} needs variants that vary one factor at a time (a spec's [one_at_a_time] table)")
    scenes = {s for _, s, _ in variants}
    for g, members in (table.get("groups") or {}).items():
        unknown = [s for s in members if s not in scenes]
        if unknown:
            raise ConfigError(f"{where} group '{g}' names scene(s) no variant flies: {unknown}")


@dataclass(frozen=True, slots=True)
class Threshold:
    """Where one curve's success first falls below the threshold along one factor: ``level`` (None:
    it never does at the levels run), the success ``rate`` there and its ``runs``; ``complete`` is
    False when some level of the factor has no finished run of this curve."""

    level: float | None
    rate: float
    runs: int
    complete: bool
    highest: float  # the highest level with a finished run [the factor's unit]

    def text(self) -> str:
        if self.level is not None:
            return f"{_tick(self.level)} ({self.rate:.2f} of {self.runs})"
        if math.isnan(self.highest):
            return "not run"
        return "never" if self.complete else f"not below up to {_tick(self.highest)}"


@dataclass(frozen=True, slots=True)
class Panel:
    """One figure's data: the curves of each metric (success first) for one factor and scene group."""

    factor: str
    group: str
    scenes: tuple[str, ...]
    curves: dict[str, dict[str, lines.Line]]  # metric -> curve label -> points by increasing level
    binary: dict[str, bool]


def series(variants: list[dict], cfg: dict) -> tuple[list[Panel], dict[tuple[str, str, str], Threshold]]:
    """The report's data from :func:`swarmnav.experiments.report.build_tables`' variants (each with
    ``name``, ``scenario``, ``variables`` and per-metric ``values``): a :class:`Panel` per factor
    and group, and per (group, curve, factor) the :class:`Threshold` of the success metric."""
    success, threshold = cfg["success"], float(cfg.get("threshold", 0.8))
    metrics = [success, *cfg.get("metrics", [])]
    factors = list(dict.fromkeys(v["variables"].get("varied") for v in variants if v["variables"].get("varied")))
    groups = dict(cfg.get("groups") or {}) or _one_group_per_scene([v["scenario"] for v in variants])
    label = _curve_labels(variants, factors)
    panels, table = [], {}
    for g, scenes in groups.items():
        mine = [v for v in variants if v["scenario"] in scenes and "varied" in v["variables"]]
        for f in factors:
            on = [v for v in mine if v["variables"]["varied"] in ("", f) and f in v["variables"]]
            pooled: dict[str, dict[float, dict[str, list[np.ndarray]]]] = {}
            for v in on:
                at = float(v["variables"][f])
                cell = pooled.setdefault(label[v["name"]], {}).setdefault(at, {m: [] for m in metrics})
                for m in metrics:
                    cell[m].append(np.asarray(v["values"].get(m, np.zeros(0)), dtype=float))
            levels = sorted({at for c in pooled.values() for at in c})
            per_metric = {m: np.concatenate([a for c in pooled.values() for cell in c.values() for a in cell[m]]
                                            or [np.zeros(0)]) for m in metrics}
            binary = {m: _binary(per_metric[m]) for m in metrics}
            curves: dict[str, dict[str, lines.Line]] = {m: {} for m in metrics}
            for c, by_level in pooled.items():
                for m in metrics:
                    cols: list[list[float]] = [[], [], [], [], [], []]
                    for at in sorted(by_level):
                        vals = np.concatenate(by_level[at][m]) if by_level[at][m] else np.zeros(0)
                        finite = vals[np.isfinite(vals)]
                        mean, low, high = lines.interval(finite, binary[m])
                        for col, x in zip(cols, (at, mean, low, high, len(finite), len(vals) - len(finite))):
                            col.append(x)
                    curves[m][c] = lines.Line(*(np.array(col, dtype=float) for col in cols[:4]),
                                              *(np.array(col, dtype=int) for col in cols[4:]))
                table[(g, c, f)] = first_below(curves[success][c], threshold, levels)
            panels.append(Panel(f, g, tuple(scenes), curves, binary))
    return panels, table


def first_below(line: lines.Line, threshold: float, levels: list[float]) -> Threshold:
    """The lowest level of ``line`` (points by increasing level) with a finished run whose mean is
    below ``threshold``; ``levels`` are every level the factor takes in the sweep."""
    run = [k for k in range(len(line.x)) if line.runs[k] > 0]
    highest = float(line.x[run[-1]]) if run else math.nan
    complete = set(levels) <= {float(line.x[k]) for k in run}
    for k in run:
        if line.mean[k] < threshold:
            return Threshold(float(line.x[k]), float(line.mean[k]), int(line.runs[k]), complete, highest)
    return Threshold(None, math.nan, 0, complete, highest)


def table(panels: list[Panel], thresholds: dict[tuple[str, str, str], Threshold], cfg: dict,
          units: dict[str, str]) -> dict[str, Any]:
    """The report table (``{"title", "columns", "rows", "note"}``, as report.tables gives): per group
    and curve, the first level of each factor at which success falls below the threshold."""
    factors = list(dict.fromkeys(p.factor for p in panels))
    curves = list(dict.fromkeys((g, c) for g, c, _ in thresholds))
    columns = [{"label": "scenes", "metric": None, "kind": "name"}, {"label": "method", "metric": None, "kind": "name"}]
    columns += [{"label": f"{f} [{units[f]}]" if units.get(f) else f, "metric": f, "kind": "ours"} for f in factors]
    rows = [[g, c] + [thresholds[(g, c, f)].text() if (g, c, f) in thresholds else "–" for f in factors]
            for g, c in curves]
    th = float(cfg.get("threshold", 0.8))
    note = (f"The lowest level of each factor (the others at their baseline) at which the mean `{cfg['success']}` "
            f"over the group's runs is below {th:g}, with that mean and its runs in brackets; \"never\": not at "
            f"any level of the sweep; \"not below up to L\": levels above L have no finished run yet; "
            f"\"not run\": no level has one.")
    return {"title": f"Success below {th:g}: first level of each factor", "columns": columns, "rows": rows,
            "note": note}


def to_csv(panels: list[Panel]) -> str:
    """Every point of every figure: factor, group, curve, level, metric, mean, low, high, runs,
    dropped (non-finite values left out)."""
    out = ["factor,group,curve,level,metric,mean,low,high,runs,dropped"]
    for p in panels:
        for m, by_curve in p.curves.items():
            for c, ln in by_curve.items():
                for k in range(len(ln.x)):
                    out.append(",".join([p.factor, _csv(p.group), _csv(c), f"{ln.x[k]:g}", m, *(
                        "" if not math.isfinite(x) else repr(float(x)) for x in (ln.mean[k], ln.low[k], ln.high[k])),
                        str(int(ln.runs[k])), str(int(ln.dropped[k]))]))
    return "\n".join(out) + "\n"


def figure(panel: Panel, title: str, labels: dict[str, str], threshold: float, success: str):
    """A panel per metric (success first, the threshold dashed), a curve per method
    (:func:`swarmnav.experiments.lines.figure`)."""
    shown = {m: {name: ln for name, ln in c.items() if ln.runs.sum()} for m, c in panel.curves.items()}
    shown = {m: c for m, c in shown.items() if c}  # a curve or a panel without a finished run is not drawn
    fig = lines.figure(shown, panel.binary, panel.factor, f"{title}: {panel.factor}, {panel.group}", labels)
    if success in shown:
        fig.axes[list(shown).index(success)].axhline(threshold, ls="--", lw=1.0, color="0.4")
    return fig


def stem(panel: Panel) -> str:
    """File stem of a panel's figure: ``robustness-net.latency-hes-scenes``."""
    return f"robustness-{panel.factor}-" + re.sub(r"[^a-z0-9.]+", "-", panel.group.lower()).strip("-")


def _curve_labels(variants: list[dict], factors: list[str]) -> dict[str, str]:
    """A curve per value of what the variants differ by besides the scene and the factors (the
    method in a [matrix] of methods)."""
    skip = {"scenario", "varied", *factors}
    keys: list[str] = []
    for v in variants:
        keys.extend(k for k in v["variables"] if k not in skip and k not in keys)
    differ = [k for k in keys if len({str(v["variables"].get(k)) for v in variants}) > 1]
    out = {}
    for v in variants:
        text = ", ".join(str(v["variables"].get(k)) for k in differ)
        out[v["name"]] = text or str(v.get("method") or v["variables"].get("method") or "all")
    return out


def _one_group_per_scene(scenes: list[str]) -> dict[str, list[str]]:
    """Each scene its own group, named by the scene, a generator spec by its first argument
    (``random_forest:density=0.35``) unless two scenes would share that name."""
    scenes = list(dict.fromkeys(scenes))
    short = [s.split(",")[0] if ":" in s else s for s in scenes]
    names = short if len(set(short)) == len(short) else scenes
    return {n: [s] for n, s in zip(names, scenes)}


def _binary(vals: np.ndarray) -> bool:
    finite = vals[np.isfinite(vals)]
    return len(finite) > 0 and bool(np.all((finite == 0.0) | (finite == 1.0)))


def _csv(text: str) -> str:
    return '"' + text.replace('"', '""') + '"' if ("," in text or '"' in text) else text


def _tick(v: float) -> str:
    return f"{v:g}"
