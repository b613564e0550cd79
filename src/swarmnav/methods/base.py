"""The method contract: what a navigation method receives each step and what it returns.

A method is a small stateful object that wires pure functions. The rollout loop calls
``reset`` once and then ``act`` every step; ``act`` returns the command for the method's own
dynamics model and an ``info`` dict. Metrics-only data goes in ``info``:

- ``labels``: (N,) int sub-swarm id of every agent (omitted: one swarm);
- ``events``: list of ``{"action", "source", "reason"}`` structural events this step;
- ``done``: True ends the run after this step (the recorded arrays stop there);
- anything else is ignored by the loop.

``summary()`` returns method-specific run metrics (floats) merged into ``RunResult.metrics``.
An optional ``artifacts()`` returns extra files of the run, ``{file name: str | bytes}``, kept
in ``RunResult.artifacts`` and written into the run directory (e.g. an LLM transcript).
An optional ``timings()`` returns wall-clock figures (``RunResult.timings``, never metrics). An
optional ``plans()`` returns the trajectories the method committed, as flat arrays ``step``
(P,), ``robot`` (P,), ``offsets`` (P + 1,), ``points`` (M, d) [m] and ``times`` (M,) [s]
(``swarmnav.planning.plan_log.PlanLog`` builds them), kept in ``RunResult.plans`` and drawn by
the replay viewer. An optional ``close()`` releases what ``reset`` started (planning threads);
the rollout calls it when the steps end, however they end. An optional ``oracle`` attribute
(HES's ``decision=oracle``) receives the run's lookahead simulator (docs/oracle.md).
docs/methods/contract.md states the whole contract.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.world.scenario import Scenario


@dataclass(frozen=True, slots=True)
class Observation:
    """What the agents know at step ``step``: each its own state (``positions[i]``,
    ``velocities[i]``), and the others' states as its network delivered them (``view``; None: the
    ideal network, every agent's true state at once). A method reads another agent's state only
    through :meth:`others` (docs/network.md). Under imperfect perception (``sensing``; docs/sensing.md)
    ``positions`` and ``velocities`` are each agent's estimates of its own state, and a range
    sensor is read through :meth:`scan`."""

    step: int
    time: float  # [s]
    positions: np.ndarray  # (N, d) [m], d = the world's dimension
    velocities: np.ndarray  # (N, d) [m/s]
    view: Any = None  # swarmnav.sim.network.View, or None (ideal network)
    sensing: Any = None  # swarmnav.sensing.perception.Perception, or None (perfect perception)

    def scan(self, cast, x: np.ndarray, directions: np.ndarray, max_range: float) -> np.ndarray:
        """Every agent's range-sensor reading (N, R) [m]: ``cast(x)``, the method's exact kernel
        (rays ``directions`` (R, d), range ``max_range`` [m]) from its positions ``x`` (N, d), row i
        agent i. Under imperfect perception the rays leave from the true positions and come back
        with the run's range noise, dropouts and field of view (docs/sensing.md); under perfect
        perception this is ``cast(x)``."""
        if self.sensing is None:
            return cast(x)
        return self.sensing.scan(cast, x, directions, max_range)

    def others(self, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Agent ``j[p]``'s position (P, d) [m] and velocity (P, d) [m/s] as agent ``i[p]`` last
        received them, and whether it has received any (P,) bool (a pair never heard must be
        left out). The ideal network gives the true states."""
        if self.view is None:
            return self.positions[j], self.velocities[j], np.ones(len(j), dtype=bool)
        return self.view.positions[i, j], self.view.velocities[i, j], np.isfinite(self.view.age[i, j])

    def known(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every agent's picture of every other: positions (N, N, d) [m] and velocities (N, N, d)
        [m/s] of agent j as agent i last received them, and (N, N) bool heard; row i, column i
        is agent i's own state. All pairs: for methods whose kernels take all pairs at once."""
        n = len(self.positions)
        if self.view is None:
            shape = (n, *self.positions.shape)
            return (np.broadcast_to(self.positions, shape), np.broadcast_to(self.velocities, shape),
                    np.ones((n, n), dtype=bool))
        return self.view.positions, self.view.velocities, np.isfinite(self.view.age)

    def received(self, name: str) -> np.ndarray | None:
        """What each agent received of every other's publication ``name`` (a method's ``info
        ["publish"]``; docs/network.md): an (N, N, ...) float array (NaN: none received yet) or an
        (N, N) object array (None: none received yet), row i, column i agent i's own last one.
        None under the ideal network (the method reads its own arrays) and before anything was
        published under that name."""
        return None if self.view is None else self.view.payload(name)


class Dynamics(Protocol):
    def step(self, p: np.ndarray, v: np.ndarray, command: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]: ...


class Method(Protocol):
    """A navigation method (see module docstring)."""

    name: str
    params: Any
    dynamics: Dynamics
    dt: float  # integration step [s] the method is designed for
    dims: tuple[int, ...]  # world dimensions flown natively; (2,): a 3-D scene is flown in its slice at z_fly
    # optional ``networked: bool`` (absent: False): True for a method that reads every other agent
    # only through ``Observation.others`` / ``known``; the rollout refuses a non-ideal network
    # (``net.*``) for any other method with one line
    # optional ``periodic: bool`` (absent: True): False for a method that cannot fly a periodic
    # box (the trajectory planners); the rollout refuses such a run with one line
    # optional ``range_sensor: bool`` (absent: False): True for a method that reads a range sensor
    # (LiDAR ring, 3-D scan) through ``Observation.scan``; the rollout refuses the range
    # options of imperfect perception (``sense.range_noise``, ``dropout``, ``fov``) for any other

    def reset(self, scenario: Scenario, positions: np.ndarray, velocities: np.ndarray, rng: np.random.Generator) -> None: ...

    def act(self, obs: Observation, rng: np.random.Generator) -> tuple[np.ndarray, dict]: ...

    def summary(self) -> dict[str, float]: ...


def check_map_bytes(method: str, what: str, need: float, limit: int, key: str, hint: str) -> None:
    """Refuse (ConfigError) a run whose maps would take ``need`` bytes, more than ``limit``.

    Maps a method sizes by the world (grids over the bounds or the start-goal box) are checked
    before they are allocated: a world kilometres wide at a 0.1 m resolution would otherwise end
    in a MemoryError (or take the machine's memory) instead of one line naming the parameter.
    """
    if not need <= limit:
        raise ConfigError(f"{method}: {what} needs {format_bytes(need)} of maps (limit {format_bytes(limit)}: "
                          f"{key}); {hint}")


def format_bytes(n: float) -> str:
    """``n`` bytes in binary units, three significant digits: ``2 GiB``, ``2.84 PiB``."""
    if not math.isfinite(n):
        return "over 1e308 B"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB"):
        if n < 1024:
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} YiB"


def format_extent(lo, hi) -> str:
    """The extent of a box as ``2000000 m x 42.5 m`` (0.1 m; beyond 10 000 km, 4 digits)."""
    sides = (float(b - a) for a, b in zip(lo, hi))
    return " x ".join((f"{s:.4g}" if s >= 1e7 else f"{s:.1f}".removesuffix(".0")) + " m" for s in sides)
