"""Passage mode (ours, beyond the paper): the safety distance inside a throat the planner chose.

Eq. (36) adds ``k_e (d_safe - d + 1)^2 >= k_e = 48 m/s^2`` for every local minimum of the LiDAR
ring closer than d_safe. In a throat narrower than ``2 d_safe`` both sides are within d_safe and
the gate corner pushes an agent at the entrance backwards with tens of m/s^2 against
a_max = 2.6 m/s^2: the safety law forbids exactly the passage the planner committed to.

Passage mode keys the near-obstacle term on the geometry of that passage instead. A member of
a sub-swarm whose route is a detected throat of width w, while inside the throat's *tube*
(within ``half_len`` of the throat along its normal and within ``w/2 + reach`` of its centre
line across it), uses

    d_safe_eff = min(d_safe - relief, w/2 - margin)

so the centre line of the throat keeps ``margin`` of clearance beyond d_safe_eff (the
near-obstacle term stays off there and engages only for an agent more than ``margin`` off
centre), and the term never pushes a member out of a throat it fits through. Everywhere else,
and as soon as the member leaves the tube, d_safe applies unchanged. ``relief`` lowers d_safe a
little even where w/2 - margin >= d_safe, for throats that leave a narrow band without being
narrower than 2 (d_safe + margin) (which throats are passages at all: ``HesParams.passage_band``).
"""

from __future__ import annotations

import numpy as np


def throat_dsafe(half_width, d_safe: float, margin: float, relief: float = 0.0):
    """d_safe_eff [m] in a throat of half-width ``half_width`` [m] (scalar or array):
    min(d_safe - relief, max(w/2 - margin, 0)). Passage mode's tubes and the stall planner's
    narrow places both use it."""
    return np.minimum(d_safe - relief, np.maximum(np.asarray(half_width, dtype=float) - margin, 0.0))


def passage_dsafe(x: np.ndarray, mid: np.ndarray, normal: np.ndarray, width: float, d_safe: float,
                  margin: float, half_len: float, reach: float, relief: float = 0.0) -> np.ndarray:
    """Per-agent safety distance [m] for agents at ``x`` (M, 2) following a throat.

    Args:
        x: (M, 2) positions [m] of the members of the sub-swarm whose route is the throat.
        mid, normal: (2,) throat midpoint [m] and unit exit direction.
        width: throat width w [m]; d_safe: the nominal safety distance [m] (Table A1).
        margin: clearance [m] kept between the throat's centre line and d_safe_eff.
        half_len: tube half-length [m] along ``normal``; reach: tube half-width beyond w/2 [m].
        relief: [m] d_safe_eff never exceeds d_safe - relief inside the tube.

    Returns:
        (M,) d_safe_eff = min(d_safe - relief, max(w/2 - margin, 0)) inside the tube, d_safe outside.
    """
    rel = np.asarray(x, dtype=float) - mid
    along = rel @ normal
    across = np.abs(rel @ np.array([-normal[1], normal[0]]))
    inside = (np.abs(along) <= half_len) & (across <= 0.5 * width + reach)
    return np.where(inside, throat_dsafe(0.5 * width, d_safe, margin, relief), d_safe)
