"""The replanning schedule: every robot replans every ``T_p`` seconds of the control clock."""

from __future__ import annotations


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
