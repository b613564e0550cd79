"""Occupancy maps the field uses, read from their files and turned into exact boxes.

Formats (``docs/maps.md``):

* MovingAI 2-D grids (``.map``) and their scenarios (``.scen``): ``type octile``, ``height H``,
  ``width W``, ``map``, then H rows of W characters; ``.``, ``G`` and ``S`` are passable,
  ``@``, ``O``, ``T`` (trees) and ``W`` (water: not passable from land) are obstacles. The file
  has no unit: a cell is ``cell`` metres (default 1 m).
* ROS ``map_server`` maps: a YAML file (``image``, ``resolution``, ``origin``, ``negate``,
  ``occupied_thresh``, ``free_thresh``, ``mode``) and its PGM/PNG image.
* MovingAI 3-D voxel maps (``.3dmap``): ``voxel W H D``, then one ``x y z`` line per occupied
  voxel of ``cell`` metres.
* Point clouds (``.ply`` read with plyfile, ``.pcd`` with pypcd4): the ``x y z`` of each point
  [m]; the voxels of ``cell`` metres that hold a point are occupied.

Axes: world x grows with the column, world y upward. A grid's row 0 is the *top* of the
picture in both MovingAI and ROS files, so file row ``r`` of an ``H``-row map is world row
``H - 1 - r``: the map reads the same way up in a plot as in an image viewer, as in ROS
(whose ``origin`` is the pose of the lower-left pixel). A voxel's z is up.

Occupied cells become axis-aligned boxes by an exact merge (:func:`merge_cells`): every
occupied cell lies in exactly one box and no free cell in any, so every sensor and method
sees the file's occupied set, only in fewer pieces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from swarmnav.errors import ScenarioError
from swarmnav.world.obstacles import Box

#: MovingAI characters (movingai.com/benchmarks/formats.html): passable and blocked terrain.
MOVINGAI_FREE = ".GS"
MOVINGAI_BLOCKED = "@OTW"
#: Square-grid map types (octile: the benchmarks' type; tile and octile_unicost: the same grid
#: with other move costs, which do not change the obstacles).
MOVINGAI_TYPES = ("octile", "tile", "octile_unicost")
#: Largest map a file may declare [cells] (our choice: 16.8 M cells, four times the largest
#: MovingAI benchmark map, so a typo in a header fails at once instead of exhausting memory).
MAX_CELLS = 1 << 24
#: The ROS ``map_server`` modes.
ROS_MODES = ("trinary", "scale", "raw")
#: What a ROS map's unknown cells become (``unknown``): obstacles (the default: a swarm never
#: plans through space nobody has seen) or free space.
UNKNOWN_AS = ("occupied", "free")
#: Suffixes of the map files a scene may name.
MAP_SUFFIXES = (".map", ".scen", ".yaml", ".yml", ".3dmap", ".ply", ".pcd")
#: Voxel side of a point cloud when none is given [m] (our choice: the 0.1 m occupancy grids of
#: SPH's and EGO-Swarm's planners and of mockamap's worlds).
CLOUD_CELL = 0.1


@dataclass(frozen=True, slots=True, eq=False)
class OccupancyGrid:
    """A map as a boolean grid.

    Attributes:
        occupied: (ny, nx) bool, ``occupied[iy, ix]`` for the cell whose lower-left corner is
            ``origin + cell * (ix, iy)`` (world y up: row 0 is the bottom); (nz, ny, nx) in 3-D.
            Read only.
        origin: world position [m] of the lower corner of cell 0.
        cell: cell side [m].
        source: the file it came from (for messages).
    """

    occupied: np.ndarray
    origin: tuple[float, ...]
    cell: float
    source: str

    @property
    def dim(self) -> int:
        return self.occupied.ndim

    @property
    def shape_xyz(self) -> tuple[int, ...]:
        """Cells along x, y (and z)."""
        return tuple(reversed(self.occupied.shape))

    @property
    def bounds(self) -> tuple[float, ...]:
        """The map's extent ``(xmin, ymin[, zmin], xmax, ymax[, zmax])`` [m]."""
        lo = tuple(float(o) for o in self.origin)
        hi = tuple(float(o + self.cell * n) for o, n in zip(self.origin, self.shape_xyz))
        return lo + hi

    def center(self, index: tuple[int, ...]) -> tuple[float, ...]:
        """World position [m] of the centre of the cell with (ix, iy[, iz]) ``index``."""
        return tuple(float(o + self.cell * (i + 0.5)) for o, i in zip(self.origin, index))

    def boxes(self) -> tuple[Box, ...]:
        """The occupied cells merged into boxes (:func:`merge_cells`), in world metres."""
        return _boxes(self)


# --------------------------------------------------------------------------- exact merge

def merge_cells(occupied: np.ndarray) -> np.ndarray:
    """Occupied cells of a 2-D or 3-D boolean grid merged into boxes, exactly.

    Each line of cells along x becomes its maximal runs; runs with the same x extent in
    consecutive rows (y) become one rectangle; rectangles with the same footprint in
    consecutive layers (z) become one box. Every occupied cell lies in exactly one box and no
    free cell in any (the boxes' interiors are disjoint and their union is the occupied set).

    Args:
        occupied: (ny, nx) or (nz, ny, nx) bool grid, index order ``[iz,] iy, ix``.

    Returns:
        (K, 2 d) int64 half-open cell ranges ``[ix0, iy0(, iz0), ix1, iy1(, iz1)]``.
    """
    occ = np.asarray(occupied, dtype=bool)
    if occ.ndim not in (2, 3):
        raise ValueError(f"occupied must be a 2-D or 3-D grid, got {occ.ndim} dimensions")
    d = occ.ndim
    lines = occ.reshape(-1, occ.shape[-1])
    pad = np.zeros((lines.shape[0], lines.shape[1] + 2), dtype=np.int8)
    pad[:, 1:-1] = lines
    step = np.diff(pad, axis=1)
    line, x0 = np.nonzero(step == 1)  # row-major: each line's starts and ends come in order
    _, x1 = np.nonzero(step == -1)
    lo, hi = [x0.astype(np.int64)], [x1.astype(np.int64)]
    rest = [v.astype(np.int64) for v in np.unravel_index(line, occ.shape[:-1])]  # (iy,) or (iz, iy)
    while rest:  # merge along y, then z
        lo, hi, rest = _merge_along(lo, hi, rest)
    return np.column_stack([*lo, *hi]).reshape(-1, 2 * d)


def _merge_along(lo: list, hi: list, rest: list) -> tuple[list, list, list]:
    """One merge step: items with the same extent on the merged axes (``lo``/``hi``) and the same
    coordinates on the axes still to merge (``rest[:-1]``) whose coordinate ``rest[-1]`` is
    consecutive become one item spanning those coordinates."""
    pos, others = rest[-1], rest[:-1]
    keys = [*others, *lo, *hi]
    order = np.lexsort((pos, *keys))  # grouped by the keys, each group by pos
    new = np.zeros(len(order), dtype=bool)
    new[:1] = True
    for k in keys:
        ks = k[order]
        new[1:] |= ks[1:] != ks[:-1]
    ps = pos[order]
    new[1:] |= ps[1:] != ps[:-1] + 1
    first = order[new]
    last = order[np.append(new[1:], True)[: len(order)]]
    return ([v[first] for v in lo] + [pos[first]], [v[first] for v in hi] + [pos[last] + 1],
            [v[first] for v in others])


def rasterize(ranges: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """How many boxes ``ranges`` (K, 2 d) cover each cell of a grid of ``shape`` (index order
    ``[iz,] iy, ix``): the inverse of :func:`merge_cells`, for checking it."""
    d = len(shape)
    count = np.zeros(shape, dtype=np.int64)
    for r in np.asarray(ranges):
        sl = tuple(slice(int(r[a]), int(r[d + a])) for a in reversed(range(d)))
        count[sl] += 1
    return count


@lru_cache(maxsize=8)
def _boxes(grid: OccupancyGrid) -> tuple[Box, ...]:
    ranges = merge_cells(grid.occupied)
    d = grid.dim
    o = np.asarray(grid.origin, dtype=np.float64)
    # corners from integer indices, so boxes that touch share their face's coordinate exactly
    lo = o + grid.cell * ranges[:, :d]
    hi = o + grid.cell * ranges[:, d:]
    return tuple(Box(tuple(map(float, a)), tuple(map(float, b))) for a, b in zip(lo.tolist(), hi.tolist()))


# --------------------------------------------------------------------------- readers

def _read_text(path: Path, what: str) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such {what}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(f"{path}: cannot read: {_one_line(e)}") from None


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split()) or type(e).__name__


def _cell(cell: float, src: str) -> float:
    if isinstance(cell, bool) or not isinstance(cell, (int, float)) or not math.isfinite(cell) or cell <= 0:
        raise ScenarioError(f"{src}: cell must be a finite number > 0 [m], got {cell!r}")
    return float(cell)


def _int(tok: str, src: str, what: str, lo: int = 0) -> int:
    try:
        v = int(tok)
    except ValueError:
        raise ScenarioError(f"{src}: {what} must be an integer, got {tok!r}") from None
    if v < lo:
        raise ScenarioError(f"{src}: {what} must be >= {lo}, got {v}")
    return v


def read_movingai_map(path: str | Path, cell: float = 1.0) -> OccupancyGrid:
    """Read a MovingAI ``.map`` grid (movingai.com/benchmarks/formats.html).

    Cell ``(x, y)`` of the file (column x, row y counted from the top) is the square
    ``[x c, (x + 1) c] x [(H - 1 - y) c, (H - y) c]`` with ``c = cell`` [m]: the map's lower-left
    corner is the world origin and world y points up the picture.
    """
    p = Path(path)
    src = str(p)
    cell = _cell(cell, src)
    lines = _read_text(p, "map file").splitlines()
    head: dict[str, str] = {}
    k = 0
    while k < len(lines) and lines[k].strip().lower() != "map":
        parts = lines[k].split()
        if parts:
            if len(parts) != 2 or parts[0].lower() not in ("type", "height", "width"):
                raise ScenarioError(f"{src}: line {k + 1}: expected 'type T', 'height H', 'width W' or 'map', "
                                    f"got {lines[k].strip()[:40]!r}")
            if parts[0].lower() in head:
                raise ScenarioError(f"{src}: line {k + 1}: '{parts[0]}' given twice")
            head[parts[0].lower()] = parts[1]
        k += 1
    for key in ("type", "height", "width"):
        if key not in head:
            raise ScenarioError(f"{src}: the header has no '{key}' line (a MovingAI map starts 'type octile', "
                                "'height H', 'width W', 'map')")
    if head["type"].lower() not in MOVINGAI_TYPES:
        raise ScenarioError(f"{src}: map type {head['type']!r} is not a square grid "
                            f"(types: {', '.join(MOVINGAI_TYPES)})")
    if k == len(lines):
        raise ScenarioError(f"{src}: no 'map' line: the file ends in its header")
    h = _int(head["height"], src, "height", 1)
    w = _int(head["width"], src, "width", 1)
    if h * w > MAX_CELLS:
        raise ScenarioError(f"{src}: {w} x {h} cells is more than {MAX_CELLS} cells")
    rows = lines[k + 1:]
    while rows and not rows[-1].strip():
        rows.pop()
    if len(rows) != h:
        raise ScenarioError(f"{src}: the header says height {h} but {len(rows)} map rows follow")
    grid = np.empty((h, w), dtype=bool)
    table = np.full(256, 2, dtype=np.int8)  # 2: a character of neither kind
    table[[ord(c) for c in MOVINGAI_FREE]] = 0
    table[[ord(c) for c in MOVINGAI_BLOCKED]] = 1
    for r, row in enumerate(rows):
        if len(row) != w:
            raise ScenarioError(f"{src}: map row {r} has {len(row)} characters, the header says width {w}")
        kind = table[np.frombuffer(row.encode("ascii", "replace"), dtype=np.uint8)]  # non-ASCII: '?'
        if (kind == 2).any():
            x = int(np.argmax(kind == 2))
            raise ScenarioError(f"{src}: map row {r}, column {x}: unknown terrain {row[x]!r} "
                                f"(passable: {' '.join(MOVINGAI_FREE)}; obstacles: {' '.join(MOVINGAI_BLOCKED)})")
        grid[h - 1 - r] = kind == 1
    grid.setflags(write=False)
    return OccupancyGrid(grid, (0.0, 0.0), cell, src)


@dataclass(frozen=True, slots=True)
class ScenRow:
    """One problem of a MovingAI ``.scen`` file: cells as the file gives them (column, row from
    the top), the optimal octile path length in cells (diagonal sqrt 2, no corner cutting)."""

    bucket: int
    map: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float


def read_movingai_scen(path: str | Path) -> tuple[ScenRow, ...]:
    """Read a MovingAI ``.scen`` file: a ``version`` line, then rows of 9 fields
    ``bucket map width height start_x start_y goal_x goal_y optimal_length``."""
    p = Path(path)
    src = str(p)
    lines = [ln for ln in _read_text(p, "scenario file").splitlines() if ln.strip()]
    if not lines or lines[0].split()[0].lower() != "version":
        raise ScenarioError(f"{src}: a MovingAI scenario starts with a 'version 1' line")
    out = []
    for k, ln in enumerate(lines[1:]):
        f = ln.split()
        if len(f) < 9:
            raise ScenarioError(f"{src}: row {k} has {len(f)} fields, a scenario row has 9 "
                                "(bucket map width height start_x start_y goal_x goal_y optimal_length)")
        name = " ".join(f[1:-7])
        b = _int(f[0], src, f"row {k} bucket")
        w, h, sx, sy, gx, gy = (_int(t, src, f"row {k} {n}") for t, n in
                                zip(f[-7:-1], ("width", "height", "start_x", "start_y", "goal_x", "goal_y")))
        try:
            opt = float(f[-1])
        except ValueError:
            raise ScenarioError(f"{src}: row {k} optimal_length must be a number, got {f[-1]!r}") from None
        if not (math.isfinite(opt) and opt >= 0):
            raise ScenarioError(f"{src}: row {k} optimal_length must be finite and >= 0, got {f[-1]!r}")
        out.append(ScenRow(b, name, w, h, (sx, sy), (gx, gy), opt))
    if not out:
        raise ScenarioError(f"{src}: no scenario rows after the version line")
    return tuple(out)


_ROS_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}


def read_ros_map(path: str | Path, unknown: str = "occupied") -> OccupancyGrid:
    """Read a ROS ``map_server`` map: its YAML and the image it names (PGM, PNG, ...).

    As ``map_server`` does: pixel row 0 is the top of the map, ``origin`` is the pose
    ``[x, y, yaw]`` [m, m, rad] of the lower-left pixel's lower-left corner (yaw 0 only), a
    pixel's occupancy is ``p = (255 - v) / 255`` (``v / 255`` with ``negate``) for its grey
    value (the mean of its colour channels) ``v``; ``p > occupied_thresh`` is occupied,
    ``p < free_thresh`` free, anything between unknown (trinary and scale modes; in scale mode
    a translucent pixel is unknown too). In raw mode ``v`` itself is the occupancy in percent
    (0-100; 255 unknown), compared with the same thresholds as ``v / 100``. Unknown cells are
    obstacles, or free with ``unknown = "free"``.
    """
    import yaml  # PyYAML
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    src = str(p)
    if unknown not in UNKNOWN_AS:
        raise ScenarioError(f"{src}: unknown must be one of {', '.join(UNKNOWN_AS)}, got {unknown!r}")
    try:
        meta = yaml.safe_load(_read_text(p, "map YAML file"))
    except yaml.YAMLError as e:
        raise ScenarioError(f"{src}: malformed YAML: {_one_line(e)}") from None
    if not isinstance(meta, dict):
        raise ScenarioError(f"{src}: a ROS map YAML is a mapping of image, resolution, origin, negate, "
                            "occupied_thresh, free_thresh (and mode)")
    bad = sorted(str(k) for k in meta if k not in _ROS_KEYS)
    if bad:
        raise ScenarioError(f"{src}: unknown key {bad[0]!r} (allowed: {', '.join(sorted(_ROS_KEYS))})")
    for key in ("image", "resolution", "origin", "occupied_thresh", "free_thresh"):
        if key not in meta:
            raise ScenarioError(f"{src}: '{key}' is required")

    def number(key: str, v) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ScenarioError(f"{src}: {key} must be a finite number, got {v!r}")
        return float(v)

    res = number("resolution", meta["resolution"])
    if res <= 0:
        raise ScenarioError(f"{src}: resolution must be > 0 [m/pixel], got {res}")
    origin = meta["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        raise ScenarioError(f"{src}: origin must be [x, y, yaw], got {origin!r}")
    ox, oy, yaw = (number("origin", v) for v in origin)
    if yaw != 0.0:
        raise ScenarioError(f"{src}: origin yaw {yaw} rad: only yaw = 0 is supported (maps are axis-aligned)")
    occ_t = number("occupied_thresh", meta["occupied_thresh"])
    free_t = number("free_thresh", meta["free_thresh"])
    if not 0.0 <= free_t < occ_t <= 1.0:
        raise ScenarioError(f"{src}: thresholds need 0 <= free_thresh < occupied_thresh <= 1, "
                            f"got free_thresh {free_t}, occupied_thresh {occ_t}")
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise ScenarioError(f"{src}: negate must be 0 or 1, got {negate!r}")
    mode = meta.get("mode", "trinary")
    if mode not in ROS_MODES:
        raise ScenarioError(f"{src}: mode must be one of {', '.join(ROS_MODES)}, got {mode!r}")
    image = meta["image"]
    if not isinstance(image, str) or not image:
        raise ScenarioError(f"{src}: image must be a file name, got {image!r}")
    ip = Path(image) if Path(image).is_absolute() else p.parent / image
    try:
        with Image.open(ip) as im:
            im.load()
            pix = _grey_alpha(im, src, ip)
    except FileNotFoundError:
        raise ScenarioError(f"{src}: image {image!r} does not exist ({ip})") from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as e:
        raise ScenarioError(f"{src}: image {image!r} cannot be read: {_one_line(e)}") from None
    grey, alpha = pix
    h, w = grey.shape
    if h * w > MAX_CELLS:
        raise ScenarioError(f"{src}: image of {w} x {h} pixels is more than {MAX_CELLS} cells")
    if mode == "raw":
        occ_p = grey / 100.0
        unknown_px = grey == 255.0
    else:
        occ_p = grey / 255.0 if negate else (255.0 - grey) / 255.0
        unknown_px = (alpha < 255) if mode == "scale" else np.zeros_like(grey, dtype=bool)
    is_occ = (occ_p > occ_t) & ~unknown_px
    is_free = (occ_p < free_t) & ~unknown_px
    is_unknown = ~(is_occ | is_free)
    grid = is_occ | (is_unknown if unknown == "occupied" else False)
    grid = np.ascontiguousarray(grid[::-1])  # image row 0 is the top: world row H - 1
    grid.setflags(write=False)
    return OccupancyGrid(grid, (ox, oy), res, src)


def _grey_alpha(im, src: str, ip: Path) -> tuple[np.ndarray, np.ndarray]:
    """A pixel's grey value (the mean of its colour channels, 0-255) and alpha (255: opaque)."""
    mode = im.mode
    if mode == "P":
        im = im.convert("RGBA")
        mode = "RGBA"
    if mode == "1":
        im = im.convert("L")
        mode = "L"
    if mode not in ("L", "LA", "RGB", "RGBA"):
        raise ScenarioError(f"{src}: image {ip.name} has pixel mode {mode}; 8-bit grey or colour images only")
    a = np.asarray(im, dtype=np.float64)
    if a.ndim == 2:
        return a, np.full(a.shape, 255.0)
    colour = a[..., :-1] if mode in ("LA", "RGBA") else a
    alpha = a[..., -1] if mode in ("LA", "RGBA") else np.full(a.shape[:2], 255.0)
    return colour.mean(axis=2), alpha


def read_voxel_map(path: str | Path, cell: float = 1.0) -> OccupancyGrid:
    """Read a MovingAI 3-D voxel map (``.3dmap``): a ``voxel W H D`` line, then one ``x y z`` line
    per occupied voxel (0 <= x < W, 0 <= y < H, 0 <= z < D). Voxel ``(x, y, z)`` is the cube
    ``[x, x + 1] x [y, y + 1] x [z, z + 1]`` times ``cell`` [m]; z is up (our reading: the
    format does not name its vertical axis)."""
    p = Path(path)
    src = str(p)
    cell = _cell(cell, src)
    lines = [ln for ln in _read_text(p, "voxel map file").splitlines() if ln.strip()]
    head = lines[0].split() if lines else []
    if len(head) != 4 or head[0].lower() != "voxel":
        raise ScenarioError(f"{src}: a MovingAI voxel map starts with 'voxel W H D'")
    w, h, d = (_int(t, src, n, 1) for t, n in zip(head[1:], ("W", "H", "D")))
    if w * h * d > MAX_CELLS:
        raise ScenarioError(f"{src}: {w} x {h} x {d} voxels is more than {MAX_CELLS} cells")
    body = lines[1:]
    xyz = np.zeros((len(body), 3), dtype=np.int64)
    for k, ln in enumerate(body):
        tok = ln.split()
        try:
            if len(tok) != 3:
                raise ValueError
            xyz[k] = [int(t) for t in tok]
        except (ValueError, OverflowError):
            raise ScenarioError(f"{src}: line {k + 2}: a voxel is three integers 'x y z', "
                                f"got {ln.strip()[:40]!r}") from None
    out = (xyz < 0) | (xyz >= np.array([w, h, d]))
    if out.any():
        k = int(np.argmax(out.any(axis=1)))
        raise ScenarioError(f"{src}: line {k + 2}: voxel {xyz[k].tolist()} lies outside the header's "
                            f"{w} x {h} x {d}")
    grid = np.zeros((d, h, w), dtype=bool)
    grid[xyz[:, 2], xyz[:, 1], xyz[:, 0]] = True
    grid.setflags(write=False)
    return OccupancyGrid(grid, (0.0, 0.0, 0.0), cell, src)


def read_point_cloud(path: str | Path, cell: float = CLOUD_CELL) -> OccupancyGrid:
    """Read a point cloud (``.ply`` or ``.pcd``) as 3-D occupancy: every voxel of side ``cell`` [m]
    that holds a point is occupied.

    Points are ``x y z`` in metres in the file's own frame (a PCD ``VIEWPOINT`` is the sensor's
    pose, not a transform of the points, as in PCL). Voxels lie on the lattice of multiples of
    ``cell`` from the world origin: point ``p`` is in voxel ``floor(p / cell)``, as an occupancy
    grid map with that resolution indexes it; the grid spans the voxels from the lowest to the
    highest point. PLY: the ``vertex`` element's ``x``, ``y``, ``z`` properties (ASCII or binary;
    plyfile). PCD: the ``x``, ``y``, ``z`` fields (ASCII, binary or binary_compressed; pypcd4),
    with ``POINTS`` = ``WIDTH`` x ``HEIGHT`` points. A point that is not finite (PCL marks
    invalid returns with NaN) is an error: give a cloud of valid points.
    """
    p = Path(path)
    src = str(p)
    cell = _cell(cell, src)
    if not p.is_file():
        raise ScenarioError(f"{src}: no such point cloud file")
    xyz = _ply_points(p, src) if p.suffix.lower() == ".ply" else _pcd_points(p, src)
    if len(xyz) == 0:
        raise ScenarioError(f"{src}: the cloud has no points")
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ScenarioError(f"{src}: point {k} is not finite ({', '.join(f'{v:g}' for v in xyz[k])}); "
                            f"{int(bad.sum())} of {len(xyz)} points are NaN or infinite")
    with np.errstate(over="ignore", invalid="ignore"):
        idx_f = np.floor(xyz / cell)
    if not (np.abs(idx_f) < 2.0**52).all():
        raise ScenarioError(f"{src}: points lie too far from the origin for {cell:g} m voxels")
    idx = idx_f.astype(np.int64)
    lo, hi = idx.min(axis=0), idx.max(axis=0)
    shape = hi - lo + 1  # x, y, z
    if float(np.prod(shape.astype(float))) > MAX_CELLS:
        raise ScenarioError(f"{src}: {' x '.join(map(str, shape.tolist()))} voxels of {cell:g} m is more than "
                            f"{MAX_CELLS} cells (raise cell)")
    grid = np.zeros(tuple(shape[::-1].tolist()), dtype=bool)
    rel = idx - lo
    grid[rel[:, 2], rel[:, 1], rel[:, 0]] = True
    grid.setflags(write=False)
    return OccupancyGrid(grid, tuple(float(v) for v in lo * cell), cell, src)


def _ply_points(p: Path, src: str) -> np.ndarray:
    from plyfile import PlyData, PlyParseError  # plyfile: the PLY reader

    try:
        ply = PlyData.read(str(p))
        names = [e.name for e in ply.elements]
        if "vertex" not in names:
            raise ScenarioError(f"{src}: no 'vertex' element (elements: {', '.join(names) or 'none'})")
        v = ply["vertex"].data
        missing = [a for a in "xyz" if a not in (v.dtype.names or ())]
        if missing:
            raise ScenarioError(f"{src}: the vertices have no {', '.join(missing)} property")
        with np.errstate(invalid="ignore", over="ignore"):  # a damaged value becomes NaN or inf: refused below
            return np.column_stack([np.asarray(v[a], dtype=np.float64) for a in "xyz"])
    except ScenarioError:
        raise
    except (PlyParseError, ValueError, TypeError, KeyError, IndexError, EOFError, OSError, UnicodeError,
            MemoryError, OverflowError) as e:
        raise ScenarioError(f"{src}: not a readable PLY file: {_one_line(e)[:200]}") from None


def _pcd_points(p: Path, src: str) -> np.ndarray:
    from pydantic import ValidationError
    from pypcd4 import PointCloud  # pypcd4: the PCD reader

    try:
        pc = PointCloud.from_path(p)
        meta = pc.metadata
        data = np.atleast_1d(pc.pc_data)
        if meta.points != meta.width * meta.height:
            raise ScenarioError(f"{src}: the header says POINTS {meta.points} but WIDTH x HEIGHT = "
                                f"{meta.width} x {meta.height}")
        if len(data) != meta.points:
            raise ScenarioError(f"{src}: the header says POINTS {meta.points} but the data holds {len(data)} "
                                "(a truncated file?)")
        missing = [a for a in "xyz" if a not in (data.dtype.names or ())]
        if missing:
            raise ScenarioError(f"{src}: no {', '.join(missing)} field (fields: {', '.join(meta.fields)})")
        return np.column_stack([np.asarray(data[a], dtype=np.float64) for a in "xyz"])
    except ScenarioError:
        raise
    except (ValidationError, ValueError, TypeError, KeyError, IndexError, EOFError, OSError, UnicodeError,
            RuntimeError, MemoryError, OverflowError, AttributeError, __import__("struct").error) as e:
        raise ScenarioError(f"{src}: not a readable PCD file: {_one_line(e)[:200]}") from None


def map_kind(path: str | Path) -> str | None:
    """``"movingai"``, ``"scen"``, ``"ros"``, ``"voxel"`` or ``"cloud"`` for a map file's name;
    None otherwise."""
    name = str(path).lower()
    if name.endswith(".scen"):
        return "scen"
    if name.endswith(".map"):
        return "movingai"
    if name.endswith((".yaml", ".yml")):
        return "ros"
    if name.endswith(".3dmap"):
        return "voxel"
    if name.endswith((".ply", ".pcd")):
        return "cloud"
    return None


def load_grid(path: str | Path, cell: float | None = None, unknown: str = "occupied") -> OccupancyGrid:
    """Read any supported map file (by its suffix) as an :class:`OccupancyGrid`.

    Args:
        path: a ``.map``, ``.yaml``/``.yml`` (ROS) or ``.3dmap`` file.
        cell: [m] cell side of a MovingAI grid or voxel map (default 1 m); a ROS map has its
            own ``resolution`` and takes none.
        unknown: what a ROS map's unknown cells are (:data:`UNKNOWN_AS`).
    """
    p = Path(path)
    kind = map_kind(p)
    if kind == "ros":
        if cell is not None:
            raise ScenarioError(f"{p}: a ROS map has its own resolution: cell is for MovingAI grids and voxel maps")
        key = (str(p.resolve()), (_stamp(p), _stamp(_ros_image(p))), None, unknown)
    elif kind in ("movingai", "voxel", "cloud"):
        if unknown != "occupied":
            raise ScenarioError(f"{p}: unknown is for ROS maps (a {'point cloud' if kind == 'cloud' else 'MovingAI map'} "
                                "has no unknown cells)")
        default = CLOUD_CELL if kind == "cloud" else 1.0
        key = (str(p.resolve()), _stamp(p), default if cell is None else cell, unknown)
    else:
        raise ScenarioError(f"{p}: not a map file (map files: {', '.join(s for s in MAP_SUFFIXES if s != '.scen')})")
    return _cached_grid(kind, str(p), *key)


def _ros_image(p: Path) -> Path:
    """The image a ROS map YAML names (for the cache key only; the reader checks everything)."""
    import yaml

    try:
        image = yaml.safe_load(p.read_text(encoding="utf-8")).get("image")
        return Path(image) if Path(image).is_absolute() else p.parent / image
    except Exception:  # noqa: BLE001 - any damage is reported by read_ros_map
        return p


def _stamp(p: Path) -> tuple[int, int]:
    try:
        st = p.stat()
    except OSError:
        return (0, 0)  # the reader reports the missing file
    return (st.st_mtime_ns, st.st_size)


@lru_cache(maxsize=8)
def _cached_grid(kind: str, path: str, _resolved: str, _stamp: tuple, cell, unknown: str) -> OccupancyGrid:
    if kind == "ros":
        return read_ros_map(path, unknown)
    if kind == "voxel":
        return read_voxel_map(path, cell)
    if kind == "cloud":
        return read_point_cloud(path, cell)
    return read_movingai_map(path, cell)
