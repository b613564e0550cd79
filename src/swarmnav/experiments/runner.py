"""Run an experiment's (variant, seed) grid on a local process pool; write runs.csv and summary.csv."""

from __future__ import annotations

import csv
import math
import os
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, Callable

import numpy as np

from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.experiments.spec import Experiment, Variant

#: Metrics where the worst case over seeds matters: summary.csv also gets ``<metric>_min``.
MIN_METRICS = ("d_clr_min", "min_inter_agent_distance", "Y", "R_goal")


def check(exp: Experiment) -> None:
    """Fail fast (before any worker starts) on a bad method, parameter or scene."""
    from swarmnav.methods import registry
    from swarmnav.world.scenario import load_scenario

    for v in exp.variants:
        try:
            registry.make(v.method, **v.params)
            load_scenario(v.scenario, n=v.n)
        except SwarmnavError as e:
            raise ConfigError(f"{exp.name} variant '{v.name}': {e}") from None


def run_one(variant: Variant, seed: int, save_dir: str | None = None) -> dict[str, Any]:
    """One run -> one runs.csv row (config columns, seed, status, every metric)."""
    from swarmnav.sim import run
    from swarmnav.world.scenario import load_scenario

    row: dict[str, Any] = {**variant.columns(), "seed": seed}
    t0 = time.perf_counter()
    try:
        scn = load_scenario(variant.scenario, n=variant.n)
        res = run(variant.method, scn, seed=seed, steps=variant.steps, **variant.params)
        if save_dir:
            res.save(Path(save_dir) / _safe(variant.name) / f"seed{seed}")
        row.update(status="done", error="")
        row.update(res.metrics)
    except Exception as e:  # a failed run is recorded, never fatal to the sweep
        row.update(status="failed", error=f"{type(e).__name__}: {e}".splitlines()[0])
        row["traceback"] = traceback.format_exc(limit=3)
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def run_experiment(
    exp: Experiment,
    out: str | Path,
    *,
    workers: int = 1,
    save_runs: bool = False,
    progress: bool = True,
    on_row: Callable[[dict], None] | None = None,
) -> tuple[list[dict], list[dict]]:
    """Run every (variant, seed); write ``out/runs.csv`` and ``out/summary.csv``."""
    check(exp)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(v, s) for v in exp.variants for s in exp.seeds]
    save_dir = str(out / "runs") if save_runs else None
    rows: list[dict] = []
    bar = _bar(len(jobs), progress)
    if workers <= 1:
        for v, s in jobs:
            rows.append(run_one(v, s, save_dir))
            _tick(bar, rows[-1], on_row)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futs = [pool.submit(run_one, v, s, save_dir) for v, s in jobs]
            for f in as_completed(futs):
                rows.append(f.result())
                _tick(bar, rows[-1], on_row)
    if bar is not None:
        bar.close()
    order = {(v.name, s): k for k, (v, s) in enumerate(jobs)}
    rows.sort(key=lambda r: order[(r["variant"], r["seed"])])
    for r in rows:
        r.pop("traceback", None)
    summary = summarize(rows, exp.variants)
    write_csv(out / "runs.csv", rows)
    write_csv(out / "summary.csv", summary)
    return rows, summary


def summarize(rows: list[dict], variants) -> list[dict]:
    """One row per variant: mean and population std of each metric (``<m>_mean``, ``<m>_std``),
    ``<m>_min`` for :data:`MIN_METRICS`, and run counts."""
    out = []
    for v in variants:
        mine = [r for r in rows if r["variant"] == v.name]
        done = [r for r in mine if r["status"] == "done"]
        s: dict[str, Any] = {**v.columns(), "runs": len(mine), "failed": len(mine) - len(done)}
        keys = [k for k in (done[0] if done else {}) if k not in s and k not in ("seed", "status", "error")
                and _is_number(done[0][k])]
        for k in keys:
            vals = np.array([float(r[k]) for r in done], dtype=float)
            s[f"{k}_mean"] = float(np.mean(vals))
            s[f"{k}_std"] = float(np.std(vals))  # population form, as the HES paper
            if k in MIN_METRICS:
                s[f"{k}_min"] = float(np.min(vals))
        out.append(s)
    return out


def write_csv(path: Path, rows: list[dict]) -> None:
    cols: list[str] = []
    for r in rows:
        cols.extend(k for k in r if k not in cols)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k, "")) for k in cols})
    os.replace(tmp, path)


def _fmt(v: Any) -> Any:
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else str(v)
    return v


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool)


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_.=" else "_" for c in name)


def _bar(total: int, progress: bool):
    if not progress or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="run", dynamic_ncols=True)


def _tick(bar, row: dict, on_row) -> None:
    if bar is not None:
        bar.update(1)
        if row["status"] != "done":
            bar.write(f"failed: {row['variant']} seed {row['seed']}: {row['error']}")
    if on_row is not None:
        on_row(row)
