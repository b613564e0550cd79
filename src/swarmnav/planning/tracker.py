"""References sampled from each robot's plan, and the tracking law that follows them.

A planner hands over one plan per robot (anything with a ``sample(tau) -> (q, v, a)``, e.g. a
B-spline); :class:`References` samples all of them once per replan at the control rate, so the
control loop reads the reference of step ``k`` as an array lookup. The command is the tracking
law of the SPH paper's eq. (13) without its force term,

    a_i = k_p (q*_i - q_i) + k_v (v*_i - v_i) + a*_i,

which is also how the Table II peers' controllers follow their trajectories (a PD loop on
position and velocity with the planned acceleration as feed-forward).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

#: a plan's sampler: times [s] from the plan's start (L,) -> q, v, a, each (L, D)
Sampler = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


class References:
    """Every robot's reference, sampled at ``tau_j = j dt`` from the step it was planned."""

    __slots__ = ("q", "v", "a", "k0")

    def __init__(self) -> None:
        self.q = self.v = self.a = None  # (N, L, D) position [m], velocity [m/s], acceleration [m/s^2]
        self.k0 = 0  # step at which they were sampled

    @property
    def empty(self) -> bool:
        return self.q is None

    @property
    def length(self) -> int:
        return 0 if self.q is None else self.q.shape[1]

    def load(self, samplers: Sequence[Sampler], step: int, length: int, dt: float, dim: int) -> None:
        """Sample each robot's plan over ``length`` control steps of ``dt`` [s] from ``step``."""
        n = len(samplers)
        tau = dt * np.arange(length)
        self.q = np.empty((n, length, dim))
        self.v = np.empty((n, length, dim))
        self.a = np.empty((n, length, dim))
        for r, f in enumerate(samplers):
            self.q[r], self.v[r], self.a[r] = f(tau)
        self.k0 = step

    def at(self, step: int, delay: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The references of ``step`` (each robot ``delay`` steps behind, if given); past the
        end of a plan, its last sample."""
        n, length = self.q.shape[:2]
        k = step - self.k0
        k = np.clip(k - delay if delay is not None else np.full(n, k), 0, length - 1)
        r = np.arange(n)
        return self.q[r, k], self.v[r, k], self.a[r, k]


def track(x: np.ndarray, v: np.ndarray, q_ref: np.ndarray, v_ref: np.ndarray, a_ref: np.ndarray,
          k_p: float, k_v: float, feedforward: np.ndarray | None = None) -> np.ndarray:
    """The tracking law (SPH eq. 13): ``feedforward + k_p (q* - q) + k_v (v* - v) + a*`` [m/s^2],
    (N, D); ``feedforward`` is SPH's ``F / m`` (None: none)."""
    if feedforward is None:
        return k_p * (q_ref - x) + k_v * (v_ref - v) + a_ref
    return feedforward + k_p * (q_ref - x) + k_v * (v_ref - v) + a_ref
