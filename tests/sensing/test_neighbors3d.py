"""Neighbour search in 3-D open space against brute-force pair distances: the k-d tree
functions and the cell-list CSR (used by the metrics' minimum inter-agent distance)."""

from __future__ import annotations

import numpy as np
import pytest

from swarmnav.sensing import neighbor_lists, neighbor_pairs, pairwise_min_distance
from swarmnav.sensing.cells import neighbour_csr


def brute(pos: np.ndarray, radius: float) -> set[tuple[int, int]]:
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    i, j = np.nonzero(np.triu(d <= radius, k=1))
    return set(zip(i.tolist(), j.tolist()))


@pytest.fixture(params=[(300, 6.0, 0.9), (200, 1e4, 0.5)], ids=["dense", "far-flung"])
def swarm(request):
    n, extent, radius = request.param
    rng = np.random.default_rng(n)
    pos = rng.uniform(0, extent, (n, 3))
    pos[1] = pos[0] + [0.1, -0.2, 0.3]  # at least one close pair, also in the far-flung swarm
    pos[2] = pos[0]  # and a coincident one
    return pos, radius


def test_kdtree_functions_match_bruteforce(swarm):
    pos, r = swarm
    i, j = neighbor_pairs(pos, r)
    got = list(zip(i.tolist(), j.tolist()))
    assert got == sorted(got) and set(got) == brute(pos, r)
    indptr, idx = neighbor_lists(pos, r)
    assert indptr[-1] == 2 * len(got)
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2)
    assert pairwise_min_distance(pos) == d[np.triu_indices(len(pos), 1)].min() == 0.0


def test_cell_list_matches_bruteforce(swarm):
    pos, r = swarm
    n = len(pos)
    idx = np.empty(64 * n, np.int64)
    d2 = np.empty(64 * n)
    order, start, end, total = neighbour_csr(pos, r, 0.0, False, idx, d2)
    assert total <= len(idx) and sorted(order.tolist()) == list(range(n))
    got = {(a, int(b)) for a in range(n) for b in idx[start[a]:end[a]]}
    want = brute(pos, r)
    sym = want | {(j, i) for i, j in want}
    # default min_d2 = 0 drops the agent itself and the coincident agent 2 of agent 0
    assert got == {p for p in sym if {p[0], p[1]} != {0, 2}}
    for a in range(n):
        b = idx[start[a]:end[a]]
        np.testing.assert_array_equal(d2[start[a]:end[a]], np.sum((pos[b] - pos[a]) ** 2, axis=1))
    # min_d2 < 0 keeps self and coincident agents
    order, start, end, total = neighbour_csr(pos, r, 0.0, False, idx, d2, -1.0)
    assert total == len(sym) + n  # every pair both ways (the coincident one too) plus self


def test_periodic_box_is_planar_only():
    pos = np.zeros((4, 3))
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        neighbor_pairs(pos, 1.0, box=5.0)
    with pytest.raises(ValueError, match=r"\(N, 2\) or \(N, 3\)"):
        neighbor_pairs(np.zeros((4, 4)), 1.0)
