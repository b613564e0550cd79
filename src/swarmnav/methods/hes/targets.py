"""Stage 4 of a HES step, the references of eq. (23): each agent's slot p*_i and cruise speed.

A navigating sub-swarm's slots are its template around c_s(k) (:func:`template`), assigned to its
members by the Hungarian method every ``slot_refresh`` steps (or when the members change); an
encircling one's are points on the circle of ``r_enc`` around the goal that its subleader sees
free (ours: the paper does not give the encircle slots). Agents a part routes on their own
(``Step.own``) head for their own target.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmnav.methods.hes.corridors import free_points
from swarmnav.methods.hes.decision import ENCIRCLE
from swarmnav.methods.hes.formation import assign_slots, hex_template, ring_slots
from swarmnav.methods.hes.step import Step, SubSwarm


def references(h, step: Step) -> None:
    """Fill ``step.slot`` (N, 2) p*_i [m] and ``step.speed`` (N,) v_s [m/s]."""
    p = h.params
    x, k = step.x, step.k
    slot = np.empty_like(x)
    speed = np.empty(h.n)
    speed.fill(p.core.v_s)  # every agent: its sub-swarm's cruise speed (queued ones too)
    any_queued = step.n_own > 0
    if any_queued:
        queued = step.own >= 0
        slot[queued] = step.own_target[queued]
    part = h.partition()
    for s, sub in h.subs.items():
        members = part.members[part.index[s]]
        if any_queued:
            members = members[~queued[members]]
        m = len(members)
        if m == 0:
            continue
        if sub.mode == ENCIRCLE:
            place(slot, members, h.goal, ring_offsets(h, step, sub, members), None)
            continue
        tmpl = template(p, m, sub)
        if k - sub.slot_step >= p.core.slot_refresh or not (
                sub.slot_members is members or np.array_equal(sub.slot_members, members)):
            sub.slot_members = members
            sub.slot_index = assign_slots(x[members], sub.waypoint + tmpl, p.core.assign_exact)
            sub.slot_step = k
        place(slot, members, sub.waypoint, tmpl, sub.slot_index)
    step.slot, step.speed = slot, speed


@njit(cache=True)
def place(slot, members, base, offsets, index):
    """``slot[members] = base + offsets[index]`` (``offsets`` in member order if ``index`` is None),
    in one pass."""
    for i in range(members.shape[0]):
        o = i if index is None else index[i]
        slot[members[i], 0] = base[0] + offsets[o, 0]
        slot[members[i], 1] = base[1] + offsets[o, 1]


def ring_offsets(h, step: Step, sub: SubSwarm, members: np.ndarray) -> np.ndarray:
    """The encircle slots of a sub-swarm relative to the goal, (m, 2) [m]: m points on the circle of
    ``r_enc`` spread over the angles its subleader sees free (``enc_clear``), assigned every
    ``slot_refresh`` steps. With ``enc_orbit`` the ring turns at angular rate v_s / r_enc (the
    slots move at the cruise speed) and is laid out and assigned only when the sub-swarm's size
    changes: a member lagging behind its moving slot would otherwise be handed the slot behind
    it at the next assignment and turn back."""
    p, x, k = h.params, step.x, step.k
    m = len(members)
    omega = p.core.v_s / p.core.r_enc if p.core.enc_orbit else 0.0  # [rad/s]
    if sub.ring_offsets is None or len(sub.ring_offsets) != m or (
            not omega and k - sub.slot_step >= p.core.slot_refresh):
        a = sub.subleader
        ang = h.ring_angles + omega * k * p.paper.dt if omega else h.ring_angles
        pts = h.goal[None, :] + p.core.r_enc * np.column_stack([np.cos(ang), np.sin(ang)])
        free = free_points(step.ring[a], x[a, 0], x[a, 1], h.cos, h.sin, pts, p.core.enc_clear, p.paper.lidar_range)
        ring = ring_slots(h.goal, p.core.r_enc, m, free, ang)
        r_i = assign_slots(x[members], ring, p.core.assign_exact)
        sub.ring_offsets = ring[r_i] - h.goal
        sub.slot_step = k
    if not omega:
        return sub.ring_offsets
    turn = omega * (k - sub.slot_step) * p.paper.dt
    return turned(sub.ring_offsets, math.cos(turn), math.sin(turn))


@njit(cache=True)
def turned(o, c, s):
    """The offsets ``o`` (m, 2) turned by the angle whose cosine and sine are ``c, s``."""
    out = np.empty(o.shape)
    for i in range(o.shape[0]):
        out[i, 0] = c * o[i, 0] - s * o[i, 1]
        out[i, 1] = s * o[i, 0] + c * o[i, 1]
    return out


def template(p, m: int, sub: SubSwarm) -> np.ndarray:
    """alpha_s R(psi_s) Delta_f of eq. (23) for a sub-swarm of m agents, (m, 2) [m].

    Delta_f: the unit hex template, squeezed across the formation axis by ``squeeze`` and
    stretched along it by ``1 / squeeze``; alpha_s = spacing (k_p + k_path) / k_p, so that
    where the slot attraction (eq. 24) balances the corridor centering toward c_s (eq. 32) the
    agents sit ``spacing`` apart."""
    alpha = p.core.spacing * (p.paper.k_p + p.paper.k_path) / p.paper.k_p
    hx, hy = sub.heading.tolist()
    return oriented(hex_template(m), hx, hy, float(sub.squeeze), alpha)


@njit(cache=True)
def oriented(t, hx, hy, squeeze, alpha):
    """The template ``t`` (m, 2) squeezed across its axis (x / squeeze, y squeeze), turned to the
    heading ``(hx, hy)`` and scaled by ``alpha``."""
    out = np.empty(t.shape)
    for i in range(t.shape[0]):
        u = t[i, 0] / squeeze
        w = t[i, 1] * squeeze
        out[i, 0] = (hx * u - hy * w) * alpha
        out[i, 1] = (hy * u + hx * w) * alpha
    return out
