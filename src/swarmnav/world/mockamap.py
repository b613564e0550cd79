"""The map generators of mockamap, the simulator world of SPH's and EGO-Swarm's released code.

mockamap (HKUST Aerial Robotics; copied into the EGO-Swarm and SPH releases) draws a voxel world
of ``x_length x y_length x z_length`` metres at ``resolution`` metres per voxel, centred on
x = y = 0 with its floor at z = 0, and publishes one point per occupied voxel. Its four map types:

1. **Perlin 3-D noise**: improved Perlin noise (Perlin 2002) of the voxel indices,
   ``sum over it = 1..fractal of (attenuation / it) * noise(2^it * complexity * (i, j, k))``;
   the ``fill`` fraction of voxels with the largest noise is occupied (the threshold is the
   value at rank ``int(N (1 - fill))`` of the N sorted values; a voxel above it is occupied).
2. **Random posts**: ``obstacle_number`` square posts, centre uniform over the map, side uniform
   in ``[width_min, width_max]``, height uniform in ``[0, z_length]`` [m]; a post of side w covers
   ``2 * (ceil(w / res) // 2)`` voxels along x and y from its centre's voxel, and ``ceil(h / res)``
   layers from the floor.
3. **2-D maze**: recursive division of a grid of ``road_width`` cells (walls one cell thick, three
   doors in the four wall arms of each division), every wall cell extruded from floor to ceiling.
4. **3-D maze**: ``numNodes`` random voxels are cell cores; a voxel whose two nearest cores are
   nearly equidistant (distance difference below one voxel) lies on a wall; the walls between
   cores whose indices sum into ``(int((1 - connectivity) N), int((1 + connectivity) N))`` have a
   hole of ``roadRad`` (voxels / 3) round the line joining the two cores.

What is ours (docs/maps-generators.md): the random numbers (NumPy, not the C++ library's engines,
so a seed gives a different map of the same kind), solid posts (mockamap publishes only a post's
surface voxels; its inside is enclosed, and solid posts give the inside test and signed distance
the post they see), and a maze division that is correct on rectangular grids.

Draws come from a stream of their own, ``SeedSequence([seed, TAG])``.
"""

from __future__ import annotations

import math

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world.maps import OccupancyGrid

#: The stream tag of mockamap draws ("mock"): SeedSequence([seed, TAG]).
TAG = 0x6D6F636B
#: Map types, as mockamap numbers them.
TYPES = {1: "perlin3d", 2: "random", 3: "maze2d", 4: "maze3d"}
#: Most voxels a map may have (our choice: 2.6 times SPH's released world of 200 x 200 x 40 voxels;
#: the Perlin noise and the 3-D maze hold a few float arrays of this size).
MAX_VOXELS = 1 << 22


def voxel_shape(resolution: float, x_length: float, y_length: float, z_length: float) -> tuple[int, int, int]:
    """Voxels along x, y, z: ``int(length / resolution)``, as mockamap sizes its map (a small
    tolerance keeps e.g. 20 m / 0.1 m at 200 voxels despite rounding)."""
    return tuple(int(math.floor(v / resolution + 1e-9)) for v in (x_length, y_length, z_length))


def generate(type: int = 1, seed: int = 511, resolution: float = 0.1, x_length: float = 20.0,
             y_length: float = 20.0, z_length: float = 4.0, complexity: float = 0.03, fill: float = 0.15,
             fractal: int = 1, attenuation: float = 0.1, width_min: float = 0.6, width_max: float = 1.5,
             obstacle_number: int = 10, road_width: float = 1.0, add_wall_x: int = 0, add_wall_y: int = 0,
             numNodes: int = 10, connectivity: float = 0.5, roadRad: int = 2) -> OccupancyGrid:
    """A mockamap world as a 3-D occupancy grid (module docstring; parameters as mockamap names them).

    The grid's voxel ``[k, j, i]`` is the cube with lower corner ``(-X/2 + i r, -Y/2 + j r, k r)``
    for ``r = resolution`` and ``X = nx r``, ``Y = ny r`` (:func:`voxel_shape`): the point mockamap
    publishes for that voxel is this corner, and a map built from its cloud marks this cube.
    Ranges are checked by the scene generator (``swarmnav.world.generators.mockamap``).
    """
    nx, ny, nz = voxel_shape(resolution, x_length, y_length, z_length)
    if min(nx, ny, nz) < 1:
        raise ScenarioError(f"mockamap: resolution {resolution:g} m is coarser than the map "
                            f"({x_length:g} x {y_length:g} x {z_length:g} m)")
    if nx * ny * nz > MAX_VOXELS:
        raise ScenarioError(f"mockamap: {nx} x {ny} x {nz} voxels is more than {MAX_VOXELS}; "
                            "raise resolution or shrink the map")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), TAG]))
    if type == 1:
        occ = _perlin_map(rng, (nz, ny, nx), complexity, fill, fractal, attenuation)
    elif type == 2:
        occ = _random_posts(rng, (nz, ny, nx), resolution, width_min, width_max, obstacle_number)
    elif type == 3:
        occ = _maze2d_map(rng, (nz, ny, nx), resolution, road_width, add_wall_x, add_wall_y)
    elif type == 4:
        occ = _maze3d_map(rng, (nz, ny, nx), numNodes, connectivity, roadRad)
    else:
        raise ScenarioError(f"mockamap: type must be one of 1-4 ({', '.join(f'{k} {v}' for k, v in TYPES.items())}), "
                            f"got {type!r}")
    occ.setflags(write=False)
    origin = (-nx * resolution / 2, -ny * resolution / 2, 0.0)
    return OccupancyGrid(occ, origin, float(resolution), f"mockamap:type={type},seed={seed}")


# --------------------------------------------------------------------------- 1: Perlin 3-D noise

def perlin_noise(perm: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Improved Perlin noise (Perlin 2002, "Improving noise") in [0, 1], as mockamap scales it.

    Args:
        perm: (512,) int permutation table (a permutation of 0-255, repeated).
        x, y, z: coordinates, broadcast together.

    Returns:
        ``(n + 1) / 2`` for the gradient noise ``n`` in [-1, 1]: the fade curve
        ``6t^5 - 15t^4 + 10t^3`` blends the dot products of the 12 edge gradients hashed to the
        eight corners of the unit cube round each point.
    """
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    X, Y, Z = (f.astype(np.int64) & 255 for f in (fx, fy, fz))
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = (t * t * t * (t * (t * 6.0 - 15.0) + 10.0) for t in (x, y, z))
    A = perm[X] + Y
    B = perm[X + 1] + Y
    AA, AB, BA, BB = perm[A] + Z, perm[A + 1] + Z, perm[B] + Z, perm[B + 1] + Z

    def grad(h, gx, gy, gz):  # the 12 directions to the cube's edge midpoints (4 repeated)
        h = perm[h] & 15
        a = np.where(h < 8, gx, gy)
        b = np.where(h < 4, gy, np.where((h == 12) | (h == 14), gx, gz))
        return np.where(h & 1, -a, a) + np.where(h & 2, -b, b)

    def lerp(t, a, b):
        return a + t * (b - a)

    x1, y1, z1 = x - 1.0, y - 1.0, z - 1.0
    res = lerp(w,
               lerp(v, lerp(u, grad(AA, x, y, z), grad(BA, x1, y, z)),
                    lerp(u, grad(AB, x, y1, z), grad(BB, x1, y1, z))),
               lerp(v, lerp(u, grad(AA + 1, x, y, z1), grad(BA + 1, x1, y, z1)),
                    lerp(u, grad(AB + 1, x, y1, z1), grad(BB + 1, x1, y1, z1))))
    return (res + 1.0) / 2.0


def perlin_field(rng: np.random.Generator, shape: tuple[int, int, int], complexity: float, fractal: int,
                 attenuation: float) -> np.ndarray:
    """mockamap's fractal noise of the voxel indices, (nz, ny, nx): the sum over octaves
    ``it = 1..fractal`` of ``attenuation / it * noise(2^it complexity (i, j, k))``."""
    perm = rng.permutation(256)
    perm = np.concatenate([perm, perm]).astype(np.int64)
    nz, ny, nx = shape
    out = np.zeros(shape)
    i, j = np.arange(nx)[None, :], np.arange(ny)[:, None]
    for k in range(nz):  # one layer at a time: a few (ny, nx) temporaries, not (nz, ny, nx) ones
        for it in range(1, fractal + 1):
            f = 2**it
            out[k] += attenuation / it * perlin_noise(perm, (f * i) * complexity, (f * j) * complexity,
                                                      np.full((1, 1), (f * k) * complexity))
    return out


def _perlin_map(rng, shape, complexity, fill, fractal, attenuation) -> np.ndarray:
    v = perlin_field(rng, shape, complexity, fractal, attenuation)
    flat = v.ravel()
    tpos = int(flat.size * (1.0 - fill))
    threshold = np.partition(flat, tpos)[tpos]  # mockamap: sort, take the value at rank tpos
    return v > threshold


# --------------------------------------------------------------------------- 2: random posts

def _random_posts(rng, shape, res, width_min, width_max, number) -> np.ndarray:
    nz, ny, nx = shape
    occ = np.zeros(shape, dtype=bool)
    # mockamap draws x, y in [-X/2, X/2], w, h per post: here the voxel coordinates from the map's corner
    x = rng.uniform(0.0, nx * res, number)
    y = rng.uniform(0.0, ny * res, number)
    w = rng.uniform(width_min, width_max, number)
    h = rng.uniform(0.0, nz * res, number)
    half = np.ceil(w / res - 1e-9).astype(np.int64) // 2  # mockamap: r in [-(n / 2), n / 2) for n = ceil(w / res)
    layers = np.minimum(np.ceil(h / res - 1e-9).astype(np.int64), nz)
    i0 = np.floor(x / res).astype(np.int64)
    j0 = np.floor(y / res).astype(np.int64)
    for a, b, s, t in zip(i0.tolist(), j0.tolist(), half.tolist(), layers.tolist()):
        occ[:t, max(b - s, 0):max(b + s, 0), max(a - s, 0):max(a + s, 0)] = True  # clipped to the map
    return occ


# --------------------------------------------------------------------------- 3: 2-D maze

def _maze2d_map(rng, shape, res, road_width, add_wall_x, add_wall_y) -> np.ndarray:
    nz, ny, nx = shape
    per = road_width / res
    cw = int(round(per))
    if cw < 1 or abs(per - cw) > 1e-6 * max(1.0, per):
        raise ScenarioError(f"mockamap: road_width ({road_width:g} m) must be a whole number of voxels "
                            f"({res:g} m each)")
    mx, my = nx // cw, ny // cw
    if mx < 1 or my < 1:
        raise ScenarioError(f"mockamap: road_width ({road_width:g} m) is wider than the map")
    maze = maze2d(rng, mx, my)
    if add_wall_x:
        maze[:, 0] = maze[:, -1] = True
    if add_wall_y:
        maze[0, :] = maze[-1, :] = True
    plane = np.zeros((ny, nx), dtype=bool)
    plane[: my * cw, : mx * cw] = np.kron(maze.T, np.ones((cw, cw), dtype=bool))
    return np.broadcast_to(plane, shape).copy()


def maze2d(rng: np.random.Generator, mx: int, my: int) -> np.ndarray:
    """A recursive-division maze of ``mx x my`` cells, ``maze[i, j]`` True for a wall cell.

    A region of at least 5 x 5 cells gets a wall along a random row and a random column, each one
    cell thick, crossing at an interior cell; three of the four wall arms get a door (one free
    cell each), the arm left shut chosen at random; a wall's end is opened where it would close a
    door of the enclosing wall; then the four quarters are divided in turn. A 4 x 4 region is
    divided once without recursion; a 3 x 4 (4 x 3) strip gets one wall across its middle with a
    door; a 3 x 3 region gets a post at its centre. (mockamap's rules, on both axes of a
    rectangular grid.)
    """
    m = np.zeros((mx, my), dtype=bool)
    stack = [(0, mx - 1, 0, my - 1)]
    while stack:
        xl, xh, yl, yh = stack.pop()
        if xh - xl >= 3 and yh - yl >= 3:
            big = xh - xl >= 4 and yh - yl >= 4
            for _ in range(64):  # a wall in front of a door of the enclosing wall: choose again
                xm = int(rng.integers(xl + 1, xh))
                ym = int(rng.integers(yl + 1, yh))
                if not big or not _blocks_door(m, xl, xh, yl, yh, xm, ym):
                    break
            m[xl:xh + 1, ym] = True
            m[xm, yl:yh + 1] = True
            doors = ((int(rng.integers(xl, xm)), ym), (int(rng.integers(xm + 1, xh + 1)), ym),
                     (xm, int(rng.integers(yl, ym))), (xm, int(rng.integers(ym + 1, yh + 1))))
            shut = int(rng.integers(4))
            for k, d in enumerate(doors):
                if k != shut:
                    m[d] = False
            _open_ends(m, xl, xh, yl, yh, xm, ym)
            if big:
                stack += [(xl, xm - 1, yl, ym - 1), (xm + 1, xh, yl, ym - 1),
                          (xl, xm - 1, ym + 1, yh), (xm + 1, xh, ym + 1, yh)]
        elif xh - xl >= 2 and yh - yl >= 3:  # 3 x 4+: one wall along y at the middle column
            _strip(m, rng, xl + 1, yl, yh, along_y=True)
        elif xh - xl >= 3 and yh - yl >= 2:  # 4+ x 3: one wall along x at the middle row
            _strip(m, rng, yl + 1, xl, xh, along_y=False)
        elif xh - xl >= 2 and yh - yl >= 2:
            m[xl + 1, yl + 1] = True
    return m


def _free(m: np.ndarray, i: int, j: int) -> bool:
    """Whether cell (i, j) exists and is free (outside the grid counts as a wall)."""
    return 0 <= i < m.shape[0] and 0 <= j < m.shape[1] and not m[i, j]


def _blocks_door(m, xl, xh, yl, yh, xm, ym) -> bool:
    return _free(m, xm, yl - 1) or _free(m, xm, yh + 1) or _free(m, xl - 1, ym) or _free(m, xh + 1, ym)


def _open_ends(m, xl, xh, yl, yh, xm, ym) -> None:
    if _free(m, xm, yl - 1):
        m[xm, yl] = False
    if _free(m, xm, yh + 1):
        m[xm, yh] = False
    if _free(m, xl - 1, ym):
        m[xl, ym] = False
    if _free(m, xh + 1, ym):
        m[xh, ym] = False


def _strip(m, rng, at, lo, hi, along_y: bool) -> None:
    """One wall across a 3-cell-wide strip, its ends opened where they meet a door, else one door."""
    cell = (lambda t: (at, t)) if along_y else (lambda t: (t, at))
    for t in range(lo, hi + 1):
        m[cell(t)] = True
    opened = False
    for end, beyond in ((lo, lo - 1), (hi, hi + 1)):
        if _free(m, *cell(beyond)):
            m[cell(end)] = False
            opened = True
    if not opened:
        m[cell(int(rng.integers(lo, hi + 1)))] = False


# --------------------------------------------------------------------------- 4: 3-D maze

def _maze3d_map(rng, shape, num_nodes, connectivity, road_rad) -> np.ndarray:
    nz, ny, nx = shape
    cores = np.column_stack([rng.integers(0, nx, num_nodes), rng.integers(0, ny, num_nodes),
                             rng.integers(0, nz, num_nodes)]).astype(np.float64)  # (i, j, k) [voxels]
    k, j, i = np.meshgrid(np.arange(nz, dtype=np.float64), np.arange(ny, dtype=np.float64),
                          np.arange(nx, dtype=np.float64), indexing="ij", sparse=True)
    d1 = np.full(shape, 1e4)
    d2 = np.full(shape, 1e5)
    p1 = np.full(shape, -1, dtype=np.int64)
    p2 = np.full(shape, -1, dtype=np.int64)
    for n, (ci, cj, ck) in enumerate(cores):  # the two nearest cores, first index kept on ties
        d = np.sqrt((i - ci) ** 2 + (j - cj) ** 2 + (k - ck) ** 2)
        first = d < d1
        second = ~first & (d < d2)
        d2 = np.where(first, d1, np.where(second, d, d2))
        p2 = np.where(first, p1, np.where(second, n, p2))
        d1 = np.where(first, d, d1)
        p1 = np.where(first, n, p1)
    wall = np.abs(d2 - d1) < 1.0  # within one voxel of the bisecting plane
    s = p1 + p2
    holed = (s > int((1 - connectivity) * num_nodes)) & (s < int((1 + connectivity) * num_nodes))
    gap = np.linalg.norm(cores[np.maximum(p1, 0)] - cores[np.maximum(p2, 0)], axis=-1)
    return wall & (~holed | (d1 + d2 - gap >= road_rad / 3.0))
