"""Theorem 1 (HES Appendix B) as a test.

Structure frozen (two sub-swarms, fixed subleaders and nearest-neighbour partners), the smooth
core of eq. (38): the seven differentiable terms built from the controller's own force
functions, without the LiDAR term, occlusion, saturation or switching. As in Appendix B the
formation cruises rigidly at a known time-varying velocity v_s(t) whose acceleration is fed
forward, and the restoring intra / follower / cohesion terms are taken in fixed-reference form
(their targets are the reference points of the partner, the subleader's slot and c_s). The
mechanical energy

    V = 1/2 sum |v_i - v_s|^2 + sum k_p/2 |e_i|^2 + sum k_path/2 |p_i - c_s|^2
        + sum k_intra/2 (|p_i - q_i| - d_thr)_+^2 + sum_followers k_l/2 (|p_i - p*_sl| - d_0)_+^2
        + sum k_coh/2 (|p_i - c_s| - d_c)_+^2
        + sum_pairs k_sep max(0, log(r_sep / d_ij)) + sum_same-sub-swarm pairs k_ir max(0, log(d_ir / d_ij))

must never increase, and every formation error must stay within sqrt(2 V(t0) / k_p).
"""

import math

import numpy as np

from swarmnav.methods.hes import forces as F
from swarmnav.methods.hes.formation import hex_template
from swarmnav.methods.hes.params import HesParams

P = HesParams()
# Thresholds of the dead-band springs are our choices; small values here make every term act.
D_THR, D_0, D_C = 1.0, 1.0, 0.4
GROUP = np.array([0, 0, 0, 1, 1, 1])
SL = np.array([0, 0, 0, 3, 3, 3])  # subleader of each agent
FOLLOWER = SL != np.arange(6)
PARTNER = np.array([1, 0, 1, 4, 3, 4])  # frozen nearest-neighbour partner
OFFSET = np.vstack([hex_template(3) * 1.4, hex_template(3) * 1.4 + [0.0, 2.5]])  # slots at t0 - c(t0)
C_OFF = np.array([OFFSET[GROUP == g].mean(axis=0) for g in GROUP])  # c_s at t0 per agent


def v_s(t):
    return np.array([1.0 + 0.4 * math.sin(0.7 * t), 0.3 * math.cos(0.5 * t)])


def v_s_dot(t):
    return np.array([0.28 * math.cos(0.7 * t), -0.15 * math.sin(0.5 * t)])


def shift(t):
    """Integral of v_s from 0 to t (the rigid translation of every reference point)."""
    return np.array([t + 0.4 / 0.7 * (1 - math.cos(0.7 * t)), 0.6 * math.sin(0.5 * t)])


def refs(t):
    s = shift(t)
    slot = OFFSET + s
    return slot, C_OFF + s, slot[PARTNER], slot[SL]


def core(x, v, t):
    slot, cs, q_nn, q_sl = refs(t)
    vs = np.tile(v_s(t), (6, 1))
    everyone = np.ones(6, dtype=bool)
    return (F.attraction(x, v, slot, vs, P.paper.k_p, P.paper.k_v)
            + F.separation(x, GROUP, P.paper.k_sep, P.core.r_sep, 1e-6, False)
            + F.centering(x, cs, P.paper.k_path)
            + F.spring(x, q_nn, P.paper.k_intra, D_THR, everyone)
            + F.separation(x, GROUP, P.paper.k_ir, P.core.d_ir, 1e-6, True)
            + F.spring(x, q_sl, P.paper.k_l, D_0, FOLLOWER) + F.velocity_match(v, vs, P.paper.k_vl, FOLLOWER)
            + F.spring(x, cs, P.paper.k_coh, D_C, everyone)
            + v_s_dot(t))  # feedforward of the known cruise acceleration


def energy(x, v, t):
    slot, cs, q_nn, q_sl = refs(t)
    dead = lambda d, d0: np.maximum(d - d0, 0.0) ** 2  # noqa: E731
    V = 0.5 * np.sum((v - v_s(t)) ** 2)
    V += 0.5 * P.paper.k_p * np.sum((x - slot) ** 2) + 0.5 * P.paper.k_path * np.sum((x - cs) ** 2)
    V += 0.5 * P.paper.k_intra * np.sum(dead(np.linalg.norm(x - q_nn, axis=1), D_THR))
    V += 0.5 * P.paper.k_l * np.sum(dead(np.linalg.norm(x - q_sl, axis=1), D_0)[FOLLOWER])
    V += 0.5 * P.paper.k_coh * np.sum(dead(np.linalg.norm(x - cs, axis=1), D_C))
    for i in range(6):
        for j in range(i + 1, 6):
            d = np.linalg.norm(x[i] - x[j])
            V += P.paper.k_sep * max(0.0, math.log(P.core.r_sep / d))
            if GROUP[i] == GROUP[j]:
                V += P.paper.k_ir * max(0.0, math.log(P.core.d_ir / d))
    return V


def rk4(x, v, t, h):
    def f(x, v, t):
        return v, core(x, v, t)

    k1 = f(x, v, t)
    k2 = f(x + h / 2 * k1[0], v + h / 2 * k1[1], t + h / 2)
    k3 = f(x + h / 2 * k2[0], v + h / 2 * k2[1], t + h / 2)
    k4 = f(x + h * k3[0], v + h * k3[1], t + h)
    return (x + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
            v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]))


def active_set(x, t):
    """Which pieces of the piecewise-smooth potential are active (pair within a radius, spring
    stretched beyond its dead band): the gradient jumps only where this set changes."""
    d = np.linalg.norm(x[:, None] - x[None], axis=2)[np.triu_indices(6, 1)]
    slot, cs, q_nn, q_sl = refs(t)
    return np.concatenate([d < P.core.r_sep, d < P.core.d_ir, np.linalg.norm(x - q_nn, axis=1) > D_THR,
                           np.linalg.norm(x - q_sl, axis=1) > D_0, np.linalg.norm(x - cs, axis=1) > D_C])


def step(x, v, t, h, h_min):
    """One RK4 step, bisected down to ``h_min`` where the active set changes, so that the
    integration error at a gradient jump (O(h^2) per crossing) stays far below the dissipation."""
    x2, v2 = rk4(x, v, t, h)
    if h <= h_min or np.array_equal(active_set(x, t), active_set(x2, t + h)):
        return x2, v2
    xm, vm = step(x, v, t, h / 2, h_min)
    return step(xm, vm, t + h / 2, h / 2, h_min)


def test_theorem1_energy_non_increasing_and_error_bounded():
    rng = np.random.default_rng(7)
    slot0 = refs(0.0)[0]
    x = slot0 + rng.uniform(-0.9, 0.9, (6, 2))  # formation errors of up to ~1 m
    v = v_s(0.0) + rng.normal(0.0, 0.8, (6, 2))  # and error velocities
    h, T = 4e-3, 10.0
    V0 = energy(x, v, 0.0)
    bound = math.sqrt(2 * V0 / P.paper.k_p)
    Vs, errs, active = [V0], [], np.zeros(3, dtype=bool)
    t = 0.0
    for _ in range(int(T / h)):
        x, v = step(x, v, t, h, h / 256)
        t += h
        Vs.append(energy(x, v, t))
        errs.append(np.linalg.norm(x - refs(t)[0], axis=1).max())
        d = np.linalg.norm(x[:, None] - x[None], axis=2)[np.triu_indices(6, 1)]
        active |= [bool(np.any(d < P.core.r_sep)), bool(np.any(d < P.core.d_ir)), True]
    Vs = np.array(Vs)
    # Non-increasing up to the integrator's error (RK4, 4 ms steps refined at gradient jumps).
    assert np.max(np.diff(Vs)) <= 1e-8 * V0
    assert Vs[-1] < 0.5 * V0  # and it really dissipates (damping D_i > 0)
    assert max(errs) <= bound  # ||e_i(t)|| <= sqrt(2 V(t0) / k_p) throughout
    assert active[0]  # the separation term took part
