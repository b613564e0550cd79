"""Alignment measures of HWVEM Section 3.1: consistency degree Deg_con and convergence time k_con.

Pure functions of heading arrays, shared by the methods (which track them while running) and
the figures (which recompute them from stored velocities).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from swarmnav.methods.vicsek.geometry import wrap

Norm = Literal["l1", "l2", "linf"]


def deg_con(theta: np.ndarray, ref: float | np.ndarray, norm: Norm = "l1") -> np.ndarray | float:
    """Eq. (28)-(29): ``Deg_con = (pi - ||theta - theta_d|| / N) / pi``.

    The deviations are wrapped to ``[-pi, pi)``. The paper writes ``||.||`` without naming the
    norm. ``"l2"`` (the models' default ``deg_con_norm``, chosen on Table 1: docs/methods/vicsek.md)
    is the Euclidean norm divided by N, so ``Deg_con^d = 0.9984`` asks for a root-mean-square
    deviation of ``0.0016 pi sqrt(N)`` rad (0.29 deg x sqrt(N)); ``"l1"`` makes ``||.||/N`` the
    mean absolute deviation (0.29 deg at every N); ``"linf"`` is the largest deviation / N.

    Args:
        theta: (..., N) headings [rad].
        ref: reference heading(s) [rad], broadcast against ``theta[..., 0]``.
        norm: "l1", "l2" or "linf".

    Returns:
        Deg_con in ``[0, 1]`` for each leading index.
    """
    th = np.asarray(theta, dtype=np.float64)
    dev = np.abs(wrap(th - np.asarray(ref, dtype=np.float64)[..., None]))
    n = th.shape[-1]
    if norm == "l1":
        m = dev.sum(axis=-1) / n
    elif norm == "l2":
        m = np.sqrt((dev * dev).sum(axis=-1)) / n
    elif norm == "linf":
        m = dev.max(axis=-1) / n
    else:
        raise ValueError(f"unknown Deg_con norm {norm!r} (l1, l2, linf)")
    out = (np.pi - m) / np.pi
    return float(out) if np.ndim(out) == 0 else out


def circular_mean(theta: np.ndarray) -> np.ndarray | float:
    """Direction of the mean unit vector of headings (..., N) [rad]: the consensus direction
    that VEM and IVEM, which have no information UAV, are measured against."""
    th = np.asarray(theta, dtype=np.float64)
    out = np.arctan2(np.sin(th).sum(axis=-1), np.cos(th).sum(axis=-1))
    return float(out) if np.ndim(out) == 0 else out


def k_con(series: np.ndarray, threshold: float) -> float:
    """Eq. (27): the first step ``k0`` with ``Deg_con(k) >= threshold`` for every recorded
    ``k >= k0``; +inf if the last recorded value is below the threshold (not converged within
    the record)."""
    x = np.asarray(series, dtype=np.float64)
    if len(x) == 0 or x[-1] < threshold:
        return float("inf")
    below = np.nonzero(x < threshold)[0]
    return float(below[-1] + 1) if len(below) else 0.0


def headings_from_velocities(velocities: np.ndarray) -> np.ndarray:
    """Headings (K + 1, N) [rad] of recorded velocities (exact for the constant-speed runs of
    Section 3.1, where v = v0 (cos theta, sin theta))."""
    v = np.asarray(velocities, dtype=np.float64)
    return np.arctan2(v[..., 1], v[..., 0])
