"""Vectorised sampling of the triangulated terrain surface (the same surface as
:meth:`navstress.world.world.Terrain.height_at`, its faces :func:`navstress.world.world.terrain_faces`),
and the exports' mission markers."""

from __future__ import annotations


import numpy as np

from navstress.world.world import Terrain


def surface_heights(terrain: Terrain, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Heights of the triangulated surface at points (x, y), clamped to the map.

    Same triangulation as ``Terrain.height_at``: each cell is split by the diagonal from
    vertex (i, j) to (i+1, j+1). Returns float64 of the broadcast shape of x and y.
    """
    h = terrain.heights.astype(np.float64)
    rows, cols = h.shape
    xa, ya = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
    fx = np.clip(xa / terrain.cell_m, 0.0, cols - 1.000001)
    fy = np.clip(ya / terrain.cell_m, 0.0, rows - 1.000001)
    j = fx.astype(np.int64)
    i = fy.astype(np.int64)
    u, v = fx - j, fy - i
    h00, h10 = h[i, j], h[i, j + 1]
    h01, h11 = h[i + 1, j], h[i + 1, j + 1]
    lower = h00 + u * (h10 - h00) + v * (h11 - h10)
    upper = h00 + v * (h01 - h00) + u * (h11 - h01)
    return np.where(u >= v, lower, upper)


def resample_square(terrain: Terrain, n: int) -> np.ndarray:
    """The surface sampled on an ``n`` x ``n`` grid spanning the whole map (rows along +y).

    Exact at grid vertices that coincide with terrain vertices; elsewhere the value of the
    triangulated surface (piecewise linear), so no new extremes are introduced.
    """
    sx, sy = terrain.size_m
    xs = np.linspace(0.0, sx, n)
    ys = np.linspace(0.0, sy, n)
    return surface_heights(terrain, xs[None, :], ys[:, None])


def next_pow2_plus1(n: int) -> int:
    """Smallest 2**k + 1 >= n (k >= 1), the image side Gazebo heightmaps require."""
    k = 1
    while (1 << k) + 1 < n:
        k += 1
    return (1 << k) + 1


#: The mission markers of the SDF and mesh exports (meters): the start is a disc with an arrow
#: along the start heading, the goal a disc with a pole.
MARKER = {"radius": 0.5, "thickness": 0.04, "arrow_length": 1.2, "arrow_width": 0.15, "pole_height": 2.5}
#: Their colours (RGBA, 0-255).
MARKER_RGBA = {"start": (26, 191, 51, 255), "goal": (217, 26, 26, 255)}
