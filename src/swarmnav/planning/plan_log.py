"""The trajectories a planner committed during a run, kept for replay (the ``plans()`` hook).

A planner that commits trajectories (SPH, EGO-Swarm, the other Table II peers) adds each one
to a :class:`PlanLog` when it commits it, sampled every :data:`SAMPLE_SPACING` of plan time,
and returns :meth:`PlanLog.arrays` from its optional ``plans()`` hook; the rollout keeps that as
``RunResult.plans`` and the replay viewer draws it (docs/methods/contract.md gives the hook's
contract). Recording reads a plan and never changes it, so a run flies the same with or
without anyone asking for its plans.
"""

from __future__ import annotations

import numpy as np

#: Plan time [s] between two recorded samples of a committed trajectory (our choice: at the
#: planners' 1 m/s a sample every 0.1 m, finer than any drawn line needs, and a 90 s run of
#: 15 EGO-Swarm robots stays near a megabyte; docs/viewer.md).
SAMPLE_SPACING = 0.1
#: Plan time [s] recorded at most from a commit (our bound: 200 m at the planners' 1 m/s, beyond
#: every scene here; a plan stretched without bound by near-zero speed limits stays 2001 samples).
HORIZON = 200.0


def sample_times(duration: float, spacing: float = SAMPLE_SPACING) -> np.ndarray:
    """Times [s] from a plan's start at which it is recorded: every ``spacing`` and its end
    (the first :data:`HORIZON` of a longer plan)."""
    duration = float(duration)
    duration = HORIZON if duration > HORIZON else duration if duration > 0 else 0.0  # NaN: the start only
    tau = spacing * np.arange(int(np.floor(duration / spacing + 1e-9)) + 1)
    return tau if duration - tau[-1] <= 1e-9 else np.append(tau, duration)


def sample_rows(length: int, dt: float, spacing: float = SAMPLE_SPACING) -> np.ndarray:
    """Rows of a plan already sampled at ``dt`` over ``length`` steps (row j at ``j dt``) that
    are recorded: every ``round(spacing / dt)``-th row and the last (within :data:`HORIZON`)."""
    length = min(int(length), int(HORIZON / dt + 1e-9) + 1)
    stride = max(1, int(round(spacing / dt)))
    rows = np.arange(0, int(length), stride)
    return rows if rows[-1] == length - 1 else np.append(rows, length - 1)


class PlanLog:
    """Committed trajectories in commit order, as flat arrays (see :meth:`arrays`)."""

    __slots__ = ("_step", "_robot", "_points", "_times", "_dim")

    def __init__(self, dim: int) -> None:
        self._dim = int(dim)
        self._step: list[int] = []
        self._robot: list[int] = []
        self._points: list[np.ndarray] = []
        self._times: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self._step)

    def add(self, step: int, robot: int, times: np.ndarray, points: np.ndarray) -> None:
        """Record that ``robot`` committed at control step ``step`` the trajectory through
        ``points`` (M, d) [m] at run times ``times`` (M,) [s] (non-decreasing, M >= 1).

        A non-finite sample (an optimiser gone astray under extreme parameters) ends the record
        of the plan there; a plan without a finite first sample is not recorded."""
        points = np.asarray(points, dtype=np.float32).reshape(-1, self._dim)
        times = np.asarray(times, dtype=np.float32).reshape(-1)
        if len(points) != len(times) or len(points) == 0:
            raise ValueError(f"a plan needs as many times as points (>= 1), got {len(times)} and {len(points)}")
        bad = ~(np.isfinite(points).all(axis=1) & np.isfinite(times))
        if bad.any():
            cut = int(np.argmax(bad))
            if cut == 0:
                return
            points, times = points[:cut], times[:cut]
        self._step.append(int(step))
        self._robot.append(int(robot))
        self._points.append(points)
        self._times.append(times)

    def arrays(self) -> dict[str, np.ndarray]:
        """The hook's return value: ``step`` (P,) int32, ``robot`` (P,) int32, ``offsets``
        (P + 1,) int64, ``points`` (M, d) float32 [m], ``times`` (M,) float32 [s]; plan j is rows
        ``offsets[j]:offsets[j + 1]`` of ``points`` and ``times``."""
        counts = np.array([len(t) for t in self._times], dtype=np.int64)
        return {
            "step": np.array(self._step, dtype=np.int32),
            "robot": np.array(self._robot, dtype=np.int32),
            "offsets": np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            "points": np.concatenate(self._points) if self._points else np.zeros((0, self._dim), np.float32),
            "times": np.concatenate(self._times) if self._times else np.zeros(0, np.float32),
        }
