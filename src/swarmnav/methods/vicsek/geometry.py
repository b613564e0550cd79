"""Pure geometry of the Vicsek family: the obstacle-avoidance rule (HWVEM Section 2.3) and the
information UAV's path following.

Both are functions of arrays; the method object only keeps the state between steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmnav.sensing import nearest_obstacle


def wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles mapped to ``[-pi, pi)``."""
    t = np.mod(np.asarray(a, dtype=np.float64) + np.pi, 2 * np.pi) - np.pi
    return np.where(t >= np.pi, t - 2 * np.pi, t)


def avoidance(
    geom,
    positions: np.ndarray,
    theta_g: np.ndarray,
    theta_prev: np.ndarray,
    r_avoid: float,
    theta_obstruct: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which agents avoid an obstacle and the heading they take, eq. (20)-(22).

    Agent ``i`` avoids when its nearest obstacle point ``x_obs`` satisfies

    - eq. (20): ``|x_i - x_obs| <= r_avoid`` and
    - eq. (21): ``|wrap(theta_g_i - angle(x_obs - x_i))| <= theta_obstruct``,

    i.e. the obstacle is close and lies across its genuine desired direction. It then flies
    along the tangent of the obstacle at ``x_obs``, the one of the two opposite tangent
    directions that makes an acute angle with its previous heading ``theta_prev`` (Figure 3).
    The tangent is perpendicular to ``x_obs - x_i``: on an edge or a circle this is the
    boundary tangent; at a polygon vertex it is the supporting line perpendicular to the
    approach. A point on the boundary itself (distance 0) has no direction, hence no tangent,
    and the agent keeps its genuine direction (the paper: "if it only detects the obstacle
    point without tangent, it will move in the original direction").

    Args:
        geom: the world's ``Geometry``.
        positions: (N, 2) agent positions [m].
        theta_g: (N,) genuine desired headings theta^g(k+1) [rad], eq. (18).
        theta_prev: (N,) headings of the previous step theta(k) [rad].
        r_avoid: trigger distance [m], eq. (20).
        theta_obstruct: trigger half-angle [rad], eq. (21).

    Returns:
        ``(avoiding (N,) bool, theta_obs (N,) [rad], dist (N,) signed distance [m])``;
        ``theta_obs`` is meaningful where ``avoiding``.
    """
    dist, direction = nearest_obstacle(geom, positions)
    has_dir = np.any(direction != 0.0, axis=1)
    phi = np.arctan2(direction[:, 1], direction[:, 0])  # angle of x_obs - x_i
    blocking = np.abs(wrap(theta_g - phi)) <= theta_obstruct
    avoiding = (dist <= r_avoid) & has_dir & blocking
    t_plus = phi + np.pi / 2
    acute = np.cos(t_plus - theta_prev)
    # exactly perpendicular to the previous heading: take the side nearer the genuine direction
    tie = acute == 0.0
    acute = np.where(tie, np.cos(t_plus - theta_g), acute)
    theta_obs = wrap(np.where(acute >= 0.0, t_plus, t_plus - np.pi))
    return avoiding, theta_obs, dist


@dataclass(frozen=True, slots=True)
class Polyline:
    """A predetermined path: vertices (M, 2) [m] and cumulative arc length (M,) [m]."""

    points: np.ndarray
    s: np.ndarray

    @classmethod
    def of(cls, points) -> Polyline:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        keep = np.concatenate([[True], np.any(np.diff(p, axis=0) != 0.0, axis=1)])
        p = p[keep]  # repeated vertices give zero-length segments
        if len(p) < 2:
            raise ValueError("a path needs two distinct points")
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        return cls(p, s)

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def project(self, x: np.ndarray, s_lo: float, s_hi: float) -> float:
        """Arc length of the point of the path nearest to ``x`` among arc lengths in
        ``[s_lo, s_hi]`` (a window keeps the progress from jumping to a later, nearby part of
        the path)."""
        a, b = self.points[:-1], self.points[1:]
        e = b - a
        ee = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", x - a, e) / ee, 0.0, 1.0)
        s = np.clip(self.s[:-1] + t * np.sqrt(ee), s_lo, s_hi)
        q = self.at(s)
        return float(s[np.argmin(np.sum((q - x) ** 2, axis=1))])

    def at(self, s: np.ndarray | float) -> np.ndarray:
        """Points at arc lengths ``s``; beyond the end the last segment is extended."""
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        k = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        seg = self.points[k + 1] - self.points[k]
        frac = (s - self.s[k]) / (self.s[k + 1] - self.s[k])
        return self.points[k] + frac[:, None] * seg


def pursue(path: Polyline, x: np.ndarray, s_prev: float, lookahead: float) -> tuple[float, float]:
    """Carrot-chasing path following of the information UAV.

    The progress ``s`` is the projection of ``x`` on the path within ``[s_prev, s_prev + 2
    lookahead]`` (monotone); the reference heading theta_d points from ``x`` to the path point
    ``lookahead`` metres further on (past the end: along the last segment, so the UAV keeps
    flying straight after the path ends).

    Returns:
        ``(theta_d [rad], s [m])``.
    """
    s = max(s_prev, path.project(x, s_prev, s_prev + 2.0 * lookahead))
    carrot = path.at(s + lookahead)[0]
    d = carrot - x
    return float(np.arctan2(d[1], d[0])), s
