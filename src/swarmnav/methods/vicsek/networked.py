"""The Vicsek family on a network (docs/network.md): each agent aligns with what it received.

Under the ideal network every agent reads its neighbours' true positions, headings and layers,
and one neighbour list of the true positions serves all of them. On a network agent i knows
agent j only as its last message carried it: the position (``Observation.known``) and what j
published with it (``info["publish"]``): its heading theta_j, whether it was avoiding an
obstacle (o_j of eq. 18), its layer l_j (eq. 5) and, for IVEM in the ``raw`` reading, the number
eq. (30) compares. Agent i's neighbours are the agents it has heard, with a heading, within the
neighbour radius of its own position by its picture of them; each enters the kernels as a ghost
slot that only agent i reads (``kernels`` module docstring). Fed every agent's true state and
last publication, this gives the ideal path's headings and velocities up to the order of
floating-point sums (tests/methods/vicsek/test_networked.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmnav.methods.vicsek.kernels import NO_LAYER

#: What each agent publishes each step (read back with ``Observation.received``).
THETA, AVOIDING, LAYER, NUMBER = "vicsek_theta", "vicsek_avoiding", "vicsek_layer", "vicsek_theta_num"


@dataclass(frozen=True, slots=True)
class Pictures:
    """Every agent's neighbours as it knows them, in the kernels' CSR form over ghost slots.

    ``nb`` is ``(order, start, end, indices, dist2)``: agent i's neighbours are the slots
    ``indices[start[i]:end[i]]`` (N + e for entry e), at squared distances ``dist2`` [m^2] from
    its own position. The per-slot arrays hold the N agents' own values first, the ghosts after.
    """

    nb: tuple
    pos: np.ndarray  # (N + E, 2) [m]
    theta: np.ndarray  # (N + E,) [rad]
    avoiding: np.ndarray  # (N + E,) bool
    layers: np.ndarray  # (N + E,) int64
    number: np.ndarray | None  # (N + E,) eq. (30)'s numbers, or None
    iu_nb: np.ndarray  # (N + E,) bool: the slot's agent is a neighbour of the information UAV
    ident: np.ndarray  # (N + E,) int64: the agent each slot stands for


def pictures(obs, x: np.ndarray, own: dict, radius: float, r2: float, box: float, wrap: bool,
             iu: int) -> Pictures:
    """Each agent's neighbours from its own position ``x`` (N, 2) [m] and what it received.

    ``own`` holds the agents' own current values: ``theta``, ``avoiding``, ``layers`` and
    ``number`` (None when not used). A neighbour of agent i is an agent j != i it has heard with a
    heading, at ``0 < d <= radius`` [m] from x_i by i's picture of j (minimum image in a periodic
    box of side ``box`` when ``wrap``). Whether j is a neighbour of the information UAV ``iu`` (the
    WVEM weight k_beta) agent i judges from its pictures of both (within sqrt(``r2``) [m]).
    """
    n = len(x)
    kx, _, heard = obs.known()
    theta_in = obs.received(THETA)
    mask = heard & ~np.eye(n, dtype=bool)
    if theta_in is None:  # nothing published yet: no heading known, no neighbour to align with
        mask[:] = False
    else:
        mask &= np.isfinite(theta_in)
    d = _offset(kx - x[:, None, :], box, wrap)
    d2 = np.einsum("ijk,ijk->ij", d, d)
    mask &= (d2 > 0.0) & (d2 <= radius * radius)
    i, j = np.nonzero(mask)  # row-major: each agent's entries contiguous, in agent order
    e = len(i)
    counts = np.bincount(i, minlength=n)
    end = np.cumsum(counts)
    start = end - counts
    slots = n + np.arange(e, dtype=np.int64)
    nb = (np.arange(n, dtype=np.int64), start.astype(np.int64), end.astype(np.int64), slots, d2[i, j])

    def ext(own_values, name, dtype):
        if e == 0:
            return np.asarray(own_values, dtype=dtype).copy()
        got = obs.received(name)
        return np.concatenate([np.asarray(own_values, dtype=dtype), got[i, j].astype(dtype)])

    theta = ext(own["theta"], THETA, np.float64)
    avoiding = ext(own["avoiding"], AVOIDING, np.bool_)
    if iu >= 0:
        layers = ext(own["layers"], LAYER, np.int64)
    else:  # no information UAV: no layers (only HWVEM reads them)
        layers = np.full(n + e, NO_LAYER, dtype=np.int64)
    number = ext(own["number"], NUMBER, np.float64) if own["number"] is not None else None
    pos = np.concatenate([x, kx[i, j]])
    # the information UAV's neighbours: agent i's own judgement of itself (by its picture of the
    # UAV) and of each neighbour j (by its pictures of j and of the UAV)
    iu_nb = np.zeros(n + e, dtype=np.bool_)
    if iu >= 0:
        own_d2 = d2[:, iu]
        iu_nb[:n] = heard[:, iu] & (own_d2 > 0.0) & (own_d2 <= r2)
        iu_nb[iu] = False
        if e:
            dj = _offset(kx[i, j] - kx[i, iu], box, wrap)
            dj2 = np.einsum("pk,pk->p", dj, dj)
            iu_nb[n:] = heard[i, iu] & (j != iu) & (dj2 > 0.0) & (dj2 <= r2)
    ident = np.concatenate([np.arange(n, dtype=np.int64), j.astype(np.int64)])
    return Pictures(nb, pos, theta, avoiding, layers, number, iu_nb, ident)


def _offset(d: np.ndarray, box: float, wrap: bool) -> np.ndarray:
    """Offsets ``d`` [m], minimum image in a periodic square of side ``box`` when ``wrap``."""
    if box > 0.0 and wrap:
        return d - box * np.floor(d / box + 0.5)
    return d
