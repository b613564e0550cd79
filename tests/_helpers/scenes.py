"""Random obstacle scenes for oracle tests (shared by the sensing tests)."""

from __future__ import annotations

import numpy as np

from swarmnav.world.obstacles import Box, Circle, Polygon, polygon_is_simple


def random_scene(rng: np.random.Generator, extent: float = 15.0, n_boxes: int = 4,
                 with_l_shape: bool = True) -> list:
    """Boxes, circles and concave star polygons (both orientations), overlaps allowed, plus
    optionally a fixed clockwise concave L at (20..26, 20..26)."""
    obs: list = []
    for _ in range(n_boxes):
        lo = rng.uniform(-extent, extent, 2)
        obs.append(Box(tuple(lo), tuple(lo + rng.uniform(0.5, 5.0, 2))))
    for _ in range(3):
        obs.append(Circle(tuple(rng.uniform(-extent, extent, 2)), float(rng.uniform(0.3, 2.0))))
    for _ in range(3):
        k = int(rng.integers(5, 9))
        # One vertex per angular sector: gaps stay < pi, so the radial polygon is simple.
        ang = 2 * np.pi * (np.arange(k) + rng.uniform(0.0, 0.8, k)) / k
        rad = rng.uniform(0.5, 3.0, k)
        c = rng.uniform(-extent, extent, 2)
        pts = c + np.c_[rad * np.cos(ang), rad * np.sin(ang)]
        if rng.random() < 0.5:
            pts = pts[::-1]  # clockwise
        obs.append(Polygon(tuple(map(tuple, pts))))
    if with_l_shape:
        obs.append(Polygon(((20, 20), (20, 26), (22, 26), (22, 22), (26, 22), (26, 20))[::-1]))
    assert all(polygon_is_simple(o.vertices()) for o in obs if isinstance(o, Polygon))
    return obs
