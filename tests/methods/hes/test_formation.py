"""Slot assignment of eq. (23): the Hungarian optimum for small sub-swarms, a banded sort above."""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from swarmnav.methods.hes.formation import assign_slots, hex_template


def _cost(x, slots, r):
    return float(np.sum((x - slots[r]) ** 2))


@pytest.mark.parametrize("m", [1, 5, 20, 64])
def test_small_sub_swarms_get_the_minimal_assignment(m):
    rng = np.random.default_rng(m)
    x = rng.uniform(-8, 8, (m, 2))
    slots = 2.0 * hex_template(m) + [5.0, 1.0]
    r = assign_slots(x, slots, exact=64)
    cost = np.sum((x[:, None, :] - slots[None, :, :]) ** 2, axis=2)
    rows, cols = linear_sum_assignment(cost)
    assert sorted(r.tolist()) == list(range(m))
    assert _cost(x, slots, r) == pytest.approx(cost[rows, cols].sum())


@pytest.mark.parametrize("m", [65, 200, 500])
def test_large_sub_swarms_get_a_bijection_in_band_order(m):
    rng = np.random.default_rng(m)
    x = rng.uniform(-20, 20, (m, 2))
    slots = 2.0 * hex_template(m) + [30.0, 0.0]
    r = assign_slots(x, slots, exact=64)
    assert sorted(r.tolist()) == list(range(m))  # every slot taken once
    # its excess over the optimum is a small part of a random bijection's
    best = linear_sum_assignment(np.sum((x[:, None, :] - slots[None, :, :]) ** 2, axis=2))
    opt = _cost(x[best[0]], slots, best[1])
    excess = _cost(x, slots, r) - opt
    assert 0.0 <= excess < 0.25 * (_cost(x, slots, rng.permutation(m)) - opt)
