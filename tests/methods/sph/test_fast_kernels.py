"""The compiled parts of SPH's coordination step against the plain NumPy / SciPy code they replaced,
on random inputs: equal to the last bit (the same sums in the same order), since SPH's runs must
stay bit-identical to the stored references."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from swarmnav.methods.sph.kernel import kernel_slope, kernel_value, sph_forces
from swarmnav.methods.sph.visibility import components, link_changes


def _forces_add_at(x, v, i, j, *, h, c, m, k_den, k_rep, k_vis, rho0, gamma, kind, r_floor):
    """sph_forces as first written: every pair term scattered with np.add.at."""
    n = x.shape[0]
    rho = np.full(n, m * float(kernel_value(np.zeros(1), h, c, kind)[0]))
    grad_sum = np.zeros_like(x)
    rep = np.zeros_like(x)
    if len(i):
        d = x[i] - x[j]
        r = np.sqrt(np.einsum("pd,pd->p", d, d))
        w = m * kernel_value(r, h, c, kind)
        np.add.at(rho, i, w)
        np.add.at(rho, j, w)
        rs = np.maximum(r, r_floor)
        unit = d / rs[:, None]
        g = kernel_slope(r, h, c, kind)[:, None] * unit
        np.add.at(grad_sum, i, g)
        np.add.at(grad_sum, j, -g)
        f = unit / rs[:, None]
        np.add.at(rep, i, f)
        np.add.at(rep, j, -f)
    pressure = -k_den / rho * ((rho / rho0) ** gamma - 1.0)
    return pressure[:, None] * grad_sum + k_rep * rep + -k_vis * v, rho


@pytest.mark.parametrize("seed", range(8))
def test_forces_equal_the_add_at_scatter_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    n, dim = int(rng.integers(1, 120)), int(rng.choice([2, 3]))
    x = rng.uniform(-6.0, 6.0, (n, dim))
    x[rng.random(n) < 0.1] = x[0]  # coincident agents: the r_floor branch
    v = rng.normal(size=(n, dim))
    i, j = np.triu_indices(n, 1)
    keep = rng.random(len(i)) < rng.uniform(0.0, 1.0)  # a random set of visible pairs, in order
    i, j = i[keep].astype(np.int64), j[keep].astype(np.int64)
    kw = dict(h=float(rng.uniform(1.0, 10.0)), c=54.97, m=1.0, k_den=1.0, k_rep=1.0, k_vis=1.5,
              rho0=float(rng.choice([1e6, 0.01])), gamma=7.0, kind=str(rng.choice(["paper", "released"])),
              r_floor=0.05)
    force, rho, _ = sph_forces(x, v, i, j, **kw)
    want_force, want_rho = _forces_add_at(x, v, i, j, **kw)
    assert np.array_equal(rho, want_rho)
    assert np.array_equal(force, want_force)


@pytest.mark.parametrize("seed", range(8))
def test_components_match_scipy_with_smallest_member_labels(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 80))
    m = int(rng.integers(0, 2 * n))
    i, j = rng.integers(0, n, m), rng.integers(0, n, m)
    _, comp = connected_components(coo_matrix((np.ones(m), (i, j)), shape=(n, n)), directed=False)
    first = np.full(comp.max() + 1, n)
    np.minimum.at(first, comp, np.arange(n))
    got = components(n, i, j)
    assert got.dtype == np.int32
    assert np.array_equal(got, first[comp])


def test_components_of_no_agents():
    assert components(0, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)).shape == (0,)


@pytest.mark.parametrize("seed", range(8))
def test_link_changes_match_isin(seed):
    rng = np.random.default_rng(seed)
    universe = 400
    prev = np.sort(rng.choice(universe, int(rng.integers(0, 60)), replace=False))
    in_range = rng.permutation(rng.choice(universe, int(rng.integers(0, 80)), replace=False))  # any order
    vis = rng.random(len(in_range)) < 0.6
    want = (int(np.count_nonzero(~np.isin(in_range[vis], prev))), int(np.count_nonzero(np.isin(in_range[~vis], prev))))
    assert link_changes(prev, in_range, vis) == want
