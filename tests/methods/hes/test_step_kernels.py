"""Compiled passes of the perceive, targets and trail stages against the plain numpy forms they
replace, on random cases: the same bits."""

import math

import numpy as np

from swarmnav.methods.hes.report import strayed
from swarmnav.methods.hes.targets import turned
from swarmnav.methods.hes.trail import n_cut_off
from swarmnav.sensing import PreparedGeometry, segments_blocked
from swarmnav.world.catalog import load_scenario


def test_strayed_is_distance_or_line_of_sight_to_the_centroid():
    geom = load_scenario("default_corridor").geometry
    arrays = PreparedGeometry(geom).planar_arrays
    lo, hi = np.asarray(geom.bbox_lo).min(axis=0), np.asarray(geom.bbox_hi).max(axis=0)
    rng = np.random.default_rng(2)
    for trial in range(300):
        n = int(rng.integers(1, 30))
        x = rng.uniform(lo, hi, (n, 2)) if trial % 2 else rng.uniform(lo, lo + 8.0, (n, 2))
        labels = rng.integers(0, 4, n)
        ids = np.unique(labels)
        col = np.searchsorted(ids, labels)
        sl = np.array([rng.choice(np.flatnonzero(labels == s)) for s in ids])
        stray = float(rng.uniform(0.5, 6.0))
        check = trial % 3 != 0
        far, nearest = strayed(x, col, sl, stray, check, *arrays)
        cents = np.array([x[labels == s].sum(axis=0) / np.count_nonzero(labels == s) for s in ids])
        ref = np.array([math.hypot(*(x[a] - c)) > stray for a, c in zip(sl, cents)])
        if check:
            ref |= segments_blocked(geom, x[sl], cents)
        assert np.array_equal(far, ref)
        for j, s in enumerate(ids):
            m = np.flatnonzero(labels == s)
            d2 = np.sum((x[m] - cents[j]) ** 2, axis=1)
            assert nearest[j] == m[np.argmin(d2)]


def test_turned_is_the_rotation_of_the_offsets():
    rng = np.random.default_rng(4)
    for _ in range(200):
        o = rng.normal(0, 5, (int(rng.integers(0, 30)), 2))
        t = float(rng.uniform(-7, 7))
        c, s = math.cos(t), math.sin(t)
        ref = np.column_stack([c * o[:, 0] - s * o[:, 1], s * o[:, 0] + c * o[:, 1]]).reshape(-1, 2)
        assert np.array_equal(turned(o, c, s), ref)


def test_n_cut_off_counts_slot_subleader_and_centroid_all_blocked():
    rng = np.random.default_rng(6)
    for _ in range(200):
        b = rng.random((int(rng.integers(0, 30)), 4)) < 0.6
        assert n_cut_off(b) == np.count_nonzero(b[:, 0] & b[:, 2] & b[:, 3])
