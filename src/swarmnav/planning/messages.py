"""What robots broadcast, counted in bytes, so communication is measured rather than assumed.

Every broadcast is one UDP datagram to the swarm (the SPH paper's robots share positions over
Wi-Fi UDP broadcast, Section IV-B; EGO-Swarm and MADER broadcast trajectories on a shared
topic). A message's size is its payload plus the UDP (8 B) and IPv4 (20 B) headers, with the
payload the fields a planner must send, 8 B a float and 4 B an integer (our reading; the
papers give no sizes):

- position: sender id (4 B), time stamp (8 B) and position (3 floats): 64 B with
  headers, whatever the world's dimension (the paper's robots fly in 3-D);
- trajectory: sender id, trajectory id (4 B each), start time and knot span (8 B each), the
  count of control points (4 B) and the control points (3 floats each).

:class:`CommLog` adds up what a run sent; ``summary(duration)`` gives the ``comm_*`` metrics:
messages, bytes, and the swarm's aggregate load ``comm_mbps`` [Mbit/s] over the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

HEADERS = 28  # [B] UDP (8) + IPv4 (20)
FLOAT = 8  # [B]
INT = 4  # [B]
POSITION_BYTES = HEADERS + INT + FLOAT + 3 * FLOAT  # 64 B
_TRAJECTORY_HEAD = HEADERS + 2 * INT + 2 * FLOAT + INT  # 56 B before the control points


def trajectory_bytes(n_points: int) -> int:
    """Size [B] of a broadcast trajectory of ``n_points`` control points (module docstring)."""
    return _TRAJECTORY_HEAD + 3 * FLOAT * int(n_points)


class CommLog:
    """Messages a run sent: counts and bytes, and periodic broadcasts on the control clock."""

    __slots__ = ("messages", "bytes")

    def __init__(self) -> None:
        self.messages = 0
        self.bytes = 0

    def send(self, count: int, size: int) -> None:
        """``count`` messages of ``size`` bytes each."""
        self.messages += int(count)
        self.bytes += int(count) * int(size)

    def periodic(self, step: int, dt: float, rate_hz: float, count: int, size: int) -> None:
        """``count`` robots broadcast ``size``-byte messages at ``rate_hz``: they send at the steps
        ``step % every == 0`` with ``every = max(1, round(1 / (rate_hz dt)))``."""
        if rate_hz > 0 and step % max(1, int(round(1.0 / (rate_hz * dt)))) == 0:
            self.send(count, size)

    def summary(self, duration: float) -> dict[str, float]:
        """``comm_messages``, ``comm_bytes`` [B] and ``comm_mbps``: bits sent per second of the
        run ``duration`` [s], in Mbit/s."""
        return {
            "comm_messages": float(self.messages),
            "comm_bytes": float(self.bytes),
            "comm_mbps": self.bytes * 8 / duration / 1e6 if duration > 0 else 0.0,
        }


@dataclass(frozen=True, slots=True)
class Broadcast:
    """One trajectory a robot broadcast, as every receiver holds it: immutable, so a copy that
    arrives late is the trajectory as it was sent (docs/network.md).

    ``sampler(tau)`` gives the plan at times ``tau`` [s] from its start as a tuple whose first
    array is the positions (L, D) [m]; the plan starts at ``start`` [s] on the run's clock (the
    clock every robot shares) and holds its last state after ``end`` [s]. ``data`` is what a
    planner sends besides (its control points, the step it was committed at); the arrays in it
    are never changed after the broadcast."""

    sampler: Callable
    start: float
    end: float
    data: Any = None
    nbytes: int = 0  # [B] its size on the air without the UDP/IP headers (module docstring); 0: not counted


def sample_broadcasts(plans, times: np.ndarray, dim: int) -> np.ndarray:
    """Positions [m] of broadcast ``plans`` (a sequence of :class:`Broadcast`, None: nothing
    received) at absolute ``times`` [s]: (len(plans), len(times), dim), NaN for None. Times
    outside a plan are clamped to it (before its start: its first state; after its end: its
    last): a plan that arrives late is read at the true present time."""
    out = np.full((len(plans), len(times), dim), np.nan)
    for k, b in enumerate(plans):
        if b is not None:
            tau = np.clip(np.asarray(times, dtype=float), b.start, b.end) - b.start
            out[k] = b.sampler(tau)[0]
    return out


class TrajectoryBoard:
    """The latest trajectory each robot has broadcast, as the others hold it under the ideal
    network (every broadcast heard at once).

    A planner that broadcasts its plan (EGO-Swarm, MADER) ``publish``-es it with its start
    time on the run's clock; the others read every robot's plan at absolute times with
    :meth:`sample`. Each publication is one trajectory message in the run's :class:`CommLog`.
    ``records`` holds each robot's latest :class:`Broadcast` (None before its first), what a
    planner publishes to a non-ideal network (``info["publish"]``).
    """

    __slots__ = ("samplers", "start", "end", "log", "records")

    def __init__(self, n: int, log: CommLog):
        self.samplers: list = [None] * n  # per robot: times from its start (L,) -> (q, v, a), each (L, D)
        self.start = np.full(n, np.nan)  # [s] start of each robot's plan on the run's clock
        self.end = np.full(n, np.nan)  # [s] its end (the plan holds its last state after it)
        self.log = log
        self.records: list[Broadcast | None] = [None] * n

    def publish(self, robot: int, sampler, t_start: float, duration: float, n_points: int, data: Any = None) -> None:
        """Robot ``robot`` broadcasts a plan of ``n_points`` control points starting at
        ``t_start`` [s] and lasting ``duration`` [s]; ``data``: what it sends besides
        (:class:`Broadcast`)."""
        self.samplers[robot] = sampler
        self.start[robot] = t_start
        self.end[robot] = t_start + duration
        self.records[robot] = Broadcast(sampler, float(self.start[robot]), float(self.end[robot]), data,
                                        trajectory_bytes(n_points) - HEADERS)
        self.log.send(1, trajectory_bytes(n_points))

    def sample(self, robots: np.ndarray, times: np.ndarray, dim: int) -> np.ndarray:
        """Positions [m] of ``robots``' latest plans at absolute ``times`` [s]: (len(robots),
        len(times), dim); NaN for a robot that has published nothing. Times outside a plan are
        clamped to it (before its start: its first state; after its end: its last)."""
        out = np.full((len(robots), len(times), dim), np.nan)
        for k, r in enumerate(robots):
            f = self.samplers[r]
            if f is not None:
                tau = np.clip(np.asarray(times, dtype=float), self.start[r], self.end[r]) - self.start[r]
                out[k] = f(tau)[0]
        return out
