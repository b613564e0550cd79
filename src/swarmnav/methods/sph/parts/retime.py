"""Re-timing of local plans the spline cuts short (ours, not in the paper; switch ``retime`` > 0, on in
``preset=retime``, the 3-D Table II set; docs/methods/sph.md, *Re-timing*)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from swarmnav.planning.bspline import evaluate, optimize
from swarmnav.planning.maps import resample


def retimed(plan, start, end, pts: np.ndarray, retime: float, ctrl_spacing: float,
            guide: Callable[[np.ndarray], np.ndarray], dt_knot: float, esdf, costs, max_iter: int):
    """``plan`` optimised again, seeded from its own curve, if that curve is shorter than
    ``retime`` times the grid path ``pts`` it was seeded from (a path the spline cuts short);
    None if it is not. The knots are spent on the path's length, so the cut spline flies
    slower than the planner's speed, and from a reference at rest it starts so slowly that
    the next replan starts from rest again. ``guide`` turns path points ``ctrl_spacing`` [m]
    apart into the interior control points, as for the first optimisation."""
    tau = np.linspace(0.0, plan.duration, 8 * (plan.ctrl.shape[0] - 3) + 1)
    curve, _, _ = evaluate(plan.ctrl, plan.dt_knot, tau)
    length = float(np.sum(np.linalg.norm(np.diff(curve, axis=0), axis=1)))
    if length >= retime * float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))):
        return None
    seed = guide(resample(curve, ctrl_spacing))  # the end point is not a guide
    if len(seed) == 0:
        return None
    return optimize(start, end, seed, dt_knot, esdf, costs, max_iter)
