"""Footprints on a grid: the exact distance from grid points to obstacle footprints (boxes turned
by their yaw, upright cylinders), and the free space of a robot as a raster whose connected parts
a flood fill finds (the ``rooms`` and ``clutter`` generators' reachability checks, and the
occupancy grids of :mod:`navstress.world.barn_metrics`).

A grid of ``rows`` x ``cols`` points at (x, y) = (x0 + j*cell, y0 + i*cell).

    >>> from navstress.world.world import Obstacle
    >>> d = footprint_distance((1, 3), 1.0, (Obstacle("c", 0.0, 0.0, 0.0, (1.0, 1.0, 1.0), shape="cylinder"),), 5.0)
    >>> [round(float(v), 3) for v in d[0]]
    [0.0, 0.5, 1.5]
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.world.world import Obstacle


class Footprints(NamedTuple):
    """Obstacle footprints as arrays, one entry per obstacle."""

    x: np.ndarray  # centres (m)
    y: np.ndarray
    hx: np.ndarray  # half sides along the box's own axes (m); a cylinder: its radius in both
    hy: np.ndarray
    c: np.ndarray  # cos and sin of a box's yaw (a cylinder: 1, 0)
    s: np.ndarray
    cyl: np.ndarray  # 1 for a cylinder, 0 for a box


def footprints(obstacles: tuple[Obstacle, ...] | list[Obstacle]) -> Footprints:
    """The arrays of ``obstacles``' footprints."""
    cyl = np.array([o.is_cylinder for o in obstacles], np.uint8)
    yaw = np.array([0.0 if o.is_cylinder else o.yaw for o in obstacles], np.float64)
    return Footprints(np.array([o.x for o in obstacles], np.float64), np.array([o.y for o in obstacles], np.float64),
                      np.array([o.size[0] / 2 for o in obstacles], np.float64),
                      np.array([o.size[1] / 2 for o in obstacles], np.float64),
                      np.cos(yaw), np.sin(yaw), cyl)


@numba.njit(cache=True)
def _distance(rows: int, cols: int, cell: float, origin: tuple[float, float], fp: Footprints,
              reach: float) -> np.ndarray:
    """Exact distance from each grid point to the nearest footprint (0 inside), ``inf`` where
    farther than ``reach``."""
    out = np.full((rows, cols), np.inf)
    x0, y0 = origin
    for k in range(fp.x.shape[0]):
        if fp.cyl[k]:
            ex = fp.hx[k] + reach
            ey = ex
        else:
            ex = abs(fp.c[k]) * fp.hx[k] + abs(fp.s[k]) * fp.hy[k] + reach
            ey = abs(fp.s[k]) * fp.hx[k] + abs(fp.c[k]) * fp.hy[k] + reach
        j0 = max(0, int(math.floor((fp.x[k] - ex - x0) / cell)))
        j1 = min(cols - 1, int(math.ceil((fp.x[k] + ex - x0) / cell)))
        i0 = max(0, int(math.floor((fp.y[k] - ey - y0) / cell)))
        i1 = min(rows - 1, int(math.ceil((fp.y[k] + ey - y0) / cell)))
        for i in range(i0, i1 + 1):
            py = y0 + i * cell - fp.y[k]
            for j in range(j0, j1 + 1):
                px = x0 + j * cell - fp.x[k]
                if fp.cyl[k]:
                    d = max(math.sqrt(px * px + py * py) - fp.hx[k], 0.0)
                else:
                    lx = fp.c[k] * px + fp.s[k] * py
                    ly = -fp.s[k] * px + fp.c[k] * py
                    dx = max(abs(lx) - fp.hx[k], 0.0)
                    dy = max(abs(ly) - fp.hy[k], 0.0)
                    d = math.sqrt(dx * dx + dy * dy)
                if d < out[i, j]:
                    out[i, j] = d
    return out


def footprint_distance(shape: tuple[int, int], cell_m: float, obstacles: tuple[Obstacle, ...] | list[Obstacle],
                       reach: float, origin: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """Distance (m) from each point of the grid (``origin`` + (j, i) * ``cell_m``) to the nearest
    footprint, ``inf`` beyond ``reach``."""
    if not obstacles:
        return np.full(shape, np.inf)
    out: np.ndarray = _distance(int(shape[0]), int(shape[1]), float(cell_m), (float(origin[0]), float(origin[1])),
                                footprints(obstacles), float(reach))
    return out


def free_raster(size_m: tuple[float, float], cell_m: float, obstacles: tuple[Obstacle, ...] | list[Obstacle],
                clearance_m: float) -> np.ndarray:
    """Where a robot's centre may be: the cell centres ((j + 1/2), (i + 1/2)) * ``cell_m`` of the
    map at least ``clearance_m`` from every footprint and from the map's edge (bool, rows along y)."""
    cols = max(1, int(round(size_m[0] / cell_m)))
    rows = max(1, int(round(size_m[1] / cell_m)))
    d = footprint_distance((rows, cols), cell_m, obstacles, clearance_m, origin=(cell_m / 2, cell_m / 2))
    free = d >= clearance_m
    xs = (np.arange(cols) + 0.5) * cell_m
    ys = (np.arange(rows) + 0.5) * cell_m
    free &= ((xs >= clearance_m) & (xs <= size_m[0] - clearance_m))[None, :]
    free &= ((ys >= clearance_m) & (ys <= size_m[1] - clearance_m))[:, None]
    out: np.ndarray = free
    return out


def components(free: np.ndarray) -> np.ndarray:
    """Labels of the 4-connected parts of ``free`` (0 where not free; 1, 2, ... per part)."""
    from scipy import ndimage  # here: 0.3-0.5 s to import, and a process that only runs missions never needs it

    labels, _n = ndimage.label(free)
    out: np.ndarray = labels
    return out


def cell_of(x: float, y: float, cell_m: float, shape: tuple[int, int]) -> tuple[int, int]:
    """The (row, col) of the raster cell holding (x, y) (clamped to the raster)."""
    i = min(max(int(math.floor(y / cell_m)), 0), shape[0] - 1)
    j = min(max(int(math.floor(x / cell_m)), 0), shape[1] - 1)
    return i, j


def raster_cell_for(size_m: tuple[float, float], finest_m: float = 0.05, max_cells: int = 4_000_000) -> float:
    """The raster's cell: ``finest_m``, or coarser on a map that would need more than ``max_cells``."""
    need = math.sqrt(size_m[0] * size_m[1] / max_cells)
    return max(finest_m, need)
