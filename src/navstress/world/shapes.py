"""Exact footprint geometry of obstacles of every shape (docs/worlds.md, "Obstacle shapes and walls").

An obstacle's footprint is a closed set of the ground plane: a box's rectangle turned by its yaw,
or a cylinder's disc (radius ``size[0] / 2``; its yaw has no effect). Every consumer of obstacles
outside the simulator tests footprints here, never through a bounding circle:

* :func:`aabb`: the footprint's axis-aligned bounding box (exact: a disc's is x +- r);
* :func:`distance`: the distance from a point to the footprint (0 inside);
* :func:`overlap`: whether two footprints share an interior point (touching is allowed);
* :func:`disc_clear`: whether a footprint keeps out of an open disc (the mission's free discs);
* :func:`inside_map`: whether a footprint lies inside the map;
* :func:`cells_touched`: a conservative raster of a footprint: every cell of a grid the closed
  footprint touches (the placement and clearance rasters mark these);
* :func:`wall_boxes`: the boxes of a polyline wall (``obstacles.walls`` of a WorldSpec).

**Walls.** A wall polyline ``p0, p1, ..., pn`` of thickness ``t`` and height ``h`` becomes one box
of kind ``wall`` per segment: centred on the segment's midpoint, turned along it (yaw =
``atan2(dy, dx)``), ``length + t`` long, ``t`` thick and ``h`` high: each segment is extended by
half the thickness at both ends (a *square cap*, as SVG's ``stroke-linecap: square``), so that two
segments meeting at a joint at any angle leave no gap at the joint's outer corner (at a right
angle the two boxes both cover the ``t x t`` square of the corner). Consecutive segments of one
wall therefore overlap at their joint (at most ``t**2``; the obstruction descriptor counts that
area twice), and a wall's free ends stick out ``t / 2`` past its end points.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

from navstress.world.spec import wall_segment
from navstress.world.world import Obstacle

if TYPE_CHECKING:
    from navstress.world.spec import WallSpec

#: The kind of the boxes of a wall polyline.
WALL_KIND = "wall"
#: Relative slack of the closed tests (cells touched): a footprint that only touches a cell at
#: rounding distance still marks it (conservative).
_EPS = 1e-9


def is_axis_box(o: Obstacle) -> bool:
    """A box not turned (yaw 0): its footprint is its bounding box."""
    return o.shape == "box" and o.yaw == 0.0


def aabb(o: Obstacle) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1): the footprint's axis-aligned bounding box (exact for every shape)."""
    if o.is_cylinder:
        r = o.size[0] / 2
        return (o.x - r, o.y - r, o.x + r, o.y + r)
    c = o.corners()
    return (float(c[:, 0].min()), float(c[:, 1].min()), float(c[:, 0].max()), float(c[:, 1].max()))


def _local(o: Obstacle, px: np.ndarray | float, py: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Points in the box's own frame (x along its first side)."""
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    dx, dy = np.asarray(px, np.float64) - o.x, np.asarray(py, np.float64) - o.y
    return c * dx + s * dy, -s * dx + c * dy


def distance(o: Obstacle, px: np.ndarray | float, py: np.ndarray | float) -> np.ndarray:
    """Distance (m) from points (px, py) to the footprint of ``o`` (0 inside), broadcast."""
    if o.is_cylinder:
        d = np.hypot(np.asarray(px, np.float64) - o.x, np.asarray(py, np.float64) - o.y) - o.size[0] / 2
        out: np.ndarray = np.maximum(d, 0.0)
        return out
    lx, ly = _local(o, px, py)
    ex = np.maximum(np.abs(lx) - o.size[0] / 2, 0.0)
    ey = np.maximum(np.abs(ly) - o.size[1] / 2, 0.0)
    res: np.ndarray = np.hypot(ex, ey)
    return res


def disc_clear(o: Obstacle, cx: float, cy: float, r: float) -> bool:
    """Whether the closed footprint keeps out of the open disc of radius ``r`` around (cx, cy)."""
    return float(distance(o, cx, cy)) >= r


def inside_map(o: Obstacle, size_x: float, size_y: float) -> bool:
    """Whether the footprint lies inside the map [0, size_x] x [0, size_y]."""
    x0, y0, x1, y1 = aabb(o)
    return x0 >= 0.0 and y0 >= 0.0 and x1 <= size_x and y1 <= size_y


def _axes(o: Obstacle) -> list[tuple[float, float]]:
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    return [(c, s), (-s, c)]


def _project(corners: np.ndarray, ax: tuple[float, float]) -> tuple[float, float]:
    p = corners[:, 0] * ax[0] + corners[:, 1] * ax[1]
    return float(p.min()), float(p.max())


def overlap(a: Obstacle, b: Obstacle) -> bool:
    """Whether the footprints of ``a`` and ``b`` share an interior point (touching is allowed).

    Exact: two discs by the distance of their centres, a disc and a box by the distance of the
    disc's centre to the box, two boxes by the separating axis theorem (two boxes not turned: by
    their bounding boxes, the test placement always made)."""
    if a.is_cylinder and b.is_cylinder:
        return math.hypot(a.x - b.x, a.y - b.y) < (a.size[0] + b.size[0]) / 2
    if a.is_cylinder or b.is_cylinder:
        disc, box = (a, b) if a.is_cylinder else (b, a)
        return not disc_clear(box, disc.x, disc.y, disc.size[0] / 2)
    if is_axis_box(a) and is_axis_box(b):
        p, q = aabb(a), aabb(b)
        return p[0] < q[2] and q[0] < p[2] and p[1] < q[3] and q[1] < p[3]
    ca, cb = a.corners(), b.corners()
    for ax in _axes(a) + _axes(b):
        lo_a, hi_a = _project(ca, ax)
        lo_b, hi_b = _project(cb, ax)
        if not (lo_a < hi_b and lo_b < hi_a):
            return False  # a separating axis (or one they only touch along)
    return True


def cells_touched(o: Obstacle, rx: float, ry: float, nx: int, ny: int) -> tuple[int, int, np.ndarray] | None:
    """The cells of a grid (cell (b, a) = x in [a rx, (a+1) rx], y in [b ry, (b+1) ry], ``nx`` x
    ``ny`` cells) that the closed footprint of ``o`` touches: ``(b0, a0, mask)`` with ``mask`` the
    touched cells of the window starting at row ``b0``, column ``a0``; None when it touches none.

    Conservative (a cell the footprint only touches at rounding distance is marked too): a disc
    marks the cells within its radius, a box the cells whose rectangle meets it (separating axis
    theorem on the cell and the box)."""
    x0, y0, x1, y1 = aabb(o)
    a0, a1 = max(0, int(math.floor(x0 / rx))), min(nx - 1, int(math.floor(x1 / rx)))
    b0, b1 = max(0, int(math.floor(y0 / ry))), min(ny - 1, int(math.floor(y1 / ry)))
    if a1 < a0 or b1 < b0:
        return None
    xa = np.arange(a0, a1 + 1) * rx  # cell lower-left corners
    yb = np.arange(b0, b1 + 1) * ry
    slack = _EPS * max(1.0, abs(o.x), abs(o.y), o.size[0], o.size[1])
    if o.is_cylinder:
        r = o.size[0] / 2
        dx = np.maximum(np.maximum(xa - o.x, o.x - (xa + rx)), 0.0)
        dy = np.maximum(np.maximum(yb - o.y, o.y - (yb + ry)), 0.0)
        mask = dx[None, :] ** 2 + dy[:, None] ** 2 <= (r + slack) ** 2
        return b0, a0, mask
    if is_axis_box(o):
        return b0, a0, np.ones((b1 - b0 + 1, a1 - a0 + 1), bool)
    # separating axes: the grid's (x, y: the box's bounding box already settles them) and the box's
    cx0, cy0 = xa[None, :] + np.zeros((len(yb), 1)), yb[:, None] + np.zeros((1, len(xa)))
    mask = np.ones(cx0.shape, bool)
    hx, hy = o.size[0] / 2, o.size[1] / 2
    for (ux, uy), h in zip(_axes(o), (hx, hy)):
        centre = ux * (cx0 + rx / 2 - o.x) + uy * (cy0 + ry / 2 - o.y)  # the cell centre on the axis
        half = (abs(ux) * rx + abs(uy) * ry) / 2  # the cell's half extent on the axis
        mask &= np.abs(centre) <= h + half + slack
    return b0, a0, mask


def mark(occ: np.ndarray, rx: float, ry: float, o: Obstacle, value: int = 1) -> None:
    """Set every cell of ``occ`` (rows along y) that the closed footprint of ``o`` touches."""
    ny, nx = occ.shape
    hit = cells_touched(o, rx, ry, nx, ny)
    if hit is None:
        return
    b0, a0, mask = hit
    win = occ[b0:b0 + mask.shape[0], a0:a0 + mask.shape[1]]
    win[mask] = value


def wall_boxes(points: Sequence[tuple[float, float]], thickness_m: float, height_m: float,
               kind: str = WALL_KIND, z: float = 0.0) -> list[Obstacle]:
    """The boxes of a wall polyline (see the module docstring): one per segment, in order."""
    out: list[Obstacle] = []
    for a, b in zip(points, points[1:]):
        x, y, yaw, length = wall_segment(a, b, thickness_m)
        out.append(Obstacle(kind=kind, x=x, y=y, yaw=yaw, size=(length, thickness_m, height_m), z=z))
    return out



def wall_obstacles(walls: Sequence[WallSpec]) -> list[Obstacle]:
    """The boxes of a spec's ``obstacles.walls``, wall after wall, segment after segment."""
    out: list[Obstacle] = []
    for w in walls:
        out.extend(wall_boxes(w.points, w.thickness_m, w.height_m))
    return out


def first_in_disc(obstacles: Sequence[Obstacle], cx: float, cy: float, r: float) -> int:
    """The index of the first obstacle whose footprint enters the open disc of radius ``r``
    around (cx, cy), -1 when none does."""
    if r <= 0:
        return -1
    for k, o in enumerate(obstacles):
        x0, y0, x1, y1 = aabb(o)
        if x1 > cx - r and x0 < cx + r and y1 > cy - r and y0 < cy + r and not disc_clear(o, cx, cy, r):
            return k
    return -1
