"""Trajectory metrics kept with every run.

``tortuousness`` is the mean absolute heading change between successive positions of the
trajectory *resampled at a fixed travelled distance* (default every 0.5 m, after discarding moves shorter than
0.1 m from the last kept position), in radians per step. Resampling by distance, not time, keeps sensor jitter and stops (where the heading of
a tiny displacement is noise) from dominating the angle: a straight run scores ~0, a run
that zig-zags or circles scores high.

    >>> import numpy as np
    >>> xy = np.column_stack([np.linspace(0, 10, 101), np.zeros(101)])
    >>> round(path_length(xy), 6), round(tortuousness(xy), 6)
    (10.0, 0.0)
"""

from __future__ import annotations

import math

import numpy as np

RESAMPLE_STEP_M = 0.5


def path_length(xy: np.ndarray) -> float:
    """Length of the polyline through the (N, 2) positions."""
    if len(xy) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(np.asarray(xy, dtype=np.float64), axis=0).T)))


def drop_jitter(xy: np.ndarray, min_move_m: float) -> np.ndarray:
    """Keep a point only once it is ``min_move_m`` away from the last kept one (first kept)."""
    p = np.asarray(xy, dtype=np.float64)
    if len(p) == 0:
        return p.copy()
    keep = [0]
    lx, ly = p[0]
    for k in range(1, len(p)):
        x, y = p[k]
        if (x - lx) ** 2 + (y - ly) ** 2 >= min_move_m**2:
            keep.append(k)
            lx, ly = x, y
    return p[keep]


def resample_by_distance(xy: np.ndarray, step_m: float = RESAMPLE_STEP_M) -> np.ndarray:
    """Points every ``step_m`` of travelled distance along the polyline (first point kept),
    after dropping moves shorter than ``step_m / 5`` (jitter while stopped adds no distance)."""
    p = drop_jitter(xy, step_m / 5)
    if len(p) < 2:
        return p.copy()
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] < step_m:
        return p[:1].copy()
    targets = np.arange(0.0, s[-1] + 1e-12, step_m)
    keep = np.concatenate([[True], seg > 0])  # np.interp needs increasing abscissae
    return np.column_stack([np.interp(targets, s[keep], p[keep, 0]), np.interp(targets, s[keep], p[keep, 1])])


def tortuousness(xy: np.ndarray, step_m: float = RESAMPLE_STEP_M) -> float:
    """Mean |heading change| (rad) between successive distance-resampled positions; 0 if too short."""
    r = resample_by_distance(xy, step_m)
    if len(r) < 3:
        return 0.0
    d = np.diff(r, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    dh = np.diff(heading)
    dh = (dh + math.pi) % (2 * math.pi) - math.pi
    return float(np.mean(np.abs(dh)))
