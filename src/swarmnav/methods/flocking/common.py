"""What the two flocking methods share: the range sensor, the surface points it sees, the
neighbours' broadcast states, and pair differences.

- **Sensing** is APF's (``methods/apf.py``): every robot's own LiDAR ring in the plane
  (:func:`swarmnav.sensing.lidar_ring`), a Fibonacci sphere of rays in 3-D
  (:meth:`swarmnav.sensing.PreparedGeometry.range_into`), so the reactive methods see the same
  obstacles the same way.
- **Surface points**: an obstacle surface a robot sees is one local minimum of its range ring
  (sphere): for a wall the foot of the perpendicular, for a convex obstacle its nearest point.
  These are Olfati-Saber's beta-agents (the projection of the robot onto the obstacle,
  Section VII) and Vásárhelyi's shill agents (the nearest point of an obstacle's edge).
- **Messages**: each robot broadcasts its position and velocity at ``broadcast_hz``; the others
  hold the last one they received (zero-order hold), and every message is counted in a
  :class:`~swarmnav.planning.messages.CommLog`, so ``comm_mbps`` is measured.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmnav.methods.base import Observation
from swarmnav.planning.messages import FLOAT, HEADERS, INT, CommLog
from swarmnav.sensing import PreparedGeometry, fibonacci_sphere, lidar_ring
from swarmnav.world.scenario import Scenario

#: [B] one state message: sender id (4 B), time stamp (8 B), position and velocity (3 floats each),
#: with the UDP/IPv4 headers; 3 floats whatever the world's dimension, as the position message
STATE_BYTES = HEADERS + INT + FLOAT + 6 * FLOAT  # 88 B
#: [m] where a robot that has heard nothing of another places it: far beyond every interaction
#: range of the flocking laws, so the pair contributes nothing
UNHEARD = 1e9


class RangeSensor:
    """Each robot's range ring (2-D, ``n_rays`` rays) or range sphere (3-D, ``n_rays_3d``
    Fibonacci-lattice rays), and the surface points it sees (module docstring)."""

    def __init__(self, scenario: Scenario, n_rays: int, n_rays_3d: int, max_range: float):
        self.geom = scenario.geometry
        self.dim = scenario.dim
        self.max_range = float(max_range)
        if self.dim == 3:
            self.dirs = fibonacci_sphere(n_rays_3d)
            self._prepared = PreparedGeometry(self.geom) if not self.geom.is_empty else None
            self._ranges = np.empty((scenario.n, n_rays_3d))
            self._nbrs = sphere_neighbours(self.dirs)
        else:
            theta = 2 * np.pi * np.arange(n_rays) / n_rays
            self.dirs = np.column_stack([np.cos(theta), np.sin(theta)])
            self._nbrs = None
        self.n_rays = len(self.dirs)

    def ranges(self, x: np.ndarray) -> np.ndarray:
        """(N, R) range [m] of every ray of every robot; ``max_range`` where nothing is hit."""
        if self.geom.is_empty:
            return np.full((len(x), self.n_rays), self.max_range)
        if self.dim == 2:
            return lidar_ring(self.geom, x, self.n_rays, self.max_range)
        if len(x) != len(self._ranges):
            self._ranges = np.empty((len(x), self.n_rays))
        return self._prepared.range_into(np.ascontiguousarray(x), self.dirs, self.max_range, self._ranges)

    def surface_points(self, x: np.ndarray, within: float,
                       obs: Observation | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The surfaces robot ``agent[k]`` sees closer than ``within`` [m]: ``(agent, dist, normal)``
        with ``dist`` (K,) [m] and ``normal`` (K, d) the unit vector from the surface point to the
        robot; the point itself is ``x[agent] - dist * normal``. ``obs``: the step's observation,
        whose perception the ranges pass through (docs/sensing.md); None: exact ranges."""
        ring = self.ranges(x) if obs is None else obs.scan(self.ranges, x, self.dirs, self.max_range)
        agent, ray = local_minima(ring, min(within, self.max_range), self._nbrs)
        return agent, ring[agent, ray], -self.dirs[ray]


def local_minima(ring: np.ndarray, within: float, nbrs: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rays that are local minima of each robot's ranges, closer than ``within``: ``(agent, ray)``.

    In a ring (``nbrs`` None) ray k is a minimum when ``r[k-1] > r[k] <= r[k+1]`` (circularly): a
    plateau of equal ranges gives its first ray only, so a flat run of equal returns is one
    surface. On a sphere ``nbrs`` (R, k) lists each ray's nearest rays; ray k is a minimum when
    it is shorter than every neighbour of lower index and no longer than every one of higher
    index (the same tie rule). A robot inside an obstacle reads 0 on every ray: no minimum.
    """
    if nbrs is None:
        prev = np.concatenate([ring[:, -1:], ring[:, :-1]], axis=1)  # circular neighbours
        nxt = np.concatenate([ring[:, 1:], ring[:, :1]], axis=1)
        is_min = (ring < prev) & (ring <= nxt) & (ring < within)
    else:
        is_min = np.zeros(ring.shape, dtype=np.bool_)
        _sphere_minima(np.ascontiguousarray(ring), nbrs, float(within), is_min)
    agent, ray = np.nonzero(is_min)
    return agent, ray


@njit(cache=True)
def _sphere_minima(ring, nbrs, within, out):
    """``out[a, k]`` <- ray k of robot a is a minimum of the sphere (:func:`local_minima`'s rule)."""
    n, n_rays = ring.shape
    for a in range(n):
        for k in range(n_rays):
            r = ring[a, k]
            if not r < within:
                continue
            ok = True
            for t in range(nbrs.shape[1]):
                j = nbrs[k, t]
                if (j < k and not r < ring[a, j]) or (j > k and not r <= ring[a, j]):
                    ok = False
                    break
            out[a, k] = ok


def sphere_neighbours(dirs: np.ndarray, k: int = 6) -> np.ndarray:
    """(R, k) indices of each direction's ``k`` nearest other directions (by angle)."""
    from scipy.spatial import cKDTree

    _, idx = cKDTree(dirs).query(dirs, k=k + 1)
    return np.ascontiguousarray(idx[:, 1:])


def pair_differences(x: np.ndarray, others: np.ndarray | None = None,
                     period: np.ndarray | None = None, heard: np.ndarray | None = None) -> np.ndarray:
    """(N, N, d) ``others[j] - x[i]`` at ``[i, j]`` (``others`` defaults to ``x``: what robot i knows
    of robot j against its own state; (N, N, d) ``others[i, j]``: each robot's own picture, from
    the network); the nearest image in a periodic box of side ``period`` (d,); pairs not ``heard``
    (N, N) placed :data:`UNHEARD` away."""
    o = x if others is None else others
    diff = (o if o.ndim == 3 else o[None, :, :]) - x[:, None, :]
    if period is not None:
        diff -= period * np.round(diff / period)
    if heard is not None:  # a robot never heard: far beyond every interaction range, so it adds nothing
        diff[~heard] = 0.0
        diff[~heard, 0] = UNHEARD
    return diff


class StateBoard:
    """Every robot's position and velocity as the others last received them (module docstring)."""

    __slots__ = ("_steps", "dt", "log", "rate_hz", "v", "x")

    def __init__(self, rate_hz: float, dt: float):
        self.rate_hz = float(rate_hz)
        self.dt = float(dt)
        self.log = CommLog()
        self.x: np.ndarray | None = None
        self.v: np.ndarray | None = None
        self._steps = 0

    def update(self, obs: Observation) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Broadcast at ``obs.step`` if it is a sending step (the first step always is); return the
        states held: ``(x, v)`` (N, d) each, every robot's broadcast; or, on a network
        (``obs.view``), (N, N, d) each, robot i's picture of robot j at ``[i, j]``; and the (N, N)
        pairs heard (None: all), for :func:`pair_differences`."""
        x, v = obs.positions, obs.velocities
        every = max(1, int(round(1.0 / (self.rate_hz * self.dt))))
        if self.x is None or obs.step % every == 0:
            self.x, self.v = x.copy(), v.copy()
            self.log.send(len(x), STATE_BYTES)
        self._steps += 1
        if obs.view is None:
            return self.x, self.v, None
        kx, kv, heard = obs.known()
        return kx, kv, (None if heard.all() else heard)

    def summary(self) -> dict[str, float]:
        return self.log.summary(self._steps * self.dt)


def velocity_differences(v: np.ndarray, others: np.ndarray) -> np.ndarray:
    """(N, N, d) ``others[j] - v[i]`` at ``[i, j]``, or ``others[i, j] - v[i]`` for (N, N, d)
    ``others`` (each robot's own picture, from the network)."""
    return (others if others.ndim == 3 else others[None, :, :]) - v[:, None, :]
