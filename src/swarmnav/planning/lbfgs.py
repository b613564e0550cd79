"""The two pieces of L-BFGS (Nocedal & Wright, Alg. 7.4) that the compiled spline optimisers
share (SPH's in ``planning/bspline.py``, EGO-Swarm's in ``methods/ego_swarm/optimizer.py``);
each optimiser keeps its own cost, line search and stopping rule around them.

The curvature pairs live in a ring buffer: ``S``, ``Y`` (mem, n), ``rho`` (mem,), the next slot
``head`` and the number stored ``count``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def direction(g, S, Y, rho, alpha, head, count, mem, first_step):
    """The quasi-Newton step ``H g`` by the two-loop recursion with the ``s'y / y'y`` scaling;
    with no pair stored, ``g`` scaled so the first step moves at most ``first_step`` [m]."""
    q = g.copy()
    for c in range(count):  # newest first
        idx = (head - 1 - c) % mem
        alpha[idx] = rho[idx] * np.dot(S[idx], q)
        q -= alpha[idx] * Y[idx]
    if count > 0:
        last = (head - 1) % mem
        q *= 1.0 / (rho[last] * np.dot(Y[last], Y[last]))
    else:
        q *= min(1.0, first_step / max(np.sqrt(np.dot(g, g)), 1e-12))
    for c in range(count - 1, -1, -1):  # oldest first
        idx = (head - 1 - c) % mem
        b = rho[idx] * np.dot(Y[idx], q)
        q += (alpha[idx] - b) * S[idx]
    return q
