"""The control stage's compiled passes against the plain forms they replace, on random cases:
the same bits (the control stage of a run may not change when it is fused)."""

import math

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
                nn=F.nearest_in_group(x, labels), sig=rng.choice([0.0, 0.2, 1.0], (n, 4), p=[0.1, 0.2, 0.7]), ring=ring,
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
        got = C.eq38(*args)
        assert got.tobytes() == ref.tobytes()  # the same bits, signed zeros included


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
        got = C.couple_workspace(n)
        for a in got:  # stale values from an earlier step must not survive
            a.fill(7)
        C.couple_occlude_kernel(x, labels, col, sub_sl, sub_wp, sub_nav, *rows, slot, 0.2, check,
                                *prep.planar_arrays, *got)
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


def test_candidate_rays_are_the_candidate_mask_in_ray_order():
    """The word-skipping scan lists exactly the rays of the candidate mask, ascending, for ring
    lengths that are and are not multiples of 8 (a stale workspace changes nothing)."""
    rng = np.random.default_rng(17)
    for _ in range(300):
        n = int(rng.integers(1, 70))
        ring = np.round(rng.uniform(0.5, 3.0, n), 1)  # plateaus of equal ranges
        below = float(rng.uniform(0.5, 3.5))
        mask = rng.integers(0, 256, 8 * ((n + 7) // 8) + int(rng.integers(0, 9))).astype(np.uint8)
        idx = np.full(n, -7, dtype=np.int64)
        m = F.candidate_rays(ring, below, mask, idx)
        want = np.empty(n, dtype=np.bool_)
        F.minimum_candidates(ring, below, want)
        plain = [r for r in range(n) if r in (0, n - 1) or
                 (ring[r] < below and ring[r] < ring[r - 1] and ring[r] <= ring[r + 1])]
        assert np.flatnonzero(want).tolist() == plain
        assert idx[:m].tolist() == plain


def _guard_reference(a, x, v, dt, a_brake, margin, a_max, passes=4):
    """agent_guard's contact guard written out over every pair (no distance skip), plain Python."""
    n = len(x)
    w = v + dt * a
    for i in range(n):
        for _ in range(passes):
            moved = False
            for j in range(n):
                if j == i:
                    continue
                ux, uy = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1]
                d = math.sqrt(ux * ux + uy * uy)
                if d <= 0.0:
                    continue
                ux, uy = ux / d, uy / d
                c = w[i, 0] * ux + w[i, 1] * uy
                if c <= 0.0:
                    continue
                sj = v[j, 0] * ux + v[j, 1] * uy
                c_max = math.sqrt(max(2.0 * a_brake * (d - margin) + sj * abs(sj), 0.0))
                if c > c_max + 1e-12:
                    w[i, 0] -= (c - c_max) * ux
                    w[i, 1] -= (c - c_max) * uy
                    moved = True
            if not moved:
                break
    out = np.empty((n, 2))
    for i in range(n):
        bx, by = (w[i, 0] - v[i, 0]) / dt - a[i, 0], (w[i, 1] - v[i, 1]) / dt - a[i, 1]
        ax, ay = a[i]
        if bx == 0.0 and by == 0.0:
            out[i] = a[i]
        elif (ax + bx) ** 2 + (ay + by) ** 2 <= a_max * a_max:
            out[i] = ax + bx, ay + by
        elif bx * bx + by * by >= a_max * a_max:
            s = a_max / math.sqrt(bx * bx + by * by)
            out[i] = s * bx, s * by
        else:
            aa, ab, bb = ax * ax + ay * ay, ax * bx + ay * by, bx * bx + by * by
            lam = min(max((-ab + math.sqrt(max(ab * ab - aa * (bb - a_max * a_max), 0.0))) / aa, 0.0), 1.0)
            out[i] = bx + lam * ax, by + lam * ay
    return out


def test_contact_guard_skips_only_neighbours_it_cannot_bind():
    from swarmnav.methods.hes.parts.barriers import agent_guard

    rng = np.random.default_rng(14)
    for trial in range(300):
        n = int(rng.integers(1, 30))
        x = rng.uniform(0, float(rng.choice([3.0, 10.0, 40.0])), (n, 2))
        v = rng.normal(0, float(rng.choice([0.3, 1.5, 4.0])), (n, 2))
        a = F.saturate(rng.normal(0, 3, (n, 2)), 2.6)
        got = agent_guard(a, x, v, 0.1, 1.5, 0.6, 2.6, 4)
        assert np.array_equal(got, _guard_reference(a, x, v, 0.1, 1.5, 0.6, 2.6))
