"""The control stage's compiled passes against the plain forms they replace, on random cases:
the same bits (the control stage of a run may not change when it is fused)."""

import numpy as np

from swarmnav.methods.hes import control as C
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.params import HesParams

P = HesParams()
G = F.gain_vector(P)
R = 360
TH = 2 * np.pi * np.arange(R) / R
COS, SIN = np.cos(TH), np.sin(TH)


def random_case(rng, n):
    """A random swarm of n agents in up to three sub-swarms, with rings that see a few walls."""
    x = rng.uniform(-6, 6, (n, 2))
    v = rng.normal(size=(n, 2))
    labels = rng.integers(0, 3, n)
    sl = np.array([np.flatnonzero(labels == g)[0] for g in labels])
    cent = np.array([x[labels == g].mean(axis=0) for g in labels])
    ring = np.full((n, R), P.paper.lidar_range)
    for i in range(n):
        for _ in range(int(rng.integers(0, 4))):
            r0 = int(rng.integers(0, R))
            ring[i, r0:r0 + 40] = rng.uniform(0.3, 15.0) + rng.uniform(0, 1, len(ring[i, r0:r0 + 40]))
    return dict(x=x, v=v, labels=labels, sl=sl, follower=sl != np.arange(n), cent=cent, wp=cent + rng.normal(size=(n, 2)),
                nav=rng.random(n) < 0.7, slot=x + rng.normal(size=(n, 2)), speed=rng.uniform(0.5, 3.0, n),
                nn=F.nearest_in_group(x, labels), sig=np.where(rng.random((n, 4)) < 0.2, 0.2, 1.0), ring=ring,
                dsafe=rng.uniform(0.5, P.paper.d_safe, n))


def test_eq38_is_synthesize_of_the_gathered_rows_bit_for_bit():
    rng = np.random.default_rng(11)
    for _ in range(300):
        n = int(rng.integers(1, 30))
        c = random_case(rng, n)
        x, v = c["x"], c["v"]
        rows = neighbour_rows(x, max(P.core.r_sep, P.core.d_ir))
        vslot = F.slot_velocity(x, c["slot"], c["speed"], P.core.eps_v)
        ref_t = F.force_terms(x, v, c["labels"], x[c["sl"]], v[c["sl"]], c["follower"], c["cent"], c["wp"], c["nav"],
                              c["slot"], vslot, c["nn"], c["sig"], c["ring"], COS, SIN, G, c["dsafe"], *rows)
        args = (x, v, c["labels"], c["sl"], c["follower"], c["cent"], c["wp"], c["nav"], c["slot"], c["speed"],
                P.core.eps_v, c["nn"], c["sig"], c["ring"], COS, SIN, G, c["dsafe"], *rows)
        assert np.array_equal(C.eq38_terms(*args), ref_t)
        ref = F.synthesize(x, v, c["labels"], x[c["sl"]], v[c["sl"]], c["follower"], c["cent"], c["wp"], c["nav"],
                           c["slot"], vslot, c["nn"], c["sig"], c["ring"], COS, SIN, G, c["dsafe"], *rows)
        assert np.array_equal(C.eq38(*args), ref)


def test_couple_occlude_is_couple_then_the_segments_tested_bit_for_bit():
    from swarmnav.sensing import PreparedGeometry, segments_blocked
    from swarmnav.world.catalog import load_scenario

    geom = load_scenario("default_corridor").geometry
    prep = PreparedGeometry(geom)
    lo, hi = np.asarray(geom.bbox_lo).min(axis=0), np.asarray(geom.bbox_hi).max(axis=0)
    rng = np.random.default_rng(5)
    for trial in range(200):
        n = int(rng.integers(1, 30))
        x = rng.uniform(lo, hi, (n, 2))
        labels = rng.integers(0, 3, n)
        ids = np.unique(labels)
        col = np.searchsorted(ids, labels)
        sub_sl = np.array([np.flatnonzero(labels == s)[0] for s in ids])
        sub_wp = rng.uniform(lo, hi, (len(ids), 2))
        sub_nav = rng.random(len(ids)) < 0.5
        rows = neighbour_rows(x, 3.0)
        slot = x + rng.normal(0, 4, (n, 2))
        check = trial % 4 != 0
        got = C.couple_occlude_kernel(x, labels, col, sub_sl, sub_wp, sub_nav, *rows, slot, 0.2, check,
                                      *prep.planar_arrays)
        ref = C.couple(x, labels, col, sub_sl, sub_wp, sub_nav, *rows)
        for a, b in zip(got[:6], ref):
            assert np.array_equal(a, b)
        sl_idx, nn, cent = ref[0], ref[5], ref[4]
        if check:
            near = np.where(nn >= 0, nn, np.arange(n))
            ends = np.concatenate([slot, x[near], x[sl_idx], cent])
            blocked = segments_blocked(geom, np.tile(x, (4, 1)), ends).reshape(4, n).T
        else:
            blocked = np.zeros((n, 4), dtype=bool)
        assert np.array_equal(got[6], blocked)
        assert np.array_equal(got[7], np.where(blocked, 0.2, 1.0))


def _rings_with_plateaus(rng, n):
    """Random rings with walls, flat runs, ties and rays at R_L."""
    ring = np.full((n, R), P.paper.lidar_range)
    for i in range(n):
        for _ in range(int(rng.integers(0, 6))):
            r0, ln = int(rng.integers(0, R)), int(rng.integers(1, 80))
            seg = np.round(rng.uniform(0.2, 19.0) + np.abs(np.linspace(-1, 1, ln)) * rng.uniform(0, 3), 1)
            idx = (r0 + np.arange(ln)) % R
            ring[i, idx] = np.minimum(ring[i, idx], seg)
    return ring


def test_lidar_repulsion_and_ring_anchors_test_every_ray_as_the_plain_loop():
    """The candidate pre-pass changes nothing: the same minima, summed in ray order (bit for bit)."""
    from swarmnav.methods.hes.corridors import ring_anchors

    rng = np.random.default_rng(13)
    for _ in range(100):
        n = int(rng.integers(1, 12))
        ring = _rings_with_plateaus(rng, n)
        dsafe = rng.uniform(0.5, 1.5, n)
        args = (P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e)
        ref = np.zeros((n, 2))
        for i in range(n):
            for r in range(R):
                d = ring[i, r]
                if d < P.paper.r_trigger and F.is_local_min(ring[i], r):
                    w = F.repulsion_magnitude(max(d, P.core.d_floor), *args, dsafe[i], False)
                    ref[i, 0] -= w * COS[r]
                    ref[i, 1] -= w * SIN[r]
            anchors = [r for r in range(R) if ring[i, r] < P.paper.lidar_range and F.is_local_min(ring[i], r)]
            assert ring_anchors(ring[i], P.paper.lidar_range).tolist() == anchors
        got = F.lidar_repulsion_each(ring, COS, SIN, *args, dsafe, P.core.d_floor, False)
        assert np.array_equal(got, ref)
