"""The replanning schedule (every robot replans every ``T_p`` seconds of the control clock),
the plan-length guard and the planners' timing figures."""

from __future__ import annotations

import numpy as np

from swarmnav.errors import ConfigError

#: Control steps a plan may take (our bound; a planner keeps each plan sampled at the control
#: rate, 1e5 steps of references are 72 MB for 15 robots in 2-D).
MAX_PLAN_STEPS = 100_000


def check_plan_steps(method: str, horizon: str, length: float, v_max: float, a_max: float, dt: float,
                     factor: float = 1.0) -> None:
    """Refuse (ConfigError) bounds whose plan cannot fit in :data:`MAX_PLAN_STEPS` steps of ``dt``:
    ``factor`` x (a plan of ``length`` [m] (parameter ``horizon``) at ``v_max``, then a stop at
    ``a_max``). Near-zero bounds (v_max = 1e-200 m/s) would stretch a plan past any memory and
    turn its timing into inf or NaN; each value alone is within its declared range."""
    seconds = factor * (length / v_max + v_max / a_max)
    if not seconds / dt <= MAX_PLAN_STEPS:
        raise ConfigError(f"{method}: a plan of {horizon} = {length:g} m at v_max = {v_max:g} m/s, then a stop at "
                          f"a_max = {a_max:g} m/s^2, lasts {seconds:.3g} s, {seconds / dt:.3g} control steps of dt "
                          f"(at most {MAX_PLAN_STEPS:.0e}); raise v_max or a_max")


class ReplanSchedule:
    """Replans every ``every`` control steps: ``every = max(1, round(T_p / dt))``.

    ``due(step)`` is True at the first step and whenever ``every`` steps have passed since the
    last replan (``done(step)`` records it), so a plan made late does not shift the grid of
    later ones any further than it has to.
    """

    __slots__ = ("every", "last")

    def __init__(self, period: float, dt: float):
        self.every = max(1, int(round(period / dt)))  # [steps]
        self.last: int | None = None  # step of the last replan

    def due(self, step: int) -> bool:
        return self.last is None or step - self.last >= self.every

    def done(self, step: int) -> None:
        self.last = step


def plan_time_summary(samples_ms: list[float]) -> dict[str, float]:
    """The planners' ``timings()`` figures from wall-clock samples [ms], one per robot per
    replan (or control step): ``plan_ms_median``, ``plan_ms_p95`` and ``plan_ms_max``; all 0
    for a run that never planned. Wall clock, so never metrics (docs/methods/contract.md)."""
    t = np.asarray(samples_ms, dtype=float) if len(samples_ms) else np.zeros(1)
    return {"plan_ms_median": float(np.median(t)), "plan_ms_p95": float(np.percentile(t, 95)),
            "plan_ms_max": float(t.max())}
