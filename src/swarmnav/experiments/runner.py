"""Run an experiment's (variant, seed) grid on a back end, into a resumable results store.

The driver owns the store: workers compute a run and write its trajectory file, the driver
commits the row. Rerunning into the same directory runs only what is missing or failed, so
a sweep killed at any moment (driver or worker, even by SIGKILL) loses no finished run and
ends, after a rerun, with exactly the runs of an uninterrupted sweep.
"""

from __future__ import annotations

import csv
import fnmatch
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.experiments import stats
from swarmnav.experiments.backends import BACKENDS
from swarmnav.experiments.jobs import Job, plan, variant_key
from swarmnav.experiments.paired import unknown_hint
from swarmnav.experiments.spec import Experiment
from swarmnav.experiments.store import Store

#: Metrics where the worst case over seeds matters: summary.csv also gets ``<metric>_min``.
MIN_METRICS = ("d_clr_min", "min_inter_agent_distance", "Y", "R_goal", "min_inter_robot_distance",
               "min_robot_obstacle_distance", "sph_success")
#: Metrics whose spread over seeds is reported as quartiles: ``<m>_p25``, ``<m>_p50``, ``<m>_p75``.
QUANTILE_METRICS = ("k_con", "P_s")
#: Per-run 0/1 outcomes: summary.csv also gets ``<m>_fraction``, the share of runs where it is 1.
FRACTION_METRICS = ("converged",)


def _write_files(root: Path, row: dict) -> None:
    """Write a row's trajectory (``trajectories/kk/KEY.npz``) and artifacts
    (``trajectories/kk/KEY/NAME``), each under a temporary name and renamed into place."""
    data = row.pop("_npz", None)
    if data is not None:
        rel = Path("trajectories") / row["key"][:2] / f"{row['key']}.npz"
        _atomic_write(root / rel, data)
        row["trajectory"] = str(rel)
    paths = []
    for name, content in sorted(row.pop("_artifacts", {}).items()):
        rel = Path("trajectories") / row["key"][:2] / row["key"] / Path(name).name
        _atomic_write(root / rel, content.encode() if isinstance(content, str) else content)
        paths.append(str(rel))
    row["artifacts"] = paths


def merge_stores(sources: list[str | Path], into: str | Path) -> tuple[int, int]:
    """Copy every finished run of the stores ``sources`` that ``into`` has not finished, with its
    trajectory and artifact files, and each experiment's description that ``into`` lacks (so
    ``swarmnav report --experiment NAME`` works there). Runs are keyed by their configuration,
    so a run flown in two sweeps, or on two machines, lands once; the same experiment run later
    into ``into`` finds it done. Returns (runs copied, runs already there)."""
    dst = Store(into)
    have = dst.done_keys()
    copied = skipped = 0
    for src_root in sources:
        src_root = Path(src_root)
        if src_root.resolve() == dst.root.resolve():
            raise ConfigError(f"merge: {src_root} is the target store itself")
        if not (src_root / "results.sqlite").exists():
            raise ConfigError(f"merge: {src_root} holds no results store (results.sqlite)")
        src = Store(src_root)
        rows = []
        for row in src.rows():
            if row["status"] != "done" or row["key"] in have:
                skipped += row["status"] == "done"
                continue
            for rel in ([row["trajectory"]] if row.get("trajectory") else []) + list(row["artifacts"]):
                _atomic_write(dst.root / rel, (src.root / rel).read_bytes())
            rows.append(row)
            have.add(row["key"])
        dst.put_many(rows)  # after their files: a row never points at a file that is not there
        copied += len(rows)
        known = set(dst.meta_keys())
        for key in src.meta_keys():
            if key.startswith("experiment:") and key not in known:
                dst.set_meta(key, src.meta(key))
    return copied, skipped


def _atomic_write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def run_experiment(
    exp: Experiment,
    out: str | Path,
    *,
    workers: int = 1,
    backend: str = "local",
    ray_address: str | None = None,
    save_trajectories: bool = True,
    progress: bool = True,
    on_row: Callable[[dict], None] | None = None,
    force: bool = False,
    variants: Sequence[str] | None = None,
) -> tuple[list[dict], list[dict]]:
    """Run every missing (variant, seed) of ``exp`` into the store in ``out``.

    ``variants`` (glob patterns of variant names, e.g. ``["lsc/*"]``) flies only the variants it
    matches; the store still records the whole spec, so the report shows every variant with the
    runs it has, and sweeps of other variants into the same store (or merged into it) add to it.
    A pattern that matches no variant is a one-line ConfigError, before anything runs.

    A store that holds another sweep is refused (ConfigError, before anything runs) unless
    ``force``: the same experiment with variants configured differently (another ``--set``
    value, an edited spec), or a store of another experiment. The seeds may differ: more or
    fewer seeds of the same variants is the same sweep. ``force`` makes ``exp`` the store's
    record of its name; stored runs are never deleted (a run's key is its whole configuration,
    so the report and CSVs show only the runs of the recorded spec).

    Returns the exported ``runs.csv`` and ``summary.csv`` rows (also written to ``out``).
    """
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend '{backend}' (known: {', '.join(BACKENDS)})")
    if workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {workers}")
    jobs = plan(exp)
    wanted = select_variants([v.name for v in exp.variants], variants) if variants else None
    store = Store(out)
    meta = _spec_meta(exp, jobs)
    if not force:
        _check_same_sweep(store, meta)
    store.set_meta(f"experiment:{exp.name}", meta)
    store.set_meta("last_experiment", exp.name)
    done = store.done_keys()
    # Two variants may declare the identical configuration: it is run once and reported under both.
    mine = [j for j in jobs if wanted is None or j.variant.name in wanted]
    todo = list({j.key: j for j in mine if j.key not in done}.values())
    bar = _Progress(len(mine), len(mine) - len(todo), progress)

    def finished(row: dict) -> None:
        _write_files(store.root, row)  # the files exist before the row that names them
        store.put(row)  # committed before anything else learns of it
        bar.update(row)
        if on_row is not None:
            on_row(row)

    try:
        if todo:
            BACKENDS[backend](todo, workers=workers, on_result=finished, keep_trajectory=save_trajectories,
                              ray_address=ray_address)
    finally:
        bar.close()
    return export(store, exp.name)


def select_variants(names: list[str], patterns: Sequence[str]) -> set[str]:
    """The variant names that match any of the glob ``patterns`` (``fnmatch``, case-sensitive).
    A pattern matching none is a one-line ConfigError naming the closest variants."""
    out: set[str] = set()
    for pat in patterns:
        hit = {n for n in names if fnmatch.fnmatchcase(n, pat)}
        if not hit:
            raise ConfigError(f"--variants: '{pat}' matches no variant{unknown_hint(pat, names)}")
        out |= hit
    return out


def export(store: Store, experiment: str) -> tuple[list[dict], list[dict]]:
    """Write ``runs.csv`` and ``summary.csv`` for ``experiment`` from the store; return them."""
    meta = store.meta(f"experiment:{experiment}")
    if meta is None:
        raise SwarmnavError(f"{store.root}: no experiment '{experiment}' in the store")
    runs = [_csv_row(r) for r in job_rows(store, meta)]
    variants = meta["variants"]
    summary = summarize(runs, variants)
    write_csv(store.root / "runs.csv", runs)
    write_csv(store.root / "summary.csv", summary)
    return runs, summary


def _spec_meta(exp: Experiment, jobs: list[Job]) -> dict:
    first = {}
    for j in jobs:
        first.setdefault(j.variant.name, j)
    return {
        "name": exp.name, "description": exp.description, "seeds": list(exp.seeds),
        "overrides": dict(exp.overrides),
        "variants": [{"name": v.name, "columns": v.columns(), "config": variant_key(first[v.name]),
                      "variables": v.variables} for v in exp.variants],
        "keys": [j.key for j in jobs], "jobs": [[j.key, j.variant.name, j.seed] for j in jobs], "report": exp.report,
    }


def _check_same_sweep(store: Store, new: dict) -> None:
    """Refuse (one-line ConfigError) to run the sweep ``new`` into a store holding another one."""
    name = new["name"]
    old = store.meta(f"experiment:{name}")
    if old is None:
        last = store.meta("last_experiment")
        if last is not None and last != name:
            raise ConfigError(f"{store.root} holds the results of experiment '{last}'; --force adds '{name}' beside "
                              f"it (swarmnav report --experiment NAME picks one), or choose another --out")
        return
    why = _difference(old, new)
    if why:
        raise ConfigError(f"{store.root} holds a different sweep of '{name}' ({why}); --force makes this one the "
                          f"store's '{name}' (stored runs are kept), or choose another --out")


def _difference(old: dict, new: dict) -> str:
    """How two records of one experiment differ in their variants ("" if they do not): their
    names, or a variant's configuration. Seeds are free to differ."""
    before, now = [v["name"] for v in old["variants"]], [v["name"] for v in new["variants"]]
    if before != now:
        what = f"other variants: {len(before)} stored, {len(now)} now"
    else:
        if all("config" in v for v in old["variants"]):
            changed = [v["name"] for v, w in zip(old["variants"], new["variants"]) if v["config"] != w["config"]]
        else:  # a store written before variants had a key: compare the runs of the seeds both plan
            keys = {(variant, seed): key for key, variant, seed in old["jobs"]}
            changed = list(dict.fromkeys(variant for key, variant, seed in new["jobs"]
                                         if keys.get((variant, seed), key) != key))
        if not changed:
            return ""
        what = ("every variant" if len(changed) == len(now) else
                f"variant{'s' if len(changed) > 1 else ''} {', '.join(changed[:3])}{' ...' if len(changed) > 3 else ''}") \
            + " configured differently"
    if old.get("overrides") is not None and old["overrides"] != new["overrides"]:
        what += f": --set {_sets(old['overrides'])} then, {_sets(new['overrides'])} now"
    return what


def _sets(overrides: dict) -> str:
    return " ".join(f"{k}={v}" for k, v in overrides.items()) or "nothing"


def job_rows(store: Store, meta: dict) -> list[dict]:
    """The stored rows of an experiment's jobs, in job order, one per (variant, seed): a run
    shared by two variants appears under each variant's name."""
    by_key = {r["key"]: r for r in store.rows(keys=meta["keys"])}
    out = []
    for key, variant, seed in meta["jobs"]:
        if key in by_key:
            out.append({**by_key[key], "variant": variant, "seed": seed})
    return out


def _csv_row(r: dict) -> dict[str, Any]:
    params = {f"param.{k}": v for k, v in sorted(r["params"].items())}
    row = {"variant": r["variant"], "method": r["method"], "scenario": r["scenario"], "steps": r["steps"],
           "n": r["n"] if r["n"] is not None else "", **params, "seed": r["seed"], "status": r["status"],
           "error": r["error"]}
    row.update(r["metrics"])
    row.update(wall_time_s=r["wall_time_s"], trajectory=r["trajectory"], key=r["key"], version=r["version"])
    return row


def summarize(rows: list[dict], variants: list[dict]) -> list[dict]:
    """One row per variant: mean and population std of each metric (``<m>_mean``, ``<m>_std``),
    ``<m>_min`` for :data:`MIN_METRICS`, quartiles for :data:`QUANTILE_METRICS`,
    ``<m>_fraction`` for :data:`FRACTION_METRICS`, and run counts."""
    out = []
    skip = {"seed", "status", "error", "wall_time_s", "trajectory", "key", "version", "steps", "n"}
    for v in variants:
        mine = [r for r in rows if r["variant"] == v["name"]]
        done = [r for r in mine if r["status"] == "done"]
        s: dict[str, Any] = {**v["columns"], "runs": len(mine), "done": len(done), "failed": len(mine) - len(done)}
        keys = [k for k in (done[0] if done else {}) if k not in s and k not in skip and not k.startswith("param.")
                and _is_number(done[0][k])]
        for k in keys:
            vals = np.array([float(r[k]) for r in done if _is_number(r.get(k))], dtype=float)
            if not len(vals):
                continue
            s[f"{k}_mean"] = stats.mean(vals)
            s[f"{k}_std"] = stats.std(vals)
            if k in MIN_METRICS:
                s[f"{k}_min"] = float(np.min(vals))
            if k in QUANTILE_METRICS:
                for q in (25, 50, 75):
                    s[f"{k}_p{q}"] = stats.percentile(vals, q)
            if k in FRACTION_METRICS:
                s[f"{k}_fraction"] = float(np.mean(vals == 1.0))
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


class _Progress:
    """tqdm bar over all runs of the experiment: done / failed / remaining, with an ETA."""

    def __init__(self, total: int, already: int, enabled: bool):
        self.failed = 0
        self.done = already
        self.total = total
        self.bar = None
        if enabled and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=already, unit="run", dynamic_ncols=True)
            self._postfix()

    def _postfix(self) -> None:
        self.bar.set_postfix_str(f"done {self.done - self.failed}, failed {self.failed}, "
                                 f"remaining {self.total - self.done}")

    def update(self, row: dict) -> None:
        self.done += 1
        if row["status"] != "done":
            self.failed += 1
        if self.bar is not None:
            self.bar.update(1)
            self._postfix()
            if row["status"] != "done":
                self.bar.write(f"failed: {row['variant']} seed {row['seed']}: {row['error']}")

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
