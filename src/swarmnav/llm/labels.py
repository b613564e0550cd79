"""The oracle's labels of the decision benchmark's states (docs/llm-bench.md).

A decision state is re-created by the run it came from, not by a snapshot: each row names its
run (``scene``, ``seed``, ``steps`` K, the method parameters ``params``, e.g. ``{"preset":
"paper"}``) and its step ``k``. Runs are deterministic for a seed, so flying that rule run
again reaches z(k) exactly; at step k an :class:`~swarmnav.methods.hes.oracle.OracleProbe`
flies every feasible action ahead in copies of the run (the action at step k, then
``oracle_horizon`` seconds with the rule deciding, the lookahead of ``decision=oracle``) and
scores each by the oracle's objective J [m]. The replayed z(k) is compared with the recorded
one: a difference (a state file recorded by another version of the code) is an error, never
a silent mislabel. A snapshot would tie the file to the in-memory layout of the method; a
(scene, seed, build, step) row stays readable and is re-labelled by one command.

Each labelled row gets ``oracle``: ``choice`` (the feasible action of the largest J; an exact
tie goes to the rule's action, else to the first of split, merge, keep), ``J`` [m] and the
``outcomes`` of every feasible action, ``horizon_s`` and the objective's ``weights``.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import asdict
from typing import Any, Callable, TextIO

from swarmnav.errors import ConfigError
from swarmnav.llm.prompt import jsonable

#: the keys a row needs to name its run (besides ``k`` and ``state``)
RUN_KEYS = ("scene", "seed", "steps", "params")


def build_of(params: dict[str, Any]) -> str:
    """The build a row's parameters select: ``paper`` or ``swarmnav`` (the default)."""
    return str(params.get("preset", "swarmnav"))


def oracle_choice(J: dict[str, float], rule_executed: str) -> str:
    """The action of the largest J; an exact tie goes to the rule's executed action, else to A_STR order."""
    best = max(J.values())
    if J.get(rule_executed) == best:
        return rule_executed
    return next(a for a in ("split", "merge", "keep") if J.get(a) == best)


def executed(rule: str, feasible: list[str]) -> str:
    """Pi_feas of eq. (22) on a row: ``rule`` if it is feasible, else keep."""
    return rule if rule in feasible else "keep"


def probe_run(scene: str, seed: int, *, steps: int, params: dict[str, Any],
              select: Callable[[int, Any, str, tuple], bool]) -> list[dict[str, Any]]:
    """Fly the rule run of HES with ``params`` on ``scene``/``seed`` for ``steps`` steps and return a
    labelled row for every step ``select(step, z, rule_action, feasible)`` picks."""
    import swarmnav
    from swarmnav.methods import registry
    from swarmnav.methods.hes.oracle import OracleProbe

    hes = registry.make("hes", **params)
    probe = OracleProbe(hes.rule_policy(), hes.params, select)
    swarmnav.run(hes.use_source(probe), scene, seed=seed, steps=steps)
    p = hes.params
    weights = {"w_reach": p.oracle_w_reach, "w_success": p.oracle_w_success, "w_crash": p.oracle_w_crash,
               "w_unsafe": p.oracle_w_unsafe}
    build = build_of(params)
    rows = []
    for pt in probe.points:
        feasible = list(pt.feasible)
        rows.append({
            "id": f"{scene}/{build}/s{seed}/k{pt.k}", "scene": scene, "build": build, "seed": int(seed),
            "steps": int(steps), "params": dict(params), "k": pt.k,
            "state": {k: jsonable(v, digits=None) for k, v in pt.z.to_dict().items()},
            "rule": pt.rule.action, "rule_reason": pt.rule.reason, "feasible": feasible,
            "oracle": {"choice": oracle_choice(pt.J, executed(pt.rule.action, feasible)),
                       "J": {a: float(v) for a, v in pt.J.items()},
                       "outcomes": {a: {k: v for k, v in asdict(o).items() if k != "action"}
                                    for a, o in pt.outcomes.items()},
                       "horizon_s": float(p.oracle_horizon), "weights": weights},
        })
    return rows


def label_states(rows: list[dict[str, Any]], progress: TextIO | None = None) -> list[dict[str, Any]]:
    """``rows`` (decision states naming their run) with the oracle's labels, in the same order.

    Each run is flown once, however many of its steps are listed.

    Raises:
        ConfigError: a row that does not name its run, or whose replayed z(k) differs from the
            recorded one.
    """
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, r in enumerate(rows):
        missing = [k for k in (*RUN_KEYS, "k", "state") if k not in r]
        if missing:
            raise ConfigError(f"decision state {r.get('id', i)}: cannot re-create its run without "
                              f"{', '.join(missing)} (record states with benchmarks/record_llm_states.py)")
        if not isinstance(r["params"], dict):
            raise ConfigError(f"decision state {r.get('id', i)}: params must be an object of method parameters")
        groups[(r["scene"], int(r["seed"]), int(r["steps"]), json.dumps(r["params"], sort_keys=True))].append(i)
    out: list[dict[str, Any] | None] = [None] * len(rows)
    for (scene, seed, steps, params), idx in groups.items():
        wanted = {int(rows[i]["k"]) for i in idx}
        got = {r["k"]: r for r in probe_run(scene, seed, steps=steps, params=json.loads(params),
                                            select=lambda step, z, rule, feasible: step in wanted)}
        for i in idx:
            row, new = rows[i], got.get(int(rows[i]["k"]))
            if new is None:
                raise ConfigError(f"decision state {row.get('id', i)}: the run has no step {row['k']} "
                                  f"(it ends at {steps} steps)")
            if new["state"] != row["state"]:
                diff = sorted(k for k in set(new["state"]) | set(row["state"])
                              if new["state"].get(k) != row["state"].get(k))
                raise ConfigError(f"decision state {row.get('id', i)}: the replayed z(k) differs from the recorded "
                                  f"one ({', '.join(diff)}); the file was recorded by another version: re-record it")
            out[i] = {**row, "oracle": new["oracle"]}
        if progress is not None:
            print(f"  labelled {len(idx)} states of {scene} seed {seed} ({build_of(json.loads(params))} build)",
                  file=progress, flush=True)
    return out  # type: ignore[return-value]


def check_label(row: dict[str, Any], where: str) -> None:
    """ConfigError unless ``row['oracle']`` is a consistent label of the row."""
    o = row["oracle"]
    if not isinstance(o, dict) or not isinstance(o.get("J"), dict):
        raise ConfigError(f"{where}: oracle must be an object with J (an objective per feasible action)")
    J = o["J"]
    if sorted(J) != sorted(row["feasible"]):
        raise ConfigError(f"{where}: oracle J must give every feasible action ({', '.join(row['feasible'])}), "
                          f"got {', '.join(sorted(J)) or 'none'}")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in J.values()):
        raise ConfigError(f"{where}: oracle J must be finite numbers [m]")
    if o.get("choice") not in J or J[o["choice"]] != max(J.values()):
        raise ConfigError(f"{where}: oracle choice must be a feasible action of the largest J")
