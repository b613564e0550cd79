"""``random_forest(min_passage=...)``: only forests with a corridor the swarm can use are trials."""

import numpy as np
import pytest

from swarmnav.errors import ScenarioError
from swarmnav.world.generators import _crossable, random_forest
from swarmnav.world.obstacles import Circle


def _discs(scn):
    c = [(o.center, o.radius) for o in scn.obstacles if isinstance(o, Circle)]
    return np.array([x for x, _ in c]), np.array([r for _, r in c])


def test_crossable_sees_a_closed_and_an_open_barrier():
    # a column of touching discs across a 4 m strip closes it; shift one and a 1.2 m gap opens
    closed = np.array([[2.0, -1.5], [2.0, -0.5], [2.0, 0.5], [2.0, 1.5]])
    r = np.full(4, 0.5)
    assert not _crossable(closed, r, 4.0, 4.0, 0.2)
    opened = closed.copy()
    opened[1, 0] = 3.7  # leaves a 1 m + gap between the discs at y = -1.5 and y = 0.5
    assert _crossable(opened, r, 4.0, 4.0, 0.8)
    assert not _crossable(opened, r, 4.0, 4.0, 1.2)


@pytest.mark.parametrize("seed", [1, 4, 7])
def test_dense_forests_have_the_passage_and_keep_their_density(seed):
    kw = dict(density=0.45, seed=seed, length=12, r_min=1.0, r_max=2.0)
    scn = random_forest(**kw, min_passage=1.0)
    c, r = _discs(scn)
    assert _crossable(c, r, 12.0, 20.0, 1.0)
    frac = np.pi * (r**2).sum() / (12 * 20)
    assert 0.45 <= frac < 0.45 + np.pi * 2.0**2 / (12 * 20)  # the last disc (r <= 2 m) overshoots
    assert random_forest(**kw, min_passage=1.0).to_dict() == scn.to_dict()  # deterministic


def test_a_forest_that_passes_first_is_unchanged_and_impossible_fails_loudly():
    kw = dict(density=0.15, seed=3, length=12, r_min=1.0, r_max=2.0)
    assert random_forest(**kw, min_passage=1.0).to_dict() == random_forest(**kw).to_dict()
    with pytest.raises(ScenarioError, match="passage"):
        random_forest(density=0.45, seed=1, length=12, r_min=1.0, r_max=2.0, min_passage=15.0, max_forests=3)
