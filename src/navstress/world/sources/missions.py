"""Missions in an imported world (docs/worlds.md, "Any world in campaigns, searches, compare and
gate"): a given start or goal checked against the world's geometry, and a start/goal pair drawn
per map seed in the free space with the robot's clearance.

The free space is a raster of the obstacles' footprints (cell :func:`raster_cell`; a cell is
occupied when its centre lies within half a cell diagonal of a footprint, so that every point of a
footprint is within that of an occupied cell's centre) and its Euclidean distance transform. A
point may be a start or a goal when its distance to every footprint and to the map's edges is at
least the *clearance* (the robot's half diagonal plus :data:`CLEARANCE_MARGIN_M`: the robot may
turn on the spot there); start and goal lie in one connected part of the space where the robot's
half width fits (8-connected cells), so the goal is reachable by a robot of that width. The
distance between them is at least ``mission.min_distance_m`` capped at
:data:`MIN_DISTANCE_CAP` x the map's diagonal (the default 50 m is meant for the paper's 100 m
maps; an office is smaller)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from navstress.errors import GenerationError, SpecError
from navstress.world.freespace import cells_inside
from navstress.world.world import Mission, Obstacle, WorldSource

#: The clearance of a drawn start or goal beyond the robot's half diagonal (m).
CLEARANCE_MARGIN_M = 0.1
#: A drawn pair's least distance is at most this fraction of the map's diagonal.
MIN_DISTANCE_CAP = 0.5
#: Finest raster cell (m) and the most cells of the free-space raster.
FINEST_CELL_M = 0.05
MAX_CELLS = 4_000_000
#: Starts tried before a drawn mission gives up.
MAX_TRIES = 200


def raster_cell(size_m: tuple[float, float]) -> float:
    """The free-space raster's cell: :data:`FINEST_CELL_M`, coarser on a map of more than
    :data:`MAX_CELLS` such cells."""
    return max(FINEST_CELL_M, math.sqrt(size_m[0] * size_m[1] / MAX_CELLS))


def inside_footprint(o: Obstacle, x: float, y: float) -> bool:
    """Whether (x, y) lies in the closed footprint of ``o`` (exact)."""
    dx, dy = x - o.x, y - o.y
    if o.is_cylinder:
        return dx * dx + dy * dy <= (o.size[0] / 2) ** 2
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    return abs(lx) <= o.size[0] / 2 and abs(ly) <= o.size[1] / 2


def occupancy(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...], cell: float) -> np.ndarray:
    """Boolean raster (rows along y) of the cells whose centre is within half a cell diagonal of a footprint."""
    nx, ny = max(1, math.ceil(size_m[0] / cell)), max(1, math.ceil(size_m[1] / cell))
    occ = np.zeros((ny, nx), bool)
    h = cell * math.sqrt(0.5)
    for o in obstacles:
        r = o.radius_xy + h
        a0, a1 = max(0, int((o.x - r) / cell)), min(nx - 1, int((o.x + r) / cell))
        b0, b1 = max(0, int((o.y - r) / cell)), min(ny - 1, int((o.y + r) / cell))
        if a1 < a0 or b1 < b0:
            continue
        xs = (np.arange(a0, a1 + 1) + 0.5) * cell - o.x
        ys = (np.arange(b0, b1 + 1) + 0.5) * cell - o.y
        if o.is_cylinder:
            hit = xs[None, :] ** 2 + ys[:, None] ** 2 <= r * r
        else:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            lx = c * xs[None, :] + s * ys[:, None]
            ly = -s * xs[None, :] + c * ys[:, None]
            hit = (np.abs(lx) <= o.size[0] / 2 + h) & (np.abs(ly) <= o.size[1] / 2 + h)
        occ[b0:b1 + 1, a0:a1 + 1] |= hit
    return occ


def clearance_map(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...],
                  cell: float, outline: Sequence[Sequence[float]] | None = None) -> np.ndarray:
    """A lower bound of each raster cell centre's distance (m) to the nearest footprint and to the
    map's edges; with ``outline`` (an imported map's, ``map_outline_m``), the cells outside it
    (the padding) count as obstacles."""
    from scipy import ndimage  # (as the descriptors import it: only where used)

    occ = occupancy(size_m, obstacles, cell)
    if outline is not None:
        occ |= ~cells_inside(np.asarray(outline, np.float64), occ.shape, cell)
    ny, nx = occ.shape
    if occ.any():
        d = ndimage.distance_transform_edt(~occ) * cell - cell * math.sqrt(0.5)
    else:
        d = np.full(occ.shape, np.inf)
    xs = (np.arange(nx) + 0.5) * cell
    ys = (np.arange(ny) + 0.5) * cell
    edge = np.minimum(np.minimum(xs, size_m[0] - xs)[None, :], np.minimum(ys, size_m[1] - ys)[:, None])
    out: np.ndarray = np.minimum(d, edge)
    return out


def check_point(name: str, given: tuple[float, ...], xy: tuple[float, float], size_m: tuple[float, float],
                obstacles: tuple[Obstacle, ...], source: WorldSource) -> None:
    """SpecError naming ``mission.<name>`` when the point ``xy`` (navstress's frame; ``given``: as
    the spec gives it, in the source's frame) lies outside the map or inside an obstacle."""
    ox, oy = source.origin
    x, y = xy
    where = (f"a point of {source.path} in its own frame, inside [{ox:g}, {ox + size_m[0]:g}] x "
             f"[{oy:g}, {oy + size_m[1]:g}]")
    if not (0.0 <= x <= size_m[0] and 0.0 <= y <= size_m[1]):
        raise SpecError(f"mission.{name}", list(given), f"{where} (it lies outside the map)",
                        f"move the {name}, or leave it out to use the source's own or draw one (mission.mode: random)")
    for o in obstacles:
        if inside_footprint(o, x, y):
            raise SpecError(f"mission.{name}", list(given), f"{where}, outside every obstacle (it lies inside a "
                            f"{o.kind} at ({o.x + ox:.3g}, {o.y + oy:.3g}))", f"move the {name} into the free space")


def usable(mission: Mission, size_m: tuple[float, float], obstacles: tuple[Obstacle, ...]) -> bool:
    """Whether a source's own mission can be run: start and goal distinct, inside the map and
    outside every obstacle (a source without a mission of its own leaves a placeholder that is not)."""
    pts = (mission.start[:2], mission.goal)
    if math.hypot(pts[0][0] - pts[1][0], pts[0][1] - pts[1][1]) <= 0.0:
        return False
    for x, y in pts:
        if not (0.0 <= x <= size_m[0] and 0.0 <= y <= size_m[1]):
            return False
        if any(inside_footprint(o, x, y) for o in obstacles):
            return False
    return True


def draw_mission(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...], gen: np.random.Generator, *,
                 clearance: float, half_width: float, min_distance_m: float, free_radius_m: float,
                 start: tuple[float, float, float] | None = None,
                 goal: tuple[float, float] | None = None,
                 outline: Sequence[Sequence[float]] | None = None, where: str = "the imported map") -> Mission:
    """A start/goal pair drawn with ``gen`` in the free space (see the module docstring); a given
    ``start`` or ``goal`` (navstress's frame) is kept and the other drawn. GenerationError when
    the free space holds no such pair."""
    from scipy import ndimage

    cell = raster_cell(size_m)
    dist = clearance_map(size_m, obstacles, cell, outline)
    ny, nx = dist.shape
    free = dist >= clearance
    labels, _ = ndimage.label(dist >= half_width, structure=np.ones((3, 3), bool))
    min_d = min(min_distance_m, MIN_DISTANCE_CAP * math.hypot(*size_m))
    cells = np.flatnonzero(free)
    if cells.size == 0:
        raise GenerationError(f"{where}: no free point where the robot can stand and turn (a clearance of {clearance:.3g} m from "
                              f"every obstacle and edge) in the {size_m[0]:g}x{size_m[1]:g} m imported map; use a "
                              "smaller robot, or a map with more room (for a map: check its negate and thresholds, "
                              "or import unknown cells as free)")
    cx = (cells % nx + 0.5) * cell
    cy = (cells // nx + 0.5) * cell
    comp = labels.ravel()[cells]

    def index_of(x: float, y: float) -> int:
        return int(min(ny - 1, max(0, int(y / cell))) * nx + min(nx - 1, max(0, int(x / cell))))

    def partner(x: float, y: float, c: int) -> tuple[float, float] | None:
        """A point drawn in component ``c`` at least ``min_d`` from (x, y), None when there is none."""
        ok = (comp == c) & (c > 0) & (np.hypot(cx - x, cy - y) >= min_d)
        cand = np.flatnonzero(ok)
        if cand.size == 0:
            return None
        j = int(cand[gen.integers(cand.size)])
        return float(cx[j]), float(cy[j])

    s_xy: tuple[float, float] | None = None
    g_xy: tuple[float, float] | None = None
    if start is not None and goal is not None:
        s_xy, g_xy = (start[0], start[1]), goal
    elif start is not None:
        s_xy = (start[0], start[1])
        g_xy = partner(*s_xy, int(labels.ravel()[index_of(*s_xy)]))
    elif goal is not None:
        g_xy = goal
        s_xy = partner(*g_xy, int(labels.ravel()[index_of(*g_xy)]))
    else:
        for _ in range(MAX_TRIES):
            k = int(gen.integers(cells.size))
            g_xy = partner(float(cx[k]), float(cy[k]), int(comp[k]))
            if g_xy is not None:
                s_xy = (float(cx[k]), float(cy[k]))
                break
    if s_xy is not None and g_xy is not None:
        yaw = start[2] if start is not None else math.atan2(g_xy[1] - s_xy[1], g_xy[0] - s_xy[0])
        return Mission(start=(float(s_xy[0]), float(s_xy[1]), float(yaw)), goal=(float(g_xy[0]), float(g_xy[1])),
                       free_radius_m=free_radius_m)
    raise GenerationError(f"no start/goal pair at least {min_d:.3g} m apart (mission.min_distance_m, capped at "
                          f"{MIN_DISTANCE_CAP:g} x the map's diagonal) with the robot's clearance of {clearance:.3g} m "
                          f"in one connected free area of the {size_m[0]:g}x{size_m[1]:g} m imported map; lower "
                          "mission.min_distance_m or give the start and goal")
