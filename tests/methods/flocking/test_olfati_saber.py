"""Olfati-Saber's Algorithm 3: the vectorised terms against a per-pair reference written from the
paper's formulas, the functions' defining properties, momentum conservation of the free-space
alpha-term, the alpha-lattice it converges to, and bad input refused in one line."""

import math

import numpy as np
import pytest

from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.flocking.olfati_saber import (
    OlfatiSaberParams,
    action,
    alpha_term,
    beta_term,
    bump,
    gamma_term,
    phi_alpha,
    phi_beta,
    sigma_norm,
)
from swarmnav.world import from_dict
from tests._helpers.cli import run_cli

P = OlfatiSaberParams()


# ------------------------------------------------------------------ a plain reference, one pair at a time


def _sn(v, eps):
    return (math.sqrt(1 + eps * sum(c * c for c in v)) - 1) / eps


def _rho(z, h):
    if 0 <= z < h:
        return 1.0
    if h <= z <= 1:
        return 0.5 * (1 + math.cos(math.pi * (z - h) / (1 - h)))
    return 0.0


def _s1(z):
    return z / math.sqrt(1 + z * z)


def _phi(z, a, b):
    c = abs(a - b) / math.sqrt(4 * a * b)
    return 0.5 * ((a + b) * _s1(z + c) + (a - b))


def _alpha_ref(q, v, p):
    r_a, d_a = _sn([p.r], p.eps), _sn([p.d], p.eps)
    out = np.zeros_like(q)
    for i in range(len(q)):
        for j in range(len(q)):
            if i == j:
                continue
            dq = q[j] - q[i]
            z = _sn(dq, p.eps)
            n_ij = dq / math.sqrt(1 + p.eps * float(dq @ dq))
            out[i] += p.c1_alpha * _rho(z / r_a, p.h_alpha) * _phi(z - d_a, p.a, p.b) * n_ij
            out[i] += p.c2_alpha * _rho(z / r_a, p.h_alpha) * (v[j] - v[i])
    return out


def _beta_ref(v, agent, dist, normal, p):
    d_b = _sn([p.d_obs], p.eps)
    out = np.zeros_like(v)
    for k in range(len(agent)):
        if dist[k] >= p.r_obs:
            continue
        i = agent[k]
        dq = -dist[k] * normal[k]  # qh - q_i
        z = _sn(dq, p.eps)
        n_hat = dq / math.sqrt(1 + p.eps * float(dq @ dq))
        proj = v[i] - (v[i] @ normal[k]) * normal[k]  # (I - a a^T) p_i
        out[i] += p.c1_beta * _rho(z / d_b, p.h_beta) * (_s1(z - d_b) - 1) * n_hat
        out[i] += p.c2_beta * _rho(z / d_b, p.h_beta) * (proj - v[i])
    return out


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(5))
def test_alpha_term_matches_the_per_pair_reference(dim, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(0, 2.5, (9, dim))  # pairs inside d, between d and r, and beyond r
    v = rng.normal(0, 1, (9, dim))
    diff = q[None] - q[:, None]
    fast = alpha_term(diff, v[None] - v[:, None], P)
    np.testing.assert_allclose(fast, _alpha_ref(q, v, P), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(5))
def test_beta_term_matches_the_per_agent_reference(dim, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(0, 1, (6, dim))
    agent = rng.integers(0, 6, 20)
    dist = rng.uniform(0.05, 1.1, 20)  # some beyond r' = 0.864 m: left out
    normal = rng.normal(size=(20, dim))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    np.testing.assert_allclose(beta_term(v, agent, dist, normal, P), _beta_ref(v, agent, dist, normal, P),
                               rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------ properties of the paper's functions


def test_sigma_norm_is_differentiable_with_the_paper_gradient():
    rng = np.random.default_rng(0)
    for _ in range(20):
        z = rng.normal(0, 3, 3)
        h = 1e-6
        num = np.array([(sigma_norm(np.sum((z + h * e) ** 2), 0.1) - sigma_norm(np.sum((z - h * e) ** 2), 0.1))
                        / (2 * h) for e in np.eye(3)])
        np.testing.assert_allclose(num, z / np.sqrt(1 + 0.1 * z @ z), rtol=1e-6, atol=1e-8)
    assert sigma_norm(0.0, 0.1) == 0.0
    s = sigma_norm(np.linspace(0, 100, 1000), 0.1)
    assert np.all(np.diff(s) > 0)


@pytest.mark.parametrize("h", [0.2, 0.5, 0.9])
def test_bump_is_one_then_falls_smoothly_to_zero(h):
    z = np.linspace(-0.5, 1.5, 4001)
    y = bump(z, h)
    assert np.all(y[(z >= 0) & (z < h)] == 1.0) and np.all(y[z > 1] == 0.0) and np.all(y[z < 0] == 0.0)
    inside = (z >= 0) & (z <= 1)
    assert np.all(np.diff(y[inside]) <= 1e-15)  # non-increasing on [0, 1]
    assert bump(h, h) == pytest.approx(1.0) and bump(1.0, h) == pytest.approx(0.0, abs=1e-15)
    assert np.max(np.abs(np.diff(y[inside]))) < 4 * (z[1] - z[0]) / (1 - h)  # continuous (Lipschitz pi/2(1-h))


def test_phi_alpha_vanishes_at_d_pulls_beyond_pushes_inside_and_ends_at_r():
    r_a, d_a = sigma_norm(P.r ** 2, P.eps), sigma_norm(P.d ** 2, P.eps)
    assert phi_alpha(d_a, P) == pytest.approx(0.0, abs=1e-12)  # a = b: c = 0, phi(0) = 0
    z = np.linspace(0, 1.2 * r_a, 2000)
    f = phi_alpha(z, P)
    assert np.all(f[(z > 1e-9) & (z < d_a - 1e-9)] < 0) and np.all(f[(z > d_a + 1e-9) & (z < r_a - 1e-9)] > 0)
    assert np.all(f[z >= r_a] == 0)
    assert np.all(np.abs(action(np.linspace(-50, 50, 101), P.a, P.b)) <= 0.5 * (P.a + P.b))  # bounded action


def test_phi_beta_only_repels_and_only_within_d_obs():
    d_b = sigma_norm(P.d_obs ** 2, P.eps)
    z = np.linspace(0, 2 * d_b, 1000)
    f = phi_beta(z, P)
    assert np.all(f <= 0) and np.all(f[z >= d_b] == 0) and np.all(f[z < 0.5 * d_b] < 0)


# ------------------------------------------------------------------ invariants and the lattice


@pytest.mark.parametrize("dim", [2, 3])
def test_free_space_alpha_term_conserves_momentum(dim):
    rng = np.random.default_rng(3)
    q, v = rng.uniform(0, 4, (12, dim)), rng.normal(size=(12, dim))
    u = alpha_term(q[None] - q[:, None], v[None] - v[:, None], P)
    np.testing.assert_allclose(u.sum(axis=0), 0.0, atol=1e-11)  # pairwise terms antisymmetric
    assert np.abs(u).max() > 1.0  # not trivially zero


def test_gamma_term_is_bounded_pull_plus_damping():
    x = np.array([[100.0, 0.0], [0.5, 0.0]])
    u = gamma_term(x, np.zeros_like(x), np.zeros(2), np.zeros(2), P)
    assert np.linalg.norm(u[0]) <= P.c1_gamma and u[0, 0] < 0 and u[1, 0] < 0
    assert np.linalg.norm(u[0]) == pytest.approx(P.c1_gamma, rel=1e-4)


def test_free_agents_settle_into_an_alpha_lattice_at_distance_d():
    """Algorithm 2's free flock (alpha + a gamma-agent at the centre) from a random cloud: every
    agent ends with its nearest neighbour at d within 10 % (the lattice is quasi: the pull of the
    gamma-agent compresses it slightly)."""
    rng = np.random.default_rng(5)
    n = 12
    q = rng.uniform(-2.5, 2.5, (n, 2))
    v = np.zeros((n, 2))
    dt = 0.01
    for _ in range(4000):
        u = alpha_term(q[None] - q[:, None], v[None] - v[:, None], P)
        u += gamma_term(q, v, np.zeros(2), np.zeros(2), OlfatiSaberParams(c1_gamma=0.5, c2_gamma=1.0))
        v = v + dt * u
        q = q + dt * v
    dist = np.linalg.norm(q[None] - q[:, None], axis=2)
    np.fill_diagonal(dist, np.inf)
    nearest = dist.min(axis=1)
    assert np.all(np.abs(nearest - P.d) < 0.1 * P.d), nearest
    assert np.abs(v).max() < 0.05  # at rest


# ------------------------------------------------------------------ the method


def _wall_scene(dim):
    if dim == 2:
        return from_dict({"name": "wall", "swarm": {"n": 1, "spawn": [-0.01, -0.01, 0.01, 0.01]},
                          "goal": {"position": [0.0, 0.0]},
                          "obstacles": [{"type": "box", "min": [-5.0, 0.6], "max": [5.0, 2.0]}]})
    return from_dict({"name": "wall3", "swarm": {"n": 1, "spawn": [-0.01, -0.01, 0.99, 0.01, 0.01, 1.01]},
                      "goal": {"position": [0.0, 0.0, 1.0]},
                      "obstacles": [{"type": "box", "min": [-5.0, 0.6, -5.0], "max": [5.0, 2.0, 5.0]}]})


@pytest.mark.parametrize("dim", [2, 3])
def test_a_robot_near_a_wall_is_pushed_straight_away_from_it(dim):
    scn = _wall_scene(dim)
    m = registry.make("olfati-saber", c1_gamma=0.0, c2_gamma=0.0)
    x = np.zeros((1, dim))
    if dim == 3:
        x[0, 2] = 1.0
    m.reset(scn, x, np.zeros_like(x), np.random.default_rng(0))
    u, _ = m.act(Observation(0, 0.0, x, np.zeros_like(x)), np.random.default_rng(0))
    assert u[0, 1] < -1.0  # the wall is 0.6 m away at +y
    # straight away: exactly in the ring (a ray points at the wall's foot); in 3-D within the sphere's
    # ray spacing (2048 Fibonacci rays, ~4.5 deg apart: tan 4.5 deg = 0.079)
    tol = 1e-9 if dim == 2 else 0.079
    assert np.linalg.norm(np.delete(u[0], 1)) < tol * abs(u[0, 1])
    assert m.summary()["olfati_saber_beta_agents_mean"] == 1.0  # one surface: one beta-agent


def test_comm_load_is_counted_from_the_broadcasts():
    import swarmnav

    res = swarmnav.run("olfati-saber", "random_forest:density=0.15,seed=1", seed=1, steps=100)
    n = res.positions.shape[1]
    # 100 steps of 0.02 s = 2 s at 10 Hz: 20 broadcasts of n messages of 88 B each
    assert res.metrics["comm_messages"] == 20 * n
    assert res.metrics["comm_mbps"] == pytest.approx(20 * n * 88 * 8 / 2.0 / 1e6)


@pytest.mark.parametrize("args, says", [(("a=6", "b=5"), "needs 0 < a <= b"),
                                        (("h_alpha=1.5",), "h_alpha"),
                                        (("preset=papr",), "unknown preset")])
def test_bad_input_is_refused_in_one_line_with_exit_2(args, says, tmp_path):
    sets = [a for s in args for a in ("--set", s)]
    r = run_cli("run", "--method", "olfati-saber", "--scenario", "default_corridor", "--steps", "2", *sets,
                "--out", str(tmp_path / "o"), "--quiet", "--force")
    assert r.returncode == 2 and "Traceback" not in r.stderr and says in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
