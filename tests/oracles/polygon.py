"""Exact polygon geometry for the planner's footprint tests: the area of a convex polygon inside
an axis-aligned square (Sutherland-Hodgman clipping, then the shoelace formula)."""

from __future__ import annotations

import numpy as np


def clip_area(rect: np.ndarray, x0: float, y0: float, side: float) -> float:
    """Area of the convex polygon ``rect`` inside the square [x0, x0+side] x [y0, y0+side]."""
    poly = [tuple(p) for p in rect]
    for axis, bound, keep_ge in ((0, x0, True), (0, x0 + side, False), (1, y0, True), (1, y0 + side, False)):
        out = []
        for k in range(len(poly)):
            p, q = poly[k], poly[(k + 1) % len(poly)]
            pin = (p[axis] >= bound) if keep_ge else (p[axis] <= bound)
            qin = (q[axis] >= bound) if keep_ge else (q[axis] <= bound)
            if pin:
                out.append(p)
            if pin != qin:
                f = (bound - p[axis]) / (q[axis] - p[axis])
                out.append((p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])))
        poly = out
        if not poly:
            return 0.0
    xs, ys = np.array(poly).T
    return 0.5 * abs(float(np.dot(xs, np.roll(ys, 1)) - np.dot(ys, np.roll(xs, 1))))
