"""Experiments: declarative specs and the runner."""

from swarmnav.experiments.runner import run_experiment
from swarmnav.experiments.spec import Experiment, Variant, builtin_names, load_experiment, parse_seeds

__all__ = ["Experiment", "Variant", "builtin_names", "load_experiment", "parse_seeds", "run_experiment"]
