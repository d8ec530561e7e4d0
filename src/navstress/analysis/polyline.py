"""Ramer-Douglas-Peucker simplification of the report's run lines, compiled (numba).

A paper-sized report draws thousands of trajectories; simplifying them in a Python loop was a
tenth of its time. :func:`rdp_keep` is the same algorithm in one compiled loop, with the same
arithmetic in the same order (numba compiles without fast-math: nothing reassociated or fused;
``hypot`` is libm's, as numpy's), so it keeps exactly the points the Python version kept: a test
compares them on arbitrary polylines.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))


@numba.njit(cache=True)
def rdp_keep(xy: np.ndarray, tol: float) -> np.ndarray:
    """The mask of the points of the polyline ``xy`` (N, 2) to keep so that no dropped point is
    farther than ``tol`` from the simplified line (its distance to the line through the kept
    points around it; to the point itself when those two coincide); first and last always kept.
    Of several equally far points, the first is kept (``np.argmax``; a NaN distance counts as the
    largest, as there)."""
    n = xy.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    if n == 0:
        return keep
    keep[0] = True
    keep[n - 1] = True
    stack = np.empty((max(n, 1), 2), dtype=np.int64)
    stack[0, 0], stack[0, 1] = 0, n - 1
    top = 1
    while top > 0:
        top -= 1
        i, j = stack[top, 0], stack[top, 1]
        if j - i < 2:
            continue
        ax, ay = xy[i, 0], xy[i, 1]
        s0, s1 = xy[j, 0] - ax, xy[j, 1] - ay
        length = math.hypot(s0, s1)
        k = -1
        best = 0.0
        for m in range(i + 1, j):
            p0, p1 = xy[m, 0] - ax, xy[m, 1] - ay
            if length < 1e-12:
                d = math.hypot(p0, p1)
            else:
                d = abs(s0 * p1 - s1 * p0) / length
            if math.isnan(d):
                if k < 0 or not math.isnan(best):
                    k, best = m, d
                break  # np.argmax: the first NaN
            if k < 0 or d > best:
                k, best = m, d
        if best > tol:
            keep[k] = True
            stack[top, 0], stack[top, 1] = i, k
            stack[top + 1, 0], stack[top + 1, 1] = k, j
            top += 2
    return keep
