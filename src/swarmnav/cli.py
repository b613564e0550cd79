"""The ``swarmnav`` command: a thin layer over the library.

Bad input (unknown scene, malformed file, unknown ``--set`` key, ...) ends with one line on
stderr and exit code 2; no traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Sequence

from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.params import coerce

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse prints the usage block too)
        raise ConfigError(f"{self.prog}: {message}")


def _parse_sets(items: Sequence[str] | None) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items or ():
        key, eq, val = item.partition("=")
        if not eq or not key.strip():
            raise ConfigError(f"--set expects key=value, got {item!r}")
        out[key.strip()] = val.strip()
    return out


#: LLM decision flags (HES Section 3.3): sugar for ``--set KEY=VALUE``, see docs/llm.md.
_LLM_FLAGS = (
    ("--decision", "decision", "rule (default) | ollama | openai | llamacpp | replay | oracle (docs/oracle.md)"),
    ("--llm-url", "llm_url", "model server URL (ollama: http://HOST:11434, openai: http://HOST:PORT/v1)"),
    ("--llm-model", "llm_model", "model name on the server (default qwen2.5:3b)"),
    ("--llm-timeout", "llm_timeout", "per-call timeout [s] (default 120)"),
    ("--llm-interval", "llm_interval", "steps between LLM calls, T_llm (default 50)"),
    ("--llm-gguf", "llm_gguf", "GGUF model file for --decision llamacpp"),
    ("--llm-latency", "llm_latency", "blocking (default) | real | fixed:SECONDS"),
    ("--llm-replay", "llm_replay", "transcript or run directory for --decision replay"),
)


def _add_llm_flags(p: argparse.ArgumentParser) -> None:
    for flag, key, text in _LLM_FLAGS:
        p.add_argument(flag, dest=key, metavar=key.removeprefix("llm_").upper(), help=text)


def _llm_sets(args, params: dict[str, str]) -> dict[str, str]:
    """``params`` with the LLM flags added; a flag and a ``--set`` of the same key must agree."""
    for flag, key, _ in _LLM_FLAGS:
        value = getattr(args, key, None)
        if value is None:
            continue
        if key in params and params[key] != value:
            raise ConfigError(f"{flag} {value} contradicts --set {key}={params[key]}")
        params[key] = value
    return params


def _writable_dir(path, flag: str, shown=None) -> Path:
    """Create ``path`` (with parents) and check it can be written, before any long work."""
    d, shown = Path(path), shown or path
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ConfigError(f"{flag} {shown}: cannot create the directory {d} ({e.strerror})") from None
    try:  # os.access says yes to root even where files cannot be made (/proc, read-only mounts)
        with tempfile.TemporaryFile(dir=d):
            pass
    except OSError as e:
        raise ConfigError(f"{flag} {shown}: cannot write in {d} ({e.strerror})") from None
    return d


def _writable_file(path, flag: str) -> Path:
    """``path``'s directory exists (created if needed) and is writable."""
    _writable_dir(Path(path).parent, flag, shown=path)
    return Path(path)


def _run_outputs() -> tuple[str, ...]:
    """The file names a run directory gets from swarmnav: the run's own files, the LLM
    transcript, and the figures and viewer ``run --plot/--view``, ``plot`` and ``view`` write."""
    from swarmnav.llm.decider import TRANSCRIPT
    from swarmnav.sim.result import RUN_FILES

    return (*RUN_FILES, TRANSCRIPT, "trajectory.png", "perspective.png", "viewer.html")


def _claim_run_dir(d: Path, force: bool) -> list[Path]:
    """Check ``run --out DIR`` before the run: a directory that already holds a run (any of
    :func:`_run_outputs`, or its half-written ``.tmp``) is refused unless ``force``, since the
    new run would keep the old one's figure, viewer or transcript beside its own files. With
    ``force``, returns those files for the caller to remove; other files are never touched."""
    names = [n for name in _run_outputs() for n in (name, name + ".tmp")]
    blocked = [n for n in names if (d / n).exists() and not (d / n).is_file()]
    if blocked:
        raise ConfigError(f"run: --out {d}: {d / blocked[0]} is a directory, where a run writes a file")
    found = [n for n in names if (d / n).is_file()]
    if found and not force:
        raise ConfigError(f"run: --out {d} already holds a run ({', '.join(found[:4])}"
                          f"{', ...' if len(found) > 4 else ''}); --force replaces it, or choose another directory")
    return [d / n for n in found]


def _clear_run(d: Path, old: list[Path]) -> None:
    """Remove the previous run's files (``run --force``) and name on stderr what is kept."""
    for f in old:
        f.unlink(missing_ok=True)
    others = sorted(p.name for p in d.iterdir() if p.name not in
                    {n for name in _run_outputs() for n in (name, name + ".tmp")})
    if others:
        print(f"swarmnav: --force replaced the run in {d}; kept files that are not a run's: {', '.join(others)}",
              file=sys.stderr)


def _cmd_scenarios(args) -> int:
    from swarmnav.world.catalog import load_scenario
    from swarmnav.world.generators import GENERATORS
    from swarmnav.world.scenario import builtin_names

    if args.action is None:
        for name in builtin_names():
            s = load_scenario(name)
            print(f"{name:28s} N={s.n:<4d} goal=({s.goal[0]:g}, {s.goal[1]:g}) m  {s.description}")
        print("generators: " + ", ".join(f"{g}:key=value,..." for g in GENERATORS))
        print("map files (docs/maps.md): X.map.scen#ROW, X.map#start=x:y,goal=x:y, X.yaml#start=x:y,goal=x:y, "
              "X.3dmap#start=x:y:z,goal=x:y:z, X.ply#start=x:y:z,goal=x:y:z,cell=0.1 (or X.pcd)")
        return 0
    if args.action != "show" or not args.name:
        raise ConfigError("usage: swarmnav scenarios [show NAME [--plot PNG]]")
    s = load_scenario(args.name)
    if args.plot:
        _writable_file(args.plot, "--plot")
    print(json.dumps(s.to_dict(), indent=2) if args.json else s.to_toml(), end="\n" if args.json else "")
    if args.plot:
        from swarmnav.viz import plot_scene

        print(f"wrote {plot_scene(s, args.plot)}", file=sys.stderr)
    return 0


def _cmd_methods(args) -> int:
    from swarmnav.methods import registry

    if args.name is None:
        plugins = set(registry.plugins())
        for name in registry.names():
            print(f"{name:10s} {registry.spec(name).description}" + ("  [plugin]" if name in plugins else ""))
        print("swarmnav methods NAME lists a method's parameters: default, unit, valid range, source")
        for why in registry.plugin_errors():  # a broken plugin is named; the others fly as ever
            print(f"swarmnav: warning: {why}", file=sys.stderr)
        return 0
    _print_params(registry.spec(args.name), sys.stdout)
    return 0


def _cmd_check_method(args) -> int:
    from swarmnav.sim.check import check_method, scenes_of

    scenes = None
    if args.scenes:
        scenes = [x.strip() for x in args.scenes.split(",") if x.strip()]
        known = scenes_of(args.name)
        unknown = [x for x in scenes if x not in known]
        if unknown:
            raise ConfigError(f"--scenes: {', '.join(unknown)} not among the scenes {args.name} can fly "
                              f"({', '.join(known)})")
    if args.steps is not None and args.steps < 1:
        raise ConfigError(f"--steps must be >= 1, got {args.steps}")
    verdicts = check_method(args.name, scenes, args.steps, report=lambda v: print(v.line(), flush=True))
    failed = sum(not v.ok for v in verdicts)
    print(f"{args.name}: {'conforms' if not failed else f'{failed} of {len(verdicts)} checks failed'}")
    return 0 if not failed else 1


def _print_params(spec, out) -> None:
    """The parameter table of a registered method (``swarmnav methods NAME``)."""
    import shutil
    import textwrap

    from swarmnav.params import aliases, default_build, describe, differences, preset_aliases, preset_doc, presets

    def shown(v) -> str:
        return ("true" if v else "false") if isinstance(v, bool) else ('""' if v == "" else f"{v:g}" if isinstance(v, float) else str(v))

    dims = getattr(spec.factory, "dims", None) or getattr(getattr(spec.factory, "func", None), "dims", ())
    print(f"{spec.name}: {spec.description}", file=out)
    if dims:
        planar = " (a 3-D scene is flown in its horizontal slice at z_fly)" if tuple(dims) == (2,) else ""
        print(f"worlds: {' and '.join(f'{d}-D' for d in dims)}{planar}", file=out)
    print("run options (--set): n = swarm size [-]" + (", z_fly = altitude of the slice flown in a 3-D scene [m]"
                                                      if tuple(dims) == (2,) else "")
          + (", plans = false keeps no committed trajectories (docs/methods/contract.md)"
             if callable(getattr(spec.factory, "plans", None)) else ""), file=out)
    if spec.networked:
        from swarmnav.sim.network import NetParams

        net = ", ".join(f"net.{i.name} [{i.unit or '-'}] {i.range}" for i in describe(NetParams))
        print(f"network (--set net.NAME; docs/network.md; defaults: the ideal network): {net}", file=out)
    else:
        print("network: the ideal one only (this method does not read the others through a network yet)", file=out)
    from swarmnav.sensing.perception import MAP_OPTIONS, RANGE_OPTIONS, SenseParams

    ranged = getattr(spec.factory, "range_sensor", False)
    mapping = getattr(spec.factory, "map_sensor", False)
    sense = ", ".join(f"sense.{i.name} [{i.unit or '-'}] {' | '.join(i.choices) if i.choices else i.range}"
                      for i in describe(SenseParams)
                      if (ranged or mapping or i.name not in RANGE_OPTIONS) and (mapping or i.name not in MAP_OPTIONS))
    print(f"perception (--set sense.NAME; docs/sensing.md; defaults: perfect perception): {sense}"
          + ("" if ranged else " (the range options apply to the scans of sense.map=scans)" if mapping
             else " (no range sensor: the range options do not apply)"), file=out)
    from swarmnav.dynamics.vehicle import VehicleParams
    from swarmnav.dynamics.wind import WindParams

    names = {"model": "vehicle", "downwash": "downwash"}

    def values(i) -> str:
        if i.choices:
            return "|".join(map(str, i.choices))
        return {"bool": "true|false", "text": "a name"}.get(i.kind, str(i.range))

    veh = ", ".join(f"{names.get(i.name, 'vehicle.' + i.name)} [{i.unit or '-'}] {values(i)}"
                    for i in describe(VehicleParams)) + ", " + ", ".join(
        f"wind.{i.name} [{i.unit or '-'}] {values(i)}" for i in describe(WindParams))
    print(f"vehicle (--set; docs/vehicle.md; defaults: the method's own point mass): {veh}", file=out)
    table = presets(spec.params)
    if table:
        cls, default = spec.params, default_build(spec.params)
        paper = "paper" if "paper" in table else None
        print(f"builds: the default is {f'preset={default}' if default else 'the defaults'}; the paper's is "
              f"{f'preset={paper}' if paper else 'none'}" + (" (the same build)" if paper == default else ""), file=out)
        print("presets (--set preset=NAME; values given beside it apply on top):", file=out)
        for name in table:
            tag = ", ".join(t for t, on in (("the default", name == default), ("the paper", name == paper)) if on)
            tag = f" ({tag})" if tag else ""
            print(f"  {name}{tag}: {preset_doc(cls, name) or 'no description'}", file=out)
            if name == default:
                continue
            diff = differences(cls, name)
            if not diff:
                print("    = the default build", file=out)
                continue
            print(f"    differs from the default in {len(diff)} parameter(s) (default -> {name}):", file=out)
            w = max(len(k) for k, _, _ in diff)
            for k, a, b in diff:
                print(f"      {k:{w}s}  {shown(a)} -> {shown(b)}", file=out)
        for old, new in preset_aliases(cls).items():
            print(f"  {old}: the earlier name of preset {new} (still accepted, same values)", file=out)
    old = aliases(spec.params)
    if old:
        print(f"older flat names are accepted too ({len(old)}, e.g. {', '.join(f'{k} = {v}' for k, v in list(old.items())[:2])})",
              file=out)
    rows = [(i.name, shown(i.default), i.unit or "-", i.valid, i.source, i.doc) for i in describe(spec.params)]
    head = ("parameter", "default", "unit", "valid", "source", "meaning")
    widths = [max(len(r[c]) for r in [head, *rows]) for c in range(5)]
    lead = sum(widths) + 2 * 5
    width = shutil.get_terminal_size((120, 24)).columns if out.isatty() else 0
    for r in [head, *rows]:
        cells = "  ".join(c.ljust(w) for c, w in zip(r[:5], widths))
        meaning = [r[5]] if width - lead < 30 else textwrap.wrap(r[5], width - lead) or [""]
        print(f"{cells}  {meaning[0]}".rstrip(), file=out)
        for more in meaning[1:]:
            print(" " * lead + more, file=out)


def _cmd_run(args) -> int:
    from swarmnav.sim import run
    from swarmnav.world.catalog import load_scenario

    if (args.scenario is None) == (args.scenario_file is None):
        raise ConfigError("run: give exactly one of --scenario NAME or --scenario-file PATH")
    if args.steps is not None and args.steps < 1:
        raise ConfigError(f"run: --steps must be >= 1, got {args.steps}")
    horizon = args.horizon
    if args.steps is None and horizon is None:
        steps = 1000
    else:
        steps = args.steps
    params = _llm_sets(args, _parse_sets(args.set))
    n = params.pop("n", None)
    n = None if n is None else coerce(n, int, "--set n")
    scn = load_scenario(Path(args.scenario_file) if args.scenario_file else args.scenario, n=n)
    old_run = _claim_run_dir(_writable_dir(args.out, "--out"), args.force)
    progress = sys.stderr.isatty() and not args.quiet
    res = run(args.method, scn, seed=args.seed, steps=steps, horizon=horizon, progress=progress, **params)
    if old_run:  # only now: a run that fails keeps the previous one in place
        _clear_run(Path(args.out), old_run)
    out = res.save(args.out)
    m = res.metrics
    steps = res.config["steps"]
    print(f"{res.config['method']} on {scn.name}, seed {args.seed}, {steps} steps of {res.config['dt']:g} s "
          f"({res.config['horizon']:g} s simulated, {res.wall_time:.2f} s wall)")
    contacts = (f"  collisions = {m['collisions']:.0f}  crashes = {m['crashes']:.0f} of {res.positions.shape[1]} "
                f"(contact = {res.config['rules']['contact']})")
    if "Y" in m:  # a goal to reach: the navigation metrics
        print(f"  Y = {m['Y']:.0f}  R_goal = {m['R_goal']:.3f}  E_mean = {m['E_mean']:.3f} m  "
              f"R_unsafe = {m['R_unsafe']:.3f}  d_clr_min = {m['d_clr_min']:.3f} m"
              + (f"  L_mean = {m['L_mean']:.1f} m" if "L_mean" in m else "") + contacts)
    else:  # no goal (a periodic box): what the Vicsek family is judged by (HWVEM Table 1)
        print("  no goal (periodic box)  "
              + (f"converged = {m['converged']:.0f}  k_con = {m['k_con']:.0f} steps  "
                 f"deg_con_final = {m['deg_con_final']:.3f}  " if "k_con" in m else "")
              + f"min_inter_agent_distance = {m['min_inter_agent_distance']:.3f} m" + contacts)
    if args.plot:
        from swarmnav.viz import plot_run

        print(f"  figure: {plot_run(res, out / 'trajectory.png')}")
    if args.view:
        from swarmnav.viz.viewer import llm_marks, write_viewer

        print(f"  viewer: {write_viewer(res, out / 'viewer.html', marks=llm_marks(out))}")
    if "hes_oracle_decisions" in m:  # decision=oracle (docs/oracle.md)
        t = res.timings
        print(f"  oracle: {m['hes_oracle_decisions']:.0f} decision points flown ahead, {m['hes_oracle_changed']:.0f} "
              f"changed from the rule's action, {m['hes_oracle_steps_per_decision']:.0f} lookahead steps and "
              f"{t.get('oracle_ms_per_decision', float('nan')):.0f} ms per decision point")
    if m.get("llm_calls", 0) > 0 and "llm_latency_median_s" in m:
        print(f"  LLM: {m['llm_calls']:.0f} calls, {m['llm_fallback_used']:.0f} fallbacks, "
              f"{m['llm_projected']:.0f} projected to keep, latency median {m['llm_latency_median_s']:.2f} s "
              f"(max {m['llm_latency_max_s']:.2f} s)")
        if "llm_valid" in m:
            print(f"  LLM answers: {m['llm_valid']:.0f} valid, {m['llm_feasible']:.0f} feasible, "
                  f"{m['llm_agree_rule']:.0f} equal to the rule's, {m['llm_differs_feasible']:.0f} feasible and "
                  f"different from the rule's")
    print(f"  wrote {out}/metrics.json, trajectory.npz, config.json" + "".join(f", {a}" for a in res.artifacts))
    return 0


def _cmd_llm(args) -> int:
    from swarmnav.llm.check import check
    from swarmnav.llm.config import LlmParams
    from swarmnav.params import build

    if args.action == "label":
        return _llm_label(args)
    params = _llm_sets(args, _parse_sets(args.set))
    params.setdefault("decision", "ollama")
    if args.action == "check":
        return check(build(LlmParams, params, context="llm check"), sys.stdout)
    from swarmnav.llm import bench

    p = build(LlmParams, params, context="llm bench")
    states = bench.load_states(args.states)
    if args.choice:  # the states where an answer can change the executed action
        states = [r for r in states if len(r["feasible"]) > 1]
    states = states[: args.limit or None]
    if args.transcript:
        with open(args.transcript, "w", encoding="utf-8") as sink:
            res = bench.bench(p, states, progress=sys.stderr, sink=sink)
    else:
        res = bench.bench(p, states, progress=sys.stderr)
    bench.report(res, sys.stdout)
    if args.summary:
        res.write_summary(args.summary)
        print(f"  wrote {args.summary}")
    return 0


def _llm_label(args) -> int:
    """``swarmnav llm label --states IN --out OUT``: the oracle's labels of recorded states."""
    import json

    from swarmnav.llm import bench
    from swarmnav.llm.labels import label_states

    if not args.out:
        raise ConfigError("llm label needs --out FILE (the labelled states)")
    rows = bench.load_states(args.states)[: args.limit or None]
    rows = label_states([{k: v for k, v in r.items() if k != "oracle"} for r in rows], progress=sys.stderr)
    try:
        with open(args.out, "w", encoding="utf-8") as f:
            f.writelines(json.dumps(r, allow_nan=False) + "\n" for r in rows)
    except OSError as e:
        raise ConfigError(f"--out {args.out}: cannot write it ({e.strerror})") from None
    print(f"labelled {len(rows)} states, wrote {args.out}")
    return 0


def _cmd_plot(args) -> int:
    from swarmnav.sim import RunResult
    from swarmnav.viz import plot_run

    res = RunResult.load(args.dir)
    if args.perspective:
        from swarmnav.viz.perspective import plot_perspective

        out = _writable_file(args.out or Path(args.dir) / "perspective.png", "--out")
        print(f"wrote {plot_perspective(res, out, step=args.step)}")
        return 0
    if args.step is not None:
        raise ConfigError("plot: --step applies to --perspective only")
    out = _writable_file(args.out or Path(args.dir) / "trajectory.png", "--out")
    print(f"wrote {plot_run(res, out)}")
    return 0


def _cmd_view(args) -> int:
    from swarmnav.sim import RunResult
    from swarmnav.viz.viewer import llm_marks, write_viewer

    d = Path(args.dir)
    if not d.is_dir():
        raise ConfigError(f"view: {d} is not a run directory (not a directory)")
    res = RunResult.load(d)
    if args.out and Path(args.out).is_dir():
        raise ConfigError(f"view: --out {args.out} is a directory; give the HTML file's name")
    out = _writable_file(args.out or d / "viewer.html", "--out")
    path = write_viewer(res, out, marks=llm_marks(d))
    print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    if args.open:
        import webbrowser

        if not webbrowser.open(path.resolve().as_uri()):
            print(f"swarmnav: no browser to open; open {path} yourself", file=sys.stderr)
    return 0


def _cmd_animate(args) -> int:
    from swarmnav.sim import RunResult
    from swarmnav.viz import animate_run

    res = RunResult.load(args.dir)
    _writable_file(args.out, "--out")
    print(f"wrote {animate_run(res, args.out, fps=args.fps)}")
    return 0


def _cmd_experiment(args) -> int:
    from swarmnav.experiments import builtin_names, load_experiment, run_experiment

    if args.list or not (args.name or args.spec):
        for name in builtin_names():
            print(name)
        return 0
    if args.out is None:
        raise ConfigError("experiment: --out DIR is required")
    if args.workers < 1:
        raise ConfigError(f"experiment: --workers must be >= 1, got {args.workers}")
    exp = load_experiment(args.spec or args.name, overrides=_parse_sets(args.set), seeds=args.seeds)
    _writable_dir(args.out, "--out")
    rows, summary = run_experiment(exp, args.out, workers=args.workers, backend=args.backend,
                                   ray_address=args.ray_address, save_trajectories=not args.no_trajectories,
                                   progress=not args.quiet, force=args.force,
                                   variants=_split_patterns(args.variants))
    failed = sum(r["status"] != "done" for r in rows)
    print(f"{exp.name}: {len(rows)} runs ({failed} failed) -> {args.out}/results.sqlite, runs.csv, summary.csv")
    # the SPH paper's success test means something where the experiment reproduces an SPH table
    # (any method flown on its scenes), not on the HES or HWVEM scenes
    sph_table = str(exp.report.get("reference", "")).startswith("sph") or exp.name.startswith("sph")
    for s in summary:
        if not s["runs"]:  # a variant --variants left out, with nothing stored yet
            continue
        # the metrics that mean something for the runs: navigation, or consensus in a periodic box
        # (no goal, no obstacles)
        names = (("Y_mean", "R_goal_mean", "E_mean_mean", "R_unsafe_mean") + (("sph_success_mean",) if sph_table else ())
                 if "Y_mean" in s else ("converged_mean", "k_con_mean", "deg_con_final_mean"))
        keys = [k for k in (*names, "collisions_mean", "crashes_mean") if k in s]
        print(f"  {s['variant']:32s} " + "  ".join(f"{k}={s[k]:.3f}" for k in keys))
    if failed:
        print(f"  {failed} run(s) failed (see the error column of runs.csv); rerun the same command to retry them",
              file=sys.stderr)
    return 1 if failed else 0


def _split_patterns(text: str | None) -> list[str] | None:
    if text is None:
        return None
    pats = [p.strip() for p in text.split(",") if p.strip()]
    if not pats:
        raise ConfigError("--variants: give one or more variant names or glob patterns, e.g. 'lsc/*,sph/0.35'")
    return pats


def _cmd_merge(args) -> int:
    from swarmnav.experiments.runner import merge_stores

    _writable_dir(args.into, "--into")
    copied, there = merge_stores(args.sources, args.into)
    print(f"merged {copied} run(s) into {args.into}/results.sqlite ({there} already there); "
          f"run the experiment into it to add the runs it lacks, then: swarmnav report {args.into}")
    return 0


def _cmd_report(args) -> int:
    from swarmnav.experiments.report import write_report

    viewers = None
    if not args.no_viewers and (Path(args.dir) / "results.sqlite").exists():
        from swarmnav.viz.store_views import write_store_viewers

        viewers, problems = write_store_viewers(args.dir, experiment=args.experiment, progress=sys.stderr.isatty())
        for line in problems:
            print(f"swarmnav: {line}", file=sys.stderr)
    for path in write_report(args.dir, experiment=args.experiment, compare=args.compare, viewers=viewers):
        print(f"wrote {path}")
    if viewers:
        print(f"wrote {len(viewers)} replay viewers under {Path(args.dir) / 'report_files' / 'viewers'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from swarmnav._version import __version__

    p = _Parser(prog="swarmnav", description="Simulate and compare multi-UAV swarm navigation (HES, SPH, HWVEM).")
    p.add_argument("--version", action="version", version=f"swarmnav {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

    s = sub.add_parser("scenarios", help="list built-in scenes, or show one")
    s.add_argument("action", nargs="?", choices=["show"])
    s.add_argument("name", nargs="?")
    s.add_argument("--plot", metavar="PNG", help="draw the scene to this PNG file")
    s.add_argument("--json", action="store_true", help="print JSON instead of a TOML scene file")
    s.set_defaults(fn=_cmd_scenarios)

    s = sub.add_parser("methods", help="list registered methods, or one method's parameters")
    s.add_argument("name", nargs="?", help="a method: list its parameters (default, unit, valid range, source)")
    s.set_defaults(fn=_cmd_methods)

    s = sub.add_parser("check-method", help="the conformance checks of a method (a plugin's, or module:Factory)")
    s.add_argument("name", help="a registered method, or module:Factory / path/to/file.py:Factory")
    s.add_argument("--scenes", metavar="A,B", help="only these of the scenes the method can fly (default: all)")
    s.add_argument("--steps", type=int, help="steps of each scene run (default: 2 s of the method's steps, at least 40)")
    s.set_defaults(fn=_cmd_check_method)

    s = sub.add_parser("run", help="run one simulation and write a run directory")
    s.add_argument("--method", required=True)
    s.add_argument("--scenario", metavar="NAME", help="built-in scene or generator spec")
    s.add_argument("--scenario-file", metavar="PATH",
                   help="a .toml scene file, or a map file with options (X.map.scen#ROW; docs/maps.md)")
    s.add_argument("--seed", type=int, default=1)
    length = s.add_mutually_exclusive_group()
    length.add_argument("--steps", type=int, help="integration steps (default 1000; the method's dt each)")
    length.add_argument("--horizon", type=float, metavar="SECONDS",
                        help="simulated time [s] instead of --steps: the same horizon for every method")
    s.add_argument("--out", required=True, metavar="DIR")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="method parameter (repeatable); n=N resizes the swarm")
    s.add_argument("--plot", action="store_true", help="also draw DIR/trajectory.png")
    s.add_argument("--view", action="store_true", help="also write DIR/viewer.html, the replay viewer")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.add_argument("--force", action="store_true",
                   help="DIR already holds a run: replace it (removes only the files a run writes there)")
    _add_llm_flags(s)
    s.set_defaults(fn=_cmd_run)

    s = sub.add_parser("plot", help="draw a run directory like HES Figure 3")
    s.add_argument("dir")
    s.add_argument("--out", metavar="PNG")
    s.add_argument("--perspective", action="store_true",
                   help="one step in perspective (HES Fig. A1: arrows at z = 10 m for a planar run); "
                        "default file DIR/perspective.png")
    s.add_argument("--step", type=int, help="the step --perspective draws (default: the middle of the run)")
    s.set_defaults(fn=_cmd_plot)

    s = sub.add_parser("view", help="write a run directory's replay viewer: one self-contained HTML page")
    s.add_argument("dir")
    s.add_argument("--out", metavar="HTML", help="default: DIR/viewer.html")
    s.add_argument("--open", action="store_true", help="open it in the default web browser")
    s.set_defaults(fn=_cmd_view)

    s = sub.add_parser("animate", help="render a run directory as .gif or .mp4")
    s.add_argument("dir")
    s.add_argument("--out", required=True, metavar="FILE")
    s.add_argument("--fps", type=int, default=20)
    s.set_defaults(fn=_cmd_animate)

    s = sub.add_parser("experiment", help="run a declared experiment over seeds")
    s.add_argument("name", nargs="?")
    s.add_argument("--spec", metavar="FILE", help="a user experiment spec (.toml)")
    s.add_argument("--list", action="store_true")
    s.add_argument("--seeds", help="e.g. 1-10 or 1,3,5 (default: the spec's)")
    s.add_argument("--workers", type=int, default=1)
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="override for every variant; a|b|c sweeps")
    s.add_argument("--out", metavar="DIR", help="results directory (a rerun into it resumes)")
    s.add_argument("--backend", choices=["local", "ray"], default="local")
    s.add_argument("--ray-address", metavar="ADDR", help="join an existing Ray cluster (default: start a local one)")
    s.add_argument("--no-trajectories", action="store_true", help="store metrics only, no trajectory files")
    s.add_argument("--variants", metavar="PATTERNS",
                   help="fly only these variants: names or glob patterns, comma-separated (e.g. 'lsc/*'); "
                        "the store still records the whole spec, so its report shows every variant flown there")
    s.add_argument("--force", action="store_true",
                   help="DIR holds another sweep (other --set values or spec, or another experiment): "
                        "record this one there anyway; stored runs are kept")
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(fn=_cmd_experiment)

    s = sub.add_parser("report", help="write report.md and report.html for a results directory")
    s.add_argument("dir")
    s.add_argument("--experiment", help="which experiment of the store (default: the last one run)")
    s.add_argument("--compare", nargs=2, metavar=("A", "B"),
                   help="add the per-seed %% change of variant B against variant A (HES Fig. 5); "
                        "default: the spec's [report] compare, if any")
    s.add_argument("--no-viewers", action="store_true",
                   help="no replay viewer per run (by default each stored trajectory gets one, linked from the report)")
    s.set_defaults(fn=_cmd_report)

    s = sub.add_parser("merge", help="copy the finished runs of results directories into another one "
                       "(sweeps flown apart, e.g. on two machines, reported together)")
    s.add_argument("sources", nargs="+", metavar="SRC", help="results directories to copy from")
    s.add_argument("--into", required=True, metavar="DIR", help="the results directory to copy into (created if missing)")
    s.set_defaults(fn=_cmd_merge)

    s = sub.add_parser("llm", help="LLM decision back ends: 'llm check' asks one a sample question, "
                       "'llm bench' scores one on recorded decision states against the rule and the oracle, "
                       "'llm label' labels recorded states with the oracle's lookahead (docs/llm-bench.md)")
    s.add_argument("action", choices=["check", "bench", "label"])
    s.add_argument("--states", metavar="FILE", help="bench, label: decision states (.jsonl; default: the shipped set)")
    s.add_argument("--limit", type=int, default=0, help="bench, label: only the first N states")
    s.add_argument("--transcript", metavar="FILE", help="bench: write the answers (what --decision replay reads)")
    s.add_argument("--choice", action="store_true",
                   help="bench: only the states with two or more feasible actions (where an answer can matter)")
    s.add_argument("--summary", metavar="FILE", help="bench: write the scores per scene and build (.json, else CSV)")
    s.add_argument("--out", metavar="FILE", help="label: the labelled states (.jsonl)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="an llm_* parameter, e.g. llm_threads=1")
    _add_llm_flags(s)
    s.set_defaults(fn=_cmd_llm)
    return p


#: Printed once when a run has spent COMPILE_NOTICE_AFTER seconds compiling. Numba compiles
#: only on a cache miss: the first run of a method or of a kind of scene (2-D, 3-D), the first
#: after swarmnav's code changed, each worker process of a cold sweep. Cold figures measured by
#: ``benchmarks/bench_compile.py`` on the 2-core machine (whole command, start-up included):
#: apf 4.6 s, vem 6.9 s, sph 9.0 s (3-D 12.4 s), hes 18.8 s (3-D 20.7 s); all eight cases in a
#: row 49 s, a cold ``experiment cross-method`` 48 s; a warm run starts in ~1.4 s.
COMPILE_NOTICE = ("swarmnav: compiling numerical kernels, saved for later runs: ~5 s (apf) to ~20 s (hes) per "
                  "method on 2 cores, ~50 s for every method at once")
#: [s] of compiling before the notice: a small compile (one new signature, one edited module)
#: passes unannounced, so the notice appears only where the wait is the one it describes.
COMPILE_NOTICE_AFTER = 2.0


def _notify_compiling():
    """Print :data:`COMPILE_NOTICE` on stderr once the run has spent
    :data:`COMPILE_NOTICE_AFTER` seconds in Numba compiles. Numba's ``numba:compile`` event
    fires only on a cache miss (a warm run has none), so this is the signal that kernels are
    compiled, not an assumption. Returns the listener to pass to :func:`_stop_notice`."""
    import threading
    import time

    from numba.core import event
    from tqdm import tqdm

    class Notice(event.Listener):
        def __init__(self):
            self.depth, self.spent, self.since = 0, 0.0, 0.0  # nesting, seconds compiled, start
            self.shown, self.timer, self.lock = False, None, threading.Lock()

        def show(self):  # from the timer's thread while a compile runs, or when one ends
            with self.lock:
                if self.shown:
                    return
                self.shown = True
            tqdm.write(COMPILE_NOTICE, file=sys.stderr)  # above a progress bar, not through it

        def on_start(self, ev):  # a kernel's compile may compile the kernels it calls: count the outer one
            self.depth += 1
            if self.depth == 1 and not self.shown:
                self.since = time.perf_counter()
                self.timer = threading.Timer(max(0.0, COMPILE_NOTICE_AFTER - self.spent), self.show)
                self.timer.daemon = True
                self.timer.start()

        def on_end(self, ev):
            self.depth -= 1
            if self.depth == 0 and self.timer is not None:
                self.cancel()
                self.spent += time.perf_counter() - self.since
                if self.spent >= COMPILE_NOTICE_AFTER:  # short compiles that add up
                    self.show()

        def cancel(self):
            if self.timer is not None:
                self.timer.cancel()
                self.timer = None

    listener = Notice()
    event.register("numba:compile", listener)
    return listener


def _stop_notice(listener) -> None:
    from numba.core import event

    listener.cancel()
    event.unregister("numba:compile", listener)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    listener = None
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "fn", None):
            parser.print_help()
            return EXIT_USAGE
        if args.command in ("run", "experiment"):
            listener = _notify_compiling()
        return args.fn(args)
    except SwarmnavError as e:
        print(f"swarmnav: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("swarmnav: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `swarmnav ... | head`: the reader left; stop quietly, as Unix tools do
        if not _stdout_closed():
            raise  # some other pipe (a worker's, a server's): a bug, keep the traceback
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's exit flush would raise again
        return 1
    finally:
        if listener is not None:
            _stop_notice(listener)


def _stdout_closed() -> bool:
    """True if stdout is a pipe whose reader has gone (poll reports an error on our end)."""
    import select

    if not hasattr(select, "poll"):
        return True  # cannot tell; a broken pipe in a CLI is almost always stdout
    try:
        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        return any(ev & select.POLLERR for _, ev in poller.poll(0))
    except (OSError, ValueError):
        return False


if __name__ == "__main__":
    sys.exit(main())
