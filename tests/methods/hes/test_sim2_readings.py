"""The readings of Simulation 2 the paper build uses: eq. (36)'s near-obstacle term as
k_e (d_safe / d + 1)^2 (``core.ke_ratio``), the safety stack off keeping the waypoint's leash
(``ablation.keep_leash``) and "w/o acc. bound" lifting the safety filter too
(``ablation.relax_filter``)."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods.hes import Hes
from swarmnav.methods.hes import forces as F
from swarmnav.world import from_dict

R = 360
TH = 2 * np.pi * np.arange(R) / R
COS, SIN = np.cos(TH), np.sin(TH)
OPEN = from_dict({"name": "open", "swarm": {"n": 6, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": [60.0, 0.0]}})


def _obs_term(params, d):
    """The obstacle term of eq. (38) for one agent whose ring has one minimum d [m] on ray 90."""
    ring = np.full((1, R), 20.0)
    ring[0, 85:96] = d + 0.01 * np.abs(np.arange(85, 96) - 90)
    z2, z1 = np.zeros((1, 2)), np.zeros(1, dtype=np.int64)
    t = F.force_terms(z2, z2, z1, z2, z2, np.zeros(1, dtype=bool), z2, z2, np.ones(1, dtype=bool), z2, z2,
                      np.full(1, -1), np.ones((1, 4)), ring, COS, SIN, F.gain_vector(params),
                      np.full(1, params.paper.d_safe))
    return t[7, 0]


@pytest.mark.parametrize("d", [0.3, 1.0, 1.49, 1.51, 4.0])
def test_ke_ratio_reads_the_near_obstacle_term_as_a_ratio(d):
    p, q = Hes().params, Hes(**{"core.ke_ratio": True}).params
    a = p.paper
    base = a.k_rep * max(0, 1 / d - 1 / a.r_trigger) / d**2 * (1 + a.k_b * (max(0, a.r_trigger - d) / a.r_trigger) ** a.gamma)
    near = d < a.d_safe
    for params, extra in ((p, a.k_e * (a.d_safe - d + 1) ** 2), (q, a.k_e * (a.d_safe / d + 1) ** 2)):
        w = base + (extra if near else 0.0)
        np.testing.assert_allclose(_obs_term(params, d), [-w * COS[90], -w * SIN[90]], rtol=1e-12, atol=1e-12)
    if near:  # the ratio reading is the stronger one: 192 m/s^2 at d_safe instead of 48
        assert np.linalg.norm(_obs_term(q, d)) > np.linalg.norm(_obs_term(p, d))


def test_safety_stack_off_keeps_the_waypoint_leash_when_asked():
    # without the leash c_s jumps to the corridor target and the unclipped attraction races the
    # swarm; with it c_s still advances at v_s, and the swarm flies at cruise-like speeds
    v_s = Hes().params.core.v_s
    speed = {}
    for leash in (False, True):
        res = swarmnav.run("hes", "default_corridor", seed=1, steps=150, contact="count",  # the controller's
                           **{"ablation.safety_stack_off": True, "ablation.keep_leash": leash})  # speed, uncrashed
        speed[leash] = float(np.linalg.norm(res.velocities, axis=2).mean())  # over the first 15 s
    assert speed[False] > 1.5 * v_s
    assert speed[True] < 1.3 * v_s


def _parts(**kw):
    m = Hes(**kw)
    x = np.array([[0.0, 0.0], [1.0, 0.0]])
    m.reset(OPEN, x, np.zeros_like(x), np.random.default_rng(0))
    return [q.name for q in m.parts]


def test_relax_filter_lifts_the_safety_filter_only_with_the_bound():
    assert "wall" in _parts(**{"ablation.acceleration_bound": False})
    assert "wall" in _parts(**{"ablation.relax_filter": True})  # the bound on: the filter stays
    assert "wall" not in _parts(**{"ablation.acceleration_bound": False, "ablation.relax_filter": True})


WALL = from_dict({"name": "wall", "swarm": {"n": 6, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": [20.0, 0.0]},
                  "obstacles": [{"type": "box", "min": [10.0, -30.0], "max": [10.3, 30.0]}]})


def test_post_update_projection_keeps_unbounded_agents_out_of_the_wall():
    # the command unbounded and no safety filter: without the projection agents fly into and
    # through the wall in one step; with it every step ends core.projection short of the returns
    crossed, inside = {}, {}
    for m in (0.0, 0.1):
        res = swarmnav.run("hes", WALL, seed=1, steps=200, contact="count", **{"ablation.safety_stack_off": True,
                                                            "ablation.a_max_relaxed": 1e6, "core.projection": m})
        x, y = res.positions[..., 0], res.positions[..., 1]
        span = (np.abs(y[:-1]) < 30.0) & (np.abs(y[1:]) < 30.0)
        through = span & (x[:-1] < 10.0) & (x[1:] > 10.3)  # a step straight across the wall
        crossed[m], inside[m] = bool(through.any()), float(res.clearance.min())
    assert inside[0.0] < 0.0
    assert inside[0.1] > 0.0 and not crossed[0.1]
