"""BARN's five difficulty metrics along the shortest path, for any world.

Source: Perille, Truong, Xiao and Stone, "Benchmarking Metric Ground Navigation" (SSRR 2020),
Section III, and its code, ``difficulty_quant.py`` (class ``DifficultyMetrics``) and
``gen_world_ca.py`` in github.com/dperille/jackal-map-creation. BARN computes every metric on the
robot's C-space (an occupancy grid whose obstacles are grown by the robot) at each cell of the
path through it and averages over the path's cells:

* **distance to the closest obstacle** (``dist_closest_m``): the Euclidean distance from the cell
  to the nearest C-space obstacle cell (cell centre to cell centre; BARN's ``_dist_closest_wall``
  explores the 8-neighbourhood in order of that distance, i.e. an exact distance transform);
* **average visibility** (``visibility_m``): along each of the 8 directions (4 axes, 4 diagonals)
  the length of the run of free cells from the cell itself up to the first obstacle or the grid's
  edge (a diagonal step counts sqrt 2), averaged over the 8;
* **dispersion** (``dispersion``): along 16 directions (the 8 above and the 8 of slope 1/2 and 2,
  in angular order) whether an obstacle lies within the dispersion radius (BARN: 3 cells; a slope
  1/2 step counts 2), and the number of changes between "obstacle" and "none" going once round
  the circle;
* **characteristic dimension** (``characteristic_dim_m``): for each of the 4 axes (x, y and the two
  diagonals) the free length through the cell in both directions (the cell itself not counted,
  up to an obstacle or the edge), the smallest of the 4;
* **tortuosity** (``tortuosity``): the path's length over the straight distance between its ends.

Lengths are in meters here (BARN: cells of 0.15 m; multiply BARN's by its cell). The C-space of
a navstress world: a grid of :data:`CELL_M` (BARN's 0.15 m lattice; coarser on a map of more than
:data:`MAX_CELLS` cells) whose cell is an obstacle when its centre is closer than the robot's
clearance (its half width, as the descriptors' traversability) to a footprint, or nearer the
map's edge than that (the robot cannot leave the map). BARN grows its lattice by a square of
2 cells each side for the Jackal instead (:func:`barn_cspace` builds that one from a lattice, for
BARN's own worlds). The path: the shortest 8-connected path through the free cells from the
start's cell to the goal's (no corner cutting), where BARN's A* also limits turns to 45 degrees
and pays extra near obstacles; or a path given (e.g. BARN's ``path_N.npy``).

    >>> import numpy as np
    >>> occ = np.zeros((5, 9), bool); occ[0, :] = occ[4, :] = True   # a corridor 3 cells wide
    >>> m = grid_metrics(occ, np.array([[2, 1], [2, 7]]), 1.0)
    >>> m["tortuosity"], m["dist_closest_m"], m["characteristic_dim_m"]
    (1.0, 2.0, 2.0)
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.robot import RobotSpec
from navstress.world.generators.raster import footprint_distance
from navstress.world.world import Obstacle, World

#: BARN's lattice cell (m): the C-space grid of :func:`barn_difficulty`.
CELL_M = 0.15
#: BARN's dispersion radius: 3 cells of 0.15 m.
DISPERSION_RADIUS_M = 0.45
#: Largest C-space grid; a larger map takes coarser cells.
MAX_CELLS = 2_000_000
#: The metrics' names, in BARN's order.
NAMES = ("dist_closest_m", "visibility_m", "dispersion", "characteristic_dim_m", "tortuosity")

# BARN's 16 dispersion directions (row, col) in angular order, and the 8 visibility directions.
_DISP = np.array([(0, 1), (1, 2), (1, 1), (2, 1), (1, 0), (2, -1), (1, -1), (1, -2), (0, -1), (-2, -1),
                  (-1, -1), (-1, -2), (-1, 0), (-2, 1), (-1, 1), (-1, 2)], np.int64)
_VIS = np.array([(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc], np.int64)
_AXES = np.array([(0, 1), (1, 1), (1, 0), (1, -1)], np.int64)


@numba.njit(cache=True)
def _cell_metrics(occ: np.ndarray, r: int, c: int, disp_radius: int, dirs: tuple[np.ndarray, np.ndarray,
                  np.ndarray]) -> tuple[float, float, float]:
    """(visibility, dispersion, characteristic dimension) of free cell (r, c), in cells."""
    vis_dirs, disp_dirs, axes = dirs
    rows, cols = occ.shape
    vis = 0.0
    for k in range(vis_dirs.shape[0]):
        dr, dc = vis_dirs[k, 0], vis_dirs[k, 1]
        step = math.sqrt(dr * dr + dc * dc)
        i, j = r, c
        while 0 <= i < rows and 0 <= j < cols and not occ[i, j]:
            vis += step
            i += dr
            j += dc
    vis /= vis_dirs.shape[0]
    n = disp_dirs.shape[0]
    wall = np.zeros(n, np.bool_)
    for k in range(n):
        dr, dc = disp_dirs[k, 0], disp_dirs[k, 1]
        inc = 2 if (abs(dr) == 2 or abs(dc) == 2) else 1
        count = 0
        i, j = r, c
        while count < disp_radius:
            i += dr
            j += dc
            if i < 0 or i >= rows or j < 0 or j >= cols:
                break
            if occ[i, j]:
                wall[k] = True
                break
            count += inc
    changes = 0
    for k in range(n):
        if wall[k] != wall[(k + 1) % n]:
            changes += 1
    cd = float(rows + cols)
    for a in range(axes.shape[0]):
        w = 0.0
        for sgn in (1, -1):
            dr, dc = sgn * axes[a, 0], sgn * axes[a, 1]
            step = math.sqrt(dr * dr + dc * dc)
            i, j = r + dr, c + dc
            while 0 <= i < rows and 0 <= j < cols and not occ[i, j]:
                w += step
                i += dr
                j += dc
        cd = min(cd, w)
    return vis, float(changes), cd


@numba.njit(cache=True)
def _path_metrics(occ: np.ndarray, path: np.ndarray, disp_radius: int,
                  dirs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[float, float, float]:
    """Mean (visibility, dispersion, characteristic dimension) over the path's cells, in cells."""
    v = d = cd = 0.0
    for k in range(path.shape[0]):
        a, b, c = _cell_metrics(occ, path[k, 0], path[k, 1], disp_radius, dirs)
        v += a
        d += b
        cd += c
    n = path.shape[0]
    return v / n, d / n, cd / n


def grid_metrics(cspace: np.ndarray, path: np.ndarray, cell_m: float,
                 disp_radius_cells: int = 3) -> dict[str, float | None]:
    """BARN's five metrics of ``path`` ((n, 2) integer (row, col) cells, all free) through the
    C-space ``cspace`` (bool, True = obstacle) of cells of ``cell_m`` meters (see module doc).
    ``dist_closest_m`` is None on a grid without obstacle, ``tortuosity`` None for a path whose
    ends coincide."""
    occ = np.ascontiguousarray(cspace, dtype=np.bool_)
    p = np.ascontiguousarray(path, dtype=np.int64).reshape(-1, 2)
    if p.shape[0] == 0:
        raise ValueError("an empty path")
    if occ[p[:, 0], p[:, 1]].any():
        raise ValueError("a path through a C-space obstacle")
    from scipy import ndimage  # here: 0.3-0.5 s to import, and a process that only runs missions never needs it

    if occ.any():
        edt = ndimage.distance_transform_edt(~occ)
        dist: float | None = float(edt[p[:, 0], p[:, 1]].mean()) * cell_m
    else:
        dist = None
    vis, disp, cd = _path_metrics(occ, p, int(disp_radius_cells), (_VIS, _DISP, _AXES))
    seg = np.diff(p.astype(np.float64), axis=0)
    arc = float(np.sqrt((seg ** 2).sum(axis=1)).sum())
    chord = float(math.hypot(*(p[-1] - p[0]).astype(np.float64)))
    return {"dist_closest_m": dist, "visibility_m": float(vis) * cell_m, "dispersion": float(disp),
            "characteristic_dim_m": float(cd) * cell_m, "tortuosity": arc / chord if chord > 0 else None}


def barn_cspace(lattice: np.ndarray, robot_cells: int = 2) -> np.ndarray:
    """BARN's C-space of an occupancy lattice (``gen_world_ca.py``, ``JackalMap``): a cell is an
    obstacle when any cell within ``robot_cells`` (Chebyshev; BARN's Jackal: 2, a 5 x 5 square) is."""
    from scipy import ndimage  # here, as above

    k = 2 * int(robot_cells) + 1
    out: np.ndarray = ndimage.maximum_filter(np.asarray(lattice, bool), size=k, mode="constant", cval=False)
    return out


def cspace(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...] | list[Obstacle], clearance_m: float,
           cell_m: float = CELL_M, origin: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, float]:
    """The C-space of a world (see module doc) and its cell: True where a robot's centre at the
    cell's centre would be closer than ``clearance_m`` to a footprint or to the map's edge. The
    cells' lower-left corners at ``origin`` + (j, i) * cell (a lattice world's own cells: its
    lattice's corner, modulo the cell), covering the map."""
    cell = max(cell_m, math.sqrt(size_m[0] * size_m[1] / MAX_CELLS))
    ox, oy = origin[0] % cell, origin[1] % cell
    cols = max(1, int(math.floor((size_m[0] - ox) / cell + 1e-9)))
    rows = max(1, int(math.floor((size_m[1] - oy) / cell + 1e-9)))
    d = footprint_distance((rows, cols), cell, obstacles, clearance_m, origin=(ox + cell / 2, oy + cell / 2))
    occ = d < clearance_m
    xs = ox + (np.arange(cols) + 0.5) * cell
    ys = oy + (np.arange(rows) + 0.5) * cell
    occ |= ((xs < clearance_m) | (xs > size_m[0] - clearance_m))[None, :]
    occ |= ((ys < clearance_m) | (ys > size_m[1] - clearance_m))[:, None]
    return occ, cell


def shortest_path(occ: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> np.ndarray | None:
    """The shortest 8-connected path of free cells from ``start`` to ``goal`` ((row, col) each),
    diagonal steps only between two free orthogonal neighbours; (n, 2) cells, None when there is none."""
    rows, cols = occ.shape
    ok = ~occ
    if not (ok[start] and ok[goal]):
        return None
    idx = np.arange(rows * cols).reshape(rows, cols)
    src: list[np.ndarray] = []
    dst: list[np.ndarray] = []
    wts: list[np.ndarray] = []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = (slice(0, rows - di), slice(max(0, -dj), cols - max(0, dj)))
        b = (slice(di, rows), slice(max(0, -dj) + dj, cols - max(0, dj) + dj))
        m = ok[a] & ok[b]
        if di and dj:
            m &= ok[a[0], b[1]] & ok[b[0], a[1]]
        src.append(idx[a][m])
        dst.append(idx[b][m])
        wts.append(np.full(int(m.sum()), math.hypot(di, dj)))
    from scipy.sparse import coo_matrix  # here, as above
    from scipy.sparse.csgraph import dijkstra

    n = rows * cols
    g = coo_matrix((np.concatenate(wts), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
    s, t = int(idx[start]), int(idx[goal])
    dist, pred = dijkstra(g, directed=False, indices=s, return_predecessors=True)
    if not math.isfinite(float(dist[t])):
        return None
    out = [t]
    while out[-1] != s:
        out.append(int(pred[out[-1]]))
    cells = np.array(out[::-1], np.int64)
    return np.stack([cells // cols, cells % cols], axis=1)


def _cell(occ_shape: tuple[int, int], cell: float, x: float, y: float,
          origin: tuple[float, float] = (0.0, 0.0)) -> tuple[int, int]:
    return (min(max(int(math.floor((y - origin[1]) / cell)), 0), occ_shape[0] - 1),
            min(max(int(math.floor((x - origin[0]) / cell)), 0), occ_shape[1] - 1))


def _path_cells(points: np.ndarray, cell: float, shape: tuple[int, int], origin: tuple[float, float]) -> np.ndarray:
    """The cells a polyline of points (m) passes, sampled every quarter cell, consecutive duplicates dropped."""
    out: list[tuple[int, int]] = []
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    for k in range(len(pts)):
        a = pts[k]
        b = pts[k + 1] if k + 1 < len(pts) else pts[k]
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / (cell / 4))))
        for t in range(n + (1 if k + 1 == len(pts) else 0)):
            p = a + (b - a) * (t / n)
            c = _cell(shape, cell, float(p[0]), float(p[1]), origin)
            if not out or out[-1] != c:
                out.append(c)
    return np.array(out, np.int64).reshape(-1, 2)


def barn_difficulty_of(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...] | list[Obstacle],
                       start: tuple[float, float], goal: tuple[float, float], *, robot: RobotSpec | None = None,
                       clearance_m: float | None = None, path: np.ndarray | None = None,
                       cell_m: float = CELL_M, origin: tuple[float, float] = (0.0, 0.0)) -> dict[str, Any]:
    """BARN's five metrics (:data:`NAMES`, see module doc) of a world's parts: along ``path``
    ((n, 2) points in meters, in the world's frame) when given, else along the shortest path from
    ``start`` to ``goal`` through the C-space of the robot's clearance (``clearance_m``, default
    half the width of ``robot``, default the nominal RobotSpec). Every metric is None, and
    ``reason`` says why, when there is no path (start or goal in the C-space's obstacles, or
    apart); else ``reason`` is None. Also ``path_cells`` and ``cell_m``, the grid's. ``origin``: a
    corner of the grid's cells (:func:`cspace`)."""
    if clearance_m is None:
        clearance_m = (robot or RobotSpec()).width_m / 2
    occ, cell = cspace(size_m, obstacles, clearance_m, cell_m, origin)
    o = (origin[0] % cell, origin[1] % cell)
    out: dict[str, Any] = dict.fromkeys(NAMES)
    out.update(reason=None, path_cells=0, cell_m=cell)
    if path is not None:
        cells = _path_cells(np.asarray(path, np.float64), cell, occ.shape, o)
        if occ[cells[:, 0], cells[:, 1]].any():
            out["reason"] = "the path given passes through the C-space's obstacles"
            return out
    else:
        s = _cell(occ.shape, cell, start[0], start[1], o)
        g = _cell(occ.shape, cell, goal[0], goal[1], o)
        if occ[s] or occ[g]:
            out["reason"] = f"the {'start' if occ[s] else 'goal'} is closer than {clearance_m:.3g} m to an obstacle or the edge"
            return out
        found = shortest_path(occ, s, g)
        if found is None:
            out["reason"] = "no path from start to goal"
            return out
        cells = found
    radius = max(1, int(round(DISPERSION_RADIUS_M / cell)))
    out.update(grid_metrics(occ, cells, cell, radius))
    out["path_cells"] = int(len(cells))
    return out


def barn_difficulty(world: World, *, robot: RobotSpec | None = None, clearance_m: float | None = None,
                    path: np.ndarray | None = None, cell_m: float = CELL_M,
                    origin: tuple[float, float] = (0.0, 0.0)) -> dict[str, Any]:
    """:func:`barn_difficulty_of` a world (its obstacles, mission and size)."""
    return barn_difficulty_of(world.size_m, world.obstacles, world.mission.start[:2], world.mission.goal,
                              robot=robot, clearance_m=clearance_m, path=path, cell_m=cell_m, origin=origin)


def barn_descriptor(metrics: dict[str, Any]) -> dict[str, Any]:
    """The ``descriptors["barn"]`` entry: the five metrics and the reason (None) when there is no path."""
    out = {k: metrics[k] for k in NAMES}
    if metrics.get("reason"):
        out["reason"] = metrics["reason"]
    return out
