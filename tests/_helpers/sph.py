"""A lone SPH robot in an open field, and the reference speed its replans set."""

from __future__ import annotations

import numpy as np

import swarmnav
from swarmnav.methods import registry
from swarmnav.world import from_dict

LONE = {"name": "lone", "swarm": {"n": 1, "spawn": [-0.1, -0.1, 0.1, 0.1]}, "goal": {"position": [30.0, 0.0]},
        "world": {"bounds": [-6.0, -8.0, 36.0, 8.0]},
        "obstacles": [{"type": "circle", "center": [4.0, 7.0], "radius": 0.5}]}


def cruise_reference_speed(**params):
    """(mean reference speed [m/s] of the lone robot's replans between 4 s and 8 s of an open
    flight, the 9 s run)."""
    m = registry.make("sph", **{"preset": "paper", **params})  # the paper build unless a preset is named
    speeds = []
    orig = m._replan

    def spy(step, x, v, *rest):
        orig(step, x, v, *rest)
        if 4.0 <= step * m.dt <= 8.0:
            speeds.append(np.linalg.norm(m.references.v[0], axis=1).mean())

    m._replan = spy
    res = swarmnav.run(m, from_dict(LONE), seed=1, steps=round(9.0 / m.dt))
    return float(np.mean(speeds)), res
