"""The Vicsek family as a method: invariants of layers, headings and speed; the avoidance trigger
on circles, boxes and polygons; path following; mission bookkeeping; small-N behaviour."""

from __future__ import annotations

import math

import numpy as np
import pytest

import swarmnav
from swarmnav.methods.base import Observation
from swarmnav.methods.vicsek import VicsekFamily
from swarmnav.methods.vicsek import kernels as K
from swarmnav.methods.vicsek.geometry import Polyline, avoidance, pursue, wrap
from swarmnav.methods.vicsek.measures import circular_mean, deg_con, k_con
from swarmnav.world import from_dict
from swarmnav.world.generators import periodic_box

from . import dense_reference as R

NO_NOISE = np.zeros(0)

ALIGN = dict(v0=0.03, eta=0.0, c_rep=0.0, c_att=0.0)  # HWVEM Section 3.1


def stepper(model, scn, seed=0, **kw):
    """A method reset on ``scn`` and a function advancing it one step (positions as the rollout)."""
    rng = np.random.default_rng(seed)
    m = VicsekFamily(model, **kw)
    x = scn.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scn, x.copy(), v.copy(), rng)
    state = {"x": x, "v": v, "k": 0}

    def step():
        cmd, info = m.act(Observation(state["k"], float(state["k"]), state["x"], state["v"]), rng)
        state["x"], state["v"] = m.dynamics.step(state["x"], state["v"], cmd, m.dt)
        state["k"] += 1
        return cmd, info

    return m, state, step


# ----------------------------------------------------------------------------- invariants


@pytest.mark.parametrize("initial", ["unknown", "bfs"])
def test_layers_follow_eq5_from_the_previous_step(initial):
    scn = periodic_box(80, 4.102)
    m, st, step = stepper("hwvem", scn, seed=3, initial_layers=initial, **ALIGN)
    box = scn.bounds[2]
    A0 = R.adjacency(st["x"], 1.0, box)
    if initial == "bfs":  # the fixed point of eq. (5) on the initial graph
        fixed = np.full(80, np.inf)
        fixed[m.iu] = 1
        for _ in range(80):
            fixed = R.next_layers(A0, fixed, m.iu)
        np.testing.assert_array_equal(np.where(m.layers == K.NO_LAYER, np.inf, m.layers), fixed)
    else:
        assert m.layers[m.iu] == 1 and np.all(np.delete(m.layers, m.iu) == K.NO_LAYER)
    for _ in range(12):
        prev = np.where(m.layers == K.NO_LAYER, np.inf, m.layers.astype(float))
        A = R.adjacency(st["x"], 1.0, box)  # N_i(k-1): the neighbours when the step is taken
        step()
        now = np.where(m.layers == K.NO_LAYER, np.inf, m.layers.astype(float))
        assert now[m.iu] == 1  # the information UAV is layer 1
        np.testing.assert_array_equal(now, R.next_layers(A, prev, m.iu))


@pytest.mark.parametrize("model", ["vem", "vem-a", "ivem", "ivem-a", "wvem", "hwvem"])
def test_headings_stay_in_range_and_speed_is_v0(model):
    """Eq. (7): without attraction and repulsion every agent flies at exactly v0."""
    res = swarmnav.run(model, "periodic_box:n=60,rho=4.102", seed=4, steps=25, eta=0.3,
                       **{k: v for k, v in ALIGN.items() if k != "eta"})
    speed = np.linalg.norm(res.velocities[1:], axis=2)
    np.testing.assert_allclose(speed, 0.03, rtol=1e-12)
    m, _, step = stepper(model, periodic_box(60, 4.102), eta=0.3, **{k: v for k, v in ALIGN.items() if k != "eta"})
    for _ in range(10):
        step()
        assert np.all((m.theta >= -np.pi) & (m.theta < np.pi))


def test_info_uav_flies_the_reference_and_sits_at_the_lower_left_corner():
    scn = periodic_box(100, 4.102)
    m, st, step = stepper("vem-a", scn, seed=2, **ALIGN)
    d = np.linalg.norm(st["x"], axis=1)
    assert m.iu == int(np.argmin(d))
    for _ in range(5):
        cmd, _ = step()
        np.testing.assert_allclose(cmd[m.iu], 0.03 * np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)]))


def test_attraction_repulsion_and_the_speed_cap():
    """Eq. (25)-(26): two close agents repel, the velocity is capped at v_max, the IU is deaf."""
    scn = from_dict({"swarm": {"n": 3, "spawn": [-0.01, -0.01, 0.01, 0.01], "min_spacing": 0.0, "clearance": 0.0},
                     "goal": {"position": [50.0, 0.0]}})
    m = VicsekFamily("vem-a", eta=0.0, c_rep=1.0, c_att=0.0)
    x = np.array([[0.0, 0.0], [0.0, 0.2], [0.0, -0.2]])  # agent 0 is the IU (nearest the spawn centre)
    m.reset(scn, x, np.zeros_like(x), np.random.default_rng(0))
    assert m.iu == 0
    v, _ = m.act(Observation(0, 0.0, x, np.zeros_like(x)), np.random.default_rng(0))
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.1)  # capped at v_max = v0
    assert v[1, 1] > 0 and v[2, 1] < 0  # pushed apart, away from the other agents
    np.testing.assert_allclose(v[0], [0.1, 0.0], atol=1e-12)  # the IU flies its path, untouched


# ----------------------------------------------------------------------------- avoidance

def scene_with(obstacle):
    return from_dict({"swarm": {"n": 1, "spawn": [-9.01, -9.01, -8.99, -8.99], "min_spacing": 0.0, "clearance": 0.0},
                      "goal": {"position": [20.0, 0.0]}, "obstacles": [obstacle]})


CIRCLE = {"type": "circle", "center": [0.0, 0.0], "radius": 1.0}
BOX = {"type": "box", "min": [0.0, -2.0], "max": [2.0, 2.0]}
DIAMOND = {"type": "polygon", "points": [[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]}
TRIANGLE = {"type": "polygon", "points": [[0.0, -1.0], [2.0, 0.0], [0.0, 1.0]]}


@pytest.mark.parametrize("obstacle,x,normal", [
    (CIRCLE, [-1.3, 0.0], 0.0),  # head-on at a circle
    (BOX, [-0.3, 0.5], 0.0),  # at a box face
    (DIAMOND, [-0.8, -0.8], math.pi / 4),  # facing the lower-left edge
    (TRIANGLE, [-0.4, 0.3], 0.0),  # facing the vertical edge x = 0
], ids=["circle", "box", "diamond", "triangle"])
def test_avoidance_takes_the_tangent_at_an_acute_angle(obstacle, x, normal):
    geom = scene_with(obstacle).geometry
    pts = np.array([x, x])
    tangent = (normal + math.pi / 2, normal - math.pi / 2)
    theta_g = np.array([normal, normal])  # wants to fly straight into the obstacle
    prev = np.array([normal + 0.3, normal - 0.3])  # before: slightly left / slightly right of it
    avoiding, theta_obs, dist = avoidance(geom, pts, theta_g, prev, 0.5, 11 * math.pi / 20)
    assert avoiding.all() and np.all(dist <= 0.5)
    for k in range(2):
        assert min(abs(wrap(theta_obs[k] - t)) for t in tangent) < 1e-9  # a tangent direction
        assert math.cos(theta_obs[k] - prev[k]) > 0  # the acute one w.r.t. the previous heading
    assert theta_obs[0] != pytest.approx(theta_obs[1])


def test_avoidance_trigger_distance_and_angle():
    geom = scene_with(CIRCLE).geometry
    # eq. (20): farther than r_avoid -> no action
    av, _, _ = avoidance(geom, np.array([[-1.51, 0.0]]), np.array([0.0]), np.array([0.0]), 0.5, 11 * math.pi / 20)
    assert not av[0]
    # eq. (21): obstacle at 99 deg -/+ 1e-6 from the genuine direction
    x = np.array([[-1.3, 0.0]])  # obstacle direction 0 rad
    for th, expect in ((11 * math.pi / 20 - 1e-6, True), (11 * math.pi / 20 + 1e-6, False), (math.pi, False)):
        av, _, _ = avoidance(geom, x, np.array([th]), np.array([th]), 0.5, 11 * math.pi / 20)
        assert av[0] == expect, th


def test_avoidance_at_a_box_corner_uses_the_supporting_line():
    geom = scene_with(BOX).geometry
    x = np.array([[-0.3, -2.3]])  # nearest point: the corner (0, -2), direction (1, 1)/sqrt 2
    av, th, _ = avoidance(geom, x, np.array([math.pi / 4]), np.array([0.5]), 0.5, 11 * math.pi / 20)
    assert av[0] and abs(wrap(th[0] + math.pi / 4)) < 1e-9  # perpendicular to the approach


def test_no_tangent_on_the_boundary_itself():
    geom = scene_with(BOX).geometry
    av, _, dist = avoidance(geom, np.array([[0.0, 0.5]]), np.array([0.0]), np.array([0.0]), 0.5, 11 * math.pi / 20)
    assert dist[0] == 0.0 and not av[0]  # "moves in the original direction"


def test_avoiding_agents_are_left_out_of_the_genuine_direction():
    """Eq. (18)-(19): a neighbour that avoids an obstacle does not pull the others."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    theta = np.array([0.0, 2.0, 0.4])
    idx = np.empty(64, np.int64)
    d2 = np.empty(64)
    order, start, end, _ = K.neighbour_csr(pos, 1.0, 0.0, True, idx, d2)
    out = np.empty(3)
    avoiding = np.array([False, True, False])
    K.genuine_heading(K.VEM, order, start, end, idx, d2, 1.0, theta, theta.copy(), np.ones(3, np.int64), avoiding, -1,
                      np.zeros(3, np.bool_), 0.0, 0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out)
    assert out[0] == pytest.approx(0.4)  # only agent 2 counts


def test_ivem_rule_by_hand():
    """Eq. (30)-(31): below all neighbours -> up by half their spread; inside -> unchanged."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [3.0, 3.0], [3.3, 3.0], [3.0, 3.3]])
    theta = np.array([-1.0, 0.0, 0.5, 0.2, 0.0, 0.5])
    idx = np.empty(64, np.int64)
    d2 = np.empty(64)
    order, start, end, _ = K.neighbour_csr(pos, 1.0, 0.0, True, idx, d2)
    out = np.empty(6)
    K.genuine_heading(K.IVEM, order, start, end, idx, d2, 1.0, theta, theta.copy(), np.ones(6, np.int64),
                      np.zeros(6, np.bool_), -1, np.zeros(6, np.bool_), 0.0, 0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out)
    assert out[0] == pytest.approx(-0.75) and out[3] == pytest.approx(0.2)
    assert out[2] == pytest.approx(0.5 - 0.5)  # above both neighbours (-1, 0): down by (0 + 1) / 2



@pytest.mark.parametrize("rule, expect", [
    # agent 0 (-1.0; neighbours 0.0, 0.5), agent 3 (0.2; neighbours 0.0, 0.5), agent 2 (0.5; neighbours -1, 0)
    (K.IVEM_PRINTED, (-0.75, 0.2, 0.0)),
    (K.IVEM_MIDDLE, (0.25, 0.25, -0.5)),  # (max + min) / 2 for everyone
    (K.IVEM_PRINTED_CIRCULAR, (-0.75, 0.2, 0.0)),  # no heading near +-pi: the same as printed
    (K.IVEM_MIDDLE_CIRCULAR, (0.25, 0.25, -0.5)),
])
def test_ivem_readings_by_hand(rule, expect):
    """The four readings of eq. (30)-(31) on the configuration of test_ivem_rule_by_hand."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [3.0, 3.0], [3.3, 3.0], [3.0, 3.3]])
    theta = np.array([-1.0, 0.0, 0.5, 0.2, 0.0, 0.5])
    idx = np.empty(64, np.int64)
    d2 = np.empty(64)
    order, start, end, _ = K.neighbour_csr(pos, 1.0, 0.0, True, idx, d2)
    out = np.empty(6)
    K.genuine_heading(K.IVEM, order, start, end, idx, d2, 1.0, theta, theta.copy(), np.ones(6, np.int64),
                      np.zeros(6, np.bool_), -1, np.zeros(6, np.bool_), 0.0, 0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0,
                      NO_NOISE, out, rule)
    np.testing.assert_allclose(out[[0, 3, 2]], expect, atol=1e-12)


def test_ivem_circular_readings_across_the_seam():
    """Headings 3.0 (own) and -3.0, 3.1 (neighbours): as numbers the agent lies between them and
    keeps its heading (printed) or turns to their middle 0.05, i.e. backwards (middle); seen from
    its own heading the neighbours are at +0.28 and +0.1, so it turns up by half their spread
    (printed-circular) or to the middle of the arc they span (middle-circular), across pi."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    theta = np.array([3.0, -3.0, 3.1])
    idx = np.empty(64, np.int64)
    d2 = np.empty(64)
    order, start, end, _ = K.neighbour_csr(pos, 1.0, 0.0, True, idx, d2)
    two_pi = 2 * np.pi
    got = {}
    for rule in (K.IVEM_PRINTED, K.IVEM_MIDDLE, K.IVEM_PRINTED_CIRCULAR, K.IVEM_MIDDLE_CIRCULAR):
        out = np.empty(3)
        K.genuine_heading(K.IVEM, order, start, end, idx, d2, 1.0, theta, theta.copy(), np.ones(3, np.int64),
                          np.zeros(3, np.bool_), -1, np.zeros(3, np.bool_), 0.0, 0.1, 5.0, True, 30.0, 18.0, 1.0,
                          100.0, NO_NOISE, out, rule)
        got[rule] = out[0]
    lo, hi = 0.1, two_pi - 6.0  # the neighbours relative to 3.0 on the circle
    assert got[K.IVEM_PRINTED] == pytest.approx(3.0)
    assert got[K.IVEM_MIDDLE] == pytest.approx(0.05)
    assert got[K.IVEM_PRINTED_CIRCULAR] == pytest.approx(3.0 + (hi - lo) / 2)
    assert got[K.IVEM_MIDDLE_CIRCULAR] == pytest.approx(3.0 + (hi + lo) / 2 - two_pi)


def test_ivem_unsigned_and_self_readings_by_hand():
    """Headings 3.0 (own) and -3.0, 3.1 (neighbours). As numbers in [0, 2 pi) (ivem_range =
    unsigned) the neighbours are 2 pi - 3.0 = 3.283 and 3.1, both above the agent: it turns up by
    half their spread, across pi. With its own heading among the min and max (ivem_self, in
    [-pi, pi)) it lies inside {-3.0, 3.0, 3.1} and keeps 3.0, while agent 2 (3.1) is that set's
    maximum and turns down by half its spread, (3.1 + 3.0) / 2 (without itself: by 3.0)."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    theta = np.array([3.0, -3.0, 3.1])
    idx = np.empty(64, np.int64)
    d2 = np.empty(64)
    order, start, end, _ = K.neighbour_csr(pos, 1.0, 0.0, True, idx, d2)

    def run(shift, own):
        out = np.empty(3)
        K.genuine_heading(K.IVEM, order, start, end, idx, d2, 1.0, theta, theta.copy(), np.ones(3, np.int64),
                          np.zeros(3, np.bool_), -1, np.zeros(3, np.bool_), 0.0, 0.1, 5.0, True, 30.0, 18.0, 1.0,
                          100.0, NO_NOISE, out, K.IVEM_PRINTED, shift, own)
        return out

    unsigned = run(math.pi, False)
    assert unsigned[0] == pytest.approx(wrap(3.0 + (2 * math.pi - 3.0 - 3.1) / 2))
    # agent 1 (-3.0 -> 3.283) is above its neighbours 3.0, 3.1: down by 0.05
    assert unsigned[1] == pytest.approx(wrap(2 * math.pi - 3.0 - 0.05))
    signed = run(0.0, False)
    assert signed[0] == pytest.approx(3.0)  # between -3.0 and 3.1 as numbers in [-pi, pi)
    with_self = run(0.0, True)
    assert with_self[0] == pytest.approx(3.0)  # inside {-3.0, 3.0, 3.1}
    assert with_self[2] == pytest.approx(3.1 - (3.1 + 3.0) / 2)  # the maximum: down by half of 6.1
    assert with_self[1] == pytest.approx(-3.0 + (3.1 + 3.0) / 2)  # the minimum: up by half of 6.1


@pytest.mark.parametrize("scene", ["box", "mission"])
def test_ivem_raw_numbers_stay_the_headings(scene):
    """ivem_range = raw keeps IVEM-A's headings as unwrapped numbers: drawn in [0, 2 pi), then
    eq. (30)'s sums, arc tangents and tangent headings; wrapped, they are always the flown
    headings, and with the information UAV's reference near 0 (the mission's first leg) both
    signs occur."""
    from swarmnav.world.catalog import load_scenario

    scn = periodic_box(80, 4.102) if scene == "box" else load_scenario("hwvem_mission", n=20)
    kw = ALIGN if scene == "box" else {}
    m, st, step = stepper("ivem-a", scn, seed=4, ivem_range="raw", **kw)
    assert m.theta_num.min() >= 0.0 and m.theta_num.max() < 2 * np.pi + 1e-12  # the draw, Sec. 2.2
    seen_negative = False
    for _ in range(60):
        step()
        np.testing.assert_allclose(wrap(m.theta_num - m.theta), 0.0, atol=1e-9)
        seen_negative |= bool(np.any(m.theta_num < 0))
    assert seen_negative == (scene == "mission")


def test_layer_update_eq4_is_the_current_hop_distance():
    """layer_update = "eq4" (Algorithm 1, line 13): after every step the layers are the shortest
    neighbour sequence from the information UAV in the graph of that step (eq. 2-4)."""
    scn = periodic_box(80, 4.102)
    m, st, step = stepper("hwvem", scn, seed=3, layer_update="eq4", **ALIGN)
    box = scn.bounds[2]
    for _ in range(12):
        A = R.adjacency(st["x"], 1.0, box)  # the graph the step is taken in
        step()
        hops = np.full(80, np.inf)
        hops[m.iu] = 1
        for _ in range(80):
            hops = np.minimum(hops, R.next_layers(A, hops, m.iu))
        np.testing.assert_array_equal(np.where(m.layers == K.NO_LAYER, np.inf, m.layers.astype(float)), hops)


# ----------------------------------------------------------------------------- measures


def test_deg_con_and_k_con():
    th = np.full(10, 0.5)
    assert deg_con(th, 0.5) == 1.0
    th[0] = 0.5 + 0.1 * np.pi
    assert deg_con(th, 0.5) == pytest.approx(1 - 0.01)
    assert deg_con(np.array([np.pi - 0.01, -np.pi + 0.01]), np.pi) == pytest.approx(1 - 0.01 / np.pi)  # wrapped
    assert circular_mean(np.array([np.pi - 0.1, -np.pi + 0.1])) == pytest.approx(np.pi)
    assert k_con([0.1, 0.99, 0.5, 0.99, 0.995], 0.99) == 3.0  # eq. (27): for every later k
    assert k_con([0.1, 0.5], 0.99) == math.inf


# ----------------------------------------------------------------------------- behaviour


def test_vem_a_aligns_to_the_reference_and_vem_does_not_lock_to_it():
    kw = dict(ALIGN, stop_at_convergence=True)
    for seed in (1, 2, 3):
        a = swarmnav.run("vem-a", "periodic_box:n=30,rho=4.102", seed=seed, steps=6000, **kw)
        v = swarmnav.run("vem", "periodic_box:n=30,rho=4.102", seed=seed, steps=6000, **kw)
        assert a.metrics["converged"] == 1.0 and np.isfinite(a.metrics["k_con"])
        assert np.isfinite(v.metrics["k_con"])  # VEM reaches a consensus ...
        assert v.metrics["converged"] == 0.0  # ... but not the reference pi/4
        heading = np.arctan2(v.velocities[-1, :, 1], v.velocities[-1, :, 0])
        assert abs(wrap(circular_mean(heading) - math.pi / 4)) > 0.01


def test_hwvem_aligns_much_faster_than_vem_a_and_stops_early():
    kw = dict(ALIGN, stop_at_convergence=True, wrap_neighbours=False)
    for seed in (1, 2):
        h = swarmnav.run("hwvem", "periodic_box:n=100,rho=4.102", seed=seed, steps=6000, **kw)
        a = swarmnav.run("vem-a", "periodic_box:n=100,rho=4.102", seed=seed, steps=6000, **kw)
        assert h.metrics["k_con"] * 5 < a.metrics["k_con"]
        # stopped once Deg_con >= Deg_con^d held for converge_hold = 20 states: k_con .. k_con + 19
        assert h.positions.shape[0] == h.metrics["k_con"] + 20


@pytest.mark.parametrize("model", ["vem", "ivem"])
def test_alignment_only_models_are_deterministic(model):
    a = swarmnav.run(model, "periodic_box:n=50,rho=4.102", seed=5, steps=30)
    b = swarmnav.run(model, "periodic_box:n=50,rho=4.102", seed=5, steps=30)
    c = swarmnav.run(model, "periodic_box:n=50,rho=4.102", seed=6, steps=30)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert a.metrics == b.metrics
    assert not np.array_equal(a.positions, c.positions)


def test_bad_parameters_are_errors():
    with pytest.raises(swarmnav.ConfigError, match="unknown parameter 'p3'"):
        swarmnav.methods.registry.make("hwvem", p3=1.0)
    with pytest.raises(swarmnav.ConfigError, match="p2"):
        swarmnav.methods.registry.make("hwvem", p2=0.5)


# ----------------------------------------------------------------------------- path and mission


def test_polyline_projection_and_pursuit():
    path = Polyline.of([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    assert path.length == 20.0
    np.testing.assert_allclose(path.at([5.0, 15.0, 25.0]), [[5, 0], [10, 5], [10, 15]])  # extended past the end
    th, s = pursue(path, np.array([9.5, 0.2]), 9.0, 1.0)
    assert s == pytest.approx(9.5) and 0 < th < math.pi / 2  # cutting the corner toward (10, 0.5)
    # the window keeps the progress from jumping to the second leg when the point is near it
    assert pursue(path, np.array([9.0, 8.0]), 2.0, 1.0)[1] <= 4.0


def test_information_uav_follows_the_path():
    scn = from_dict({"swarm": {"n": 1, "spawn": [-0.01, -0.01, 0.01, 0.01], "min_spacing": 0.0, "clearance": 0.0},
                     "goal": {"position": [6.0, 6.0], "path": [[0.0, 0.0], [6.0, 0.0], [6.0, 6.0]]}})
    res = swarmnav.run("hwvem", scn, seed=0, steps=130)
    p = res.positions[:, 0]
    path = Polyline.of(scn.path)
    dist = [np.min(np.linalg.norm(path.at(np.linspace(0, 12, 1201)) - q, axis=1)) for q in p[:115]]
    assert max(dist) < 0.5  # within half the look-ahead of the polyline
    assert np.linalg.norm(p[115] - [6.0, 6.0]) < 0.6  # reached the end ...
    assert p[-1, 1] > 6.5  # ... and kept flying along the last leg


def test_mission_success_counts_agents_that_never_join():
    scn = from_dict({"swarm": {"n": 6, "spawn": [-0.01, -0.01, 0.01, 0.01], "min_spacing": 0.0, "clearance": 0.0},
                     "goal": {"position": [30.0, 0.0], "path": [[0.0, 0.0], [30.0, 0.0]]},
                     "obstacles": [{"type": "circle", "center": [15.0, 8.0], "radius": 1.0}]})
    m = VicsekFamily("hwvem", eta=0.0)
    x = np.array([[0.0, 0.0], [-0.5, 0.0], [-0.5, 0.4], [-0.5, -0.4], [-1.0, 0.0], [0.0, 5.0]])
    rng = np.random.default_rng(0)
    m.reset(scn, x, np.zeros_like(x), rng)
    v = np.zeros_like(x)
    for k in range(50):
        cmd, _ = m.act(Observation(k, float(k), x, v), rng)
        x, v = m.dynamics.step(x, v, cmd, 1.0)
    s = m.summary()
    assert s["P_s"] == pytest.approx(100 * 5 / 6)  # agent 5 starts 5 m away: never with the IU
    assert s["D_ind"] == pytest.approx(0.4, abs=0.1) and s["D_obs"] > 1.0


@pytest.mark.parametrize("scene, clearance", [("hwvem_mission_fitted", 0.6), ("hwvem_mission", 1.2)])
def test_mission_scene_has_the_paper_ingredients(scene, clearance):
    from swarmnav.sensing import signed_distance
    from swarmnav.world.catalog import load_scenario

    for n, side in ((5, 1.2375), (20, 2.4749), (50, 3.9132)):  # HWVEM Sec. 3.2 initial squares
        s = load_scenario(scene, n=n)
        x0, y0, x1, y1 = s.swarm.region
        assert x1 - x0 == pytest.approx(side, abs=1e-3) and y1 - y0 == pytest.approx(side, abs=1e-3)
    kinds = [type(o).__name__ for o in s.obstacles]
    assert {"Circle", "Polygon"} <= set(kinds) and ("Box" in kinds)
    sizes = sorted(len(o.points) for o in s.obstacles if type(o).__name__ == "Polygon")
    assert 3 in sizes and 4 in sizes  # triangles and diamonds
    path = Polyline.of(s.path)
    # the information UAV's path stays outside every obstacle's avoidance band (r_avoid = 0.5 m)
    d = signed_distance(s.geometry, path.at(np.linspace(0, path.length, 4000)))
    assert d.min() == pytest.approx(clearance, abs=1e-3) and d.min() > VicsekFamily("hwvem").params.r_avoid


@pytest.mark.parametrize("scene, params", [("hwvem_mission_fitted", "rect_offset=0.6"), ("hwvem_mission", "")])
def test_shipped_mission_scenes_are_members_of_the_family(scene, params):
    """The scene files are the fitted option / the default member of hwvem_mission_family (the
    geometry the calibration in benchmarks/hwvem_scene_fit.py ran on), at every Table 2 size."""
    from swarmnav.world.catalog import load_scenario

    def geometry(s):
        d = s.to_dict()
        return {k: v for k, v in d.items() if k not in ("name", "description")}

    for n in (5, 20, 50):
        assert geometry(load_scenario(scene, n=n)) == geometry(load_scenario(f"hwvem_mission_family:{params}", n=n))
    assert geometry(load_scenario("hwvem_mission")) != geometry(load_scenario("hwvem_mission_fitted"))


def test_experiment_specs_resize_the_periodic_box():
    from swarmnav.experiments import load_experiment
    from swarmnav.world.catalog import load_scenario

    e = load_experiment("hwvem-alignment", overrides={"n": "100|500"})
    assert [v.name for v in e.variants][:2] == ["VEM[n=100]", "VEM[n=500]"]
    s = load_scenario(e.variants[1].scenario, n=e.variants[1].n)
    assert s.n == 500 and s.bounds[2] == pytest.approx(math.sqrt(500 / 4.102))
    for name in ("hwvem-mission", "hwvem-weights", "hwvem-ablation"):
        assert load_experiment(name).variants


@pytest.mark.parametrize("reading, expect", [("new", True), ("previous", False)])
def test_avoidance_trigger_tests_the_chosen_genuine_direction(reading, expect):
    """Eq. (21) with theta^g(k + 1) (just computed, "new") or theta^g(k) ("previous"): agent 0
    last wanted to fly away from the circle (pi), its only neighbour now pulls it toward it (0)."""
    scn = from_dict({"swarm": {"n": 2, "spawn": [-0.01, -0.01, 0.01, 0.01], "min_spacing": 0.0, "clearance": 0.0},
                     "goal": {"position": [20.0, 0.0]},
                     "obstacles": [{"type": "circle", "center": [2.0, 0.0], "radius": 1.0}]})
    m = VicsekFamily("vem", eta=0.0, trigger_heading=reading)
    x = np.array([[0.6, 0.0], [0.1, 0.0]])  # agent 0 is 0.4 m from the circle (< r_avoid)
    rng = np.random.default_rng(0)
    m.reset(scn, x, np.zeros_like(x), rng)
    m.theta[:] = m.theta_g[:] = [math.pi * (1 - 1e-12), 0.0]
    m.act(Observation(0, 0.0, x, np.zeros_like(x)), rng)
    assert m.theta_g[0] == pytest.approx(0.0) and m.avoiding[0] == expect and not m.avoiding[1]


def test_mission_losses_match_the_component_test_replayed_from_the_trajectory():
    """losses() (where the separation that failed each agent began) against an oracle: the
    information UAV's connected component of every recorded state (a k-d tree graph), replayed."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    from swarmnav.world.catalog import load_scenario

    scn = load_scenario("hwvem_mission", n=20)
    m = VicsekFamily("hwvem", p1=0.0, p2=100.0)
    res = swarmnav.run(m, scn, seed=5, steps=700)
    P = res.positions[:-1]  # the states the method saw, 0 .. K-1
    gap = m.params.follow_gap
    expect = {}
    apart = np.zeros(scn.n, dtype=np.int64)
    for k, x in enumerate(P):
        pairs = cKDTree(x).query_pairs(m.params.r, output_type="ndarray")
        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(scn.n, scn.n))
        lab = connected_components(g, directed=False)[1]
        near = lab == lab[m.iu]
        apart = np.where(near, 0, apart + 1)
        for i in np.flatnonzero((apart > gap) | ((k == 0) & (apart > 0)) | ((k == len(P) - 1) & (apart > 0))):
            expect.setdefault(int(i), (k - apart[i] + 1, *P[k - apart[i] + 1, i]))
    lost = m.losses()
    assert len(expect) > 0  # this seed loses agents (so the comparison means something)
    assert sorted(expect) == lost["agent"].tolist()
    got = {int(i): (s, x, y) for i, s, x, y in zip(lost["agent"], lost["step"], lost["x"], lost["y"])}
    for i, (s, x, y) in expect.items():
        assert got[i][0] == s and got[i][1:] == pytest.approx((x, y))
    assert res.metrics["P_s"] == pytest.approx(100 * (1 - len(expect) / scn.n))
    assert lost["apart_at_end"].tolist() == [bool(apart[i] > 0) for i in sorted(expect)]


def test_safety_distances_by_scope():
    """D_ind and D_obs (Sec. 3.2) against a replay of the recorded positions: over all agents and
    steps by default (the initial placement included), from step 1 with safety_from = 1, and over
    the agents that pass the success test with safety_agents = "successful"."""
    from scipy.spatial.distance import pdist

    from swarmnav.sensing import signed_distance
    from swarmnav.world.catalog import load_scenario

    scn = load_scenario("hwvem_mission", n=20)
    runs = {kw: swarmnav.run("hwvem", scn, seed=4, steps=120, **dict(kw))
            for kw in ((), (("safety_from", 1),), (("safety_agents", "successful"),))}
    x = runs[()].positions  # (K + 1, N, 2): the states the method saw are 0 .. K - 1
    seen = x[:-1]
    pair = np.array([pdist(p).min() for p in seen])
    obs = np.array([signed_distance(scn.geometry, p).min() for p in seen])
    m = runs[()].metrics
    assert m["D_ind"] == pytest.approx(pair.min(), abs=1e-12) and m["D_obs"] == pytest.approx(obs.min(), abs=1e-12)
    late = runs[(("safety_from", 1),)].metrics
    assert late["D_ind"] == pytest.approx(pair[1:].min(), abs=1e-12)
    assert late["D_obs"] == pytest.approx(obs[1:].min(), abs=1e-12)
    ok = runs[(("safety_agents", "successful"),)].metrics
    assert ok["D_ind"] >= m["D_ind"] and ok["D_obs"] >= m["D_obs"] and ok["P_s"] == m["P_s"]


def test_deg_con_norm_only_changes_the_measurement():
    """The norm of eq. (28) reads the same flight: identical positions, and since
    ||x||_inf <= ||x||_2 <= ||x||_1, k_con(linf) <= k_con(l2) <= k_con(l1) on every run."""
    kw = dict(ALIGN, wrap_neighbours=False)
    for model, seed in (("vem-a", 1), ("ivem", 2), ("wvem", 3)):
        runs = {norm: swarmnav.run(model, "periodic_box:n=60,rho=4.102", seed=seed, steps=1500, deg_con_norm=norm, **kw)
                for norm in ("l1", "l2", "linf")}
        np.testing.assert_array_equal(runs["l1"].positions, runs["l2"].positions)
        np.testing.assert_array_equal(runs["l1"].positions, runs["linf"].positions)
        k = {norm: r.metrics["k_con"] for norm, r in runs.items()}
        assert k["linf"] <= k["l2"] <= k["l1"]
        assert np.isfinite(k["l2"])  # the default reading converges within the run
