"""Agent dynamics: pure array functions, one per model, and thin frozen wrappers.

Every model maps ``(positions, velocities, command, dt) -> (positions, velocities)`` with
(N, 2) arrays. What the command means depends on the model: a desired acceleration for the
two double integrators, a velocity for the kinematic model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


def clip_norm(x: np.ndarray, limit: float) -> np.ndarray:
    """Scale each row of ``x`` (N, 2) down to Euclidean norm ``limit`` if it is longer."""
    if not np.isfinite(limit):
        return x
    n = np.sqrt(np.einsum("ij,ij->i", x, x))
    scale = np.minimum(1.0, limit / np.maximum(n, 1e-300))
    return x * scale[:, None]


@dataclass(frozen=True, slots=True)
class DampedDoubleIntegrator:
    """HES eq. (5)-(7): ``p' = v``, ``v' = u / m - c_d v`` with the inverse-model input
    ``u = m (a_cmd + c_d v)``, so that ``v' = a_cmd``.

    Integrated by semi-implicit Euler at step ``dt``: the input is formed from ``v_k`` and the
    drag is evaluated at ``v_k``, so the inverse model cancels the drag exactly and
    ``v_{k+1} = v_k + dt a_cmd``, ``p_{k+1} = p_k + dt v_{k+1}``.
    """

    mass: float = 5.0  # m [kg], HES Table A1
    drag: float = 0.5  # c_d [1/s], HES Section 2.3

    def input(self, a_cmd: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Inverse-model control input u [N], eq. (7)."""
        return self.mass * (a_cmd + self.drag * v)

    def step(self, p: np.ndarray, v: np.ndarray, a_cmd: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        if _plain(p) and _plain(v) and _plain(a_cmd) and p.shape == v.shape == a_cmd.shape:
            p_new, v_new = np.empty(p.shape), np.empty(p.shape)  # (a returned array costs more to box)
            _damped_step(p, v, a_cmd, float(dt), float(self.mass), float(self.drag), p_new, v_new)
            return p_new, v_new
        u = self.input(a_cmd, v)
        v_new = v + dt * (u / self.mass - self.drag * v)
        return p + dt * v_new, v_new


def _plain(a) -> bool:
    """``a`` is a 2-D float64 array (the compiled step's input)."""
    return type(a) is np.ndarray and a.ndim == 2 and a.dtype == np.float64


@njit(cache=True)
def _damped_step(p, v, a_cmd, dt, mass, drag, p_new, v_new):
    """:meth:`DampedDoubleIntegrator.step` in one pass into ``p_new``, ``v_new``, element by
    element the same operations as its numpy form (the same bits), without its five temporaries."""
    n, d = p.shape
    for i in range(n):
        for c in range(d):
            u = mass * (a_cmd[i, c] + drag * v[i, c])
            w = v[i, c] + dt * (u / mass - drag * v[i, c])
            v_new[i, c] = w
            p_new[i, c] = p[i, c] + dt * w



@dataclass(frozen=True, slots=True)
class SaturatedDoubleIntegrator:
    """SPH paper's discrete double integrator with saturation:
    ``v_{k+1} = clip(v_k + dt clip(a, a_max), v_max)``, ``p_{k+1} = p_k + dt v_{k+1}``."""

    v_max: float = 1.0  # [m/s], SPH Table I
    a_max: float = 1.5  # [m/s^2], SPH Table I

    def step(self, p: np.ndarray, v: np.ndarray, a_cmd: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v_new = clip_norm(v + dt * clip_norm(a_cmd, self.a_max), self.v_max)
        return p + dt * v_new, v_new


@dataclass(frozen=True, slots=True)
class Kinematic:
    """Velocity-commanded kinematics of the Vicsek family, HWVEM eq. (7)-(8):
    ``v_{k+1} = clip(v_cmd, v_max)``, ``p_{k+1} = p_k + dt v_{k+1}``; wrapped into
    ``[0, box)`` when the world is periodic (``box`` is the period [m])."""

    v_max: float = np.inf  # [m/s]
    box: float | None = None  # period of a periodic square world [m]

    def step(self, p: np.ndarray, v: np.ndarray, v_cmd: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v_new = clip_norm(v_cmd, self.v_max)
        p_new = p + dt * v_new
        if self.box is not None:
            p_new = np.mod(p_new, self.box)
        return p_new, v_new
