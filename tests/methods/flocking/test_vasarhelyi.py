"""Vásárhelyi's optimised flocking: the vectorised terms against a per-pair reference written from
the paper's formulas, the braking curve's shape, the antisymmetry of the pair terms, the
similarity transform of the default build, the shill agents' direction, and bad input."""

import math

import numpy as np
import pytest

from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.flocking.vasarhelyi import (
    Scaled,
    VasarhelyiParams,
    braking,
    friction,
    repulsion,
    shill,
)
from swarmnav.world import from_dict
from tests._helpers.cli import run_cli

S = Scaled.of(VasarhelyiParams())


def _D(r, a, p):
    if r <= 0:
        return 0.0
    if r * p < a / p:
        return r * p
    return math.sqrt(2 * a * r - a * a / (p * p))


def _pairs_ref(x, v, s):
    out = np.zeros_like(x)
    for i in range(len(x)):
        for j in range(len(x)):
            if i == j:
                continue
            r = float(np.linalg.norm(x[i] - x[j]))
            if r < s.r0_rep:
                out[i] += s.p_rep * (s.r0_rep - r) * (x[i] - x[j]) / r
            vij = float(np.linalg.norm(v[i] - v[j]))
            vmax = max(s.v_frict, _D(r - s.r0_frict, s.a_frict, s.p_frict))
            if vij > vmax:
                out[i] += s.c_frict * (vij - vmax) * (v[j] - v[i]) / vij
    return out


def _shill_ref(v, agent, dist, normal, s):
    out = np.zeros_like(v)
    for k in range(len(agent)):
        i = agent[k]
        vs = s.v_shill * normal[k]
        vis = float(np.linalg.norm(vs - v[i]))
        cap = _D(dist[k] - s.r0_shill, s.a_shill, s.p_shill)
        if vis > cap:
            out[i] += (vis - cap) * (vs - v[i]) / vis
    return out


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("preset", ["swarmnav", "paper"])
def test_pair_terms_match_the_per_pair_reference(dim, seed, preset):
    s = Scaled.of(registry.make("vasarhelyi", preset=preset).params)
    rng = np.random.default_rng(seed)
    scale = s.r0_rep * 1.5  # pairs on both sides of r0_rep
    x = rng.uniform(0, scale, (9, dim))
    v = rng.normal(0, 2 * s.v_flock, (9, dim))
    diff = x[None] - x[:, None]
    fast = repulsion(diff, s) + friction(diff, v[None] - v[:, None], s)
    np.testing.assert_allclose(fast, _pairs_ref(x, v, s), rtol=1e-11, atol=1e-11)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(5))
def test_shill_term_matches_the_per_agent_reference(dim, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(0, 1, (6, dim))
    agent = rng.integers(0, 6, 20)
    dist = rng.uniform(-0.1, 4.0, 20)
    normal = rng.normal(size=(20, dim))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    np.testing.assert_allclose(shill(v, agent, dist, normal, S), _shill_ref(v, agent, dist, normal, S),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("a, p", [(4.16, 3.2), (3.02, 3.55), (0.5, 10.0), (10.0, 0.5)])
def test_braking_curve_is_zero_then_continuous_and_non_decreasing(a, p):
    r = np.linspace(-1, 50, 200001)
    d = braking(r, a, p)
    assert np.all(d[r <= 0] == 0) and np.all(d >= 0)
    assert np.all(np.diff(d) >= -1e-12)
    assert np.max(np.diff(d)) < 1e-2  # no jump (the two branches meet at r = a / p^2)
    knee = a / p ** 2
    assert braking(knee, a, p) == pytest.approx(knee * p) == pytest.approx(math.sqrt(2 * a * knee - (a / p) ** 2))
    far = 40.0  # far from the wall: the speed constant deceleration a stops in r, v^2 ~ 2 a r
    assert braking(far, a, p) ** 2 == pytest.approx(2 * a * far - (a / p) ** 2)


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_terms_are_antisymmetric_so_their_sum_vanishes(dim):
    rng = np.random.default_rng(2)
    x, v = rng.uniform(0, 3, (11, dim)), rng.normal(0, 1, (11, dim))
    diff = x[None] - x[:, None]
    rep, fr = repulsion(diff, S), friction(diff, v[None] - v[:, None], S)
    np.testing.assert_allclose(rep.sum(axis=0), 0, atol=1e-11)
    np.testing.assert_allclose(fr.sum(axis=0), 0, atol=1e-11)
    assert np.abs(rep).max() > 0.1 and np.abs(fr).max() > 0.01


def test_paper_preset_is_the_paper_set_and_the_default_a_similarity_transform():
    p = registry.make("vasarhelyi", preset="paper").params
    s = Scaled.of(p)
    assert (s.v_flock, s.r0_rep, s.p_rep, s.v_shill, s.a_shill) == (4.0, 25.0, 0.13, 13.6, 3.02)
    d = Scaled.of(VasarhelyiParams())
    L, T = VasarhelyiParams().length_scale, VasarhelyiParams().time_scale
    assert d.v_flock == pytest.approx(1.0)  # 4 m/s -> the vehicle's 1 m/s
    assert d.r0_rep == pytest.approx(25.0 * L) and d.p_rep == pytest.approx(0.13 / T)
    assert d.a_frict == pytest.approx(4.16 * L / T ** 2) and d.c_frict == 0.05
    # a similarity transform keeps the braking curve's shape: D_scaled(L r) = (L / T) D(r)
    r = np.linspace(0, 30, 301)
    np.testing.assert_allclose(braking(L * r, d.a_shill, d.p_shill), (L / T) * braking(r, s.a_shill, s.p_shill),
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_robot_flying_at_a_wall_is_turned_away(dim):
    box = {"type": "box", "min": [-5.0, 0.6] + ([-5.0] if dim == 3 else []), "max": [5.0, 2.0] + ([5.0] if dim == 3 else [])}
    lo, hi = [-0.01] * dim, [0.01] * dim
    scn = from_dict({"name": "w", "swarm": {"n": 1, "spawn": lo + hi}, "goal": {"position": [0.0] * dim},
                     "obstacles": [box]})
    m = registry.make("vasarhelyi", v_flock=0.0)
    x, v = np.zeros((1, dim)), np.zeros((1, dim))
    v[0, 1] = 1.0  # at the wall, 0.6 m away, at 1 m/s
    m.reset(scn, x, v, np.random.default_rng(0))
    a, _ = m.act(Observation(0, 0.0, x, v), np.random.default_rng(0))
    assert a[0, 1] < -1.0 and m.summary()["vasarhelyi_shill_agents_mean"] == 1.0
    far = registry.make("vasarhelyi", v_flock=0.0, lidar_range=0.5)  # the wall out of sensor range
    far.reset(scn, x, v, np.random.default_rng(0))
    a2, _ = far.act(Observation(0, 0.0, x, v), np.random.default_rng(0))
    np.testing.assert_allclose(a2[0], -v[0] / far.params.tau)  # nothing seen: only the tracking of v_d = 0


@pytest.mark.parametrize("args, says", [(("tau=0",), "tau"), (("p_shill=-1",), "p_shill"),
                                        (("length_scale=nan",), "length_scale")])
def test_bad_input_is_refused_in_one_line_with_exit_2(args, says, tmp_path):
    sets = [a for s in args for a in ("--set", s)]
    r = run_cli("run", "--method", "vasarhelyi", "--scenario", "default_corridor", "--steps", "2", *sets,
                "--out", str(tmp_path / "o"), "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and says in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("preset", ["swarmnav", "paper"])
def test_no_shill_agent_acts_beyond_the_sensing_cap(preset):
    """The sensor reads no farther than ``shill_reach``: there the braking curve already allows the
    largest relative speed a shill agent can have, v_shill + v_max, so its term is zero."""
    from swarmnav.methods.flocking.vasarhelyi import shill_reach

    p = registry.make("vasarhelyi", preset=preset).params
    s = Scaled.of(p)
    reach = shill_reach(s, p)
    assert braking(reach - p.shill_offset - s.r0_shill, s.a_shill, s.p_shill) >= s.v_shill + p.v_max
    rng = np.random.default_rng(0)
    v = rng.normal(size=(50, 2))
    v *= p.v_max / np.linalg.norm(v, axis=1, keepdims=True)  # every speed the vehicle can have
    normal = rng.normal(size=(50, 2))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.all(shill(v, np.arange(50), np.full(50, reach - p.shill_offset), normal, s) == 0)
    assert np.any(shill(v, np.arange(50), np.full(50, 0.9 * (reach - p.shill_offset)), normal, s) != 0)


@pytest.mark.parametrize("setting", ["time_scale=5e-324", "p_shill=1e-300"])
def test_extreme_valid_values_run_or_fail_in_one_line(setting, tmp_path):
    """Found by a fuzz of the valid ranges: T*T underflowed to a ZeroDivisionError, (a / p)^2 to an
    OverflowError. Now the parameters overflow to inf and a diverged run ends in one line."""
    r = run_cli("run", "--method", "vasarhelyi", "--scenario", "default_corridor", "--steps", "3", "--set", setting,
                "--out", str(tmp_path / "o"), "--quiet", "--force")
    assert r.returncode in (0, 2) and "Traceback" not in r.stderr
    assert r.returncode == 0 or len(r.stderr.strip().splitlines()) == 1
