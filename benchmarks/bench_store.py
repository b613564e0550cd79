"""A 10,000-run results store stays responsive: export (runs.csv, summary.csv) and report.

Run: ``python benchmarks/bench_store.py``. Builds a synthetic store of 10,000 runs (10
variants x 1000 seeds, the metric set of a real run, random values) in a temporary directory,
then times the export and ``swarmnav report`` on it, without and with ``--compare`` (the
paired-seed figure of two variants over their 1000 seeds).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from swarmnav.experiments.report import write_report
from swarmnav.experiments.runner import export
from swarmnav.experiments.store import Store, config_key

METRICS = ["E_mean", "E_90", "sigma_E", "R_goal", "Y", "R_unsafe", "d_clr_min", "R_below_0_75", "R_below_0_30",
           "L_mean", "path_stretch", "S_scene", "min_inter_agent_distance", "collisions", "N_swarm", "N_event"]


def main(n_variants: int = 10, n_seeds: int = 1000) -> None:
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as d:
        store = Store(d)
        keys, jobs, variants, rows = [], [], [], []
        t0 = time.perf_counter()
        for v in range(n_variants):
            name = f"variant{v}"
            variants.append({"name": name, "columns": {"variant": name, "method": "hes", "scenario": "default_corridor"}})
            for s in range(1, n_seeds + 1):
                cfg = {"variant": name, "seed": s}
                k = config_key(cfg)
                keys.append(k)
                jobs.append([k, name, s])
                rows.append({"key": k, "experiment": "big", "variant": name, "scenario": "default_corridor",
                             "method": "hes", "seed": s, "n": 20, "steps": 1000, "params": {}, "config": cfg,
                             "status": "done", "error": "", "version": "bench", "trajectory": "",
                             "metrics": {m: float(rng.normal(v, 1)) for m in METRICS}, "wall_time_s": 0.5})
        store.put_many(rows)
        store.set_meta("experiment:big", {"name": "big", "description": "synthetic 10,000-run store",
                                          "seeds": list(range(1, n_seeds + 1)), "variants": variants,
                                          "keys": keys, "jobs": jobs, "report": {"reference": "hes.table2"}})
        store.set_meta("last_experiment", "big")
        t_build = time.perf_counter() - t0
        size = (Path(d) / "results.sqlite").stat().st_size
        t0 = time.perf_counter()
        runs, summary = export(store, "big")
        t_export = time.perf_counter() - t0
        t0 = time.perf_counter()
        write_report(d)
        t_report = time.perf_counter() - t0
        t0 = time.perf_counter()
        write_report(d, compare=("variant0", "variant1"))
        t_compare = time.perf_counter() - t0
        print(f"store of {len(runs)} runs ({size / 2**20:.1f} MiB) built in {t_build:.1f} s")
        print(f"export runs.csv + summary.csv: {t_export:.2f} s")
        print(f"report.md + report.html:      {t_report:.2f} s   (target: seconds)")
        print(f"  with --compare variant0 variant1: {t_compare:.2f} s")


if __name__ == "__main__":
    main()
