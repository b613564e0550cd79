"""How low can R_unsafe go on narrow_alternating_gates? An idealised convoy, perfectly tracked.

The HES paper's R_unsafe (Sec. 5.1) counts a step when *any* of the N agents is within
d_safe = 1.5 m of an obstacle. On narrow_alternating_gates every 2.3 m gap lies inside the
1.5 m band of both its gate and the channel wall, so the ratio is set by how long the stream of
agents takes to cross the five gap zones. This script computes that time for the most
favourable swarm motion we could construct, with every advantage a controller cannot have:

- the path is planned with the scene's exact geometry (no perception): it leaves the open bay,
  crosses each gap on a horizontal segment at clearance ``c`` from the channel wall, and turns
  between gaps on S-curves of radius ``R`` (the turns lie outside the unsafe zones);
- the agents fly a rigid convoy of ``lanes`` abreast (``lateral`` apart) and ``spacing`` apart
  along the path, at the constant speed ``v``, and track it exactly (zero error, no start-up,
  no spawn: the convoy is formed in the open bay before the clock starts);
- the turn radius is R = v^2 / a_lat with a_lat <= a_max = 2.6 m/s^2 (Table A1); the script
  checks the reference accelerations of every lane against a_max and prints the largest.

It prints the swarm-level unsafe time of the passage and the R_unsafe it alone gives over the
paper's horizon (K = 1000 steps, Delta t = 0.1 s), for a grid of convoys, plus the closest
wall and neighbour approach of each. Anything a real swarm adds (spawn within d_safe of the
lower wall, forming the convoy, tracking error, perception of the next gap only once in range)
comes on top. docs/methods/hes.md (narrow_alternating_gates) quotes the result.

    PYTHONPATH=src python benchmarks/gates_unsafe_bound.py
    PYTHONPATH=src python benchmarks/gates_unsafe_bound.py --v 2.5 3.0 --lanes 1 2 3 --spacing 0.6
"""

from __future__ import annotations

import argparse
import itertools
import math

import numpy as np
from scipy.optimize import brentq

from swarmnav import load_scenario
from swarmnav.sensing import signed_distance
from swarmnav.world.obstacles import Box

D_SAFE = 1.5  # [m] Table A1
A_MAX = 2.6  # [m/s^2] Table A1
K, DT = 1000, 0.1  # paper Sec. 5.1: R_unsafe over steps 1 .. K-1


def gaps(scn) -> list[tuple[float, float, int]]:
    """(x_gate [m], y of the channel wall face the gap lies against [m], side +1 top / -1 bottom)
    for each gate, sorted along x."""
    boxes = [(o.min, o.max) for o in scn.obstacles if isinstance(o, Box)]
    span = max(b[1][0] - b[0][0] for b in boxes)
    walls = sorted((b for b in boxes if b[1][0] - b[0][0] >= 0.9 * span), key=lambda b: b[0][1])
    lo, hi = float(walls[0][1][1]), float(walls[-1][0][1])  # inner faces
    out = []
    for bmin, bmax in boxes:
        if bmax[0] - bmin[0] >= 0.9 * span:
            continue
        top = bmin[1] <= lo + 1e-9  # hangs from the lower wall: the gap is at the top
        out.append((0.5 * (bmin[0] + bmax[0]), hi if top else lo, 1 if top else -1))
    return sorted(out)


def _arc_line(p, h, turns, ds):
    """Sample a path from point p, heading h, exactly: ``turns`` is a list of (curvature [1/m],
    length [m]) pieces, each sampled every ``ds`` m and at its end."""
    pts = []
    x, y = p
    for kappa, length in turns:
        u = np.append(np.arange(0.0, length, ds), length)
        if kappa == 0.0:
            px, py = x + u * math.cos(h), y + u * math.sin(h)
        else:
            px = x + (np.sin(h + kappa * u) - math.sin(h)) / kappa
            py = y - (np.cos(h + kappa * u) - math.cos(h)) / kappa
        pts += list(zip(px[:-1], py[:-1]))
        x, y, h = float(px[-1]), float(py[-1]), h + kappa * length
    return pts, (x, y), h


def s_curve(p0, p1, radius, ds):
    """Heading 0 at p0 and at p1: turn by t, straight L, turn back by t (radius ``radius``);
    t solves the lateral offset exactly, so the pieces join without a jump."""
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    sgn, dy = math.copysign(1.0, dy), abs(dy)

    def miss(t):  # lateral offset reached minus the one asked for
        length = (dx - 2 * radius * math.sin(t)) / math.cos(t)
        return 2 * radius * (1 - math.cos(t)) + length * math.sin(t) - dy

    t_max = math.asin(min(dx / (2 * radius), 1.0)) if dx < 2 * radius else math.pi / 2 - 1e-9
    if dx <= 0 or miss(t_max) < 0:
        raise ValueError(f"no S-curve of radius {radius} m from {p0} to {p1}")
    t = brentq(miss, 1e-9, t_max, xtol=1e-12)
    length = (dx - 2 * radius * math.sin(t)) / math.cos(t)
    pts, _, _ = _arc_line(p0, 0.0, [(sgn / radius, radius * t), (0.0, length), (-sgn / radius, radius * t)], ds)
    return pts


def convoy_path(scn, c: float, half: float, radius: float, ds: float = 0.01) -> np.ndarray:
    """Open bay -> a horizontal crossing of every gap at clearance ``c`` from the channel wall
    (``half`` m either side of the gate's centre) -> the goal, joined by S-curves; (M, 2) [m]."""
    g = gaps(scn)
    x0 = float(np.mean([scn.swarm.spawn[0], scn.swarm.spawn[2]]))
    pts, prev, _ = _arc_line((x0 - 30.0, 0.0), 0.0, [(0.0, 30.0)], ds)
    for xg, face, side in g:
        y = face - side * c
        pts += s_curve(prev, (xg - half, y), radius, ds)
        more, prev, _ = _arc_line((xg - half, y), 0.0, [(0.0, 2 * half)], ds)
        pts += more
    pts += s_curve(prev, (prev[0] + 12.0, float(scn.goal_array[1])), radius, ds)
    more, end, _ = _arc_line((prev[0] + 12.0, float(scn.goal_array[1])), 0.0, [(0.0, 20.0)], ds)
    return np.asarray(pts + more + [end])


def ease(path: np.ndarray, window: float, ds: float = 0.01) -> np.ndarray:
    """The same path with its curvature averaged over ``window`` m (clothoid-like transitions
    instead of curvature steps, so that offset lanes change speed gradually), re-integrated
    from its start at spacing ``ds``."""
    seg = np.hypot(*np.diff(path, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    u = np.arange(0.0, s[-1], ds)
    x, y = np.interp(u, s, path[:, 0]), np.interp(u, s, path[:, 1])
    h = np.unwrap(np.arctan2(np.diff(y), np.diff(x)))
    w = max(int(window / ds), 1)
    h = np.convolve(np.pad(h, (w // 2, w - 1 - w // 2), mode="edge"), np.ones(w) / w, mode="valid")
    out = np.empty((len(h) + 1, 2))
    out[0] = x[0], y[0]
    out[1:, 0] = x[0] + np.cumsum(ds * np.cos(h))
    out[1:, 1] = y[0] + np.cumsum(ds * np.sin(h))
    return out


def fly(scn, path: np.ndarray, v: float, lanes: int, spacing: float, lateral: float, n: int):
    """Rigid convoy at speed v along ``path``; returns (unsafe time [s], min clearance [m],
    min neighbour distance [m], max reference acceleration [m/s^2])."""
    seg = np.hypot(*np.diff(path, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    tang = np.gradient(path, axis=0)
    tang /= np.hypot(*tang.T)[:, None]
    nrm = np.column_stack([-tang[:, 1], tang[:, 0]])
    ranks = np.arange(n) // lanes
    offs = (np.arange(n) % lanes - (lanes - 1) / 2) * lateral
    s_start = 28.0 + ranks.max() * spacing  # the whole convoy is in the open bay at t = 0
    t = np.arange(0.0, (s[-1] - s_start) / v, DT)
    sa = s_start + v * t[:, None] - ranks[None, :] * spacing  # (T, n) arc length of each agent
    sa = np.clip(sa, 0.0, s[-1])
    nx, ny = np.interp(sa, s, nrm[:, 0]), np.interp(sa, s, nrm[:, 1])
    pos = np.stack([np.interp(sa, s, path[:, 0]) + offs * nx, np.interp(sa, s, path[:, 1]) + offs * ny], axis=-1)
    d = signed_distance(scn.geometry, pos.reshape(-1, 2)).reshape(pos.shape[:2])
    unsafe = float(np.count_nonzero(d.min(axis=1) < D_SAFE) * DT)
    diff = pos[:, :, None, :] - pos[:, None, :, :]
    dd = np.hypot(diff[..., 0], diff[..., 1])
    dd[:, np.arange(n), np.arange(n)] = np.inf
    acc = np.diff(pos, n=2, axis=0) / DT**2
    return unsafe, float(d.min()), float(dd.min()), float(np.hypot(acc[..., 0], acc[..., 1]).max())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="narrow_alternating_gates")
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--v", type=float, nargs="+", default=[2.0, 2.5, 2.9], help="convoy speed [m/s]")
    ap.add_argument("--a-lat", type=float, default=2.4, help="turn acceleration v^2/R [m/s^2] (<= a_max)")
    ap.add_argument("--ease", type=float, default=1.0, help="curvature transitions over this length [m]")
    ap.add_argument("--lanes", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--spacing", type=float, nargs="+", default=[0.6, 0.8], help="along-path spacing [m]")
    ap.add_argument("--lateral", type=float, default=0.6, help="spacing between lanes [m]")
    ap.add_argument("--clearance", type=float, nargs="+", default=[1.15, 1.3, 1.5],
                    help="crossing line's clearance from the channel wall [m]")
    ap.add_argument("--half", type=float, nargs="+", default=[0.6, 1.2, 1.7],
                    help="half-length of the horizontal crossing around the gate's centre [m]")
    a = ap.parse_args(argv)
    scn = load_scenario(a.scene)
    horizon = (K - 1) * DT
    print(f"{a.scene}: ideal convoys of N = {a.n}, turn acceleration {a.a_lat} m/s^2, "
          f"R_unsafe = unsafe time / {horizon:.1f} s (passage only)")
    print(f"{'v':>4} {'lanes':>5} {'spacing':>7} {'c':>5} {'half':>5} {'unsafe[s]':>9} {'R_unsafe':>8} "
          f"{'min clr':>7} {'min pair':>8} {'max acc':>7}  (* reference acceleration above a_max)")
    best = None
    for v, lanes, sp in itertools.product(a.v, a.lanes, a.spacing):
        rows = []
        for c, half in itertools.product(a.clearance, a.half):
            if lanes > 1 and c - (lanes - 1) / 2 * a.lateral < 0.3:
                continue  # the outer lane would fly within 0.3 m of the wall
            # turn radius: the outer lane (offset o) feels v^2 kappa (1 + o kappa) <= a_lat
            o, q = (lanes - 1) / 2 * a.lateral, v * v / a.a_lat
            try:
                path = ease(convoy_path(scn, c, half, 0.5 * (q + math.sqrt(q * q + 4 * q * o))), a.ease)
            except ValueError:
                continue
            rows.append((fly(scn, path, v, lanes, sp, a.lateral, a.n), c, half))
        if not rows:
            continue
        (unsafe, clr, pair, acc), c, half = min(rows, key=lambda r: r[0][0])
        print(f"{v:4.1f} {lanes:5d} {sp:7.2f} {c:5.2f} {half:5.2f} {unsafe:9.1f} {unsafe / horizon:8.3f} "
              f"{clr:7.2f} {pair:8.2f} {acc:7.2f}{'*' if acc > A_MAX else ''}")
        if acc <= A_MAX and (best is None or unsafe < best[0]):
            best = (unsafe, v, lanes, sp, c, half, acc)
    if best:
        unsafe, v, lanes, sp, c, half, acc = best
        print(f"lowest: {unsafe:.1f} s -> R_unsafe {unsafe / horizon:.3f} (v {v} m/s, {lanes} abreast, "
              f"{sp} m apart, crossing {c} m off the wall, max reference acceleration {acc:.2f} m/s^2"
              f"{' > a_max' if acc > A_MAX else ''})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
