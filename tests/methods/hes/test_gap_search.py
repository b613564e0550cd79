"""Gap detection's closest-pair search, which skips blocks of rays by their bounding boxes,
against the search over every pair: the same openings, bit for bit, on rings of the paper scenes
and on random rings."""

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import detect_gaps, ring_anchors
from swarmnav.sensing import lidar_ring, ray_table
from swarmnav.world.catalog import load_scenario


@njit(cache=True)
def _wrap_(i, n):
    return i - n if i >= n else i


@njit(cache=True)
def _detect_gaps_all_pairs(ring, px, py, cos_t, sin_t, max_range, h_open):
    """detect_gaps with every pair across the peak tested (no box skip)."""
    n = ring.shape[0]
    anchors = ring_anchors(ring, max_range)
    na = anchors.shape[0]
    out = np.empty((max(na, 1), 8))
    m = 0
    if na == 0:
        return out[:0]
    hx = np.empty(n)  # every ray's return [m] (read only where it hits), computed once
    hy = np.empty(n)
    for r in range(n):
        hx[r] = px + ring[r] * cos_t[r]
        hy[r] = py + ring[r] * sin_t[r]
    for i in range(na):
        a = anchors[i]
        b = anchors[(i + 1) % na]
        span = (b - a) % n
        if na == 1:
            span = n
        if span < 2:
            continue
        pk = -1
        best = -1.0
        for s in range(1, span):
            d = ring[_wrap_(a + s, n)]
            if d > best:
                best = d
                pk = s
        if best - min(ring[a], ring[b]) < h_open:
            continue
        wbest = np.inf
        ax = ay = bx = by = 0.0
        for s in range(0, pk):
            ra = _wrap_(a + s, n)
            da = ring[ra]
            if da >= max_range:
                continue
            qx = hx[ra]
            qy = hy[ra]
            for t in range(pk + 1, span + 1):
                rb = _wrap_(a + t, n)
                db = ring[rb]
                if db >= max_range or (da - db) * (da - db) >= wbest:  # |q_a - q_b| >= |d_a - d_b|
                    continue
                ux = hx[rb] - qx
                uy = hy[rb] - qy
                w2 = ux * ux + uy * uy
                if w2 < wbest:
                    wbest = w2
                    ax, ay = qx, qy
                    bx, by = qx + ux, qy + uy
        if not np.isfinite(wbest) or wbest <= 0.0:
            continue
        w = math.sqrt(wbest)
        nx = -(by - ay) / w
        ny = (bx - ax) / w
        rp = (a + pk) % n
        if nx * cos_t[rp] + ny * sin_t[rp] < 0.0:
            nx, ny = -nx, -ny
        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = ax, ay, bx, by
        out[m, 4], out[m, 5], out[m, 6], out[m, 7] = w, nx, ny, rp
        m += 1
    return out[:m]



def _check(ring, px, py, cos_t, sin_t):
    found = 0
    for h_open in (0.5, 1.0, 3.0):
        got = detect_gaps(ring, px, py, cos_t, sin_t, 20.0, h_open)
        assert np.array_equal(got, _detect_gaps_all_pairs(ring, px, py, cos_t, sin_t, 20.0, h_open))
        found += len(got)
    return found


def test_detect_gaps_equals_the_all_pairs_search_on_scene_rings():
    rng = np.random.default_rng(15)
    found = 0
    for n_rays in (360, 90, 37):
        cos_t, sin_t = ray_table(n_rays)
        for name in ("default_corridor", "narrow_alternating_gates", "dense_cross_blocks", "off_axis_goal",
                     "random_forest:density=0.25,seed=1"):
            geom = load_scenario(name).geometry
            lo, hi = np.asarray(geom.bbox_lo).min(axis=0), np.asarray(geom.bbox_hi).max(axis=0)
            x = rng.uniform(lo - 5.0, hi + 5.0, (40, 2))
            rings = lidar_ring(geom, x, n_rays, 20.0)
            for i in range(len(x)):
                found += _check(rings[i], x[i, 0], x[i, 1], cos_t, sin_t)
    assert found > 500  # the cases hold openings


def test_detect_gaps_equals_the_all_pairs_search_on_random_rings():
    """Random walls with ties (ranges rounded to 1 cm) and rays at R_L."""
    rng = np.random.default_rng(16)
    cos_t, sin_t = ray_table(360)
    for _ in range(400):
        ring = np.full(360, 20.0)
        for _ in range(int(rng.integers(1, 8))):
            r0, ln = int(rng.integers(0, 360)), int(rng.integers(1, 120))
            idx = (r0 + np.arange(ln)) % 360
            ring[idx] = np.minimum(ring[idx], np.round(rng.uniform(0.3, 19.0) + rng.uniform(0, 2, ln), 2))
        _check(ring, float(rng.uniform(-50, 50)), float(rng.uniform(-50, 50)), cos_t, sin_t)
