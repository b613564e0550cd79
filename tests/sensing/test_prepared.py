"""PreparedGeometry answers exactly as the validating public queries it stands in for."""

from __future__ import annotations

import numpy as np
import pytest

from _helpers.scenes import random_scene
from swarmnav.sensing import PreparedGeometry, lidar_ring, ray_table, segments_blocked
from swarmnav.world.obstacles import Geometry


@pytest.mark.parametrize("seed", [0, 1])
def test_prepared_queries_equal_the_public_ones(seed):
    rng = np.random.default_rng(seed)
    geom = Geometry.from_obstacles(random_scene(rng))
    prep = PreparedGeometry(geom)
    x = rng.uniform(-18, 28, (15, 2))
    cos_t, sin_t = ray_table(90)
    ring = prep.lidar_into(x, cos_t, sin_t, 12.0, np.empty((15, 90)))
    np.testing.assert_array_equal(ring, lidar_ring(geom, x, n_rays=90, max_range=12.0))
    p, q = rng.uniform(-18, 28, (40, 2)), rng.uniform(-18, 28, (40, 2))
    got = prep.blocked_into(p, q, np.empty(40, dtype=np.bool_))
    want = segments_blocked(geom, p, q)
    np.testing.assert_array_equal(got, want)
    assert want.any() and not want.all()  # both answers occur, so the comparison means something
    assert not prep.is_empty and PreparedGeometry(Geometry.from_obstacles([])).is_empty


def test_prepared_3d_queries_equal_the_public_ones():
    from swarmnav.sensing import range_scan
    from swarmnav.world.obstacles import Box, Cylinder, Sphere

    rng = np.random.default_rng(5)
    obs = [Box((0, 0, 0), (2, 3, 2)), Cylinder((5, 5), 0.7, (0, 4)), Sphere((2, 7, 2), 1.2)]
    geom = Geometry.from_obstacles(obs, dim=3)
    prep = PreparedGeometry(geom)
    p, q = rng.uniform(-1, 9, (60, 3)), rng.uniform(-1, 9, (60, 3))
    want = segments_blocked(geom, p, q)
    np.testing.assert_array_equal(prep.blocked_into(p, q, np.empty(60, dtype=np.bool_)), want)
    assert want.any() and not want.all()
    u = rng.normal(size=(50, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    # range_scan normalises the directions again, which may move them by an ulp
    np.testing.assert_allclose(prep.range_into(p[:5], u, 6.0, np.empty((5, 50))), range_scan(geom, p[:5], u, 6.0),
                               rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        prep.lidar_into(p[:, :2].copy(), *ray_table(8), 6.0, np.empty((60, 8)))
