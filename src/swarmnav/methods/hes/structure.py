"""Stage 3 of a HES step, executed: split, merge (Section 3, eq. 13-17) and follower reassignment (eq. 41).

The decision itself (z(k), the source's proposal, Pi_feas of eq. 22) is in ``Hes.act``; these
functions change the partition held by the method and tell the parts (hooks ``split``, ``merge``).
"""

from __future__ import annotations

import numpy as np

from swarmnav.methods.hes.decision import Proposal
from swarmnav.methods.hes.hierarchy import choose_subleader, merge_pair, reassign, split_members
from swarmnav.methods.hes.step import NEVER, Step, SubSwarm


def split(h, step: Step, prop: Proposal) -> dict:
    """Split the single sub-swarm into one sub-swarm per split path (at most max_subswarms,
    each of at least min_size agents): corridors ranked by route cost, agents assigned by
    lateral order, the leader keeps its sub-swarm, new subleaders nearest their centroids."""
    p = h.params
    x = step.x
    (s0,) = h.subs
    rep = step.reports[s0]
    members = rep.pack.members
    cors = h.split_paths(step, rep)
    m = max(2, min(len(cors), p.core.max_subswarms, len(members) // max(p.core.min_size, 1)))
    cors = cors[:m]
    cent = rep.pack.centroid
    heading = h.goal - cent
    heading = heading / max(np.hypot(*heading), 1e-9)
    groups = split_members(x, members, [c.mid - cent for c in cors], [min(c.width, 10.0) for c in cors],
                           heading, p.core.min_size)
    old = h.subs.pop(s0)
    new = []
    for c, g in zip(cors, groups):
        if len(g) == 0:
            continue
        sid = s0 if h.leader in g else h.new_id()
        h.labels[g] = sid
        wp = old.waypoint.copy() if sid == s0 else x[g].mean(axis=0)
        h.subs[sid] = SubSwarm(sid, choose_subleader(x, g, h.leader), wp, mode=old.mode, route=c,
                               squeeze=old.squeeze, heading=old.heading.copy())
        new.append(sid)
    for part in h.at["split"]:
        part.split(s0, new, step.k)
    h.stats["splits"] += 1
    return {"action": "split", "source": prop.source, "reason": prop.reason,
            "agents": [int(i) for i in members], "into": len(h.subs)}


def merge(h, step: Step, prop: Proposal) -> dict:
    """Merge the pair chosen by :func:`merge_pair`; the merged sub-swarm keeps the id and
    subleader of the leader's (else the larger) part."""
    p = h.params
    ids = sorted(h.subs)
    cents = np.array([step.reports[s].pack.centroid for s in ids])
    near = np.hypot(*(cents - h.goal).T) < p.paper.r_merge
    a, b = merge_pair(cents, ids, near, p.paper.d_merge)
    size = {s: int(np.count_nonzero(h.labels == s)) for s in (a, b)}
    keep, drop = (a, b)
    if h.subs[b].subleader == h.leader or (h.subs[a].subleader != h.leader and size[b] > size[a]):
        keep, drop = b, a
    agents = np.flatnonzero((h.labels == a) | (h.labels == b))
    h.labels[h.labels == drop] = keep
    gone = h.subs.pop(drop)
    kept = h.subs[keep]
    kept.waypoint = (size[keep] * kept.waypoint + size[drop] * gone.waypoint) / (size[a] + size[b])
    kept.slot_step = NEVER
    for part in h.at["merge"]:
        part.merge(keep, drop)
    kept.mode = min(kept.mode, gone.mode) if kept.mode != gone.mode else kept.mode
    h.stats["merges"] += 1
    return {"action": "merge", "source": prop.source, "reason": prop.reason,
            "agents": [int(i) for i in agents], "into": len(h.subs)}


def reassign_followers(h, x: np.ndarray, k: int) -> None:
    """Dynamic follower reassignment, eq. (41) (see :func:`hierarchy.reassign`)."""
    p = h.params
    if len(h.subs) < 2:
        return
    ids = sorted(h.subs)
    sl_pos = x[[h.subs[s].subleader for s in ids]]
    wps = np.array([h.subs[s].waypoint for s in ids])
    protected = np.zeros(h.n, dtype=bool)
    protected[[h.subs[s].subleader for s in ids]] = True
    protected[h.leader] = True
    new, moved = reassign(x, h.labels, ids, sl_pos, wps, protected, h.last_move, k, h.ra_steps,
                          p.paper.w_sl, p.paper.w_c, p.paper.delta_min, p.paper.n_move_max)
    if len(moved):
        for s in set(h.labels[moved].tolist()) | set(new[moved].tolist()):
            h.subs[s].slot_step = NEVER
        h.labels = new
        h.last_move[moved] = k
        h.stats["reassigned"] += len(moved)
