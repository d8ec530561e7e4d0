"""Compiled kernels over boolean grids (the free space's distance transform, a map's runs of
wall cells); :mod:`navstress.world.freespace` and :mod:`navstress.world.sources.occupancy` call them."""

from __future__ import annotations

import navstress._jit  # noqa: F401  (numba's cache for this source tree, before any decorator)

import numpy as np
from numba import njit


@njit(cache=True)
def edt_squared(blocked: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """The squared Euclidean distance, in cells, from each cell's centre to the nearest blocked
    cell's centre, the cells outside the grid counted as blocked (Felzenszwalb and Huttenlocher's
    two passes: along the columns, then the lower envelope of parabolas along the rows). Exact:
    ``scipy.ndimage.distance_transform_edt`` of the grid padded by a blocked border, squared."""
    rows, cols = blocked.shape
    big = float(rows + cols + 2) ** 2
    col = np.empty((rows, cols), np.float64)
    last = np.full(cols, -1, np.int64)
    for i in range(rows):  # 1-D: distance to the nearest blocked cell (or the edge) along each column, row-major
        for j in range(cols):
            if blocked[i, j]:
                last[j] = i
                col[i, j] = 0.0
            else:
                col[i, j] = float(i - last[j])
    last[:] = rows
    for i in range(rows - 1, -1, -1):
        for j in range(cols):
            if blocked[i, j]:
                last[j] = i
            else:
                d = float(last[j] - i)
                if d < col[i, j]:
                    col[i, j] = d
    out = np.empty((rows, cols), np.float64)
    f = np.empty(cols + 2, np.float64)
    v = np.empty(cols + 2, np.int64)
    z = np.empty(cols + 3, np.float64)
    for i in range(rows):
        # the row with a blocked cell beyond each end: f(-1) = f(cols) = 0
        n = cols + 2
        f[0] = 0.0
        f[n - 1] = 0.0
        for j in range(cols):
            c = col[i, j]
            f[j + 1] = c * c if c * c < big else big
        k = 0
        v[0] = 0
        z[0] = -np.inf
        z[1] = np.inf
        for q in range(1, n):
            s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
            while s <= z[k]:
                k -= 1
                s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
            k += 1
            v[k] = q
            z[k] = s
            z[k + 1] = np.inf
        k = 0
        for q in range(1, n - 1):
            while z[k + 1] < q:
                k += 1
            d = q - v[k]
            out[i, q - 1] = d * d + f[v[k]]
    return out


@njit(cache=True)
def row_runs(mask: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """The runs of True cells of each row: (n, 3) int64 rows ``(row, start, end)`` (end
    exclusive), row-major."""
    rows, cols = mask.shape
    n = 0
    for i in range(rows):
        prev = False
        for j in range(cols):
            cur = mask[i, j]
            if cur and not prev:
                n += 1
            prev = cur
    out = np.empty((n, 3), np.int64)
    k = 0
    for i in range(rows):
        prev = False
        for j in range(cols):
            cur = mask[i, j]
            if cur and not prev:
                out[k, 0] = i
                out[k, 1] = j
            elif prev and not cur:
                out[k, 2] = j
                k += 1
            prev = cur
        if prev:
            out[k, 2] = cols
            k += 1
    return out


@njit(cache=True)
def col_runs(mask: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """The runs of True cells of each column of a row-major grid: (n, 3) int64 rows ``(col,
    start, end)``, column-major (the row runs of the transpose, without copying it)."""
    rows, cols = mask.shape
    n = 0
    prev = np.zeros(cols, np.bool_)
    for i in range(rows):
        for j in range(cols):
            cur = mask[i, j]
            if cur and not prev[j]:
                n += 1
            prev[j] = cur
    start = np.full(cols, -1, np.int64)
    runs = np.empty((n, 3), np.int64)
    k = 0
    for i in range(rows + 1):
        for j in range(cols):
            cur = mask[i, j] if i < rows else False
            if cur and start[j] < 0:
                start[j] = i
            elif not cur and start[j] >= 0:
                runs[k, 0] = j
                runs[k, 1] = start[j]
                runs[k, 2] = i
                start[j] = -1
                k += 1
    order = np.argsort(runs[:, 0] * (rows + 1) + runs[:, 1])
    return runs[order]
