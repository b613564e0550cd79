"""One job of an experiment: what to run (:class:`Job`, :func:`plan`) and running it
(:func:`execute`, :func:`failed_row`).

Shared by the runner (which plans jobs and stores their rows) and the back ends (which
execute them), so neither has to import the other.
"""

from __future__ import annotations

import hashlib
import io
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from swarmnav._version import __version__
from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.experiments.spec import Experiment, Variant
from swarmnav.experiments.store import config_key


@dataclass(frozen=True, slots=True)
class Job:
    """One run to do: a variant, a seed, and the key of its full configuration."""

    key: str
    experiment: str
    variant: Variant
    seed: int
    config: dict[str, Any]


def plan(exp: Experiment) -> list[Job]:
    """The experiment's jobs in spec order, each keyed by the hash of its configuration.

    Fails fast (before any worker starts) on a bad method, parameter or scene. The key covers
    the method, its fully resolved parameters (defaults included; not those of how a run is
    computed, such as SPH's ``threads``, which give identical results: :func:`swarmnav.params.identity`),
    the scene's identity (the text of a scene file, or a generator spec), swarm size, steps and seed.
    """
    from swarmnav.dynamics.vehicle import is_vehicle_option, record as vehicle_record, vehicle_params
    from swarmnav.methods import registry
    from swarmnav.params import identity
    from swarmnav.sensing.perception import PREFIX as SENSE_PREFIX, record as sense_record, sense_params
    from swarmnav.sim.network import PREFIX as NET_PREFIX, net_params, record as net_record
    from swarmnav.sim.rollout import is_run_option
    from swarmnav.world.catalog import load_scenario

    jobs = []
    for v in exp.variants:
        try:
            method_params = {k: x for k, x in v.params.items() if not is_run_option(k)}
            params = identity(registry.make(v.method, **method_params).params)
            params.update({k: x for k, x in v.params.items()
                           if is_run_option(k) and not k.startswith((NET_PREFIX, SENSE_PREFIX))
                           and not is_vehicle_option(k)})
            net = net_params({k: x for k, x in v.params.items() if k.startswith(NET_PREFIX)})
            if not net.ideal:  # the network as resolved: `net.loss=0.30` and `net.loss=0.3` are one run,
                params["net"] = net_record(net)  # and an ideal network leaves the key as without one
            sense = sense_params({k: x for k, x in v.params.items() if k.startswith(SENSE_PREFIX)})
            if not sense.perfect:  # perception as resolved, as the network; perfect leaves the key unchanged
                params["sense"] = sense_record(sense)
            # the vehicle as resolved ({"vehicle": ..., "wind": ...}); the point vehicle adds no key
            params.update(vehicle_record(*vehicle_params({k: x for k, x in v.params.items() if is_vehicle_option(k)})))
            load_scenario(v.scenario.replace("{seed}", str(exp.seeds[0])), n=v.n)
        except SwarmnavError as e:
            raise ConfigError(f"{exp.name} variant '{v.name}': {e}") from None
        for s in exp.seeds:
            scenario = v.scenario.replace("{seed}", str(s))
            config = {"method": v.method, "params": params, "scene": _scene_identity(scenario),
                      "n": v.n, "steps": v.steps, "seed": s}
            jobs.append(Job(config_key(config), exp.name, v, s, config))
    return jobs


def variant_key(job: Job) -> str:
    """sha256 of a job's configuration without its seed: the same for every seed of a variant
    (a scene that names ``{seed}`` is identified by its template), so two sweeps of the same
    variants agree on it whatever seeds each ran."""
    config = {k: v for k, v in job.config.items() if k != "seed"}
    config["scene"] = _scene_identity(job.variant.scenario)
    return config_key(config)


def _scene_identity(scenario: str) -> str:
    """A file's or built-in scene's content hash; a generator spec is its own identity."""
    from swarmnav.world.scenario import builtin_names

    if scenario in builtin_names():
        text = resources.files("swarmnav.world").joinpath("scenes", f"{scenario}.toml").read_bytes()
        return f"{scenario}@{hashlib.sha256(text).hexdigest()[:16]}"
    p = Path(scenario)
    if scenario.endswith(".toml") and p.is_file():
        return f"{p.name}@{hashlib.sha256(p.read_bytes()).hexdigest()[:16]}"
    return scenario


def execute(job: Job, keep_trajectory: bool = True) -> dict[str, Any]:
    """Run one job (in a worker) -> the store row. Never raises: a failed run is a row too.

    The trajectory travels back to the driver as compressed ``.npz`` bytes (``row["_npz"]``),
    so workers need no shared filesystem (a Ray cluster) and only the driver writes files.
    """
    from swarmnav.sim import run
    from swarmnav.world.catalog import load_scenario

    v = job.variant
    row: dict[str, Any] = {
        "key": job.key, "experiment": job.experiment, "variant": v.name,
        "scenario": v.scenario.replace("{seed}", str(job.seed)), "method": v.method, "seed": job.seed,
        "n": v.n, "steps": v.steps, "params": v.params, "config": job.config, "version": __version__,
        "metrics": {}, "trajectory": "", "error": "",
    }
    t0 = time.perf_counter()
    try:
        res = run(v.method, load_scenario(row["scenario"], n=v.n), seed=job.seed, steps=v.steps, **v.params)
        if keep_trajectory:
            buf = io.BytesIO()
            extra = {}  # a quadrotor run's attitude: the thrust axes its report viewer draws (docs/vehicle.md)
            if res.thrust_axis is not None:
                extra["thrust_axis"] = np.asarray(res.thrust_axis, dtype=np.float32)
            np.savez_compressed(buf, positions=res.positions.astype(np.float32), labels=res.labels,
                                min_clearance=res.min_clearance.astype(np.float32), **extra)
            row["_npz"] = buf.getvalue()
        if res.artifacts:  # e.g. the LLM transcript: kept beside the trajectory
            row["_artifacts"] = dict(res.artifacts)
        timings = {f"time.{k}": v for k, v in res.timings.items()}  # wall clock, stored beside the metrics
        row.update(status="done", metrics={**res.metrics, **timings})
    except Exception as e:  # noqa: BLE001 - a failed run is recorded, never fatal to the sweep
        row.update(status="failed", error=f"{type(e).__name__}: {e}".splitlines()[0][:500])
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def failed_row(job: Job, error: str) -> dict[str, Any]:
    """The row of a run whose worker never returned (it died, or the back end lost it)."""
    v = job.variant
    return {"key": job.key, "experiment": job.experiment, "variant": v.name,
            "scenario": v.scenario.replace("{seed}", str(job.seed)), "method": v.method, "seed": job.seed,
            "n": v.n, "steps": v.steps, "params": v.params, "config": job.config, "version": __version__,
            "metrics": {}, "trajectory": "", "status": "failed", "error": error[:500], "wall_time_s": None}
