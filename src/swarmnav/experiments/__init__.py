"""Experiments: declarative specs, the results store, back ends, the runner and reports."""

from swarmnav.experiments.runner import export, plan, run_experiment
from swarmnav.experiments.spec import Experiment, Variant, builtin_names, load_experiment, parse_seeds
from swarmnav.experiments.store import Store

__all__ = ["Experiment", "Store", "Variant", "builtin_names", "export", "load_experiment", "parse_seeds", "plan",
           "run_experiment"]
