"""Reports of a results directory: ``report.md`` and a self-contained ``report.html``.

Tables are in the papers' format (mean ± population std over seeds) with the published
values beside them when the experiment's spec names a reference table of the packaged
``paper_results.toml``; figures are bars with error bars (HES Figures 4 and 9) and per-seed
box plots (HES Figure 7). For two variants, the paired-seed percent change of one against the
other (HES Figure 5, :mod:`swarmnav.experiments.paired`); for the pairs a spec's
``[report.differences]`` lists, B − A with 95 % intervals (:mod:`swarmnav.experiments.differences`);
for a spec's ``[report.lines]``, metrics against a sweep variable, one line per value of another
(SPH Fig. 6, :mod:`swarmnav.experiments.lines`).
Reads the store only; never runs a simulation.
"""

from __future__ import annotations

import base64
import html
import io
import itertools
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav.errors import SwarmnavError
from swarmnav.experiments import differences, lines, paired, robustness
from swarmnav.experiments import stats
from swarmnav.experiments.store import DB_NAME, Store

#: Columns shown when a spec's [report] does not list its own.
DEFAULT_METRICS = ("Y", "R_goal", "E_mean", "R_unsafe", "d_clr_min", "L_mean", "N_swarm", "S_scene")
#: Contacts and crashes: in every report, whatever metrics a spec chooses (a run that flew
#: through a wall or crashed must never look clean).
REFEREE_METRICS = ("collisions", "crashes")
UNITS = {"E_mean": "m", "E_90": "m", "sigma_E": "m", "d_clr_min": "m", "L_mean": "m",
         "min_inter_agent_distance": "m", "flight_distance": "m", "flight_time": "s", "avg_velocity": "m/s",
         "D_obs": "m", "D_ind": "m", "k_con": "steps", "P_s": "%", "min_inter_robot_distance": "m",
         "min_robot_obstacle_distance": "m", "osc_hf_speed": "m/s", "net.latency": "s", "net.jitter": "s", "jerk_energy": "m^2/s^5", "comm_mbps": "Mbit/s", "coordination_time": "s"}
#: Tables of the report in reading order; a metric not named here goes to OTHER_GROUP.
METRIC_GROUPS = (
    ("Outcome", ("Y", "R_goal", "sph_success", "sph_arrived_fraction", "P_s", "converged", "S_scene",
                 "E_mean", "E_90", "sigma_E",
                 "success_rate", "arrived_fraction")),  # the sph_ pair's names in stores written before the rename
    ("Safety and clearance", ("R_unsafe", "R_unsafe_agent", "d_clr_min", "R_below_0_75", "R_below_0_30",
                              "min_inter_agent_distance", "min_inter_robot_distance",
                              "min_robot_obstacle_distance", "D_obs", "D_ind", "collisions", "crashes")),
    ("Path, time and velocity", ("L_mean", "path_stretch", "flight_distance", "flight_time", "avg_velocity",
                                 "jerk_energy", "k_con", "coordination_time")),
)
OTHER_GROUP = "Method-specific"
#: Value columns (ours and the paper's) in one table: eight cells like "6.001 ± 0.021" beside a
#: variant name fit a 1000 px wide page without wrapping.
MAX_VALUE_COLUMNS = 8


def paper_results() -> dict:
    """The published figures of the three papers (a copy of the project's shared reference)."""
    text = resources.files("swarmnav.experiments").joinpath("reference", "paper_results.toml").read_text("utf-8")
    return tomllib.loads(text)


def _lookup(tree: dict, dotted: str) -> Any:
    node: Any = tree
    for part in _split_dotted(dotted):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def _split_dotted(s: str) -> list[str]:
    out, cur, quoted = [], "", False
    for ch in s:
        if ch == '"':
            quoted = not quoted
        elif ch == "." and not quoted:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return out


#: run parameters that say which build ran: the preset, and the decider with its model
BUILD_KEYS = ("preset", "decision", "llm_model", "llm_gguf")


def build_label(row: dict | None) -> str:
    """What a stored run was flown with, beyond its method: ``preset=guard``, ``decision=llamacpp
    llm_gguf=smollm2`` (the variant's parameters and the sweep's --set overrides). The build is
    always named: a run without a preset is labelled with its method's default build
    (``preset=swarmnav``), and a preset's earlier name with its current one (``faithful`` ->
    ``paper``); "" only for a method without presets and nothing else set."""
    row = row or {}
    params = dict(row.get("params") or {})
    if params.get("decision") == "rule":
        params = {k: v for k, v in params.items() if not k.startswith("llm_")}
    cls = _params_class(row.get("method"))
    if cls is not None:
        from swarmnav.params import default_build, preset_aliases

        if "preset" in params:
            params["preset"] = preset_aliases(cls).get(str(params["preset"]), params["preset"])
        elif default_build(cls):
            params["preset"] = default_build(cls)
    return " ".join(f"{k}={params[k]}" for k in BUILD_KEYS if k in params)


def names_build(row: dict | None) -> bool:
    """The run's parameters name its build (a preset, a decider or a model), as a variant or --set did."""
    return any(k in ((row or {}).get("params") or {}) for k in BUILD_KEYS)


def build_column(t: dict) -> bool:
    """The first table has a ``build`` column when a variant names its build or the variants' builds
    differ; otherwise every variant flew the same default build, which ``settings`` states once."""
    builds = [v.get("build") for v in t["variants"]]
    return any(v.get("build_named") for v in t["variants"]) or len(set(builds)) > 1


def _params_class(method: str | None) -> type | None:
    """The parameter record class of a registered method, or None (unknown or no method)."""
    if not method:
        return None
    from swarmnav.errors import SwarmnavError
    from swarmnav.methods import registry

    try:
        return registry.spec(method).params
    except SwarmnavError:
        return None


def _paper_cells(ref: dict, index: int | None, metrics: list[str], metric_map: dict) -> dict[str, Any]:
    """A variant's published cells by our metric name: ``metric_map`` names the paper's key of a
    metric (``{flight_distance = "dist_m"}``) or the key and the factor that brings the paper's unit
    to ours (``{sph_success = ["success_rate", 0.01]}``: percent to a fraction); ``index`` picks the
    entry of a per-scene list (a column of the published table)."""
    out = {}
    for m in metrics:
        key, scale = metric_map.get(m, m), 1.0
        if isinstance(key, list):
            key, scale = key
        cell = ref.get(key)
        if index is not None:
            cell = cell[index] if isinstance(cell, list) and index < len(cell) else None
        out[m] = _scaled(cell, float(scale))
    return out


def _scaled(cell: Any, scale: float) -> Any:
    if scale == 1.0 or cell is None or isinstance(cell, bool):
        return cell
    if isinstance(cell, list):
        return [_scaled(c, scale) for c in cell]
    return cell * scale if isinstance(cell, (int, float)) else cell


def _fmt_ref(v: Any, index: int | None) -> str:
    if v is None:
        return ""
    if isinstance(v, dict):
        return ""
    if isinstance(v, list):
        if index is not None:  # a per-scene list; its entries may be [mean, std] themselves
            return _fmt_ref(v[index], None) if index < len(v) else ""
        if len(v) == 2:
            return f"{_num(v[0])} ± {_num(v[1])}"
        if len(v) == 4:
            return f"{_num(v[0])} [{_num(v[1])}, {_num(v[2])}, {_num(v[3])}]"
        return ", ".join(_num(x) for x in v)
    if isinstance(v, bool):
        return "yes" if v else "no"
    return _num(v)


def _ref_value(v: Any, index: int | None) -> float | None:
    """The number a chart draws for a published cell: the mean of ``[mean, std]``, the average of
    ``[avg, p25, p50, p75]``, entry ``index`` of a per-scene list; None for anything else."""
    if isinstance(v, list):
        if index is not None:
            return _ref_value(v[index], None) if index < len(v) else None
        v = v[0] if len(v) in (2, 4) else None
    if isinstance(v, (int, float, np.number)) and not isinstance(v, bool) and np.isfinite(v):
        return float(v)
    return None


def _num(x: Any) -> str:
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(x)
    x = float(x)
    if not np.isfinite(x):
        return str(x)
    a = abs(x)
    return f"{x:.2f}" if a >= 100 else f"{x:.3f}" if a >= 0.01 or a == 0 else f"{x:.2e}"


def report_metrics(meta: dict, rows: list[dict]) -> list[str]:
    """The report's columns: the spec's ``[report] metrics``, else those of :data:`DEFAULT_METRICS`
    that some finished run has."""
    names = list((meta.get("report") or {}).get("metrics") or [])
    present = set().union(*(r["metrics"] for r in rows if r["status"] == "done")) if rows else set()
    if not names:
        names = [m for m in DEFAULT_METRICS if m in present]
    return names + [m for m in REFEREE_METRICS if m in present and m not in names]


def build_tables(store: Store, experiment: str) -> dict[str, Any]:
    """Per-variant statistics and the matching published values (pure data, no formatting)."""
    meta = store.meta(f"experiment:{experiment}")
    if meta is None:
        raise SwarmnavError(f"{store.root}: no experiment '{experiment}' in the store")
    from swarmnav.experiments.runner import job_rows

    rows = job_rows(store, meta)
    spec = meta.get("report") or {}
    if spec.get("trajectory_metrics"):
        rows = with_trajectory_metrics(store, rows, spec["trajectory_metrics"])
    metric_names = report_metrics(meta, rows)
    line_spec = spec.get("lines") or None
    robust = spec.get("robustness") or {}
    wanted = list(dict.fromkeys(metric_names + list((line_spec or {}).get("metrics") or [])
                                + ([robust["success"], *robust.get("metrics", [])] if robust else [])))
    ref_root = _lookup(paper_results(), spec["reference"]) if spec.get("reference") else None
    vmap = spec.get("variant_map") or {}
    planned: dict[str, int] = {}  # runs the stored spec plans per variant: its (variant, seed) jobs
    for _, name, _ in meta["jobs"]:
        planned[name] = planned.get(name, 0) + 1
    variants = []
    for v in meta["variants"]:
        mine = [r for r in rows if r["variant"] == v["name"]]
        done = [r for r in mine if r["status"] == "done"]
        per_metric = {}
        for m in wanted:
            vals = np.array([float(r["metrics"][m]) for r in done if m in r["metrics"]
                             and r["metrics"][m] is not None], dtype=float)
            per_metric[m] = vals
        base = v["name"].split("[", 1)[0]  # a swept variant (rule[preset=paper]) keeps its spec variant's paper row
        key, index = vmap.get(v["name"], vmap.get(base, base)), spec.get("reference_index")
        if isinstance(key, list):  # [reference key, entry of its per-scene lists]
            key, index = key
        ref = _lookup(ref_root, key) if isinstance(ref_root, dict) else None
        row_name = key.strip('"') + (f" [{index}]" if index is not None else "")
        cols = v.get("columns") or {}
        variants.append({"name": v["name"], "method": cols.get("method"), "scenario": cols.get("scenario"),
                         "runs": len(mine), "done": len(done), "values": per_metric,
                         "variables": variant_variables(v, meta.get("overrides") or {}),
                         "planned": planned.get(v["name"], 0), "failed": len(mine) - len(done),
                         "seeds": [r["seed"] for r in done], "build": build_label(mine[0] if mine else None),
                         "build_named": names_build(mine[0] if mine else None),
                         "paper_row": row_name if isinstance(ref, dict) and row_name != v["name"] else "",
                         "reference": _paper_cells(ref, index, metric_names, spec.get("metric_map") or {})
                         if isinstance(ref, dict) else None})
    return {"experiment": experiment, "description": meta.get("description", ""), "metrics": metric_names,
            "variants": variants, "reference": spec.get("reference"), "reference_index": None,
            "title": spec.get("title") or experiment, "n_runs": len(rows), "compare": spec.get("compare"),
            "differences": spec.get("differences"), "lines": line_spec, "robustness": robust or None,
            "planned": len(meta["jobs"]), "seed_list": list(meta.get("seeds") or []),
            "overrides": meta.get("overrides")}


def with_trajectory_metrics(store: Store, rows: list[dict], names: list[str]) -> list[dict]:
    """``rows`` with the metrics ``names`` (:data:`swarmnav.metrics.oscillation.FROM_TRAJECTORY`)
    computed from each finished run's stored trajectory and its method's step; a run without a
    trajectory file gets none. A metric the run already has is kept as stored."""
    from swarmnav.methods import registry
    from swarmnav.metrics.oscillation import FROM_TRAJECTORY
    from swarmnav.sim.rollout import is_run_option

    steps: dict[tuple, float] = {}
    out = []
    for r in rows:
        path = store.root / r["trajectory"] if r.get("status") == "done" and r.get("trajectory") else None
        if path is None or not path.is_file() or all(m in r["metrics"] for m in names):
            out.append(r)
            continue
        params = {k: v for k, v in (r.get("params") or {}).items() if not is_run_option(k)}
        key = (r["method"], tuple(sorted((k, str(v)) for k, v in params.items())))
        if key not in steps:
            steps[key] = float(registry.make(r["method"], **params).dt)
        with np.load(path) as z:
            positions = z["positions"]
        extra = {m: FROM_TRAJECTORY[m](positions, steps[key]) for m in names if m not in r["metrics"]}
        out.append({**r, "metrics": {**r["metrics"], **extra}})
    return out


def variant_variables(v: dict, overrides: dict[str, str]) -> dict[str, Any]:
    """What places a stored variant in its sweep (``Variant.variables``: [matrix] values, scenario
    variables, --set values). A store written before they were recorded: the variant's run columns
    (``n``, ``method``, ``scenario``, ``steps``) and parameters, and the values of the --set sweeps
    (recovered by matching the name against each combination of the recorded sweep values)."""
    if "variables" in v:
        return dict(v["variables"])
    cols = v.get("columns") or {}
    out = {k: cols[k] for k in ("method", "scenario", "steps", "n") if cols.get(k) not in (None, "")}
    out.update({k[len("param."):]: x for k, x in cols.items() if k.startswith("param.")})
    swept = {k: str(val).split("|") for k, val in overrides.items() if len(str(val).split("|")) > 1}
    for combo in itertools.product(*swept.values()):
        suffix = "[" + ",".join(f"{k}={c}" for k, c in zip(swept, combo)) + "]"
        if swept and v["name"].endswith(suffix):
            out.update(zip(swept, combo))
            break
    return out


def line_series(t: dict, lines_cfg: dict) -> dict[str, dict[str, lines.Line]]:
    """The data of ``lines.png`` (a spec's ``[report.lines]``): per metric, per line (label
    ``density = 0.15``), the points ``(x, mean, low, high, runs, dropped)`` by increasing x, each the
    mean over a variant's finished seeds with its 95 % interval (Wilson's for a 0/1 outcome,
    Student-t otherwise; :mod:`swarmnav.experiments.lines`). ``t`` is :func:`build_tables`' result,
    which holds the values of the stored spec's ``[report]`` and ``[report.lines]`` metrics.
    A table that does not fit the store's variants is a one-line ConfigError, two variants at one
    point of a line a ValueError."""
    placed = [(v["name"], v["variables"]) for v in t["variants"]]
    names = {k for _, vals in placed for k in vals}
    lines.check(lines_cfg, placed, names, "[report.lines]")
    drawn = lines.lines(placed, lines_cfg["x"], lines_cfg.get("series"))
    out = {}
    for m in lines_cfg["metrics"]:
        values = {v["name"]: v["values"].get(m, np.zeros(0)) for v in t["variants"]}
        out[m] = lines.series_of(drawn, values, lines.is_binary(m, list(values.values())))
    return out


def _lines_figure(t: dict) -> tuple[Any, str]:
    """``lines.png`` of the spec's ``[report.lines]`` (None if it cannot be drawn) and the report's
    paragraph on it."""
    cfg = t["lines"]
    try:
        data = line_series(t, cfg)
    except ValueError as e:  # two variants on one point: a sweep that does not spread along x
        return None, f"Line figure (`[report.lines]`): not drawn, {e}."
    x = cfg["x"]
    xs = sorted({float(p) for panel in data.values() for line in panel.values() for p in line.x})
    empty = [m for m, panel in data.items() if not any(line.runs.sum() for line in panel.values())]
    panels = {m: panel for m, panel in data.items() if m not in empty}
    missing = f" No finished run has {', '.join(f'`{m}`' for m in empty)}." if empty else ""
    apart = [v["name"] for v in t["variants"] if x not in v["variables"]]
    if apart:  # a spec's [[variants]] beside its matrix over x
        missing += f" Not drawn (no `{x}` of their own): {', '.join(apart[:6])}{' ...' if len(apart) > 6 else ''}."
    if len(xs) < 2 or not panels:
        why = f"the variants take one value of `{x}`" if len(xs) < 2 else "no metric it names has values"
        return None, f"Line figure (`[report.lines]`): not drawn, {why}.{missing}"
    binary = {m: lines.is_binary(m, [v["values"].get(m, np.zeros(0)) for v in t["variants"]]) for m in panels}
    labels = {m: _header(m) for m in [x, *panels]}
    fig = lines.figure(panels, binary, x, cfg.get("title") or t["title"], labels)
    dropped = {m: int(sum(line.dropped.sum() for line in panel.values())) for m, panel in panels.items()}
    left = "; ".join(f"`{m}`: {k} non-finite runs left out" for m, k in dropped.items() if k)
    series = f", one line per `{cfg['series']}`" if cfg.get("series") else ""
    return fig, (f"Line figure (`lines.png`): each metric against `{x}`{series}; a point is the mean over a "
                 f"variant's seeds with its 95 % interval (Wilson's for a 0/1 outcome such as `sph_success`, "
                 f"Student-t otherwise)."
                 + (f" {left}." if left else "") + missing)


def completeness(t: dict) -> str:
    """The report's line on how much of the sweep is done: runs done of planned overall, and for
    an incomplete sweep (a sweep interrupted, or with failed runs) each variant's seeds done of
    planned, e.g. ``incomplete: 6 of 10 seeds in every variant``."""
    done, planned = sum(v["done"] for v in t["variants"]), sum(v["planned"] for v in t["variants"])
    line = f"{done} of {planned} planned runs done"
    if done >= planned:
        return line + "."
    short = [v for v in t["variants"] if v["done"] < v["planned"]]
    counts = {(v["done"], v["planned"]) for v in short}
    if len(short) == len(t["variants"]) and len(counts) == 1:
        (d, p), = counts
        where = f"{d} of {p} seeds in every variant"
    else:
        where = "; ".join(f"{v['name']} {v['done']} of {v['planned']} seeds" for v in short[:6]) + \
            (f"; {len(short) - 6} more variants" if len(short) > 6 else "")
    failed = sum(v["failed"] for v in t["variants"])
    missing = planned - done - failed
    why = ", ".join(x for x in (f"{missing} not run" if missing else "", f"{failed} failed" if failed else "") if x)
    return (f"{line} — **incomplete**: {where} ({why}; rerun the same `swarmnav experiment` command "
            f"into this directory to finish it).")


def settings(t: dict) -> str:
    """The report's line on what the sweep ran with: its seeds, its ``--set`` overrides and, when
    every variant flew the same default build (no ``build`` column), that build."""
    seeds = _seed_ranges(t["seed_list"]) or "not recorded"
    if t["overrides"] is None:
        sets = "not recorded (a store written before swarmnav kept them)"
    else:
        sets = " ".join(f"`{k}={v}`" for k, v in t["overrides"].items()) or "none"
    builds = {v.get("build") for v in t["variants"]} - {"", None}
    build = f" Build of every variant: `{builds.pop()}` (its method's default)." \
        if len(builds) == 1 and not build_column(t) else ""
    return f"Seeds: {seeds}. Overrides (`--set`): {sets}.{build}"


def _seed_ranges(seeds: list[int]) -> str:
    """``[1, 2, 3, 7]`` -> ``"1-3, 7"`` (the --seeds syntax, in the planned order)."""
    out: list[list[int]] = []
    for s in seeds:
        if out and s == out[-1][1] + 1:
            out[-1][1] = s
        else:
            out.append([s, s])
    return ", ".join(f"{a}-{b}" if b > a else str(a) for a, b in out)


def _cell(vals: np.ndarray) -> str:
    if not len(vals):
        return "–"
    if len(vals) == 1:
        return _num(vals[0])
    sd = stats.std(vals)
    return f"{_num(stats.mean(vals))}" + (f" ± {_num(sd)}" if np.isfinite(sd) else "")


def _header(m: str) -> str:
    u = UNITS.get(m) or ("ms" if m.startswith("time.") and "_ms" in m else None)
    return f"{m} [{u}]" if u else m


def tables(t: dict) -> list[dict[str, Any]]:
    """The comparison table; split by metric group when it is too wide for a page.

    Each table is ``{"title", "columns", "rows"}``; a column is ``{"label", "metric", "kind"}`` with
    kind ``name`` (the variant, in every table), ``runs`` (first table only), ``ours`` or ``paper``.
    A metric has a paper column only when the published table gives it for some variant.
    """
    index = t.get("reference_index")
    refs = [[_fmt_ref((v.get("reference") or {}).get(m), index) for m in t["metrics"]] for v in t["variants"]]
    paper = {m for j, m in enumerate(t["metrics"]) if any(r[j] for r in refs)}
    if len(t["metrics"]) + len(paper) <= MAX_VALUE_COLUMNS:
        groups = [("Results", list(t["metrics"]))]  # fits one page: the spec's own column order
    else:
        groups = _metric_groups(t["metrics"], paper)
    out = []
    for title, chunk in groups:
        columns = [{"label": "variant", "metric": None, "kind": "name"}]
        if not out:
            # what ran (preset, decider and model) and which published row it is set beside, where
            # either is not the variant's name: an LLM row of ours is never read as the paper's model
            if build_column(t) and any(v.get("build") for v in t["variants"]):
                columns.append({"label": "build", "metric": None, "kind": "build"})
            if any(v.get("paper_row") for v in t["variants"]):
                columns.append({"label": "paper row", "metric": None, "kind": "paper_row"})
            columns.append({"label": "runs", "metric": None, "kind": "runs"})
        for m in chunk:
            columns.append({"label": _header(m), "metric": m, "kind": "ours"})
            if m in paper:
                columns.append({"label": f"{m} (paper)", "metric": m, "kind": "paper"})
        rows = []
        for v, ref in zip(t["variants"], refs):
            row = []
            for c in columns:
                if c["kind"] == "name":
                    row.append(v["name"])
                elif c["kind"] in ("build", "paper_row"):
                    row.append(v.get(c["kind"]) or "")
                elif c["kind"] == "runs":  # done of planned: an interrupted sweep shows 6/10, not 6/6
                    row.append(f"{v['done']}/{v['planned']}")
                elif c["kind"] == "ours":
                    row.append(_cell(v["values"][c["metric"]]))
                else:
                    row.append(ref[t["metrics"].index(c["metric"])])
            rows.append(row)
        out.append({"title": title, "columns": columns, "rows": rows})
    return out


def _metric_groups(metrics: list[str], paper: set[str]) -> list[tuple[str, list[str]]]:
    """Metrics by METRIC_GROUPS (spec order kept inside a group); a group wider than
    MAX_VALUE_COLUMNS is cut into the fewest even pieces that each fit."""
    named = {m: g for g, members in METRIC_GROUPS for m in members}
    out = []
    for g in [g for g, _ in METRIC_GROUPS] + [OTHER_GROUP]:
        ms = [m for m in metrics if named.get(m, OTHER_GROUP) == g]
        if not ms:
            continue
        width = [1 + (m in paper) for m in ms]
        n = max(1, int(np.ceil(sum(width) / MAX_VALUE_COLUMNS)))
        while True:
            cuts = np.array_split(np.arange(len(ms)), n)
            if all(sum(width[i] for i in c) <= MAX_VALUE_COLUMNS for c in cuts) or n >= len(ms):
                break
            n += 1
        for k, c in enumerate(cuts):
            out.append((g if k == 0 else f"{g}, continued", [ms[i] for i in c]))
    return out


def figures(t: dict) -> list[tuple[str, bytes]]:
    """PNG figures: bars of mean ± std per metric (HES Fig. 4/9) and per-seed box plots (Fig. 7)."""
    return [(f"{stem}.png", _png(fig)) for stem, fig in _figures(t)]


#: Offset [bar widths] of a paper marker from its variant's bar or box (both 0.6 wide): beside it,
#: clear of the next variant's.
_PAPER_DX = 0.42


def _figures(t: dict) -> list[tuple[str, Any]]:
    """The report's matplotlib figures by file stem. A published value is a black diamond beside
    its variant's bar or box (SVG group ``paper-<metric>``), "paper" in the legend."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    names = [_short(v["name"]) for v in t["variants"]]
    metrics = [m for m in t["metrics"] if any(len(v["values"][m]) for v in t["variants"])]
    out = []
    if not metrics:
        return out
    index = t.get("reference_index")
    paper = {m: [_ref_value((v.get("reference") or {}).get(m), index) for v in t["variants"]] for m in metrics}

    def draw_paper(ax, m, x0):
        i = [k for k, r in enumerate(paper[m]) if r is not None]
        if i:
            ax.plot(np.asarray(i) + x0 + _PAPER_DX, [paper[m][k] for k in i], "D", color="k", ms=5,
                    clip_on=False, zorder=3, gid=f"paper-{m}")  # a 0 on the axis stays whole

    def legend(fig, drawn, ours):
        if any(r is not None for m in drawn for r in paper[m]):
            fig.legend(handles=[ours, Line2D([], [], ls="", marker="D", color="k", ms=5,
                                             label=f"paper ({t['reference']})")],
                       loc="outside lower center", ncols=2, fontsize=8, frameon=False)

    many = len(names) > 12  # one metric per row, so dozens of variants stay legible
    ncol = 1 if many else min(4, len(metrics))
    nrow = int(np.ceil(len(metrics) / ncol))
    width = min(max(3.2, 0.35 * len(names) + 2.0), 22.0)
    fig = Figure(figsize=(width * ncol, (3.4 if many else 3.0) * nrow), layout="constrained")
    for k, m in enumerate(metrics):
        ax = fig.add_subplot(nrow, ncol, k + 1)
        means = [np.nan if np.isinf(mu := stats.mean(v["values"][m])) else mu for v in t["variants"]]  # no bar
        stds = [np.nan_to_num(stats.std(v["values"][m])) for v in t["variants"]]
        x = np.arange(len(names))
        ax.bar(x, means, width=0.6, yerr=stds, capsize=3, color=[f"C{i % 10}" for i in range(len(names))], alpha=0.85)
        draw_paper(ax, m, 0)
        ax.set_xticks(x, names, rotation=35, ha="right", fontsize=7)
        ax.set_title(_header(m), fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{t['title']}: mean ± std over seeds", fontsize=10)
    legend(fig, metrics, Patch(color="0.55", label="ours: mean ± std over seeds"))
    out.append(("bars", fig))
    box_metrics = metrics[:4]
    shape = (len(box_metrics), 1) if many else (1, len(box_metrics))
    fig = Figure(figsize=(width * shape[1], 3.4 * shape[0]), layout="constrained")
    for k, m in enumerate(box_metrics):
        ax = fig.add_subplot(*shape, k + 1)
        # runs that never get there (k_con = inf) are in the table's mean, not drawable on an axis
        data = [d if len(d := v["values"][m][np.isfinite(v["values"][m])]) else np.array([np.nan])
                for v in t["variants"]]
        ax.boxplot(data, showmeans=True, widths=0.6)
        rng = np.random.default_rng(0)  # fixed jitter: the figure is reproducible
        for i, d in enumerate(data):  # the seeds as dots; a fixed subsample of 200 for big sweeps
            shown = d if len(d) <= 200 else rng.choice(d, 200, replace=False)
            ax.plot(i + 1 + rng.uniform(-0.12, 0.12, len(shown)), shown, ".", ms=3, alpha=0.6, color="k")
        draw_paper(ax, m, 1)
        ax.set_xticks(np.arange(1, len(names) + 1), names, rotation=35, ha="right", fontsize=7)
        ax.set_title(_header(m), fontsize=9)
    fig.suptitle(f"{t['title']}: per-seed distribution (box: IQR, line: median, triangle: mean)", fontsize=10)
    legend(fig, box_metrics, Line2D([], [], ls="", marker=".", color="k", label="ours: one dot per seed"))
    out.append(("boxes", fig))
    return out


def _short(name: str, limit: int = 40) -> str:
    """Axis label of a variant: a generator spec loses its trailing arguments after the first."""
    if "," in name and ":" in name:
        name = name.split(",")[0] + ("]" if "[" in name.split(",")[0] else "")
    return name if len(name) <= limit else name[: limit - 1] + "…"


#: table columns of text (left-aligned), not numbers
_TEXT_KINDS = ("name", "build", "paper_row")


def _html_table(tab: dict) -> str:
    """One table; a metric with a paper column gets a two-level header (metric over ours | paper)."""
    e = html.escape
    cols = tab["columns"]
    two = any(c["kind"] == "paper" for c in cols)
    rs = ' rowspan="2"' if two else ""
    top, sub = [], []
    for c in cols:
        if c["kind"] in _TEXT_KINDS:
            top.append(f'<th class="name"{rs}>{e(c["label"])}</th>')
        elif c["kind"] == "paper":
            sub.append('<th class="num paper">paper</th>')
        elif c["kind"] == "ours" and two and any(o["kind"] == "paper" and o["metric"] == c["metric"] for o in cols):
            top.append(f'<th class="group" colspan="2">{e(c["label"])}</th>')
            sub.append('<th class="num">ours</th>')
        else:
            top.append(f'<th class="num"{rs}>{e(c["label"])}</th>')
    head = "<tr>" + "".join(top) + "</tr>" + (f"<tr>{''.join(sub)}</tr>" if two else "")
    note = f"<p>{_inline_html(tab['note'])}</p>\n" if tab.get("note") else ""
    body = []
    for r in tab["rows"]:
        cells = []
        for c, text in zip(cols, r):
            if c["kind"] in _TEXT_KINDS:
                cells.append(f'<td class="name">{e(text)}</td>')
                continue
            mean, pm, sd = text.partition(" ± ")  # the spread in grey, so the means read first
            inner = e(mean) + (f'<span class="sd"> ± {e(sd)}</span>' if pm else "")
            cells.append(f'<td class="num{" paper" if c["kind"] == "paper" else ""}">{inner}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<h2>{e(tab["title"])}</h2>\n{note}<div class="scroll"><table>\n<thead>{head}</thead>\n<tbody>\n'
            + "\n".join(body) + "\n</tbody></table></div>\n")


def _inline_html(text: str) -> str:
    """Markdown-ish prose as HTML: escaped, with `code` spans as <code> and **bold** as <strong>
    (no markup leaks through)."""
    text = re.sub(r"`([^`]+)`", r"<code>\1</code>", html.escape(text))
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", text)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _open(directory: str | Path, experiment: str | None) -> tuple[Store, str]:
    d = Path(directory)
    if not (d / DB_NAME).exists():
        raise SwarmnavError(f"{d}: no results store ({DB_NAME}); run 'swarmnav experiment ... --out {d}' first")
    store = Store(d)
    experiment = experiment or store.meta("last_experiment")
    if experiment is None:
        raise SwarmnavError(f"{d}: the store names no experiment")
    return store, experiment


def paired_changes(directory: str | Path, a: str, b: str, *, experiment: str | None = None,
                   metrics: list[str] | None = None) -> paired.Paired:
    """Variant ``b`` against variant ``a`` of a results directory, seed by seed (HES Figure 5).

    ``metrics`` defaults to the report's columns. The per-seed table is ``.rows`` (see
    :class:`swarmnav.experiments.paired.Paired`); an unknown variant is a one-line ConfigError.
    """
    store, experiment = _open(directory, experiment)
    meta = store.meta(f"experiment:{experiment}")
    if meta is None:
        raise SwarmnavError(f"{store.root}: no experiment '{experiment}' in the store")
    from swarmnav.experiments.runner import job_rows

    a, b = paired.check_variants((a, b), [v["name"] for v in meta["variants"]])
    rows = job_rows(store, meta)
    if (meta.get("report") or {}).get("trajectory_metrics"):
        rows = with_trajectory_metrics(store, rows, meta["report"]["trajectory_metrics"])
    return paired.pair_rows(rows, experiment, a, b, list(metrics) if metrics else report_metrics(meta, rows))


def paired_differences(directory: str | Path, pairs: list[tuple[str, str]] | list[list[str]], success: str,
                       metrics: list[str] | tuple[str, ...] = (), *,
                       experiment: str | None = None) -> list[differences.PairDifference]:
    """B − A with 95 % intervals for each pair ``(A, B)`` of a results directory's variants: the
    difference of the ``success`` rates (a 0/1 metric; Newcombe's paired interval) and of the mean
    of each of ``metrics`` over the seeds where both succeeded (paired t). A ``--set`` sweep
    appends its values to every variant name (``sph/0.15[horizon=60]``): a pair of spec names is
    then compared at each swept value both variants have. A pair whose variants the store lacks
    otherwise is returned with a note and no seeds, not an error
    (:class:`swarmnav.experiments.differences.PairDifference`)."""
    store, experiment = _open(directory, experiment)
    meta = store.meta(f"experiment:{experiment}")
    if meta is None:
        raise SwarmnavError(f"{store.root}: no experiment '{experiment}' in the store")
    from swarmnav.experiments.runner import job_rows

    rows = job_rows(store, meta)
    known = [v["name"] for v in meta["variants"]]
    return [differences.pair_difference(rows, a, b, success, list(metrics), known)
            for pair in pairs for a, b in _swept(tuple(pair), known)]


def _swept(pair: tuple[str, str], known: list[str]) -> list[tuple[str, str]]:
    """``pair`` itself if both are variants of the store, else the pairs ``(A[s], B[s])`` of each
    sweep suffix ``[s]`` both have (a ``--set`` sweep renames every variant alike); else ``pair``."""
    a, b = pair
    if a in known and b in known:
        return [pair]
    tails = [n[len(a):] for n in known if n.startswith(a + "[") and n.endswith("]")]
    both = [(a + t, b + t) for t in tails if b + t in known]
    return both or [pair]


def write_report(directory: str | Path, experiment: str | None = None,
                 compare: tuple[str, str] | None = None, viewers: dict[str, str] | None = None) -> list[Path]:
    """Write ``report.md`` (+ ``report_files/*.png``, ``*.svg``) and ``report.html`` into ``directory``.

    ``compare = (A, B)`` adds the paired-seed comparison of B against A (table, figure
    ``paired``, per-seed ``paired.csv``); without it, the pair the spec's ``[report] compare``
    declares, if any. ``viewers`` (run key -> a page's path relative to ``directory``, as
    ``swarmnav report`` makes them with :mod:`swarmnav.viz.store_views`) adds a section that
    links every run, by variant and seed, to its replay viewer.
    """
    store, experiment = _open(directory, experiment)
    d = store.root
    t = build_tables(store, experiment)
    tabs = tables(t)
    names = [v["name"] for v in t["variants"]]
    pair, pair_note = None, ""
    if compare is not None:
        pair = paired.check_variants(tuple(compare), names)  # before anything is written
    elif t["compare"]:
        if all(n in names for n in t["compare"]):
            pair = tuple(t["compare"])
        else:  # a --set sweep appends its values to every variant name
            pair_note = (f"The spec's comparison pair ({', '.join(t['compare'])}) is not among this store's "
                         f"variants; `swarmnav report DIR --compare A B` names one.")
    comparison = paired_changes(d, *pair, experiment=experiment, metrics=t["metrics"]) if pair else None
    from matplotlib import rc_context

    files = d / "report_files"
    files.mkdir(exist_ok=True)
    charts = _figures(t)
    if comparison is not None:
        tabs.append(paired.table(comparison, UNITS))
        charts.append(("paired", paired.figure(comparison, t["title"])))
        (files / "paired.csv").write_text(comparison.to_csv(), encoding="utf-8")
    else:  # an earlier report's comparison would otherwise stay beside this one
        for ext in ("png", "svg", "csv"):
            (files / f"paired.{ext}").unlink(missing_ok=True)
    lines_note = ""
    if t["lines"]:
        fig, lines_note = _lines_figure(t)
        if fig is not None:
            charts.append(("lines", fig))
    if not any(stem == "lines" for stem, _ in charts):
        for ext in ("png", "svg"):
            (files / f"lines.{ext}").unlink(missing_ok=True)
    stale = set(files.glob("robustness-*.png")) | set(files.glob("robustness-*.svg"))
    if t["robustness"]:
        cfg = t["robustness"]
        panels, firsts = robustness.series(t["variants"], cfg)
        tabs.append(robustness.table(panels, firsts, cfg, UNITS))
        labels = {m: _header(m) for m in {cfg["success"], *cfg.get("metrics", []), *(p.factor for p in panels)}}
        for p in panels:
            charts.append((robustness.stem(p), robustness.figure(p, cfg.get("title") or t["title"], labels,
                                                                 float(cfg.get("threshold", 0.8)), cfg["success"])))
        (files / "robustness.csv").write_text(robustness.to_csv(panels), encoding="utf-8")
    else:
        (files / "robustness.csv").unlink(missing_ok=True)
    for old in stale - {files / f"{stem}.{ext}" for stem, _ in charts for ext in ("png", "svg")}:
        old.unlink(missing_ok=True)
    diff_spec = t["differences"]
    if diff_spec:
        diff_metrics = list(diff_spec.get("metrics") or [])
        diffs = paired_differences(d, diff_spec["pairs"], diff_spec["success"], diff_metrics, experiment=experiment)
        tabs.append(differences.table(diffs, diff_spec["success"], diff_metrics, UNITS))
        (files / "differences.csv").write_text(differences.to_csv(diffs, diff_metrics), encoding="utf-8")
    else:
        (files / "differences.csv").unlink(missing_ok=True)
    figs = []
    for stem, fig in charts:  # PNG for the pages, SVG to print or to read the drawn values from
        figs.append((f"{stem}.png", _png(fig)))
        (files / f"{stem}.png").write_bytes(figs[-1][1])
        fig.set_layout_engine("none")  # keep the layout the PNG computed instead of solving it again
        with rc_context({"svg.fonttype": "none"}):  # labels stay text: searchable, and no glyph outlines
            fig.savefig(files / f"{stem}.svg", format="svg", metadata={"Date": None})
    ref_note = (f"Published values: `{t['reference']}` of the packaged paper_results.toml "
                f"(the papers' figures, copied as published), in a paper column beside ours where the paper "
                f"gives the metric." if t["reference"] else "No published table to compare.")
    md = [f"# {t['title']}", "", t["description"], "",
          f"Experiment `{experiment}`: {completeness(t)} Cells are mean ± population std over the seeds done.",
          "", settings(t), "", ref_note]
    if pair_note:
        md += ["", pair_note]
    if lines_note:
        md += ["", lines_note]
    for tab in tabs:
        md += ["", f"## {tab['title']}", ""] + ([tab["note"], ""] if tab.get("note") else [])
        md += ["| " + " | ".join(c["label"] for c in tab["columns"]) + " |",
               "|" + "".join("---|" if c["kind"] in _TEXT_KINDS else "--:|" for c in tab["columns"])]
        md += ["| " + " | ".join(r) + " |" for r in tab["rows"]]
    md += [""] + [f"![{n}](report_files/{n})" for n, _ in figs] + [""]
    replays = _replays(store, experiment, viewers) if viewers else []
    if replays:
        md += ["## Replays", "", "Each run's replay viewer (open in a browser), by variant and seed.", ""]
        md += [f"- {name}: " + " · ".join(f"[seed {seed}]({path})" for seed, path in links) for name, links in replays]
        md += [""]
    md_path = d / "report.md"
    md_path.write_text("\n".join(md), encoding="utf-8")
    e = html.escape
    imgs = "\n".join(f'<figure><img alt="{e(n)}" src="data:image/png;base64,{base64.b64encode(b).decode()}">'
                     f"</figure>" for n, b in figs)
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{e(t['title'])}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; padding: 0 2em; color: #222; }}
h2 {{ font-size: 1.1em; margin: 1.4em 0 0.4em; }}
.scroll {{ overflow-x: auto; }}
table {{ border-collapse: collapse; font-size: 13px; }}
th, td {{ border: 1px solid #ccc; padding: 4px 8px; }}
th {{ background: #eef3f8; font-weight: 600; }}
.name {{ text-align: left; }}
.num {{ text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }}
th.num, th.group {{ text-align: center; }}
tbody tr:nth-child(even) td {{ background: #fafafa; }}
tbody tr td.paper, th.paper {{ background: #f5f1e4; color: #444; }}
.sd {{ color: #666; }}
.incomplete {{ background: #fff4d6; border-left: 4px solid #d9a400; padding: 0.4em 0.8em; }}
img {{ max-width: 100%; }}
</style></head><body>
<h1>{e(t['title'])}</h1>
<p>{_inline_html(t['description'])}</p>
<p{' class="incomplete"' if "**incomplete**" in completeness(t) else ""}>Experiment <code>{e(experiment)}</code>: \
{_inline_html(completeness(t))} Cells are mean ± population std over the seeds done.</p>
<p>{_inline_html(settings(t))}</p>
<p>{_inline_html(ref_note)}</p>
{f"<p>{_inline_html(pair_note)}</p>" if pair_note else ""}
{f"<p>{_inline_html(lines_note)}</p>" if lines_note else ""}
<section id="results">
{"".join(_html_table(tab) for tab in tabs)}</section>
{imgs}
{_replays_html(replays)}
</body></html>
"""
    html_path = d / "report.html"
    html_path.write_text(page, encoding="utf-8")
    return [md_path, html_path]


def _replays(store: Store, experiment: str, viewers: dict[str, str]) -> list[tuple[str, list[tuple[int, str]]]]:
    """(variant, [(seed, viewer path)]) for each variant with a viewer, in spec order."""
    from swarmnav.experiments.runner import job_rows

    meta = store.meta(f"experiment:{experiment}")
    out: dict[str, list[tuple[int, str]]] = {}
    for r in job_rows(store, meta):
        if r["key"] in viewers:
            out.setdefault(r["variant"], []).append((r["seed"], viewers[r["key"]]))
    return list(out.items())


def _replays_html(replays: list[tuple[str, list[tuple[int, str]]]]) -> str:
    if not replays:
        return ""
    e = html.escape
    items = "\n".join(f"<li>{e(name)}: " + " · ".join(f'<a href="{e(path, quote=True)}">seed {seed}</a>'
                                                     for seed, path in links) + "</li>" for name, links in replays)
    return (f'<section id="replays"><h2>Replays</h2><p>Each run\'s replay viewer, by variant and seed.</p>'
            f"<ul>\n{items}\n</ul></section>")
