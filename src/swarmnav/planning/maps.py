"""Initial paths for the B-spline planner: a grid search on each robot's own occupancy map.

The SPH paper's robots build an occupancy grid from onboard perception (Fig. 1) and seed the
B-spline optimisation with a grid-search path (the released code: A* at 0.1 m). Here every
robot keeps its own map: an obstacle enters it once the obstacle's bounding box comes within
the perception range (the paper equates sensing range and R, Section IV); unknown space is
free. Each cell stores a clearance class: the number of clearances it is inside, counting
``inflation`` (no room for the body) as all of them; with ``margin = d_thr`` and a wider
``wide`` clearance: 3 within ``inflation``, 2 within d_thr (the ESDF threshold of eq. 10), 1
within ``wide``, 0 free. The search first looks for a path that keeps d_thr (classes 0-1,
class 1 costing ``1 + wide_cost`` per metre, so the path keeps the wide clearance unless that
costs a long detour), and falls back to the body clearance. It is A* on the 8-connected grid
(no corner cutting), compiled with numba.

The dimension is the scene's: on a 3-D scene (six bounds) the maps are voxel grids
(nz, ny, nx) and the search is A* on the 26-connected grid, the same classes and tiers, no
corner cutting (a diagonal step needs every cell it grazes free), the 3-D octile heuristic
weighted by ``weight_3d`` (weighted A*: a path costs at most ``weight_3d`` times the optimum;
the planar search keeps its fixed 1.001, a tie-break only).
Both searches keep their per-cell work arrays between searches, marked by a search number, so a
search costs what it expands, not the size of the grid (millions of voxels at 0.1 m). A planar
search is a function of the robot's map (the obstacles it knows), its start and goal cells and
the expansion cap, so the maps remember the last searches by those and answer a repeated one
(a robot that stands still, or one at a cell where another searched from the same map) with the
same path without searching again.

Robots may search from several threads at once: each thread keeps its own work arrays, the
remembered searches (and the 3-D labels and fields) are shared behind a lock, and the compiled
kernels release the GIL. Every search but the 3-D field search is a function of its inputs, so
the paths do not depend on which thread searched first (:attr:`OccupancyMaps.order_dependent`).
"""

from __future__ import annotations

import math
import threading

import numpy as np
from numba import njit
from scipy import ndimage

from swarmnav.sensing import signed_distance
from swarmnav.sensing.esdf import Esdf, esdf3d_query_kernel, esdf_query_kernel
from swarmnav.world.obstacles import Geometry, Obstacle

_SQRT2 = math.sqrt(2.0)

#: cost-to-go fields kept per OccupancyMaps (3-D field search): a field of a 4.6-M-voxel world is 37 MB
_FIELDS_KEPT = 6

#: planar searches remembered per robot (:meth:`OccupancyMaps.search`; ~2 KB each)
_SEARCHES_KEPT_PER_ROBOT = 8

#: the planar A*'s search numbers run up to this, then its marks are cleared (int32 marks 2 id, 2 id + 1)
_MAX_SEARCH_ID = 2**30 - 1

#: heuristic weight of the field-guided A*: a tie-break only (a path costs at most 1 + 1e-6 times the optimum)
_TIE = 1.0 + 1e-6

#: the 26 neighbour offsets (dz, dy, dx) of a voxel, z outermost
_STEPS3 = np.array([(dz, dy, dx) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)
                    if (dz, dy, dx) != (0, 0, 0)], dtype=np.int64)


def grid_cells(bounds, resolution: float) -> float:
    """The number of cells of an :class:`OccupancyMaps` grid over ``bounds`` at ``resolution`` [m],
    as a float (``inf`` for a grid too large to count)."""
    dim = len(bounds) // 2
    total = 1.0
    for k in range(dim):
        c = (bounds[dim + k] - bounds[k]) / resolution
        total *= max(math.ceil(c), 2) if math.isfinite(c) else math.inf
    return total


def bytes_per_cell(dim: int, n_robots: int, field_3d: bool, marked: bool, threads: int = 1) -> int:
    """Bytes an :class:`OccupancyMaps` holds per grid cell, searches included: a uint8 class per
    robot; planar A*: its cost, parent and mark arrays kept between searches (16 B, counted as the
    17 B of the fresh arrays it once allocated), a copy of the map when neighbours are marked; 3-D:
    the search work arrays kept between searches (24 B), and either the kept
    cost-to-go fields with the one being built (``field_3d``: 6 x 8 + 9 B) or the kept component
    labels with the passable mask being labelled (6 x 4 + 1 B). With ``threads`` searching at once
    each has its own work arrays, map copy and labelling (the field search runs in one thread:
    :attr:`OccupancyMaps.order_dependent`)."""
    if dim == 2:
        return n_robots + threads * (17 + int(marked))
    if field_3d:
        return n_robots + 24 + int(marked) + _FIELDS_KEPT * 8 + 9
    return n_robots + threads * (24 + int(marked) + 1) + _FIELDS_KEPT * 4


class OccupancyMaps:
    """Per-robot occupancy grids over the scene bounds, grown from what each robot has seen.

    Attributes:
        dim: 2 or 3, from ``bounds`` (four or six numbers, as the scene's).
        origin: (dim,) centre of cell 0 [m] (x, y[, z]); resolution: cell size [m];
        shape: (ny, nx) or (nz, ny, nx); grids: (N, *shape) uint8 clearance classes of each robot.
    """

    def __init__(self, obstacles: tuple[Obstacle, ...], bounds, n_robots: int, resolution: float,
                 inflation: float, sensing_range: float, margin: float | None = None, wide: float = 0.0,
                 wide_cost: float = 0.0, weight_3d: float = 1.001, field_3d: bool = False):
        dim = len(bounds) // 2
        lo_b, hi_b = np.asarray(bounds[:dim], dtype=float), np.asarray(bounds[dim:], dtype=float)
        self.dim = dim
        self.resolution = float(resolution)
        self.origin = lo_b + 0.5 * self.resolution
        counts = [max(int(math.ceil((hi_b[k] - lo_b[k]) / resolution)), 2) for k in range(dim)]  # nx, ny[, nz]
        self.shape = tuple(reversed(counts))
        self.sensing_range = float(sensing_range)
        self.grids = np.zeros((n_robots, *self.shape), dtype=np.uint8)
        self.known = np.zeros((n_robots, len(obstacles)), dtype=bool)
        self.levels = sorted({m for m in (margin or 0.0, wide) if m > inflation})  # clearances beyond the body's [m]
        margin = max([inflation, *self.levels])
        top = len(self.levels) + 1
        # A* step-cost factor per class: 1 + wide_cost inside the wide band (classes 1 .. top - 2)
        self.cost = np.array([1.0] + [1.0 + wide_cost] * max(top - 2, 0) + [1.0, 1.0])[: top + 1]
        lo, hi, cells = [], [], []
        for o in obstacles:
            g = Geometry.from_obstacles([o], dim=dim)
            blo, bhi = g.bbox_lo.min(axis=0), g.bbox_hi.max(axis=0)
            lo.append(blo)
            hi.append(bhi)
            cells.append(self._footprint(g, blo - margin, bhi + margin, inflation))
        self.bbox_lo = np.array(lo).reshape(-1, dim)
        self.bbox_hi = np.array(hi).reshape(-1, dim)
        self.footprints = cells
        if dim == 3:
            self.weight_3d = float(weight_3d)
        self.field_3d = bool(field_3d)
        self._fields: dict[tuple, tuple] = {}  # (field, known obstacles) by (map, goal, tier); newest last
        self.fields_built = 0
        self._components: dict[tuple, np.ndarray] = {}  # passable components by (map, tier); newest last
        self._origin = tuple(float(o) for o in self.origin)
        # planar searches already made, by (known obstacles, start cell, goal cell, cap): a robot that
        # stands still, or one where another stood, with the same map, repeats a search exactly
        self._searched: dict[tuple, tuple[np.ndarray, bool]] = {}
        self._searched_kept = _SEARCHES_KEPT_PER_ROBOT * max(n_robots, 1)
        # the A* work arrays (see the module docstring), one set per thread that searches, made at its
        # first search; the remembered searches, fields and labels are shared, behind one lock
        self._local = threading.local()
        self._lock = threading.Lock()
        self.inflation = float(inflation)
        self._hits: np.ndarray | None = None  # maps from scans (use_scans): the cells the returns hit

    def __getstate__(self) -> dict:
        """What a copy (``copy.deepcopy``, pickle) keeps: every member but the per-thread A* work
        arrays and the lock, which the copy makes afresh (no search depends on them)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_local", "_lock")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._local = threading.local()
        self._lock = threading.Lock()

    @property
    def order_dependent(self) -> bool:
        """Whether a search's path may depend on the searches made before it: the 3-D field search
        (a kept field of another map guides the A*, and which fields are kept depends on the order
        of the searches). Every other search is a function of the robot's map, the cells and the
        cap, so robots may search concurrently and find the same paths in any order."""
        return self.dim == 3 and self.field_3d

    def _work(self) -> tuple[tuple[np.ndarray, ...], int]:
        """This thread's A* work arrays and the number of its next search (a fresh set every
        ``_MAX_SEARCH_ID`` searches, when the int32 marks would run out)."""
        local = self._local
        work = getattr(local, "work", None)
        if work is None or local.searches >= _MAX_SEARCH_ID:
            n = int(np.prod(self.shape))
            if self.dim == 2:  # cost, parent (int32), mark (int32), heap keys, heap values
                work = (np.empty(n), np.empty(n, dtype=np.int32), np.zeros(n, dtype=np.int32),
                        np.empty(1024), np.empty(1024, dtype=np.int64))
            else:  # cost, parent (int64), seen (int32), closed (int32), heap keys, heap values
                work = (np.empty(n), np.empty(n, dtype=np.int64), np.zeros(n, dtype=np.int32),
                        np.zeros(n, dtype=np.int32), np.empty(1024), np.empty(1024, dtype=np.int64))
            local.work, local.searches = work, 0
        local.searches += 1
        return work, local.searches

    def _footprint(self, g: Geometry, lo, hi, inflation: float) -> tuple[np.ndarray, np.ndarray]:
        """Flat indices and clearance classes (see the module docstring) of the cells around
        one obstacle."""
        i0 = np.maximum(np.floor((lo - self.origin) / self.resolution).astype(int), 0)  # (x, y[, z])
        i1 = np.minimum(np.ceil((hi - self.origin) / self.resolution).astype(int), np.array(self.shape[::-1]) - 1)
        if np.any(i1 < i0):
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.uint8)
        # cell index arrays in grid order ((iy, ix) or (iz, iy, ix)), row-major
        index = [a.ravel() for a in np.mgrid[tuple(slice(i0[k], i1[k] + 1) for k in reversed(range(self.dim)))]]
        pts = self.origin + self.resolution * np.column_stack(index[::-1])
        d = signed_distance(g, pts)
        top = len(self.levels) + 1
        near = d < (self.levels[-1] if self.levels else inflation)
        dn = d[near]
        level = sum((dn < m).astype(np.uint8) for m in self.levels) if self.levels else np.zeros(len(dn), np.uint8)
        level = np.where(dn < inflation, top, level).astype(np.uint8)
        flat = np.ravel_multi_index(tuple(a[near] for a in index), self.shape)
        return flat.astype(np.int64), level

    # ------------------------------------------------------------------ maps from scans

    @property
    def scanned(self) -> bool:
        """Whether the maps are built from the robots' scans (:meth:`use_scans`), not from the
        known obstacles."""
        return self._hits is not None

    def use_scans(self, reach: float = 0.0) -> None:
        """Build every robot's map from its own range scans from now on (``sense.map = scans``;
        docs/sensing.md, Maps from scans): the maps start empty, :meth:`observe` adds nothing,
        and :meth:`integrate` adds the cells the scans hit. Unknown space stays free, as the
        known map's unseen space (optimistic planning, as EGO-Planner's grid map).

        The distance to the hit cells is kept up to ``reach`` [m] (at least the widest clearance
        class and one cell more) and is ``reach`` beyond: a truncated distance field, as far as
        its planner reads it."""
        self.grids[:] = 0
        self._hits = np.zeros(self.grids.shape, dtype=bool)  # (N, *shape) cells a return fell in
        self._version = np.zeros(len(self.grids), dtype=np.int64)  # changes of each robot's map
        widest = max([self.inflation, *self.levels])
        self.reach = max(float(reach), widest) + self.resolution  # [m]
        self._distance = np.full(self.grids.shape, self.reach)  # [m] cell centre to the nearest hit cell centre
        # the cells within reach of a cell: offsets (S, dim) in grid order and their distances [m]
        r = int(math.ceil(self.reach / self.resolution))
        off = np.stack(np.mgrid[(slice(-r, r + 1),) * self.dim], axis=-1).reshape(-1, self.dim)
        dist = self.resolution * np.sqrt((off * off).sum(axis=1))
        keep = dist < self.reach
        self._stencil3 = np.ascontiguousarray(np.pad(off[keep], ((0, 0), (3 - self.dim, 0))))  # (S, 3) (dz, dy, dx)
        self._stencil_distance = np.ascontiguousarray(dist[keep])
        self._searched.clear()
        self._fields.clear()
        self._components.clear()

    def integrate(self, points: np.ndarray, hit: np.ndarray) -> np.ndarray:
        """Add each robot's returns to its map: ``points`` (N, R, dim) [m] where robot n placed
        return r (its pose estimate + range x ray direction), ``hit`` (N, R) bool the returns that
        met something (not max range). A return outside the bounds is dropped. Each newly hit cell
        lowers the distance of the cells within reach to their distance from it, and their
        clearance classes follow (module docstring): exactly the distance transform of the hit
        cells, truncated at the reach. Returns (N,) bool: the robots whose map gained a cell."""
        n = len(self.grids)
        counts = np.array(self.shape[::-1])  # nx, ny[, nz]
        cell = np.rint((points - self.origin) / self.resolution).astype(np.int64)  # (N, R, dim), (x, y[, z])
        inside = hit & np.all((cell >= 0) & (cell < counts), axis=2)
        robot = np.broadcast_to(np.arange(n)[:, None], inside.shape)[inside]
        grid_index = cell[inside][:, ::-1]  # (M, dim) in grid order (iy, ix) / (iz, iy, ix)
        flat = np.ravel_multi_index(tuple(grid_index.T), self.shape)
        layer = self._hits.reshape(n, -1)
        new = ~layer[robot, flat]
        # one entry per newly hit (robot, cell)
        key = np.unique(robot[new] * layer.shape[1] + flat[new])
        robot, flat = key // layer.shape[1], key % layer.shape[1]
        gained = np.zeros(n, dtype=bool)
        gained[robot] = True
        layer[robot, flat] = True
        self._version += gained
        if len(key):
            at = np.stack(np.unravel_index(flat, self.shape), axis=1)  # (K, dim) in grid order
            pad = 3 - self.dim  # a planar map is one layer of voxels
            vox = (1,) * pad + self.shape
            _stamp(self._distance.reshape(n, *vox), self.grids.reshape(n, *vox), robot,
                   np.ascontiguousarray(np.pad(at, ((0, 0), (pad, 0)))), self._stencil3, self._stencil_distance,
                   np.array(self.levels, dtype=np.float64), self.inflation, len(self.levels) + 1)
        return gained

    def esdf(self, robot: int) -> Esdf:
        """``robot``'s distance field from its scans: nodes at the cell centres, the distance [m]
        to the nearest hit cell centre up to the reach (:meth:`use_scans`), unsigned (a scan sees a
        surface, not an inside)."""
        return Esdf(origin=self.origin, resolution=self.resolution, values=self._distance[robot])

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each robot's distance field (:meth:`esdf`) at its own point: ``points`` (N, dim) [m],
        row n read in robot n's field; ``(value (N,) [m], gradient (N, dim))``, interpolated as
        :meth:`Esdf.query`."""
        pts = np.ascontiguousarray(points, dtype=np.float64)
        val = np.empty(len(pts))
        grad = np.empty(pts.shape)
        o = np.asarray(self.origin, dtype=np.float64)
        if self.dim == 2:
            _query_each2(self._distance, o[0], o[1], self.resolution, pts, val, grad)
        else:
            _query_each3(self._distance, o[0], o[1], o[2], self.resolution, pts, val, grad)
        return val, grad

    def hit_fraction(self) -> float:
        """The mean fraction of a robot's grid cells its scans have hit (0 without scans)."""
        return 0.0 if self._hits is None else float(self._hits.mean())

    def _map_key(self, robot: int) -> tuple:
        """What a search on ``robot``'s map is a function of, beside its cells: the obstacles it
        knows, or (maps from scans) the robot and its map's version."""
        if self._hits is not None:
            return ("scans", robot, int(self._version[robot]))
        return (self.known[robot].tobytes(),)

    def observe(self, robot: int, position: np.ndarray) -> int:
        """Add to ``robot``'s map every obstacle whose bounding box is within the sensing
        range of ``position``; returns how many were new (none with maps from scans)."""
        if not len(self.footprints) or self._hits is not None:
            return 0
        d = np.maximum(np.maximum(self.bbox_lo - position, position - self.bbox_hi), 0.0)
        near = np.einsum("ij,ij->i", d, d) <= self.sensing_range**2
        new = np.flatnonzero(near & ~self.known[robot])
        flat = self.grids[robot].reshape(-1)
        for o in new:
            idx, level = self.footprints[o]
            flat[idx] = np.maximum(flat[idx], level)
        self.known[robot, new] = True
        return len(new)

    def cell(self, p: np.ndarray) -> tuple[int, ...]:
        """Grid index ``(iy, ix)`` or ``(iz, iy, ix)`` of the cell holding ``p`` [m], clamped."""
        out = []
        for k in reversed(range(self.dim)):
            c = round((float(p[k]) - self._origin[k]) / self.resolution)  # half to even, as np.round
            out.append(min(max(c, 0), self.shape[-1 - k] - 1))
        return tuple(out)

    def center(self, *index: np.ndarray) -> np.ndarray:
        """Cell centres [m] (M, dim) of grid indices given as ``(iy, ix)`` or ``(iz, iy, ix)``."""
        return self.origin + self.resolution * np.column_stack(index[::-1])

    def search(self, robot: int, start: np.ndarray, goal: np.ndarray, max_expand: int,
               others: np.ndarray | None = None, others_radius: float = 0.0) -> np.ndarray | None:
        """A* path from ``start`` to ``goal`` [m] on ``robot``'s map: (P, dim) cell centres, the
        first replaced by ``start`` itself; None if no path. A start or goal inside an
        inflated obstacle is moved to the nearest free cell (as the released planner does).
        8-connected on a planar map, 26-connected on a voxel map."""
        occ = self.grids[robot]
        marked = others is not None and len(others) and others_radius > 0 and len(self.levels) > 1
        if marked:
            occ = occ.copy()  # neighbours: cells within others_radius join the wide (costly) band
            mark = _mark_balls if self.dim == 3 else _mark_discs
            mark(occ, (np.asarray(others) - self.origin) / self.resolution, others_radius / self.resolution)
        gc = self.cell(goal)
        sc = self.cell(start)
        key = None
        if self.dim == 2 and not marked:  # a planar search is a function of the map, the cells and the cap
            key = (*self._map_key(robot), sc, gc, int(max_expand))
            with self._lock:
                found = self._searched.pop(key, None)
                if found is not None:
                    self._searched[key] = found  # most recently used last
            if found is None:  # searched outside the lock: another thread may find the same path meanwhile
                found = self._search_cells(robot, occ, sc, gc, max_expand, marked)
                with self._lock:
                    self._searched.pop(key, None)
                    while len(self._searched) >= self._searched_kept:
                        self._searched.pop(next(iter(self._searched)))
                    self._searched[key] = found
        else:
            found = self._search_cells(robot, occ, sc, gc, max_expand, marked)
        idx, at_goal = found
        if len(idx) == 0:
            return None
        path = self.center(*np.unravel_index(idx, self.shape))
        path[0] = start
        if at_goal:  # the goal itself is free: end exactly on it
            path[-1] = goal
        return path

    def _search_cells(self, robot: int, occ, sc, gc, max_expand, marked) -> tuple[np.ndarray, bool]:
        """The search of :meth:`search` between the cells ``sc`` and ``gc``: ``(flat cell indices of
        the path, empty if none; whether it ends on ``gc`` itself)``."""
        nearest_free = _nearest_free3 if self.dim == 3 else _nearest_free
        idx = np.zeros(0, dtype=np.int64)
        g = gc
        top = len(self.levels) + 1
        for blocked in (top - 1, top) if top > 1 else (1,):  # keep d_thr if possible, else the body clearance
            s = nearest_free(occ, *sc, 40, blocked)
            g = nearest_free(occ, *gc, 40, blocked)
            if s[0] >= 0 and g[0] >= 0:
                if self.dim == 3 and self.field_3d and not marked:
                    idx = self._descend(robot, occ, s, g, blocked)
                elif self.dim == 3 and not marked and not self._connected(robot, occ, s, g, blocked):
                    idx = np.zeros(0, dtype=np.int64)  # what A* finds after expanding s's whole component
                else:
                    idx = self._astar(occ, s, g, max_expand, blocked)
                if len(idx):
                    break
        return idx, g == gc

    def _connected(self, robot: int, occ, s, g, blocked) -> bool:
        """Whether voxels ``s`` and ``g`` lie in one connected component of ``robot``'s passable
        voxels (``occ < blocked``). A diagonal step needs every voxel it grazes passable, so
        26-connected paths connect exactly the face-connected (6-connected) components, labelled
        once per map and tier by scipy.ndimage. A search between components expands the start's
        whole component (or its expansion cap) and fails; knowing that beforehand gives the same
        result for a lookup."""
        key = (*self._map_key(robot), blocked)
        with self._lock:
            labels = self._components.pop(key, None)
            if labels is not None:
                self._components[key] = labels  # most recently used last
        if labels is None:  # labelled outside the lock (the labels are a function of the key)
            labels, _ = ndimage.label(occ < blocked, structure=ndimage.generate_binary_structure(3, 1))
            with self._lock:
                self._components.pop(key, None)
                while len(self._components) >= _FIELDS_KEPT:
                    self._components.pop(next(iter(self._components)))
                self._components[key] = labels
        return bool(labels[s] == labels[g] != 0)

    def _descend(self, robot: int, occ, s, g, blocked) -> np.ndarray:
        """Flat voxel indices of an optimal path from ``s`` to ``g`` on ``robot``'s map (empty:
        none), from cost-to-go fields: down the field of this very map if one is kept; else, where
        a kept field was built on a map whose obstacles this map holds too, by A* with that field
        as its heuristic (admissible and consistent when the tier's costs do not fall with the
        clearance class: a map that gained obstacles only costs more); else a new field."""
        known = self.known[robot]
        key = (*self._map_key(robot), g, blocked)
        kept = self._fields.pop(key, None)
        if kept is not None:
            self._fields[key] = kept  # most recently used last
            return _descend3(occ, kept[0], s, g, blocked, self.cost, _STEPS3)
        # a kept field guides the search where its map's obstacles are a subset of this one's;
        # maps from scans are not nested by obstacles, so they build their own
        if self._hits is None and np.all(np.diff(self.cost[:blocked]) >= 0):
            guides = [(int(k.sum()), f) for (_, kg, kb), (f, k) in self._fields.items()
                      if kg == g and kb == blocked and not np.any(k & ~known)]
            if guides:
                field = max(guides, key=lambda c: c[0])[1]
                (gcost, parent, seen, closed, keys, vals), sid = self._work()
                idx, keys, vals = _astar3h(occ, s, g, blocked, self.cost, _STEPS3, field, sid,
                                           gcost, parent, seen, closed, keys, vals)
                self._local.work = (gcost, parent, seen, closed, keys, vals)
                return idx
        field = _cost_to_go3(occ, g, blocked, self.cost, _STEPS3)
        self.fields_built += 1
        while len(self._fields) >= _FIELDS_KEPT:
            self._fields.pop(next(iter(self._fields)))
        self._fields[key] = (field, known.copy())
        return _descend3(occ, field, s, g, blocked, self.cost, _STEPS3)

    def _astar(self, occ, s, g, max_expand, blocked) -> np.ndarray:
        """Flat cell indices of the A* path between free cells ``s`` and ``g`` (empty: none)."""
        work, sid = self._work()
        if self.dim == 2:
            g_, parent, mark, keys, vals = work
            idx, keys, vals = _astar(occ, s[0], s[1], g[0], g[1], max_expand, blocked, self.cost,
                                     sid, g_, parent, mark, keys, vals)
            self._local.work = (g_, parent, mark, keys, vals)  # the heap arrays may have grown
            return idx
        gcost, parent, seen, closed, keys, vals = work
        idx, keys, vals = _astar3(occ, s, g, max_expand, blocked, self.cost, _STEPS3, sid,
                                  gcost, parent, seen, closed, keys, vals, self.weight_3d)
        self._local.work = (gcost, parent, seen, closed, keys, vals)
        return idx


@njit(cache=True, nogil=True)
def _mark_discs(occ, centres, radius):
    """Raise cells within ``radius`` [cells] of each centre [cells] to at least class 1."""
    ny, nx = occ.shape
    r = int(radius) + 1
    for k in range(centres.shape[0]):
        cx, cy = centres[k, 0], centres[k, 1]
        for y in range(max(int(cy) - r, 0), min(int(cy) + r + 2, ny)):
            for x in range(max(int(cx) - r, 0), min(int(cx) + r + 2, nx)):
                if (x - cx) ** 2 + (y - cy) ** 2 <= radius * radius and occ[y, x] == 0:
                    occ[y, x] = 1


@njit(cache=True, nogil=True)
def _mark_balls(occ, centres, radius):
    """Raise voxels within ``radius`` [cells] of each centre [cells, (x, y, z)] to at least class 1."""
    nz, ny, nx = occ.shape
    r = int(radius) + 1
    for k in range(centres.shape[0]):
        cx, cy, cz = centres[k, 0], centres[k, 1], centres[k, 2]
        for z in range(max(int(cz) - r, 0), min(int(cz) + r + 2, nz)):
            for y in range(max(int(cy) - r, 0), min(int(cy) + r + 2, ny)):
                for x in range(max(int(cx) - r, 0), min(int(cx) + r + 2, nx)):
                    if (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2 <= radius * radius and occ[z, y, x] == 0:
                        occ[z, y, x] = 1


@njit(cache=True, nogil=True)
def _nearest_free3(occ, iz, iy, ix, max_r, blocked):
    """Nearest voxel with ``occ < blocked`` (Chebyshev shells, Euclidean within a shell) to
    (iz, iy, ix); (-1, -1, -1) if none within ``max_r`` cells."""
    nz, ny, nx = occ.shape
    if occ[iz, iy, ix] < blocked:
        return iz, iy, ix
    for r in range(1, max_r + 1):
        best = 1e18
        bz, by, bx = -1, -1, -1
        for dz in range(-r, r + 1):
            for dy in range(-r, r + 1):
                for dx in range(-r, r + 1):
                    if max(abs(dz), max(abs(dy), abs(dx))) != r:
                        continue
                    z, y, x = iz + dz, iy + dy, ix + dx
                    if 0 <= z < nz and 0 <= y < ny and 0 <= x < nx and occ[z, y, x] < blocked:
                        d = dz * dz + dy * dy + dx * dx
                        if d < best:
                            best, bz, by, bx = d, z, y, x
        if bz >= 0:
            return bz, by, bx
    return -1, -1, -1


@njit(cache=True, nogil=True)
def _nearest_free(occ, iy, ix, max_r, blocked):
    """Nearest cell with ``occ < blocked`` (Chebyshev rings, Euclidean within a ring) to
    (iy, ix); (-1, -1) if none within ``max_r`` cells."""
    ny, nx = occ.shape
    if occ[iy, ix] < blocked:
        return iy, ix
    for r in range(1, max_r + 1):
        best = 1e18
        by, bx = -1, -1
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if max(abs(dy), abs(dx)) != r:
                    continue
                y, x = iy + dy, ix + dx
                if 0 <= y < ny and 0 <= x < nx and occ[y, x] < blocked:
                    d = dy * dy + dx * dx
                    if d < best:
                        best, by, bx = d, y, x
        if by >= 0:
            return by, bx
    return -1, -1


@njit(cache=True)
def _heap_push(keys, vals, size, key, val):
    """Push ``(key, val)`` on the binary min-heap ``keys[:size]``, ``vals[:size]`` (grown by doubling
    when full). The new entry moves up while its parent's key is larger (a hole moves instead of
    swaps: the same comparisons and the same arrangement as swapping). Returns the arrays and the
    new size."""
    if size == keys.shape[0]:
        nk = np.empty(2 * size)
        nv = np.empty(2 * size, dtype=np.int64)
        nk[:size] = keys
        nv[:size] = vals
        keys, vals = nk, nv
    k = size
    while k > 0:
        p = (k - 1) // 2
        kp = keys[p]
        if kp <= key:
            break
        keys[k] = kp
        vals[k] = vals[p]
        k = p
    keys[k] = key
    vals[k] = val
    return keys, vals, size + 1


@njit(cache=True)
def _heap_pop(keys, vals, size):
    """Pop the root of the heap: the last entry moves down from the root while the smaller child
    (the left one on a tie) has a smaller key (a hole, as in :func:`_heap_push`). Returns the
    root's value and the new size."""
    val = vals[0]
    size -= 1
    key = keys[size]
    last = vals[size]
    k = 0
    while True:
        l = 2 * k + 1
        if l >= size:
            break
        c = l
        kc = keys[l]
        if l + 1 < size and keys[l + 1] < kc:
            c = l + 1
            kc = keys[c]
        if key <= kc:
            break
        keys[k] = kc
        vals[k] = vals[c]
        k = c
    keys[k] = key
    vals[k] = last
    return val, size


@njit(cache=True)
def _walk_back(parent, s, goal):
    """Flat cell indices of the path ``s -> goal`` read back through ``parent``."""
    count = 1
    c = goal
    while c != s:
        c = parent[c]
        count += 1
    out = np.empty(count, dtype=np.int64)
    c = goal
    for k in range(count - 1, -1, -1):
        out[k] = c
        c = parent[c]
    return out


@njit(cache=True, nogil=True)
def _astar(occ, sy, sx, gy, gx, max_expand, blocked, cost, sid, g, parent, mark, keys, vals):
    """A* over the cells with ``occ < blocked`` of an 8-connected grid, step length 1 (diagonal
    sqrt(2)) times ``cost[occ]`` of the entered cell (all >= 1), no corner cutting, octile
    heuristic (ties broken towards larger g). Returns ``(flat cell indices start -> goal, empty
    if the goal is unreachable within max_expand expansions, keys, vals)`` (the heap arrays,
    possibly grown).

    The work arrays ``g`` (cost), ``parent`` (int32) and ``mark`` (int32) are kept between
    searches: for search number ``sid`` a cell is unseen while ``mark < 2 sid``, seen with a
    valid ``g`` and ``parent`` at ``2 sid`` and closed at ``2 sid + 1``, so nothing is cleared
    and a search costs what it expands, not the size of the grid."""
    ny, nx = occ.shape
    of = occ.ravel()
    opened = 2 * sid
    done = opened + 1
    s = sy * nx + sx
    goal = gy * nx + gx
    g[s] = 0.0
    mark[s] = opened
    parent[s] = -1
    keys, vals, size = _heap_push(keys, vals, 0, 0.0, s)
    dys = (-1, -1, -1, 0, 0, 1, 1, 1)
    dxs = (-1, 0, 1, -1, 1, -1, 0, 1)
    expanded = 0
    found = False
    while size > 0:
        cur, size = _heap_pop(keys, vals, size)
        if mark[cur] == done:
            continue
        if cur == goal:
            found = True
            break
        mark[cur] = done
        expanded += 1
        if expanded > max_expand:
            break
        cy = cur // nx
        cx = cur - cy * nx
        gcur = g[cur]
        for k in range(8):
            dy = dys[k]
            dx = dxs[k]
            y = cy + dy
            x = cx + dx
            if y < 0 or y >= ny or x < 0 or x >= nx:
                continue
            nb = y * nx + x
            o = of[nb]
            if o >= blocked:
                continue
            diag = dy != 0 and dx != 0
            if diag and (of[cy * nx + x] >= blocked or of[y * nx + cx] >= blocked):
                continue
            m = mark[nb]
            if m == done:
                continue
            ng = gcur + (1.4142135623730951 if diag else 1.0) * cost[o]
            if m != opened or ng < g[nb]:
                mark[nb] = opened
                g[nb] = ng
                parent[nb] = cur
                ady = abs(gy - y)
                adx = abs(gx - x)
                h = (ady + adx) + (1.4142135623730951 - 2.0) * min(ady, adx)
                keys, vals, size = _heap_push(keys, vals, size, ng + h * 1.001, nb)
    if not found:
        return np.zeros(0, dtype=np.int64), keys, vals
    return _walk_back(parent, s, goal), keys, vals


@njit(cache=True, nogil=True)
def _astar3(occ, s3, g3, max_expand, blocked, cost, steps, sid, g, parent, seen, closed, keys, vals, weight):
    """A* over the voxels with ``occ < blocked`` of the 26-connected grid: step length 1,
    sqrt(2) or sqrt(3) times ``cost[occ]`` of the entered voxel, no corner cutting (every voxel
    a diagonal step grazes, i.e. each partial step of its offsets, must be passable), 3-D octile
    heuristic ``d1 + (sqrt2 - 1) d2 + (sqrt3 - sqrt2) d3`` (d1 >= d2 >= d3) times ``weight``
    (>= 1; just above 1 it only breaks ties towards larger g, as the planar search). ``g, parent`` hold values for voxels whose ``seen == sid`` (this
    search's number), ``closed == sid`` marks expanded ones, so nothing is cleared between
    searches. Returns ``(flat voxel indices start -> goal or empty, keys, vals)`` (the heap
    arrays, possibly grown)."""
    nz, ny, nx = occ.shape
    plane = ny * nx
    s = (s3[0] * ny + s3[1]) * nx + s3[2]
    goal = (g3[0] * ny + g3[1]) * nx + g3[2]
    gz, gy, gx = g3[0], g3[1], g3[2]
    g[s] = 0.0
    seen[s] = sid
    parent[s] = -1
    keys, vals, size = _heap_push(keys, vals, 0, 0.0, s)
    r2, r3 = 1.4142135623730951, 1.7320508075688772
    expanded = 0
    found = False
    while size > 0:
        cur, size = _heap_pop(keys, vals, size)
        if closed[cur] == sid:
            continue
        if cur == goal:
            found = True
            break
        closed[cur] = sid
        expanded += 1
        if expanded > max_expand:
            break
        cz = cur // plane
        cy = (cur - cz * plane) // nx
        cx = cur - cz * plane - cy * nx
        for k in range(steps.shape[0]):
            dz, dy, dx = steps[k, 0], steps[k, 1], steps[k, 2]
            if not _passable3(occ, cz, cy, cx, dz, dy, dx, blocked):
                continue
            z, y, x = cz + dz, cy + dy, cx + dx
            axes = abs(dz) + abs(dy) + abs(dx)
            nb = (z * ny + y) * nx + x
            if closed[nb] == sid:
                continue
            step = 1.0 if axes == 1 else (r2 if axes == 2 else r3)
            ng = g[cur] + step * cost[occ[z, y, x]]
            if seen[nb] != sid or ng < g[nb]:
                seen[nb] = sid
                g[nb] = ng
                parent[nb] = cur
                a, b, c = abs(gz - z), abs(gy - y), abs(gx - x)
                d1 = max(a, max(b, c))
                d3 = min(a, min(b, c))
                d2 = a + b + c - d1 - d3
                h = d1 + (r2 - 1.0) * d2 + (r3 - r2) * d3
                keys, vals, size = _heap_push(keys, vals, size, ng + h * weight, nb)
    if not found:
        return np.zeros(0, dtype=np.int64), keys, vals
    return _walk_back(parent, s, goal), keys, vals


@njit(cache=True)
def _passable3(occ, cz, cy, cx, dz, dy, dx, blocked):
    """Whether the step (dz, dy, dx) from voxel (cz, cy, cx) may be taken: it stays in the grid,
    enters a voxel below ``blocked`` and grazes none at or above it (no corner cutting: every
    partial step, a proper subset of the offsets, must be passable). Symmetric: the step back
    grazes the same voxels."""
    nz, ny, nx = occ.shape
    z, y, x = cz + dz, cy + dy, cx + dx
    if z < 0 or z >= nz or y < 0 or y >= ny or x < 0 or x >= nx or occ[z, y, x] >= blocked:
        return False
    axes = abs(dz) + abs(dy) + abs(dx)
    if axes > 1:
        for mask in range(1, 7):
            pz, py, px = dz * (mask >> 2), dy * ((mask >> 1) & 1), dx * (mask & 1)
            part = abs(pz) + abs(py) + abs(px)
            if 0 < part < axes and occ[cz + pz, cy + py, cx + px] >= blocked:
                return False
    return True


@njit(cache=True, nogil=True)
def _cost_to_go3(occ, g3, blocked, cost, steps):
    """Cost of the cheapest 26-connected path from every voxel to ``g3`` (inf: unreachable), by
    Dijkstra backwards from the goal over the voxels with ``occ < blocked``: a step costs its
    length (1, sqrt 2, sqrt 3) times ``cost[occ]`` of the voxel it enters, no corner cutting;
    the same costs as the A* (``_astar3``)."""
    nz, ny, nx = occ.shape
    plane = ny * nx
    dist = np.full(nz * plane, np.inf)
    done = np.zeros(nz * plane, dtype=np.bool_)
    keys = np.empty(1 << 16)
    vals = np.empty(1 << 16, dtype=np.int64)
    goal = (g3[0] * ny + g3[1]) * nx + g3[2]
    dist[goal] = 0.0
    keys, vals, size = _heap_push(keys, vals, 0, 0.0, goal)
    lengths = (0.0, 1.0, 1.4142135623730951, 1.7320508075688772)
    while size > 0:
        cur, size = _heap_pop(keys, vals, size)
        if done[cur]:
            continue
        done[cur] = True
        cz = cur // plane
        cy = (cur - cz * plane) // nx
        cx = cur - cz * plane - cy * nx
        enter = cost[occ[cz, cy, cx]]  # a predecessor pays for entering this voxel
        for k in range(steps.shape[0]):
            dz, dy, dx = steps[k, 0], steps[k, 1], steps[k, 2]
            if not _passable3(occ, cz, cy, cx, dz, dy, dx, blocked):
                continue
            nb = ((cz + dz) * ny + cy + dy) * nx + cx + dx
            if done[nb]:
                continue
            nd = dist[cur] + lengths[abs(dz) + abs(dy) + abs(dx)] * enter
            if nd < dist[nb]:
                dist[nb] = nd
                keys, vals, size = _heap_push(keys, vals, size, nd, nb)
    return dist.reshape(occ.shape)


@njit(cache=True, nogil=True)
def _astar3h(occ, s3, g3, blocked, cost, steps, h, sid, g, parent, seen, closed, keys, vals):
    """A* as ``_astar3`` (same steps, costs, corner rule and work arrays) with the heuristic read
    from ``h`` (a cost-to-go field of a map with fewer obstacles; voxels it cannot reach are not
    entered), weighted by ``_TIE`` = 1 + 1e-6 only to break ties towards larger g (equal-cost paths
    fill whole slabs of a 26-connected grid, all of which an unweighted search would expand).
    Returns ``(flat voxel indices start -> goal or empty, keys, vals)``."""
    nz, ny, nx = occ.shape
    plane = ny * nx
    hf = h.ravel()
    s = (s3[0] * ny + s3[1]) * nx + s3[2]
    goal = (g3[0] * ny + g3[1]) * nx + g3[2]
    if not np.isfinite(hf[s]):
        return np.zeros(0, dtype=np.int64), keys, vals
    g[s] = 0.0
    seen[s] = sid
    parent[s] = -1
    keys, vals, size = _heap_push(keys, vals, 0, hf[s], s)
    lengths = (0.0, 1.0, 1.4142135623730951, 1.7320508075688772)
    found = False
    while size > 0:
        cur, size = _heap_pop(keys, vals, size)
        if closed[cur] == sid:
            continue
        if cur == goal:
            found = True
            break
        closed[cur] = sid
        cz = cur // plane
        cy = (cur - cz * plane) // nx
        cx = cur - cz * plane - cy * nx
        for k in range(steps.shape[0]):
            dz, dy, dx = steps[k, 0], steps[k, 1], steps[k, 2]
            if not _passable3(occ, cz, cy, cx, dz, dy, dx, blocked):
                continue
            z, y, x = cz + dz, cy + dy, cx + dx
            nb = (z * ny + y) * nx + x
            if closed[nb] == sid or not np.isfinite(hf[nb]):
                continue
            ng = g[cur] + lengths[abs(dz) + abs(dy) + abs(dx)] * cost[occ[z, y, x]]
            if seen[nb] != sid or ng < g[nb]:
                seen[nb] = sid
                g[nb] = ng
                parent[nb] = cur
                keys, vals, size = _heap_push(keys, vals, size, ng + hf[nb] * _TIE, nb)
    if not found:
        return np.zeros(0, dtype=np.int64), keys, vals
    return _walk_back(parent, s, goal), keys, vals


@njit(cache=True, nogil=True)
def _descend3(occ, field, s3, g3, blocked, cost, steps):
    """Flat voxel indices of the path from ``s3`` to ``g3`` that takes, from each voxel, the
    step minimising step cost + cost-to-go (the first such step in ``steps`` order): an optimal
    path of ``_cost_to_go3``'s costs. Empty if ``s3`` cannot reach the goal."""
    nz, ny, nx = occ.shape
    plane = ny * nx
    if not np.isfinite(field[s3[0], s3[1], s3[2]]):
        return np.zeros(0, dtype=np.int64)
    lengths = (0.0, 1.0, 1.4142135623730951, 1.7320508075688772)
    out = np.empty(256, dtype=np.int64)
    cz, cy, cx = s3[0], s3[1], s3[2]
    out[0] = (cz * ny + cy) * nx + cx
    count = 1
    while cz != g3[0] or cy != g3[1] or cx != g3[2]:
        best, bz, by, bx = np.inf, -1, -1, -1
        for k in range(steps.shape[0]):
            dz, dy, dx = steps[k, 0], steps[k, 1], steps[k, 2]
            if not _passable3(occ, cz, cy, cx, dz, dy, dx, blocked):
                continue
            z, y, x = cz + dz, cy + dy, cx + dx
            val = lengths[abs(dz) + abs(dy) + abs(dx)] * cost[occ[z, y, x]] + field[z, y, x]
            if val < best:
                best, bz, by, bx = val, z, y, x
        if bz < 0 or count > nz * plane:  # cannot happen on a finite field; guards a loop
            return np.zeros(0, dtype=np.int64)
        cz, cy, cx = bz, by, bx
        if count == out.shape[0]:
            grown = np.empty(2 * count, dtype=np.int64)
            grown[:count] = out
            out = grown
        out[count] = (cz * ny + cy) * nx + cx
        count += 1
    return out[:count].copy()


@njit(cache=True, nogil=True)
def _stamp(dist, grids, robots, cells, stencil, sdist, levels, inflation, top):
    """Lower ``dist[r]`` (N, nz, ny, nx) [m] around each newly hit voxel ``cells[k]`` of robot
    ``robots[k]`` to the distance ``sdist[s]`` of each ``stencil`` offset, and set the clearance
    class in ``grids`` of every voxel lowered: the number of ``levels`` above its distance, or
    ``top`` within ``inflation``."""
    nz, ny, nx = dist.shape[1], dist.shape[2], dist.shape[3]
    for k in range(cells.shape[0]):
        r = robots[k]
        for s in range(stencil.shape[0]):
            z = cells[k, 0] + stencil[s, 0]
            y = cells[k, 1] + stencil[s, 1]
            x = cells[k, 2] + stencil[s, 2]
            if z < 0 or z >= nz or y < 0 or y >= ny or x < 0 or x >= nx:
                continue
            d = sdist[s]
            if d < dist[r, z, y, x]:
                dist[r, z, y, x] = d
                if d < inflation:
                    grids[r, z, y, x] = top
                else:
                    lv = 0
                    for m in range(levels.shape[0]):
                        if d < levels[m]:
                            lv += 1
                    grids[r, z, y, x] = lv


@njit(cache=True)
def _query_each2(values, ox, oy, res, points, out_v, out_g):
    """Row n of ``points`` in the planar field ``values[n]`` (bilinear, as Esdf.query)."""
    for n in range(points.shape[0]):
        esdf_query_kernel(values[n], ox, oy, res, points[n:n + 1], out_v[n:n + 1], out_g[n:n + 1])


@njit(cache=True)
def _query_each3(values, ox, oy, oz, res, points, out_v, out_g):
    """Row n of ``points`` in the voxel field ``values[n]`` (trilinear, as Esdf.query)."""
    for n in range(points.shape[0]):
        esdf3d_query_kernel(values[n], ox, oy, oz, res, points[n:n + 1], out_v[n:n + 1], out_g[n:n + 1])


def resample(path: np.ndarray, spacing: float) -> np.ndarray:
    """Points every ``spacing`` [m] of arc length along a polyline, from its first point to
    its last (a remainder shorter than half a spacing stretches the last interval)."""
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total <= 1e-12:
        return path[:1].copy()
    n = int(math.floor(total / spacing))
    ts = spacing * np.arange(n + 1)
    if total - ts[-1] > 0.5 * spacing or n == 0:
        ts = np.append(ts, total)
    else:  # a short remainder: stretch the last interval rather than add a near-duplicate point
        ts[-1] = total
    out = np.column_stack([np.interp(ts, s, path[:, d]) for d in range(path.shape[1])])
    return out
