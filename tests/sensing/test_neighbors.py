"""Neighbour search against brute-force pair distances (open and periodic), CSR invariants."""

from __future__ import annotations

import time

import numpy as np
import pytest

from swarmnav.sensing import neighbor_lists, neighbor_pairs, pairwise_min_distance


def brute_pairs(pos: np.ndarray, radius: float, box: float | None = None) -> set[tuple[int, int]]:
    d = pos[:, None, :] - pos[None, :, :]
    if box is not None:
        d -= box * np.round(d / box)  # minimum image
    dist = np.hypot(d[..., 0], d[..., 1])
    i, j = np.nonzero(np.triu(dist <= radius, k=1))
    return set(zip(i.tolist(), j.tolist()))


@pytest.mark.parametrize("box", [None, 10.0])
def test_pairs_match_bruteforce(box):
    rng = np.random.default_rng(4)
    pos = rng.uniform(0, 10.0, (400, 2))
    i, j = neighbor_pairs(pos, 0.8, box)
    assert np.all(i < j)
    got = list(zip(i.tolist(), j.tolist()))
    assert got == sorted(got)  # canonical order
    assert set(got) == brute_pairs(pos, 0.8, box)


def test_periodic_wrap_links_opposite_borders():
    pos = np.array([[0.1, 5.0], [9.95, 5.0], [5.0, 5.0]])
    i, j = neighbor_pairs(pos, 0.5, box=10.0)
    assert list(zip(i, j)) == [(0, 1)]
    assert len(neighbor_pairs(pos, 0.5)[0]) == 0  # open space: 9.85 m apart
    # Positions outside [0, box) are wrapped first.
    i, j = neighbor_pairs(np.array([[-0.1, 2.0], [10.2, 2.0]]), 0.5, box=10.0)
    assert list(zip(i, j)) == [(0, 1)]


def test_radius_is_inclusive():
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [2.5, 0.0]])
    i, j = neighbor_pairs(pos, 1.0)
    assert list(zip(i, j)) == [(0, 1)]


def test_neighbor_lists_are_symmetric_csr():
    rng = np.random.default_rng(5)
    pos = rng.uniform(0, 8.0, (250, 2))
    indptr, idx = neighbor_lists(pos, 1.0, box=8.0)
    pairs = brute_pairs(pos, 1.0, 8.0)
    assert indptr.shape == (251,) and indptr[0] == 0 and indptr[-1] == len(idx) == 2 * len(pairs)
    for a in range(len(pos)):
        nb = idx[indptr[a]:indptr[a + 1]]
        assert np.all(np.diff(nb) > 0)  # sorted, no duplicates
        assert a not in nb
        assert set(nb.tolist()) == {j for i, j in pairs if i == a} | {i for i, j in pairs if j == a}


def test_isolated_and_tiny_inputs():
    indptr, idx = neighbor_lists(np.array([[0.0, 0.0], [5.0, 5.0]]), 1.0)
    np.testing.assert_array_equal(indptr, [0, 0, 0])
    assert idx.shape == (0,)
    i, j = neighbor_pairs(np.zeros((0, 2)), 1.0)
    assert i.shape == j.shape == (0,)
    assert pairwise_min_distance(np.zeros((1, 2))) == np.inf
    assert pairwise_min_distance(np.zeros((0, 2))) == np.inf


def test_pairwise_min_distance_matches_bruteforce():
    rng = np.random.default_rng(6)
    pos = rng.uniform(0, 20, (300, 2))
    d = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    assert pairwise_min_distance(pos) == pytest.approx(d.min(), rel=1e-12)
    assert pairwise_min_distance(np.vstack([pos, pos[:1]])) == 0.0  # coincident agents


def test_scales_to_1e5_agents_without_dense_matrix():
    # 1e5 agents at ~1 per m^2, radius 1: an N x N float matrix would need 80 GB; the tree
    # answers in well under a second. The expected pair count is N * pi r^2 * density / 2.
    rng = np.random.default_rng(8)
    n = 100_000
    side = np.sqrt(n)
    pos = rng.uniform(0, side, (n, 2))
    t0 = time.perf_counter()
    indptr, idx = neighbor_lists(pos, 1.0, box=side)
    elapsed = time.perf_counter() - t0
    n_pairs = len(idx) // 2
    assert n_pairs == pytest.approx(n * np.pi / 2, rel=0.02)  # Poisson count, sd ~ 0.3 %
    assert indptr[-1] == len(idx)
    assert elapsed < 5.0


def test_pairwise_min_distance_uses_the_minimum_image_in_a_periodic_box():
    pts = np.array([[0.1, 5.0], [9.8, 5.0], [5.0, 1.0]])  # 0.3 m apart across the seam x = 0 / 10
    assert pairwise_min_distance(pts) == pytest.approx(np.hypot(4.8, 4.0))  # open space: the seam is far
    assert pairwise_min_distance(pts, box=10.0) == pytest.approx(0.3)
