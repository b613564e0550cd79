"""Each force term of HES Section 4 against a direct transcription of its equation, on tiny
hand cases; occlusion attenuation (eq. 30), encircle switches (eq. 38), saturation (eq. 39)."""

import math

import numpy as np
import pytest

from swarmnav.methods.hes.parts import barriers as B
from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.neighbours import neighbour_rows
from swarmnav.methods.hes.params import HesParams

P = HesParams()
G = F.gain_vector(P)
DS = np.full(4, P.paper.d_safe)  # the paper's d_safe for every agent of the 4-agent cases
R = 360
TH = 2 * np.pi * np.arange(R) / R
COS, SIN = np.cos(TH), np.sin(TH)


def test_table_a1_gains_are_the_papers():
    # Table A1, transcribed; these must never be tuned.
    a1 = dict(lidar_range=20.0, r_trigger=14.0, n_rays=360, a_max=2.6, k_p=0.7, k_v=0.8, k_rep=9.0, k_e=48.0,
              k_b=0.9, gamma=1.2, k_sep=1.1, k_intra=1.8, k_ir=1.6, k_path=0.75, k_l=1.6, k_vl=0.7, k_coh=0.9,
              d_safe=1.5, sigma_occ=0.2, t_cd=10.0, r_in=8.0, r_out=11.0, r_merge=12.0, d_merge=8.0, w_sl=1.0,
              w_c=0.5, delta_min=2.0, tau_ra=2.0, n_move_max=3, dt=0.1)
    for k, v in a1.items():
        assert getattr(P.paper, k) == v, k
    from swarmnav.methods.hes import Hes

    dyn = Hes().dynamics
    assert (dyn.mass, dyn.drag) == (5.0, 0.5)  # eq. (5)-(7)


def test_slot_velocity_eq23():
    x = np.array([[0.0, 0.0], [1.0, 1.0]])
    slot = np.array([[3.0, 4.0], [1.0, 1.0]])
    v = F.slot_velocity(x, slot, np.array([2.0, 2.0]), 0.5)
    np.testing.assert_allclose(v[0], 2.0 * np.array([3.0, 4.0]) / (5.0 + 0.5))
    np.testing.assert_allclose(v[1], 0.0)


def test_attraction_eq24():
    x, v = np.array([[1.0, 2.0]]), np.array([[0.5, -1.0]])
    ps, vs = np.array([[4.0, -2.0]]), np.array([[1.0, 1.0]])
    np.testing.assert_allclose(F.attraction(x, v, ps, vs, 0.7, 0.8), 0.7 * (ps - x) + 0.8 * (vs - v))


def test_separation_eq25_and_intra_repulsion_eq31():
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.5], [5.0, 5.0]])
    g = np.array([0, 0, 1, 1])

    def direct(k, r, same):
        out = np.zeros_like(x)
        for i in range(4):
            for j in range(4):
                d = np.linalg.norm(x[i] - x[j])
                if i != j and d < r and (not same or g[i] == g[j]):
                    out[i] += k * (x[i] - x[j]) / d**2
        return out

    np.testing.assert_allclose(F.separation(x, g, 1.1, 1.6, 0.05, False), direct(1.1, 1.6, False))
    np.testing.assert_allclose(F.separation(x, g, 1.6, 1.2, 0.05, True), direct(1.6, 1.2, True))
    assert np.all(F.separation(x, g, 1.1, 1.6, 0.05, False)[3] == 0)  # nobody within r_sep


def test_centering_eq32_and_springs_eq26_27_29():
    x = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 0.0]])
    c = np.array([[3.0, 4.0], [2.0, 1.0], [0.1, 0.0]])
    np.testing.assert_allclose(F.centering(x, c, 0.75), 0.75 * (c - x))
    mask = np.array([True, True, False])
    s = F.spring(x, c, 1.8, 2.0, mask)
    np.testing.assert_allclose(s[0], 1.8 * (5.0 - 2.0) * np.array([0.6, 0.8]))  # k (d - d0) e
    np.testing.assert_allclose(s[1], 0.0)  # d = 1 <= d0: inactive
    np.testing.assert_allclose(s[2], 0.0)  # masked out
    vm = F.velocity_match(np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[0.0, 2.0], [5.0, 5.0]]), 0.7,
                          np.array([True, False]))
    np.testing.assert_allclose(vm, [[-0.7, 1.4], [0.0, 0.0]])


def test_nearest_in_group():
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.0], [10.0, 0.0]])
    nn = F.nearest_in_group(x, np.array([0, 0, 1, 1]))
    assert nn.tolist() == [1, 0, 3, 2]
    assert F.nearest_in_group(x[:1], np.array([0])).tolist() == [-1]


def omega(d):
    """Eq. (36), transcribed."""
    w = P.paper.k_rep * max(0, 1 / d - 1 / P.paper.r_trigger) / d**2 * (1 + P.paper.k_b * (max(0, P.paper.r_trigger - d) / P.paper.r_trigger) ** P.paper.gamma)
    return w + (P.paper.k_e * (P.paper.d_safe - d + 1) ** 2 if d < P.paper.d_safe else 0.0)


@pytest.mark.parametrize("d", [0.8, 1.49, 1.51, 3.0, 13.0])
def test_lidar_repulsion_eq35_37_single_minimum(d):
    ring = np.full((1, R), 20.0)
    ring[0, 85:96] = d + 0.01 * np.abs(np.arange(85, 96) - 90)  # a dip with its minimum on ray 90
    f = F.lidar_repulsion(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e, P.paper.d_safe, 0.05)
    np.testing.assert_allclose(f[0], [-omega(d) * COS[90], -omega(d) * SIN[90]], atol=1e-12)


def test_lidar_repulsion_active_set():
    ring = np.full((1, R), 20.0)
    assert np.all(F.lidar_repulsion(ring, COS, SIN, 9.0, 14.0, 0.9, 1.2, 48.0, 1.5, 0.05) == 0)  # L_i empty
    ring[0, 10] = 15.0  # a local minimum beyond R_t = 14 m is not active
    assert np.all(F.lidar_repulsion(ring, COS, SIN, 9.0, 14.0, 0.9, 1.2, 48.0, 1.5, 0.05) == 0)
    ring[0, 180:182] = 3.0  # a two-ray flat minimum counts once, at its first ray
    f = F.lidar_repulsion(ring, COS, SIN, 9.0, 14.0, 0.9, 1.2, 48.0, 1.5, 0.05)
    np.testing.assert_allclose(f[0], [omega(3.0), -omega(3.0) * SIN[180]], atol=1e-12)
    ring[0, 90:100] = 4.0 - 0.1 * np.arange(10)  # a monotone slope: minimum only at its end (ray 99)
    assert F.is_local_min(ring[0], 99) and not F.is_local_min(ring[0], 95)


def _case(n=4):
    rng = np.random.default_rng(3)
    x = rng.uniform(-2, 2, (n, 2))
    v = rng.normal(size=(n, 2))
    group = np.array([0, 0, 1, 1])
    sl = np.array([0, 0, 2, 2])
    follower = sl != np.arange(n)
    cent = np.array([x[group == g].mean(axis=0) for g in group])
    wp = cent + 1.0
    slot = x + rng.normal(size=(n, 2))
    vslot = F.slot_velocity(x, slot, np.full(n, 3.0), 0.5)
    nn = F.nearest_in_group(x, group)
    ring = np.full((n, R), 20.0)
    ring[:, 40] = 1.0  # an obstacle 1 m away on ray 40 for everyone
    return x, v, group, x[sl], v[sl], follower, cent, wp, slot, vslot, nn, ring


def test_force_terms_match_the_terms_and_sum():
    x, v, group, slp, slv, follower, cent, wp, slot, vslot, nn, ring = _case()
    nav = np.ones(4, dtype=bool)
    sig = np.ones((4, 4))
    t = F.force_terms(x, v, group, slp, slv, follower, cent, wp, nav, slot, vslot, nn, sig, ring, COS, SIN, G, DS)
    np.testing.assert_allclose(t[0], F.attraction(x, v, slot, vslot, P.paper.k_p, P.paper.k_v))
    np.testing.assert_allclose(t[1], F.separation(x, group, P.paper.k_sep, P.core.r_sep, P.core.d_floor, False))
    np.testing.assert_allclose(t[2], F.centering(x, wp, P.paper.k_path))
    np.testing.assert_allclose(t[3], F.spring(x, x[nn], P.paper.k_intra, P.core.d_thr, nn >= 0))
    np.testing.assert_allclose(t[4], F.separation(x, group, P.paper.k_ir, P.core.d_ir, P.core.d_floor, True))
    np.testing.assert_allclose(t[5], F.spring(x, slp, P.paper.k_l, P.core.d_0, follower) + F.velocity_match(v, slv, P.paper.k_vl, follower))
    np.testing.assert_allclose(t[6], F.spring(x, cent, P.paper.k_coh, P.core.d_c, np.ones(4, dtype=bool)))
    np.testing.assert_allclose(t[7], F.lidar_repulsion(ring, COS, SIN, P.paper.k_rep, P.paper.r_trigger, P.paper.k_b, P.paper.gamma, P.paper.k_e,
                                                       P.paper.d_safe, P.core.d_floor))
    assert np.all(t[5][~follower] == 0)  # subleaders have no coupling term
    a = F.synthesize(x, v, group, slp, slv, follower, cent, wp, nav, slot, vslot, nn, sig, ring, COS, SIN, G, DS)
    np.testing.assert_allclose(a, t.sum(axis=0))


@pytest.mark.parametrize("column, term", [(F.SIG_SLOT, 0), (F.SIG_NN, 3), (F.SIG_SL, 5), (F.SIG_CENT, 6)])
def test_occlusion_scales_exactly_its_attraction_term(column, term):
    x, v, group, slp, slv, follower, cent, wp, slot, vslot, nn, ring = _case()
    nav = np.ones(4, dtype=bool)
    args = (x, v, group, slp, slv, follower, cent, wp, nav, slot, vslot, nn)
    free = F.force_terms(*args, np.ones((4, 4)), ring, COS, SIN, G, DS)
    sig = np.ones((4, 4))
    sig[1, column] = P.paper.sigma_occ  # agent 1's segment to this target is blocked
    occ = F.force_terms(*args, sig, ring, COS, SIN, G, DS)
    expect = free.copy()
    expect[term, 1] *= P.paper.sigma_occ
    np.testing.assert_array_equal(occ, expect)


def test_all_four_attraction_terms_and_only_them_are_attenuated():
    x, v, group, slp, slv, follower, cent, wp, slot, vslot, nn, ring = _case()
    nav = np.ones(4, dtype=bool)
    args = (x, v, group, slp, slv, follower, cent, wp, nav, slot, vslot, nn)
    free = F.force_terms(*args, np.ones((4, 4)), ring, COS, SIN, G, DS)
    occ = F.force_terms(*args, np.full((4, 4), 0.2), ring, COS, SIN, G, DS)
    for t in range(8):
        scale = 0.2 if F.TERMS[t] in ("att", "intra", "fol", "coh") else 1.0
        np.testing.assert_allclose(occ[t], scale * free[t], err_msg=F.TERMS[t])


def test_encircle_switches_off_path_and_intra_repulsion():
    x, v, group, slp, slv, follower, cent, wp, slot, vslot, nn, ring = _case()
    x[1] = x[0] + [0.5, 0.0]  # make the intra repulsion non-zero
    nav = np.array([False, False, True, True])
    t = F.force_terms(x, v, group, slp, slv, follower, cent, wp, nav, slot, vslot, nn, np.ones((4, 4)), ring,
                      COS, SIN, G, DS)
    assert np.all(t[2][:2] == 0) and np.all(t[4][:2] == 0)
    assert np.any(t[2][2:] != 0)
    assert np.all(t[[0, 1, 3, 5, 6, 7]][:, :2].any(axis=2).sum(axis=0) >= 1)  # other terms still act


def test_saturation_eq39():
    a = np.array([[3.0, 4.0], [0.1, -0.2], [0.0, 0.0]])
    s = F.saturate(a, 2.6)
    np.testing.assert_allclose(np.linalg.norm(s[0]), 2.6)
    np.testing.assert_allclose(s[0] / 2.6, a[0] / 5.0)  # direction kept
    np.testing.assert_array_equal(s[1:], a[1:])


def test_safety_filter_bounds_speed_and_closing_speed():
    ring = np.full((1, R), 20.0)
    ring[0, 0] = 1.0  # a wall 1 m ahead on +x
    v = np.array([[3.0, 0.0]])
    a = B.safety_filter(np.zeros((1, 2)), v, ring, COS, SIN, 0.1, 10.0, 1.5, 0.5, 20.0)
    v_next = v + 0.1 * a
    assert v_next[0, 0] <= math.sqrt(2 * 1.5 * 0.5) + 1e-12  # stoppable within d - margin
    a2 = B.safety_filter(np.array([[0.0, 50.0]]), np.array([[0.0, 0.0]]), np.full((1, R), 20.0), COS, SIN, 0.1,
                         3.9, 1.5, 0.5, 20.0)
    assert np.linalg.norm(0.1 * a2) == pytest.approx(3.9)  # speed cap



def test_safety_filter_meets_every_ray_bound_between_obstacles():
    """Property: whatever the command, the next velocity respects the braking bound of every
    LiDAR return at once, also with returns on several sides (two trees, a corner), where
    one greedy sweep over the rays can leave a bound broken that an earlier ray had met."""
    rng = np.random.default_rng(7)
    for _ in range(400):
        ring = np.full((3, R), 20.0)
        for row in ring:  # two or three obstacles: arcs of close returns around random bearings
            for _ in range(rng.integers(2, 4)):
                c, w = rng.integers(0, R), rng.integers(5, 60)
                idx = (c + np.arange(-w, w + 1)) % R
                row[idx] = np.minimum(row[idx], rng.uniform(0.2, 2.0) + 0.3 * np.abs(np.arange(-w, w + 1)) / w)
        v = rng.normal(0.0, 1.0, (3, 2))
        a = rng.normal(0.0, 30.0, (3, 2))
        out = B.safety_filter(a, v, ring, COS, SIN, 0.1, 1.3, 1.5, 0.5, 20.0)
        w = v + 0.1 * out
        closing = w @ np.vstack([COS, SIN])  # (3, R)
        bound = np.sqrt(2 * 1.5 * np.maximum(ring - 0.5, 0.0))
        assert np.all(closing[ring < 20.0] <= bound[ring < 20.0] + 1e-9)
        assert np.all(np.linalg.norm(w, axis=1) <= 1.3 + 1e-9)


def test_safety_filter_with_the_nearest_returns_is_the_same_bit_for_bit():
    """Given each ring's nearest return, agents too slow for any ray to bind skip the sweeps: the
    command must not change by a bit, near walls (bounds binding) or far from them."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        ring = np.full((6, R), 20.0)
        for row in ring:
            c, w = rng.integers(0, R), rng.integers(5, 60)
            idx = (c + np.arange(-w, w + 1)) % R
            row[idx] = rng.uniform(0.3, 8.0) + 0.3 * np.abs(np.arange(-w, w + 1)) / w
        v = rng.normal(0.0, 1.0, (6, 2))
        a = rng.normal(0.0, 5.0, (6, 2))
        plain = B.safety_filter(a, v, ring, COS, SIN, 0.1, 1.3, 1.5, 0.5, 20.0)
        fast = B.safety_filter(a, v, ring, COS, SIN, 0.1, 1.3, 1.5, 0.5, 20.0, 3, ring.min(axis=1))
        assert plain.tobytes() == fast.tobytes()

def _follow(lead_brake_step, v0=3.0, gap0=4.0, steps=200):
    """1-D car following under eq. (39): the follower commands +a_max toward the leader every
    step (the worst attraction), the leader cruises at 2 m/s and brakes at a_max from
    ``lead_brake_step``; both integrate with the inverse-model dynamics (v += a dt, p += v dt).
    Returns the smallest gap [m]."""
    x = np.array([[0.0, 0.0], [gap0, 0.0]])
    v = np.array([[v0, 0.0], [2.0, 0.0]])
    active = np.array([True, False])
    d_min = np.inf
    for k in range(steps):
        a = np.array([[P.paper.a_max, 0.0], [0.0, 0.0]])
        if k >= lead_brake_step:
            a[1, 0] = -min(P.paper.a_max, v[1, 0] / P.paper.dt)
        a = F.saturate(B.agent_barrier(a, x, v, active, P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max), P.paper.a_max)
        v = v + P.paper.dt * a
        x = x + P.paper.dt * v
        d_min = min(d_min, x[1, 0] - x[0, 0])
    return d_min


@pytest.mark.parametrize("brake_at", [0, 5, 20, 60])
def test_agent_barrier_follower_never_reaches_the_contact_distance(brake_at):
    # The follower pushes toward the leader at a_max while the leader brakes to a stop at a_max:
    # with the barrier the gap stays above the 0.4 m contact distance of the collision metric
    # (discrete-time slack of one step at <= 3.9 m/s: 0.1 m below agent_margin = 0.6 m).
    assert _follow(brake_at) >= P.passage.agent_margin - 0.1
    # without it (inactive) the follower runs into the leader
    x = np.array([[0.0, 0.0], [4.0, 0.0]])
    a = np.array([[P.paper.a_max, 0.0], [0.0, 0.0]])
    v = np.array([[3.0, 0.0], [2.0, 0.0]])
    out = B.agent_barrier(a, x, v, np.array([False, False]), P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max)
    np.testing.assert_allclose(out, a, atol=1e-12)


def test_agent_barrier_only_brakes():
    # i is never pushed away by a neighbour that closes on it (i at rest, j rushing at it), and a
    # member moving away from its neighbour or sideways is not touched
    x = np.array([[0.0, 0.0], [0.8, 0.0]])
    v = np.array([[0.0, 0.0], [-3.0, 0.0]])
    a = np.zeros((2, 2))
    out = B.agent_barrier(a, x, v, np.array([True, False]), P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max)
    np.testing.assert_array_equal(out[0], [0.0, 0.0])
    v2 = np.array([[-1.0, 2.0], [0.0, 0.0]])
    out2 = B.agent_barrier(a, x, v2, np.array([True, False]), P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max)
    np.testing.assert_allclose(out2[0], [0.0, 0.0], atol=1e-12)
    # closing at 2 m/s from 1 m: the closing part is cut to sqrt(2 a_brake (1 - agent_margin)),
    # the sideways part is kept
    v3 = np.array([[2.0, 1.0], [0.0, 0.0]])
    x3 = np.array([[0.0, 0.0], [1.0, 0.0]])
    out3 = B.agent_barrier(a, x3, v3, np.array([True, False]), P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max)
    w = v3[0] + P.paper.dt * out3[0]
    assert w[0] == pytest.approx(math.sqrt(2 * P.passage.agent_brake * (1.0 - P.passage.agent_margin)))
    assert w[1] == pytest.approx(1.0)


def _guarded_rollout(x, v, target_acc, steps=150, guard=True):
    """Agents that command ``target_acc(x, v)`` saturated at a_max (eq. 39), then the contact guard
    (or not), integrated with the inverse-model dynamics (v += a dt, p += v dt). Returns the
    smallest pairwise distance [m] (sampled every step), the largest commanded norm [m/s^2] and
    the final positions."""
    d_min, a_top = np.inf, 0.0
    n = x.shape[0]
    for _ in range(steps):
        a = F.saturate(target_acc(x, v), P.paper.a_max)
        if guard:
            a = B.agent_guard(a, x, v, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
        a_top = max(a_top, float(np.linalg.norm(a, axis=1).max()))
        v = v + P.paper.dt * a
        x = x + P.paper.dt * v
        d = np.linalg.norm(x[:, None] - x[None], axis=-1) + np.diag(np.full(n, np.inf))
        d_min = min(d_min, float(d.min()))
    return d_min, a_top, x


@pytest.mark.parametrize("speed", [1.0, 2.0, 3.0, 3.9])
@pytest.mark.parametrize("offset", [0.0, 0.2])
def test_agent_guard_head_on_pair_never_touches(speed, offset):
    # Two agents closing head-on in free space at up to the speed cap (1.3 v_s = 3.9 m/s each),
    # each pushing toward the other at a_max the whole time (the worst attraction): with the
    # guard they stop short of the 0.4 m contact distance of the collision metric (one step of
    # discrete-time slack below guard_margin), and the command never exceeds a_max; without it
    # they collide.
    x = np.array([[0.0, 0.0], [12.0, offset]])
    v = np.array([[speed, 0.0], [-speed, 0.0]])

    def push(x, v):
        return 100.0 * (x[::-1] - x)

    d_min, a_top, end = _guarded_rollout(x, v, push)
    assert d_min >= 0.4
    assert d_min >= P.guard.margin - 0.1
    assert a_top <= P.paper.a_max + 1e-9
    if offset == 0.0:  # exactly head-on: they stop, neither slides past (sideways passing is allowed)
        assert end[1, 0] > end[0, 0]
        d_off, _, end_off = _guarded_rollout(x, v, push, guard=False)
        assert d_off < 0.4 or end_off[1, 0] < end_off[0, 0]  # without the guard: contact or passing through


@pytest.mark.parametrize("n", [3, 4, 5])
@pytest.mark.parametrize("speed", [1.0, 2.0])
def test_agent_guard_agents_converging_on_one_point_never_touch(n, speed):
    # n agents on a 6 m ring, all driven at a_max toward its centre (inward at ``speed`` at the
    # start): the cycled projections against every neighbour keep every pair above the contact
    # distance. (Known limits, docs/methods/hes.md: each bound acts along one pair's line, so
    # agents converging at an angle need more radial braking than guard_brake; with
    # guard_brake = 2.2 m/s^2 three agents converging at 3 m/s end at 0.34 m, and from six
    # agents on, pairs end at 0.27-0.36 m.)
    th = 2 * np.pi * np.arange(n) / n
    x = 6.0 * np.column_stack([np.cos(th), np.sin(th)])
    v = -speed * np.column_stack([np.cos(th), np.sin(th)])
    d_min, a_top, _ = _guarded_rollout(x, v, lambda x, v: -100.0 * x, steps=200)
    assert d_min >= 0.4
    assert a_top <= P.paper.a_max + 1e-9
    assert _guarded_rollout(x, v, lambda x, v: -100.0 * x, steps=200, guard=False)[0] < 0.4


def test_agent_guard_priority_over_the_clip():
    # A saturated sideways command (0, a_max) while closing at 1.6 m/s on a neighbour 1 m ahead:
    # the guard's braking b is realised whole (w . u = sqrt(2 a_brake (d - margin))) and the
    # sideways rest is scaled down to keep the norm at a_max, not the braking.
    x = np.array([[0.0, 0.0], [1.0, 0.0]])
    v = np.array([[1.6, 0.0], [0.0, 0.0]])
    a = np.array([[0.0, P.paper.a_max], [0.0, 0.0]])
    out = B.agent_guard(a, x, v, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
    c_max = math.sqrt(2 * P.guard.brake * (1.0 - P.guard.margin))
    b = (c_max - v[0, 0]) / P.paper.dt
    assert 0.0 < -b < P.paper.a_max
    assert out[0, 0] == pytest.approx(b)  # the braking, whole
    assert np.linalg.norm(out[0]) == pytest.approx(P.paper.a_max)  # within eq. (39)'s bound
    assert out[0, 1] == pytest.approx(math.sqrt(P.paper.a_max**2 - b * b))  # the rest scaled, lam < 1
    assert (v[0] + P.paper.dt * out[0])[0] == pytest.approx(c_max)
    # braking beyond a_max (2.5 m/s closing from 1 m): a_max of pure braking, nothing else
    out2 = B.agent_guard(a, x, np.array([[2.5, 0.0], [0.0, 0.0]]), P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
    np.testing.assert_allclose(out2[0], [-P.paper.a_max, 0.0], atol=1e-12)
    # an agent at rest, one it closes on at rest beside it, and a pair moving apart: untouched
    x2 = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]])
    v2 = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    a2 = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])
    np.testing.assert_allclose(B.agent_guard(a2, x2, v2, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max), a2, atol=1e-12)


def test_agent_guard_counts_the_neighbours_own_stopping_distance():
    # The bound is 2 a_brake (d - margin) + s_j |s_j| (s_j: j's speed away from i): a neighbour
    # moving away at the same speed leaves i free to follow; one closing in tightens i's bound.
    x = np.array([[0.0, 0.0], [1.5, 0.0]])
    a = np.zeros((2, 2))
    away = B.agent_guard(a, x, np.array([[3.0, 0.0], [3.0, 0.0]]), P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
    np.testing.assert_allclose(away[0], [0.0, 0.0], atol=1e-12)
    # at 0.9 m, i closing at 1 m/s: free beside a neighbour at rest (bound sqrt(1.6) m/s), cut to
    # sqrt(1.6 - 1) m/s when the neighbour closes in at 1 m/s
    x = np.array([[0.0, 0.0], [0.9, 0.0]])
    rest = B.agent_guard(a, x, np.array([[1.0, 0.0], [0.0, 0.0]]), P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
    np.testing.assert_allclose(rest[0], [0.0, 0.0], atol=1e-12)
    v = np.array([[1.0, 0.0], [-1.0, 0.0]])
    out = B.agent_guard(a, x, v, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max)
    c_max = math.sqrt(2 * P.guard.brake * (0.9 - P.guard.margin) - 1.0)
    w = v[0] + P.paper.dt * out[0]
    assert w[0] == pytest.approx(c_max)


# --------------------------------------------------------------------------- neighbour rows vs all pairs

def _swarm(n, seed):
    """n agents at ~2 m spacing in a few groups, moving at up to ~2.5 m/s, some pairs close."""
    rng = np.random.default_rng(seed)
    side = 2.0 * math.sqrt(n)
    x = rng.uniform(0.0, side, (n, 2))
    x[1::7] = x[::7][: len(x[1::7])] + rng.normal(scale=0.3, size=(len(x[1::7]), 2))  # close pairs
    v = rng.normal(scale=1.5, size=(n, 2))
    a = rng.normal(scale=2.0, size=(n, 2))
    group = rng.integers(0, 3, n)
    return x, v, a, group


@pytest.mark.parametrize("n,seed", [(80, 0), (300, 1), (300, 2)])
def test_pair_kernels_on_neighbour_rows_equal_all_pairs_bit_for_bit(n, seed):
    # The cell-list rows (N >= 64) must give the all-pairs result exactly: partners beyond the
    # radius add nothing and partners are visited in the same ascending order.
    x, v, a, group = _swarm(n, seed)
    rows = neighbour_rows(x, max(P.core.r_sep, P.core.d_ir))
    assert len(rows[1]) < n * n  # a real cell list, not every pair
    for k, r, same in ((P.paper.k_sep, P.core.r_sep, False), (P.paper.k_ir, P.core.d_ir, True)):
        assert np.array_equal(F.separation(x, group, k, r, P.core.d_floor, same, *rows),
                              F.separation(x, group, k, r, P.core.d_floor, same))
    assert np.array_equal(F.nearest_in_group(x, group, *rows), F.nearest_in_group(x, group))
    lone = group.copy()
    lone[0] = 7  # alone in its group: found by the fallback over all agents (-1)
    lone[1], lone[-1] = 8, 8  # a pair far apart: nobody of its group in its row
    assert np.array_equal(F.nearest_in_group(x, lone, *rows), F.nearest_in_group(x, lone))
    rg = neighbour_rows(x, B.brake_radius(a, v, P.paper.dt, P.guard.brake, P.guard.margin))
    assert np.array_equal(B.agent_guard(a, x, v, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max, 4, *rg),
                          B.agent_guard(a, x, v, P.paper.dt, P.guard.brake, P.guard.margin, P.paper.a_max))
    active = np.arange(n) % 2 == 0
    rb = neighbour_rows(x, B.brake_radius(a, v, P.paper.dt, P.passage.agent_brake, P.passage.agent_margin))
    assert np.array_equal(B.agent_barrier(a, x, v, active, P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max, *rb),
                          B.agent_barrier(a, x, v, active, P.paper.dt, P.passage.agent_brake, P.passage.agent_margin, P.paper.a_max))


def test_neighbour_rows_hold_every_agent_within_the_radius():
    x, *_ = _swarm(200, 3)
    ptr, idx = neighbour_rows(x, 3.0)
    d = np.hypot(*(x[:, None, :] - x[None, :, :]).transpose(2, 0, 1))
    for i in range(len(x)):
        row = idx[ptr[i]:ptr[i + 1]]
        assert np.all(np.diff(row) > 0)  # ascending, no repeats
        assert set(np.flatnonzero(d[i] <= 3.0)) <= set(row.tolist())
