"""Neighbour search among agents with a k-d tree (no N x N matrix), optionally periodic.

Pairs are unordered ``i < j`` with Euclidean distance ``<= radius`` (in a periodic square box
of side ``box``, the minimum-image distance). Results are sorted by ``(i, j)`` so they do not
depend on the tree's traversal order. Positions are (N, 2) or (N, 3) in open space; the
periodic box is planar only.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from swarmnav.sensing._kernels import as_points


def _positions(positions: np.ndarray, box: float | None) -> np.ndarray:
    """Contiguous float64 (N, 2) positions, or (N, 3) in open space; ValueError otherwise."""
    a = np.asarray(positions)
    if a.ndim == 2 and a.shape[1] == 3:
        if box is not None:
            raise ValueError("a periodic box is planar: positions must have shape (N, 2) when box is given")
        return np.ascontiguousarray(a, dtype=np.float64)
    try:
        return as_points(positions, "positions")
    except ValueError:
        raise ValueError(f"positions must have shape (N, 2) or (N, 3), got {a.shape}") from None


def _tree(positions: np.ndarray, box: float | None) -> tuple[cKDTree, np.ndarray]:
    pos = _positions(positions, box)
    if box is None:
        return cKDTree(pos), pos
    box = float(box)
    if not box > 0.0:
        raise ValueError(f"box must be > 0, got {box}")
    # cKDTree needs coordinates in [0, box); np.mod can round a tiny negative up to box itself.
    pos = np.mod(pos, box)
    pos[pos >= box] = 0.0
    return cKDTree(pos, boxsize=box), pos


def neighbor_pairs(positions: np.ndarray, radius: float, box: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All unordered agent pairs closer than ``radius`` [m].

    Args:
        positions: (N, d) agent positions [m], d = 2 or 3 (3 only in open space).
        radius: interaction radius [m]; pairs at exactly ``radius`` are included.
        box: side [m] of a periodic square box ``[0, box)^2`` (positions are wrapped into it),
            or None for open space.

    Returns:
        ``(i, j)`` int64 arrays of shape (P,), ``i < j``, sorted lexicographically.
    """
    tree, pos = _tree(positions, box)
    pairs = tree.query_pairs(float(radius), output_type="ndarray").astype(np.int64, copy=False)
    if pairs.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    # query_pairs already returns i < j; sort by the key i * N + j for a canonical order.
    order = np.argsort(pairs[:, 0] * pos.shape[0] + pairs[:, 1], kind="stable")
    pairs = pairs[order]
    return np.ascontiguousarray(pairs[:, 0]), np.ascontiguousarray(pairs[:, 1])


def neighbor_lists(positions: np.ndarray, radius: float, box: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """CSR adjacency of the radius graph: neighbours of ``a`` are ``indices[indptr[a]:indptr[a+1]]``.

    Both directions of every pair are stored, self excluded, neighbours sorted ascending.

    Args:
        positions: (N, d) agent positions [m], d = 2 or 3 (3 only in open space).
        radius: interaction radius [m] (inclusive).
        box: periodic box side [m], or None.

    Returns:
        ``(indptr (N + 1,), indices (2 P,))`` int64.
    """
    n = _positions(positions, box).shape[0]
    i, j = neighbor_pairs(positions, radius, box)
    src = np.concatenate([i, j])
    dst = np.concatenate([j, i])
    order = np.argsort(src * n + dst, kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    return indptr, dst[order]


def pairwise_min_distance(positions: np.ndarray, box: float | None = None) -> float:
    """Smallest distance [m] between two distinct agents (minimum-image in a periodic square of
    side ``box``); ``inf`` for N < 2. Positions (N, 2), or (N, 3) in open space [m]."""
    pos = _positions(positions, box)
    if pos.shape[0] < 2:
        return float("inf")
    tree, pts = _tree(pos, box)
    d, _ = tree.query(pts, k=2)
    return float(d[:, 1].min())
