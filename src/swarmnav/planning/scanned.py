"""Maps from scans: each robot's map built from its own simulated range sensing as it flies.

Under ``sense.map = scans`` (docs/sensing.md, Maps from scans) a map-based planner does not
read the obstacles within its sensing range from the world. Every ``1 / sense.scan_rate``
seconds every robot takes one scan: ``sense.scan_rays`` rays (2-D: the evenly spaced ring of
:func:`~swarmnav.sensing.lidar_ring`; 3-D: the Fibonacci sphere through
:func:`~swarmnav.sensing.range_scan`) to ``sense.scan_range`` (0: the planner's sensing range),
read through ``Observation.scan``, so the run's range noise, dropouts and field of view apply and
the rays leave from the true body. A return that meets something (shorter than the max range) is
placed in the world from the robot's *estimated* pose, ``p_hat + r u``, and the grid cell it falls
in is marked in that robot's :class:`~swarmnav.planning.maps.OccupancyMaps` grid for good
(accumulated; no free-space clearing: a cell once hit stays occupied). The clearance classes the
grid search reads and the distance field the optimisers read follow from the hit cells, updated
around each newly hit cell only (:meth:`OccupancyMaps.integrate`). Unknown space is free, but
with ``sense.scan_fill`` = D > 0 each return also marks the cells up to D behind it along the
surface's inward normal (:meth:`Scanner._inward`), so a seen face has a solid inside: on a map of
faces alone EGO-Swarm's collision repair routes through the free inside and its plans fail.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from swarmnav.errors import ConfigError
from swarmnav.planning.maps import OccupancyMaps
from swarmnav.sensing import fibonacci_sphere, lidar_ring, range_scan, ray_table


class Scanner:
    """The scans of one run's robots (module docstring): :meth:`sweep` is called every control
    step, scans when one is due, and adds the returns to the maps."""

    def __init__(self, sense: Any, geom: Any, maps: OccupancyMaps, sensing_range: float, dt: float,
                 reach: float = 0.0):
        self.maps = maps
        self.geom = geom
        self.rays = int(sense.scan_rays)
        self.max_range = float(sense.scan_range or sensing_range)  # [m]
        # control steps between scans: the rate rounded to whole steps, at most one scan a step
        self.every = max(1, int(round(1.0 / (float(sense.scan_rate) * float(dt)))))
        if maps.dim == 2:
            c, s = ray_table(self.rays)
            self.directions = np.ascontiguousarray(np.column_stack([c, s]))
            self._cast = lambda at: lidar_ring(geom, at, self.rays, self.max_range)
        else:
            self.directions = fibonacci_sphere(self.rays)
            self._cast = lambda at: range_scan(geom, at, self.directions, self.max_range)
        maps.use_scans(reach)
        self.fill = float(sense.scan_fill)  # [m] depth marked behind each return
        # the depths behind a return that are marked: every half cell up to the fill depth
        half = 0.5 * maps.resolution
        self._depths = half * np.arange(1, int(math.ceil(self.fill / half)) + 1) if self.fill > 0 else np.zeros(0)
        if len(self._depths):
            self._depths[-1] = self.fill
        self.scans = 0
        self.returns = 0

    def sweep(self, obs: Any, x: np.ndarray) -> np.ndarray:
        """Scan if one is due at ``obs.step`` and add the returns to the maps: ``x`` (N, dim) the
        robots' estimated positions [m]. Returns (N,) bool, the robots whose map gained a cell
        (all False between scans)."""
        n = len(x)
        if obs.step % self.every:
            return np.zeros(n, dtype=bool)
        ranges = obs.scan(self._cast, x, self.directions, self.max_range)  # (N, R) [m]
        hit = ranges < self.max_range
        points = x[:, None, :] + ranges[:, :, None] * self.directions[None, :, :]
        if len(self._depths):
            inward, filled = self._inward(points, ranges, hit)
            behind = points[:, :, None, :] + self._depths[None, None, :, None] * inward[:, :, None, :]
            points = np.concatenate([points, behind.reshape(n, -1, points.shape[2])], axis=1)
            hit = np.concatenate([hit, np.repeat(filled, len(self._depths), axis=1)], axis=1)
        gained = self.maps.integrate(points, hit)
        self.scans += 1
        self.returns += int(hit.sum())
        return gained

    def _inward(self, points: np.ndarray, ranges: np.ndarray, hit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The direction into the obstacle behind each return, (N, R, dim) unit vectors, and (N, R)
        bool the returns to fill behind. 2-D: the surface normal from the neighbouring returns of the
        ring (the chord through both, or the one neighbour at a silhouette's edge), turned away
        from the sensor; a return with no neighbour on the same surface (farther apart than three
        ray spacings at its range plus two cells) is not filled, as its surface is unknown. 3-D: the
        ray direction (the Fibonacci sphere has no ordered neighbours)."""
        u = np.broadcast_to(self.directions[None], points.shape)
        if self.maps.dim != 2:
            return u, hit
        lim = 3.0 * ranges * (2.0 * math.pi / self.rays) + 2.0 * self.maps.resolution  # [m]
        prev, nxt = np.roll(points, 1, axis=1), np.roll(points, -1, axis=1)
        ok_p = hit & np.roll(hit, 1, axis=1) & (np.linalg.norm(points - prev, axis=2) < lim)
        ok_n = hit & np.roll(hit, -1, axis=1) & (np.linalg.norm(nxt - points, axis=2) < lim)
        tangent = np.where((ok_p & ok_n)[..., None], nxt - prev,
                           np.where(ok_n[..., None], nxt - points, np.where(ok_p[..., None], points - prev, 0.0)))
        length = np.linalg.norm(tangent, axis=2)
        filled = (ok_p | ok_n) & (length > 1e-12)
        normal = np.stack([-tangent[..., 1], tangent[..., 0]], axis=2) / np.maximum(length, 1e-12)[..., None]
        normal *= np.where(np.sum(normal * u, axis=2) < 0.0, -1.0, 1.0)[..., None]  # away from the sensor
        return normal, filled

    def summary(self) -> dict[str, float]:
        """Run metrics of the scans: scans taken per robot, and the mean fraction of each robot's
        grid cells its map holds as hit at the end."""
        return {"scan_count": float(self.scans), "scan_hit_cells_fraction": self.maps.hit_fraction()}


#: [B] what maps from scans add per robot per grid cell: the hit flag (1) and the distance (8)
SCAN_BYTES_PER_CELL = 9


def scanner(obs: Any, geom: Any, maps: OccupancyMaps, sensing_range: float, dt: float,
            reach: float = 0.0, budget: tuple[str, float, float, str] | None = None) -> Scanner | None:
    """The run's :class:`Scanner` if its perception builds maps from scans (``sense.map = scans``),
    else None (the maps stay the known ones). ``reach`` [m]: how far from the obstacles the
    planner reads their distance (:meth:`OccupancyMaps.use_scans`). ``budget``: ``(method, bytes
    its maps take already, its limit, the limit's parameter)``; maps from scans that would pass
    the limit are refused in one line (ConfigError) before they are allocated."""
    sense = getattr(obs.sensing, "p", None)
    if sense is None or sense.map != "scans":
        return None
    if budget is not None:
        method, used, limit, key = budget
        need = used + SCAN_BYTES_PER_CELL * maps.grids.size
        if not need <= limit:
            raise ConfigError(f"{method}: maps from scans (sense.map=scans) need {need / 2**30:.3g} GiB beside the "
                              f"known maps' own (limit {limit / 2**30:.3g} GiB: {key}); use a coarser grid or a "
                              "smaller world, or sense.map=known")
    return Scanner(sense, geom, maps, sensing_range, dt, reach)
