"""The free space of a world with a robot's clearance (docs/worlds.md, "Imported maps"): where
a robot of a given size may stand and turn, its connected parts, and a default mission.

:func:`free_space` rasterises a world's obstacles (boxes at any yaw, cylinders) conservatively
on a grid (a cell is blocked when any obstacle may touch it) and measures each free cell's
clearance: the distance from its centre to the nearest blocked cell or the world's edge, taken
short by half a cell's diagonal (never more than the true distance to the obstacles' raster).
:func:`free_space_of_grid` does the same for a grid the caller has (an occupancy map's cells).
:func:`farthest_mission` draws the default mission of a world without one: the two points of
the largest connected free part (cells where the robot passes: clearance >= its half width and
a margin) that are farthest apart among those where it can turn (clearance >= its half diagonal
and a margin); the start faces the goal. Every world source and the mission drawing may use them.

    >>> import numpy as np
    >>> grid = np.zeros((40, 60), bool); grid[:, 30] = True   # a wall across a 6 x 4 m map
    >>> fs = free_space_of_grid(grid, 0.1)
    >>> m = farthest_mission(fs, pass_m=0.3, turn_m=0.4)
    >>> m.start[0] < 3.0 and m.goal[0] < 3.0                   # both on the wall's left, the larger part
    True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navstress.errors import SpecError
from navstress.world.world import Mission, Obstacle, World

#: A cell centre is at most this many cells (half a diagonal) from any point of its cell.
_HALF_DIAG = math.sqrt(0.5)
#: The margins added to a robot's half width (to pass) and half diagonal (to turn on the spot).
PASS_MARGIN_M = 0.05
TURN_MARGIN_M = 0.10


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """A world's free space on a grid of ``cell_m`` cells: ``blocked[i, j]`` for the cell
    ``[j c, (j+1) c] x [i c, (i+1) c]`` (rows along +y, as the terrain's), ``clearance`` (float32,
    m) the distance from each free cell's centre to the nearest blocked cell or the grid's edge,
    less half a cell's diagonal (0 on blocked cells)."""

    cell_m: float
    blocked: np.ndarray
    clearance: np.ndarray

    def clear(self, clearance_m: float) -> np.ndarray:
        """Cells whose centre is at least ``clearance_m`` from every obstacle."""
        out: np.ndarray = self.clearance >= clearance_m
        return out

    def centre(self, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ((j + 0.5) * self.cell_m, (i + 0.5) * self.cell_m)

    def largest_part(self, clearance_m: float) -> np.ndarray:
        """The largest 8-connected part of the cells clear by ``clearance_m`` (an all-False mask
        when none is): where a robot whose centre keeps that far from obstacles can go."""
        from scipy import ndimage

        clear = self.clear(clearance_m)
        labels, n = ndimage.label(clear, structure=np.ones((3, 3), bool))
        if n == 0:
            return clear
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        out: np.ndarray = labels == int(np.argmax(sizes))
        return out


def free_space_of_grid(blocked: np.ndarray, cell_m: float) -> FreeSpace:
    """The free space of a boolean grid (True: blocked), its edge counted as blocked."""
    # numba loads only when a free space is computed: `import navstress.world` stays light
    from navstress.world._gridkernels import edt_squared

    b = np.ascontiguousarray(blocked, dtype=np.bool_)
    d = np.sqrt(edt_squared(b))
    clearance = np.maximum((d - _HALF_DIAG) * cell_m, 0.0).astype(np.float32)
    clearance[b] = 0.0
    return FreeSpace(cell_m=float(cell_m), blocked=b, clearance=clearance)


def rasterise(obstacles: tuple[Obstacle, ...] | list[Obstacle], size_m: tuple[float, float], cell_m: float) -> np.ndarray:
    """A boolean grid of ``cell_m`` cells over ``size_m``: True where an obstacle may touch the
    cell (exact for axis-aligned boxes on the grid's lines, conservative otherwise: a turned box
    or a cylinder blocks every cell whose centre is within half a cell's diagonal of it)."""
    rows, cols = max(1, math.ceil(size_m[1] / cell_m - 1e-9)), max(1, math.ceil(size_m[0] / cell_m - 1e-9))
    out = np.zeros((rows, cols), bool)
    axis: list[tuple[float, float, float, float]] = []
    for o in obstacles:
        if not o.is_cylinder:
            q = (o.yaw / (math.pi / 2)) % 2.0
            if min(abs(q), abs(q - 1.0), abs(q - 2.0)) < 1e-12:  # yaw a multiple of pi/2: axis-aligned
                hx, hy = o.size[0] / 2, o.size[1] / 2
                if abs(q - 1.0) < 1e-12:
                    hx, hy = hy, hx
                axis.append((o.x - hx, o.y - hy, o.x + hx, o.y + hy))
                continue
        _turned(out, o, cell_m)
    if axis:
        a = np.array(axis)
        j0 = np.clip(np.floor(a[:, 0] / cell_m + 1e-9), 0, cols).astype(np.int64)
        i0 = np.clip(np.floor(a[:, 1] / cell_m + 1e-9), 0, rows).astype(np.int64)
        j1 = np.clip(np.ceil(a[:, 2] / cell_m - 1e-9), 0, cols).astype(np.int64)
        i1 = np.clip(np.ceil(a[:, 3] / cell_m - 1e-9), 0, rows).astype(np.int64)
        keep = (j1 > j0) & (i1 > i0)
        diff = np.zeros((rows + 1, cols + 1), np.int32)
        np.add.at(diff, (i0[keep], j0[keep]), 1)
        np.add.at(diff, (i0[keep], j1[keep]), -1)
        np.add.at(diff, (i1[keep], j0[keep]), -1)
        np.add.at(diff, (i1[keep], j1[keep]), 1)
        out |= np.cumsum(np.cumsum(diff, axis=0), axis=1)[:rows, :cols] > 0
    return out


def _turned(out: np.ndarray, o: Obstacle, cell_m: float) -> None:
    rows, cols = out.shape
    grow = _HALF_DIAG * cell_m
    r = o.radius_xy + grow
    j0, j1 = max(0, math.floor((o.x - r) / cell_m)), min(cols, math.ceil((o.x + r) / cell_m))
    i0, i1 = max(0, math.floor((o.y - r) / cell_m)), min(rows, math.ceil((o.y + r) / cell_m))
    if j1 <= j0 or i1 <= i0:
        return
    xs = (np.arange(j0, j1) + 0.5) * cell_m - o.x
    ys = (np.arange(i0, i1) + 0.5) * cell_m - o.y
    dx, dy = np.meshgrid(xs, ys)
    if o.is_cylinder:
        hit = np.hypot(dx, dy) <= o.size[0] / 2 + grow
    else:
        c, s = math.cos(o.yaw), math.sin(o.yaw)
        u, v = c * dx + s * dy, -s * dx + c * dy
        hit = (np.abs(u) <= o.size[0] / 2 + grow) & (np.abs(v) <= o.size[1] / 2 + grow)
    out[i0:i1, j0:j1] |= hit


def free_space(world: World, cell_m: float | None = None) -> FreeSpace:
    """The free space of ``world`` (its static obstacles; the ground is taken as drivable) on a
    grid of ``cell_m`` (default: the world's terrain cell, at most 0.1 m, or coarser for at most
    about 4 million cells)."""
    sx, sy = world.size_m
    c = float(cell_m) if cell_m is not None else min(world.terrain.cell_m, max(0.1, math.sqrt(sx * sy / 4e6)))
    blocked = rasterise(world.obstacles, world.size_m, c)
    outline = world.descriptors.get("map_outline_m")
    if outline is not None:  # an imported map: the padding around it is outside the map
        blocked |= ~cells_inside(np.asarray(outline, np.float64), blocked.shape, c)
    return free_space_of_grid(blocked, c)


def cells_inside(poly: np.ndarray, shape: tuple[int, ...], cell_m: float) -> np.ndarray:
    """Cells whose whole square lies inside the convex polygon ``poly`` (counter-clockwise)."""
    rows, cols = shape
    x = (np.arange(cols) + 0.5) * cell_m
    y = (np.arange(rows) + 0.5) * cell_m
    xx, yy = np.meshgrid(x, y)
    inside = np.ones(shape, bool)
    for k in range(len(poly)):
        (ax, ay), (bx, by) = poly[k], poly[(k + 1) % len(poly)]
        ex, ey = bx - ax, by - ay
        n = math.hypot(ex, ey)
        if n == 0:
            continue
        reach = (abs(ex) + abs(ey)) / n * cell_m / 2  # how far a cell's square reaches past its centre across the edge
        inside &= (ex * (yy - ay) - ey * (xx - ax)) / n >= reach - 1e-9
    return inside


def farthest_mission(fs: FreeSpace, *, pass_m: float, turn_m: float) -> Mission | None:
    """The default mission in ``fs``: in its largest part where a robot keeping ``pass_m`` from
    obstacles goes, the two cell centres with clearance >= ``turn_m`` farthest apart (Euclidean;
    the start the one nearer the lower-left corner, facing the goal; ``free_radius_m`` =
    ``turn_m``). None when no cell has that clearance there."""
    part = fs.largest_part(pass_m)
    cand = part & fs.clear(turn_m)
    rows_any = cand.any(axis=1)
    if not rows_any.any():
        return None
    # only the first and the last candidate of each row can be a vertex of their convex hull
    ii = np.flatnonzero(rows_any)
    sub = cand[ii]
    first = np.argmax(sub, axis=1)
    last = sub.shape[1] - 1 - np.argmax(sub[:, ::-1], axis=1)
    ii, jj = np.concatenate([ii, ii]), np.concatenate([first, last])
    x, y = fs.centre(ii, jj)
    pts = np.stack([x, y], axis=1)
    hull = _hull_points(pts)
    d2 = ((hull[:, None, :] - hull[None, :, :]) ** 2).sum(axis=2)
    a, b = np.unravel_index(int(np.argmax(d2)), d2.shape)
    p, q = hull[a], hull[b]
    if (q[0] + q[1], q[1]) < (p[0] + p[1], p[1]):
        p, q = q, p
    yaw = math.atan2(float(q[1] - p[1]), float(q[0] - p[0])) if (p != q).any() else 0.0
    return Mission(start=(float(p[0]), float(p[1]), yaw), goal=(float(q[0]), float(q[1])), free_radius_m=float(turn_m))


def _hull_points(pts: np.ndarray) -> np.ndarray:
    """The vertices of the convex hull of ``pts`` (all of them when few or degenerate): the
    farthest pair of a set is a pair of its hull's vertices."""
    if len(pts) <= 512:
        return pts
    from scipy.spatial import ConvexHull, QhullError

    try:
        out: np.ndarray = pts[ConvexHull(pts).vertices]
        return out
    except (QhullError, ValueError):  # all on a line: its two ends
        k = np.lexsort((pts[:, 1], pts[:, 0]))
        return pts[[k[0], k[-1]]]


def clearances_for(half_width_m: float, half_diagonal_m: float) -> tuple[float, float]:
    """(pass, turn): the clearances a robot of this half width and half diagonal needs to pass
    between obstacles and to turn on the spot (each with its margin)."""
    return (half_width_m + PASS_MARGIN_M, half_diagonal_m + TURN_MARGIN_M)


def default_mission(world: World, *, half_width_m: float, half_diagonal_m: float, robot_name: str = "robot",
                    fs: FreeSpace | None = None) -> Mission:
    """:func:`farthest_mission` for a robot of this size in ``world`` (SpecError naming the
    world's source file when no free cell is large enough for it)."""
    pass_m, turn_m = clearances_for(half_width_m, half_diagonal_m)
    space = fs if fs is not None else free_space(world)
    m = farthest_mission(space, pass_m=pass_m, turn_m=turn_m)
    if m is None:
        where = world.source.path if world.source is not None else "world"
        best = float(space.clearance.max()) if space.clearance.size else 0.0
        raise SpecError(where, f"{robot_name}, {turn_m:.3g} m from every wall",
                        f"a map with a free point where the robot can stand and turn ({turn_m:.3g} m from every wall: "
                        f"its half diagonal and a {TURN_MARGIN_M:g} m margin, in the largest free part); the widest "
                        f"free point of this map is {best:.3g} m from the nearest wall",
                        "check the map's negate and thresholds, import unknown cells as free (--unknown free), "
                        "or choose a smaller robot (--robot)")
    return m
