"""Compiled passes of the perceive, targets and trail stages against the plain numpy forms they
replace, on random cases: the same bits."""

import math

import numpy as np

from swarmnav.methods.hes.report import handed_over, strayed
from swarmnav.methods.hes.targets import turned
from swarmnav.methods.hes.parts.trail import n_cut_off
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
        new = sl.copy()
        assert handed_over(x, col, new, stray, check, *arrays) == np.count_nonzero(ref)
        assert np.array_equal(new, np.where(ref, nearest, sl))


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


def test_report_rows_are_the_report_stages_one_by_one():
    """Pack rows, openings (narrow ones kept only if seen through), the corridor filter and the
    members' nearest return, against make_pack, detect_gaps, seen_passages and corridors_toward."""
    from swarmnav.methods.hes.corridors import GAP_W, corridors_toward, detect_gaps, seen_passages
    from swarmnav.methods.hes.hierarchy import make_pack
    from swarmnav.methods.hes.report import report_rows
    from swarmnav.methods.hes.step import row_min
    from swarmnav.sensing import lidar_ring, ray_table

    cos_t, sin_t = ray_table(360)
    rng = np.random.default_rng(8)
    for name in ("narrow_alternating_gates", "dense_cross_blocks", "default_corridor"):
        geom = load_scenario(name).geometry
        lo, hi = np.asarray(geom.bbox_lo).min(axis=0), np.asarray(geom.bbox_hi).max(axis=0)
        for trial in range(60):
            n = int(rng.integers(2, 25))
            x = rng.uniform(lo, hi, (n, 2))
            v = rng.normal(size=(n, 2))
            ring = lidar_ring(geom, x, 360, 20.0)
            ring_min = row_min(ring)
            members = np.sort(rng.choice(n, int(rng.integers(1, n + 1)), replace=False))
            a = int(rng.choice(members))
            goal = rng.uniform(lo, hi)
            seen_w, depth = (3.6, 0.6) if trial % 2 else (0.0, 0.0)
            approach, approach_w = (2.0, 3.6) if trial % 3 else (0.0, np.inf)
            consts = np.array([20.0, 1.0, seen_w, depth, goal[0], goal[1], 1.2, math.cos(math.radians(75.0)), 0.4,
                               20.0, True, approach, approach_w, 1.5])
            m = len(members)
            buf = np.full((2 * m + 2, 2), np.nan)  # stale values must all be overwritten
            rows_out = np.full((360, 8), np.nan)
            k, clear = report_rows(x, v, members, a, ring, ring_min, cos_t, sin_t, consts, buf, rows_out)
            pack = make_pack(0, a, members, x, v)
            got = (buf[:m], buf[m:2 * m], buf[2 * m], buf[2 * m + 1], rows_out[:k], clear)
            for g, r in zip(got[:4], (pack.positions, pack.velocities, pack.centroid, pack.sl_row)):
                assert np.array_equal(g, r)
            gaps = detect_gaps(ring[a], x[a, 0], x[a, 1], cos_t, sin_t, 20.0, 1.0)
            if seen_w > 0:
                narrow = gaps[:, GAP_W] < seen_w
                keep = ~narrow
                keep[narrow] = seen_passages(gaps[narrow], ring[a], x[a, 0], x[a, 1], cos_t, sin_t, depth, 20.0)
                gaps = gaps[keep]
            cors = corridors_toward(gaps, x[a], goal, w_pass=1.2, toward_deg=75.0, through=1.5, ring=ring[a],
                                    sensor=x[a], origin=pack.centroid, rho_vis=0.4, max_range=20.0,
                                    rays=(cos_t, sin_t), approach=approach, approach_w=approach_w)
            rows = got[4][np.argsort(got[4][:, 7], kind="stable")]
            assert len(rows) == len(cors)
            for r, c in zip(rows, cors):
                assert np.array_equal(r[0:2], c.mid) and np.array_equal(r[2:4], c.normal)
                assert r[4] == c.width and np.array_equal(r[5:7], c.target) and r[7] == c.cost
            assert got[5] == min(ring_min[members].tolist())


def test_goal_range_is_the_nearest_and_farthest_hypot():
    from swarmnav.methods.hes.parts.stall import goal_range

    rng = np.random.default_rng(9)
    for _ in range(500):
        pos = rng.normal(0, 20, (int(rng.integers(1, 30)), 2))
        goal = rng.normal(0, 20, 2)
        d = pos - goal
        dist = np.hypot(d[:, 0], d[:, 1]).tolist()
        assert goal_range(pos, goal) == (min(dist), max(dist))


def test_gap_sides_counts_the_members_in_line_with_the_gap_on_each_side():
    """Against the matrix form (which may round differently: the counts agree off the boundaries)."""
    from swarmnav.methods.hes.parts.routes import gap_sides

    rng = np.random.default_rng(10)
    for _ in range(2000):
        pos = rng.normal(0, 10, (int(rng.integers(1, 25)), 2))
        mid = rng.normal(0, 10, 2)
        a = rng.uniform(0, 2 * np.pi)
        nrm = np.array([np.cos(a), np.sin(a)])
        band = float(rng.uniform(2.0, 6.0))
        rel = pos - mid
        along, across = rel @ nrm, np.abs(rel @ np.array([-nrm[1], nrm[0]]))
        inb = across < band
        assert gap_sides(pos, mid, nrm, band) == (np.count_nonzero((along > 0) & inb), np.count_nonzero((along <= 0) & inb))


def test_row_min_is_numpys_min_along_rows():
    from swarmnav.methods.hes.step import row_min

    rng = np.random.default_rng(12)
    for _ in range(500):
        a = rng.uniform(0.0, 20.0, (int(rng.integers(1, 30)), int(rng.integers(1, 400))))
        if rng.random() < 0.5:
            a = np.round(a, 1)  # ties
        assert np.array_equal(row_min(a), a.min(axis=1))
