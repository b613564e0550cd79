"""The band guard (ours, not in the paper; switch ``band_guard``, on in ``preset=guard``): inside the
obstacle band the tracking law of eq. (13) may not press a robot into the obstacle
(docs/methods/sph.md, *Final approach and band guard*)."""

from __future__ import annotations

import numpy as np


def band_guard(track: np.ndarray, d: np.ndarray, grad_d: np.ndarray, d_thr: float) -> np.ndarray:
    """Tracking acceleration ``track`` (N, D) [m/s^2] without its component towards the obstacle
    for robots inside the obstacle band (``d < d_thr``; ours, not in the paper): the reference may
    steer a robot along an obstacle but never presses it into one, so how close the robot comes
    is set by the ESDF force of eq. (6) against the swarm's push alone."""
    inside = np.flatnonzero(d < d_thr)  # most robots are outside the band: no norms for them
    if inside.size == 0:
        return track
    g = grad_d[inside]
    norm = np.linalg.norm(g, axis=1)
    keep = norm > 1e-12
    inside, unit = inside[keep], g[keep] / norm[keep, None]  # away from the obstacle
    along = np.einsum("nd,nd->n", track[inside], unit)
    out = track.copy()
    out[inside] -= np.minimum(along, 0.0)[:, None] * unit
    return out
