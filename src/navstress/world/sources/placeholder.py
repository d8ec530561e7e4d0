"""The placeholder mission of an imported world that has none of its own (a Gazebo world): a
start and a goal far apart in the free space, each at least ``clearance_m`` from every obstacle
footprint. A spec's own mission (given, or drawn per seed by :func:`~navstress.world.sources.realise`)
replaces it; it only makes the imported world a complete, runnable :class:`World` on its own.

Deterministic and cheap: the footprints are rasterised on a grid of at most ``MAX_CELLS`` cells a
side; the start is the free cell nearest the world's lower-left corner, the goal the free cell
farthest from the start, the start facing the goal. A world with no free cell gets its corners."""

from __future__ import annotations

import math

import numpy as np

from navstress.world.world import Mission, Obstacle

MAX_CELLS = 400


def placeholder_mission(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...],
                        clearance_m: float = 0.5) -> Mission:
    """A far-apart free start and goal in a world of ``size_m`` (its frame: lower-left (0, 0))."""
    sx, sy = size_m
    res = max(0.05, max(sx, sy) / MAX_CELLS)
    nx, ny = max(1, math.ceil(sx / res)), max(1, math.ceil(sy / res))
    xs = (np.arange(nx) + 0.5) * (sx / nx)
    ys = (np.arange(ny) + 0.5) * (sy / ny)
    blocked = np.zeros((ny, nx), bool)
    # the map's edge counts as an obstacle
    blocked[:, (xs < clearance_m) | (xs > sx - clearance_m)] = True
    blocked[(ys < clearance_m) | (ys > sy - clearance_m), :] = True
    for o in obstacles:
        reach = o.radius_xy + clearance_m
        i0, i1 = np.searchsorted(ys, [o.y - reach, o.y + reach])
        j0, j1 = np.searchsorted(xs, [o.x - reach, o.x + reach])
        if i0 >= i1 or j0 >= j1:
            continue
        dx = xs[None, j0:j1] - o.x
        dy = ys[i0:i1, None] - o.y
        if o.is_cylinder:
            hit = dx * dx + dy * dy <= reach * reach
        else:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            u, v = dx * c + dy * s, -dx * s + dy * c
            hit = (np.abs(u) <= o.size[0] / 2 + clearance_m) & (np.abs(v) <= o.size[1] / 2 + clearance_m)
        blocked[i0:i1, j0:j1] |= hit
    free_i, free_j = np.nonzero(~blocked)
    if len(free_i) == 0:
        start_xy, goal_xy = (min(1.0, sx / 4), min(1.0, sy / 4)), (sx - min(1.0, sx / 4), sy - min(1.0, sy / 4))
    else:
        fx, fy = xs[free_j], ys[free_i]
        k = int(np.argmin(fx * fx + fy * fy))
        start_xy = (float(fx[k]), float(fy[k]))
        g = int(np.argmax((fx - start_xy[0]) ** 2 + (fy - start_xy[1]) ** 2))
        goal_xy = (float(fx[g]), float(fy[g]))
    yaw = math.atan2(goal_xy[1] - start_xy[1], goal_xy[0] - start_xy[0])
    return Mission(start=(start_xy[0], start_xy[1], yaw), goal=goal_xy, free_radius_m=0.0)
