"""Declarative experiment specs: a named set of run configurations (variants) x seeds.

A spec is a TOML file (shipped ones live in ``swarmnav/experiments/specs``)::

    name = "apf-scenes"
    method = "apf"             # defaults inherited by every variant
    scenario = "default_corridor"
    steps = 1000
    seeds = "1-10"
    [params]                   # method parameters common to all variants
    k_att = 2.0
    [[variants]]
    name = "gates"
    scenario = "narrow_alternating_gates"
    [variants.params]
    k_rep = 4.0

A ``[matrix]`` table crosses lists into variants named ``a/b``: ``matrix = {method = ["hes",
"apf"], scenario = ["default_corridor", "off_axis_goal"]}`` gives four variants (added to any
``[[variants]]``). A ``[report]`` table tells ``swarmnav report`` which published table the
experiment reproduces: ``reference = "hes.table3"`` (a table of the packaged
``paper_results.toml``), ``metrics = [...]`` (columns, in order), optional ``title`` and
``variant_map = {variant = "reference_key"}`` when names differ (or ``["reference_key", i]``: entry
``i`` of the key's per-scene lists), ``metric_map = {metric = "paper_key"}`` (or ``["paper_key",
factor]``, the factor from the paper's unit to ours) when the paper names a metric otherwise, and
``compare = ["A", "B"]``,
the pair of variants whose paired-seed percent changes (B against A) the report draws. A
``[report.differences]`` table lists pairs ``[A, B]`` whose B − A the report gives with 95 %
intervals: ``success = "sph_success"`` (a 0/1 metric), ``metrics = ["flight_distance"]``
(continuous, over the seeds where both succeeded) and ``pairs = [["sph/0.15", "mader/0.15"]]``.
A ``[report.lines]`` table draws metrics against a variable, one line per value of another
(:mod:`swarmnav.experiments.lines`): ``x = "n"``, ``series = "density"``, ``metrics = [...]``.

``[one_at_a_time]`` sweeps factors one at a time: ``"net.latency" = [0.0, 0.05]``, ``"net.loss" =
[0.0, 0.3]`` gives every variant at the baseline (each factor's first level; ``NAME/baseline``) and
at each other level of one factor with the rest at baseline (``NAME/net.loss=0.3``): the union of
one sweep per factor, not their product. A ``[report.robustness]`` table draws success and distances
against each factor (:mod:`swarmnav.experiments.robustness`).

``--set key=value`` overrides apply to every variant: ``method``, ``scenario``, ``steps``,
``n`` (swarm size), a declared scenario variable, or a method parameter. ``key=a|b|c`` sweeps:
every variant is repeated for each value, and the value is appended to the variant name.

Scenario variables: ``scenario_vars = {density = 0.25}`` declares placeholders of the scenario
string with their defaults, e.g. ``scenario = "random_forest:density={density},seed={seed}"``;
``--set density=0.15|0.35`` then fills the scene instead of becoming a method parameter.
``{seed}`` is always the run's seed (one seed, one generated scene).
"""

from __future__ import annotations

import itertools
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from swarmnav.errors import ConfigError
from swarmnav.experiments import lines, robustness
from swarmnav.experiments.paired import check_variants
from swarmnav.params import coerce, flatten

_SPEC_KEYS = {"name", "description", "method", "scenario", "steps", "horizon", "seeds", "n", "params", "variants",
              "matrix",
              "report", "scenario_vars", "one_at_a_time"}
_REPORT_KEYS = {"reference", "reference_index", "metrics", "title", "variant_map", "metric_map", "figures", "compare",
                "differences", "lines", "trajectory_metrics", "robustness"}
_DIFFERENCES_KEYS = {"success", "metrics", "pairs"}
_MATRIX_KEYS = {"method", "scenario", "n", "steps"}
_VARIANT_KEYS = {"name", "method", "scenario", "steps", "horizon", "n", "params"}
_RUN_KEYS = {"method", "scenario", "steps", "horizon", "n"}


@dataclass(frozen=True, slots=True)
class Variant:
    """One run configuration; runs are ``(variant, seed)`` pairs."""

    name: str
    method: str
    scenario: str
    steps: int
    n: int | None = None
    params: dict[str, Any] = field(default_factory=dict)
    horizon: float | None = None  # [s] if set, steps = horizon / the method's dt (equal time across methods)
    #: what places the variant in the sweep: its [matrix] values, the scenario variables and the
    #: --set values (``{"n": 15, "density": "0.25"}``); the report's line figure reads x and series here
    variables: dict[str, Any] = field(default_factory=dict)

    def columns(self) -> dict[str, Any]:
        """Config columns of runs.csv for this variant."""
        cols = {"variant": self.name, "method": self.method, "scenario": self.scenario, "steps": self.steps,
                "n": self.n if self.n is not None else ""}
        cols.update({f"param.{k}": v for k, v in sorted(self.params.items())})
        return cols


@dataclass(frozen=True, slots=True)
class Experiment:
    name: str
    description: str
    variants: tuple[Variant, ...]
    seeds: tuple[int, ...]
    report: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, str] = field(default_factory=dict)  # the --set KEY=VALUE it was loaded with


def builtin_names() -> list[str]:
    files = resources.files("swarmnav.experiments").joinpath("specs").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def load_experiment(name_or_path: str, *, overrides: dict[str, str] | None = None,
                    seeds: str | None = None) -> Experiment:
    """Load a shipped experiment by name or a spec file, apply ``--set`` overrides and seeds."""
    p = Path(name_or_path)
    if name_or_path.endswith(".toml") or p.exists():
        try:
            text, source = p.read_text(encoding="utf-8"), str(p)
        except OSError as e:
            raise ConfigError(f"{p}: cannot read experiment spec: {e}") from None
    elif name_or_path in builtin_names():
        text = resources.files("swarmnav.experiments").joinpath("specs", f"{name_or_path}.toml").read_text("utf-8")
        source = f"{name_or_path}.toml"
    else:
        raise ConfigError(f"unknown experiment '{name_or_path}' (known: {', '.join(builtin_names())})")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{source}: malformed TOML: {e}") from None
    return from_dict(data, source, overrides or {}, seeds)


def from_dict(data: dict, source: str, overrides: dict[str, str], seeds: str | None) -> Experiment:
    bad = set(data) - _SPEC_KEYS
    if bad:
        raise ConfigError(f"{source}: unknown key(s) {sorted(bad)} (allowed: {sorted(_SPEC_KEYS)})")
    name = data.get("name", Path(source).stem)
    base = {k: data[k] for k in _RUN_KEYS if k in data}
    base_params = _params(data.get("params", {}), f"{source}: params")
    raw_variants = list(data.get("variants", []))
    matrix = data.get("matrix", {})
    if not isinstance(matrix, dict) or set(matrix) - _MATRIX_KEYS:
        raise ConfigError(f"{source}: [matrix] may only list {sorted(_MATRIX_KEYS)}")
    placed = [{} for _ in raw_variants]  # each variant's matrix values
    given = dict(overrides)
    if set(matrix) & set(overrides):  # --set on a matrix axis replaces the axis: `--set n=60` flies 60 only
        matrix, overrides = dict(matrix), dict(overrides)
        for k in set(matrix) & set(overrides):
            vals = str(overrides.pop(k)).split("|")
            matrix[k] = [coerce(x, int, f"--set {k}") for x in vals] if k in ("n", "steps") else vals
    if matrix:
        axes = list(matrix)
        lists = [m if isinstance(m, list) else [m] for m in matrix.values()]
        for combo in itertools.product(*lists):
            raw_variants.append({"name": "/".join(str(c) for c in combo), **dict(zip(axes, combo))})
            placed.append(dict(zip(axes, combo)))
    raw_variants, placed = (raw_variants, placed) if raw_variants else ([{"name": "default"}], [{}])
    factors = _factors(data.get("one_at_a_time"), overrides, source)
    if factors:  # every variant at the baseline and at each other level of one factor at a time
        overrides = {k: v for k, v in overrides.items() if k not in factors}
        raw_variants, placed = _one_at_a_time(raw_variants, placed, factors)
    report = data.get("report", {})
    if not isinstance(report, dict) or set(report) - _REPORT_KEYS:
        raise ConfigError(f"{source}: [report] unknown key(s) {sorted(set(report) - _REPORT_KEYS)} "
                          f"(allowed: {sorted(_REPORT_KEYS)})")
    variants: list[Variant] = []
    for k, v in enumerate(raw_variants):
        bad = set(v) - _VARIANT_KEYS
        if bad:
            raise ConfigError(f"{source}: variants[{k}] unknown key(s) {sorted(bad)} (allowed: {sorted(_VARIANT_KEYS)})")
        cfg = {**base, **{kk: v[kk] for kk in _RUN_KEYS if kk in v}}
        for req in ("method", "scenario"):
            if req not in cfg:
                raise ConfigError(f"{source}: variants[{k}] has no '{req}' (set it in the variant or at top level)")
        if "steps" not in cfg and "horizon" not in cfg:
            raise ConfigError(f"{source}: variants[{k}] has no 'steps' or 'horizon' (set one in the variant or at top level)")
        params = {**base_params, **_params(v.get("params", {}), f"{source}: variants[{k}].params")}
        horizon = float(cfg["horizon"]) if "horizon" in cfg and "steps" not in v else None
        if horizon is not None:
            cfg["steps"] = steps_for(str(cfg["method"]), params, horizon)
        variants.append(Variant(
            name=str(v.get("name", f"v{k}")), method=str(cfg["method"]), scenario=str(cfg["scenario"]),
            steps=int(cfg["steps"]), n=cfg.get("n"), params=params, horizon=horizon, variables=placed[k],
        ))
    svars = data.get("scenario_vars", {})
    if not isinstance(svars, dict) or set(svars) & (_RUN_KEYS | {"seed"}) or not all(
            isinstance(x, (int, float, str)) and not isinstance(x, bool) for x in svars.values()):
        raise ConfigError(f"{source}: scenario_vars must map new names (not {sorted(_RUN_KEYS | {'seed'})}) "
                          f"to numbers or strings")
    if "trajectory_metrics" in report:
        from swarmnav.metrics.oscillation import FROM_TRAJECTORY

        tm = report["trajectory_metrics"]
        if not isinstance(tm, list) or not all(isinstance(m, str) and m in FROM_TRAJECTORY for m in tm):
            raise ConfigError(f"{source}: [report] trajectory_metrics must list metrics computed from a stored "
                              f"trajectory ({sorted(FROM_TRAJECTORY)}), got {tm!r}")
    if "compare" in report:
        if not isinstance(report["compare"], list) or not all(isinstance(x, str) for x in report["compare"]):
            raise ConfigError(f"{source}: [report] compare must be a list of two variant names")
        check_variants(report["compare"], [v.name for v in variants], where=f"{source}: [report] compare")
    if "differences" in report:
        _check_differences(report["differences"], [v.name for v in variants], f"{source}: [report.differences]")
    variants = _apply_overrides(variants, overrides, svars)
    if "lines" in report:
        lines.check(report["lines"], [(v.name, v.variables) for v in variants], set(matrix) | set(svars) | set(overrides),
                    f"{source}: [report.lines]")
    if "robustness" in report:
        robustness.check(report["robustness"], f"{source}: [report.robustness]")
        robustness.check_variants(report["robustness"], [(v.name, v.scenario, v.variables) for v in variants],
                                  f"{source}: [report.robustness]")
    _check_params(variants, source)
    seed_list = parse_seeds(seeds if seeds is not None else str(data.get("seeds", "1-10")))
    names = [v.name for v in variants]
    if len(set(names)) != len(names):
        raise ConfigError(f"{source}: variant names must be unique, got {names}")
    return Experiment(name=name, description=str(data.get("description", "")), variants=tuple(variants),
                      seeds=seed_list, report=dict(report), overrides=given)


def _factors(table: Any, overrides: dict[str, str], source: str) -> dict[str, list[Any]]:
    """A spec's ``[one_at_a_time]`` table: parameter or run-option name -> its levels, the first the
    baseline (a ``--set`` of the name replaces its levels, as on a [matrix] axis); {} if absent."""
    if table is None:
        return {}
    where = f"{source}: [one_at_a_time]"
    if not isinstance(table, dict) or not table:
        raise ConfigError(f"{where} must map parameter names to lists of levels, got {table!r}")
    out: dict[str, list[Any]] = {}
    for k, levels in flatten(table).items():
        if k in _RUN_KEYS or k in ("seed", "preset"):
            raise ConfigError(f"{where} '{k}' cannot be a factor (factors are method parameters or run "
                              f"options such as net.latency)")
        if k in overrides:
            levels = str(overrides[k]).split("|")
        if not isinstance(levels, list) or len(levels) < 2 or not all(
                isinstance(x, (int, float, str)) and not isinstance(x, bool) for x in levels):
            raise ConfigError(f"{where} '{k}' must list two or more levels (the first is the baseline), got {levels!r}")
        if len({str(x) for x in levels}) != len(levels):
            raise ConfigError(f"{where} '{k}' lists a level twice: {levels!r}")
        out[k] = levels
    return out


def _one_at_a_time(raw: list[dict], placed: list[dict], factors: dict[str, list[Any]]) -> tuple[list[dict], list[dict]]:
    """Each variant once with every factor at its baseline (``NAME/baseline``) and once per other
    level of each factor, the rest at baseline (``NAME/net.latency=0.15``): the union of one sweep
    per factor, not their product. Every variant's parameters name every factor, and its variables
    record them and ``varied``, the factor it moves ("" at the baseline). Adding a factor adds
    variants and leaves the names of the others as they were."""
    base = {k: levels[0] for k, levels in factors.items()}
    settings = [("", "baseline", base)] + [(k, f"{k}={x}", {**base, k: x})
                                           for k, levels in factors.items() for x in levels[1:]]
    out, where = [], []
    for v, p in zip(raw, placed):
        for varied, tag, values in settings:
            params = {**dict(v.get("params", {})), **values}
            out.append({**v, "name": f"{v.get('name', 'default')}/{tag}", "params": params})
            where.append({**p, **values, "varied": varied})
    return out, where


def _check_differences(table: Any, known: list[str], where: str) -> None:
    """``[report.differences]``: ``success`` a metric name, ``metrics`` a list of names, ``pairs`` a
    non-empty list of two different known variants each; a one-line ConfigError otherwise."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table with {sorted(_DIFFERENCES_KEYS)}, got {table!r}")
    bad = set(table) - _DIFFERENCES_KEYS
    if bad:
        raise ConfigError(f"{where} unknown key(s) {sorted(bad)} (allowed: {sorted(_DIFFERENCES_KEYS)})")
    success = table.get("success")
    if not isinstance(success, str) or not success:
        raise ConfigError(f"{where} success must be the name of a 0/1 metric (e.g. \"sph_success\"), got {success!r}")
    metrics = table.get("metrics", [])
    if not isinstance(metrics, list) or not all(isinstance(m, str) and m for m in metrics):
        raise ConfigError(f"{where} metrics must be a list of metric names, got {metrics!r}")
    if success in metrics:
        raise ConfigError(f"{where} metrics lists the success metric '{success}' (it is compared as a rate)")
    pairs = table.get("pairs")
    if not isinstance(pairs, list) or not pairs:
        raise ConfigError(f"{where} pairs must be a non-empty list of [A, B] variant pairs, got {pairs!r}")
    for k, pair in enumerate(pairs):
        if not isinstance(pair, list) or not all(isinstance(x, str) for x in pair):
            raise ConfigError(f"{where} pairs[{k}] must be a list of two variant names, got {pair!r}")
        check_variants(pair, known, where=f"{where} pairs[{k}]")


def _params(table: Any, where: str) -> dict[str, Any]:
    """A params table, nested tables as dotted names (``[params.passage] on = false`` is ``passage.on``)."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table of KEY = VALUE, got {table!r}")
    return flatten(table)


def _check_params(variants: list[Variant], source: str) -> None:
    """Build every variant's method once, so a bad parameter fails the whole experiment before
    its first run (one line naming the variant), not every run of it."""
    from swarmnav.methods import registry
    from swarmnav.sim.rollout import is_run_option

    seen = set()
    for v in variants:
        key = (v.method, tuple(sorted((k, str(x)) for k, x in v.params.items())))
        if key in seen:
            continue
        seen.add(key)
        try:
            registry.make(v.method, **{k: x for k, x in v.params.items() if not is_run_option(k)})
        except ConfigError as e:
            raise ConfigError(f"{source}: variant {v.name}: {e}") from None


def _fill_scenario(template: str, values: dict[str, Any]) -> str:
    """Substitute ``{name}`` placeholders of a scenario string; only ``{seed}`` may remain."""
    out = template
    for k, val in values.items():
        out = out.replace("{" + k + "}", str(val))
    left = [part.split("}", 1)[0] for part in out.split("{")[1:]]
    unknown = sorted(set(left) - {"seed"})
    if unknown:
        raise ConfigError(f"scenario {template!r}: placeholder(s) {unknown} have no value (declare them in scenario_vars)")
    return out


def _apply_overrides(variants: list[Variant], overrides: dict[str, str], svars: dict[str, Any]) -> list[Variant]:
    if not overrides:
        return [Variant(name=v.name, method=v.method, scenario=_fill_scenario(v.scenario, svars), steps=v.steps,
                        n=v.n, params=v.params, horizon=v.horizon, variables={**v.variables, **svars})
                for v in variants]
    keys = list(overrides)
    choices = [str(overrides[k]).split("|") for k in keys]
    swept = [k for k, c in zip(keys, choices) if len(c) > 1]
    out = []
    for v in variants:
        for combo in itertools.product(*choices):
            cfg = {"method": v.method, "scenario": v.scenario, "steps": v.steps, "n": v.n}
            params = dict(v.params)
            values = dict(svars)
            horizon = v.horizon if "steps" not in keys else None
            for k, val in zip(keys, combo):
                if k in svars:
                    values[k] = val
                elif k == "horizon":  # [s], for every method in its own steps
                    horizon = coerce(val, float, "--set horizon")
                elif k in ("steps", "n"):
                    cfg[k] = coerce(val, int, f"--set {k}")
                elif k in ("method", "scenario"):
                    cfg[k] = val
                else:
                    params[k] = val
            cfg["scenario"] = _fill_scenario(cfg["scenario"], values)
            if "steps" in keys and "horizon" in keys:
                raise ConfigError("--set steps and --set horizon exclude each other")
            if horizon is not None:  # the method may have changed: its dt sets the step count
                cfg["steps"] = steps_for(cfg["method"], params, horizon)
            suffix = ",".join(f"{k}={val}" for k, val in zip(keys, combo) if k in swept)
            name = f"{v.name}[{suffix}]" if suffix else v.name
            variables = {**v.variables, **values, **dict(zip(keys, combo))}
            if "n" in keys:
                variables["n"] = cfg["n"]
            out.append(Variant(name=name, params=params, horizon=horizon, variables=variables, **cfg))
    return out


def steps_for(method: str, params: dict[str, Any], horizon: float) -> int:
    """Steps that cover ``horizon`` seconds with the method's own integration step."""
    from swarmnav.methods import registry

    from swarmnav.sim.rollout import is_run_option, steps_for_horizon

    dt = float(registry.make(method, **{k: v for k, v in params.items() if not is_run_option(k)}).dt)
    return steps_for_horizon(horizon, dt)


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"1-10"``, ``"1,3,5"``, ``"1-3,7"`` -> tuple of ints (order kept, duplicates removed)."""
    seeds: list[int] = []
    try:
        for part in filter(None, (s.strip() for s in str(text).split(","))):
            if "-" in part[1:]:
                a, b = part.split("-", 1) if not part.startswith("-") else (part, "")
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise ValueError
                seeds.extend(range(lo, hi + 1))
            else:
                seeds.append(int(part))
    except ValueError:
        raise ConfigError(f"--seeds: expected a list like 1-10 or 1,3,5, got {text!r}") from None
    if not seeds:
        raise ConfigError(f"--seeds: no seeds in {text!r}")
    if min(seeds) < 0:
        raise ConfigError(f"--seeds: seeds must be >= 0, got {text!r}")
    return tuple(dict.fromkeys(seeds))
