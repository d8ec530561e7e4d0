"""P3D: the local arc planner.

Each cycle a fan of arcs starts at the perceived pose: ``forward_arcs`` arcs of length
``arc_length_m`` with curvatures evenly spaced in ``[-k_max, +k_max]`` (straight included), plus
optionally a turn on the spot (its nodes are the current position at headings rotating toward
the goal side). At each of the ``nodes_per_arc`` nodes the believed footprint (RobotSpec length x
width plus margin, oriented along the arc; a circle or polygon footprint by its bounding rectangle,
:func:`footprint_half_extents`) is laid on the map; the cells it overlaps (exactly:
positive-area overlap of the oriented rectangle with the cell square) give the node's cost:

* infinite if a *fine* obstacle cell (the DTM's 0.1 m obstacle layer) overlaps the footprint,
  if a coarse cell is never seen (with the default ``unknown_cell_cost``), or if the footprint
  leaves the map;
* otherwise ``w_s * slope / max_slope + w_r * roughness / max_roughness``, where a plane is fitted
  (least squares) to the mean heights of the known coarse cells that are not obstacle cells:
  slope = its tilt, roughness = the largest absolute residual; infinite above either maximum;
* plus ``clearance_cost`` when a fine obstacle cell overlaps the footprint grown by
  ``clearance_margin_m``.

A whole cycle (node poses, a window of coarse obstacle flags and the fine obstacle cells in it,
all node costs) is one compiled call (:func:`_plan_cycle`, then :func:`_evaluate_fan` and its
steps): the obstacle test is done once per window cell, not once per footprint cell. The cycle's
constants are one named record, :data:`CYCLE`.

An arc's terrain cost is the sum of its node costs (infinite as soon as one node is). The
navigator adds a goal term per arc and elects the cheapest arc whose terrain cost is at most the
election threshold (:meth:`ArcPlanner.elect`). Approximation: the footprint is evaluated at the
nodes only (15 per 3 m arc: 0.2 m apart, less than a cell), not swept continuously.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numba as nb
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.nav.reference.config import ReferenceConfig, for_robot
from navstress.nav.reference.terrain_map import TerrainMap, cell_ground
from navstress.robot import RobotSpec

__all__ = ["CYCLE", "ArcEvaluation", "ArcPlanner", "FanCosts", "TerrainArrays", "arc_nodes", "footprint_cells",
           "footprint_slope_roughness", "new_cycle", "node_cost"]

_MAX_FP_CELLS = 4096
_EPS = 1e-9  # touching within this (rounding) is not a positive-area overlap

_I, _F = np.int64, np.float64
#: The constants of one planning cycle (:func:`_plan_cycle`, :func:`_evaluate_fan`): a record
#: (numpy structured dtype, one field a line); :func:`new_cycle` demands every field.
CYCLE = np.dtype([
    ("ox", _F), ("oy", _F),  # corner of the map's cell [0, 0] (TerrainMap.origin)
    ("cell", _F),  # coarse cell side (m)
    ("step", _F),  # obstacle step threshold (m): TerrainMap.step_m
    ("sub", _I),  # fine obstacle cells per coarse cell side: TerrainMap.sub
    ("hl", _F), ("hw", _F),  # the believed footprint's half length and half width, margin included (m)
    ("rx", _F), ("ry", _F), ("ryaw", _F),  # the perceived pose, where the fan starts
    ("exempt", _I),  # 1: the cells under the footprint at (rx, ry, ryaw) are not checked
    ("max_slope_tan", _F), ("max_rough", _F),  # a node is untraversable above either
    ("w_s", _F), ("w_r", _F),  # weights of slope and roughness in a node's cost
    ("unknown_cost", _F),  # cost of an unknown coarse cell under a footprint (inf: blocked)
    ("clear_m", _F), ("clear_cost", _F),  # the clearance ring: its width (m), its cost
    ("length", _F),  # arc length (m)
    ("spin_dir", _I),  # the turn on the spot: +1 CCW, -1 CW, 0 none
    ("spin_angle", _F),  # the angle the turn on the spot covers (rad)
], align=True)
CYCLE_FIELDS: frozenset[str] = frozenset(CYCLE.names or ())
_CYCLE_NAMES = tuple(CYCLE.names or ())


def new_cycle(**values: float) -> np.ndarray:
    """A one-record :data:`CYCLE` array; every field must be given."""
    try:  # (a planning cycle makes one: kept cheap)
        row = tuple(map(values.__getitem__, _CYCLE_NAMES))
    except KeyError:
        row = ()
    if len(row) != len(values) or not row:
        raise TypeError(f"CYCLE fields missing: {sorted(CYCLE_FIELDS - set(values))}, "
                        f"unknown: {sorted(set(values) - CYCLE_FIELDS)}")
    p = np.empty(1, CYCLE)
    p[0] = row
    return p


class TerrainArrays(NamedTuple):
    """The map a fan is costed on: a :class:`TerrainMap`'s statistics (views)."""

    zmin: np.ndarray  # (R, C) lowest z hit per cell (+inf: unknown)
    zmax: np.ndarray  # (R, C) highest z hit per cell
    zsum: np.ndarray  # (R, C) sum of the hits' z
    hits: np.ndarray  # (R, C) hits per cell (0: unknown; TerrainMap.count)
    fine: np.ndarray  # (R, C, sub*sub + 1) float32: the fine layer (TerrainMap.fine)


class FanCosts(NamedTuple):
    """What :func:`_evaluate_fan` writes, per arc and node of the fan (A arcs, N nodes each)."""

    node: np.ndarray  # (A, N) node costs (inf: blocked)
    slope: np.ndarray  # (A, N) slope tangent of the plane fitted under the footprint (NaN: blocked)
    rough: np.ndarray  # (A, N) roughness: the fit's largest absolute residual (m; NaN: blocked)
    arc: np.ndarray  # (A,) an arc's terrain cost: the sum of its node costs


class _Grid(NamedTuple):
    """The map's grid: the corner of cell [0, 0], the cell side, its size, fine cells per cell side."""

    ox: float
    oy: float
    cell: float
    rows: int
    cols: int
    sub: int


class _Rect(NamedTuple):
    """An oriented rectangle (a footprint, :func:`_rect`): its centre, heading (cos, sin), half
    length and half width, and the half extents of its bounding box on the grid axes."""

    x: float
    y: float
    c: float
    s: float
    hl: float
    hw: float
    ex: float
    ey: float


# classes of a window's coarse cells (_Window.cls)
_KNOWN, _OBSTACLE, _EXEMPT, _UNKNOWN = 0, 1, 2, 3


class _Window(NamedTuple):
    """The coarse cells around a fan (:func:`_classify`): rows ``i0 ...``, columns ``j0 ...`` of the map."""

    i0: int
    j0: int
    cls: np.ndarray  # (wi, wj) int8: _KNOWN ground, _OBSTACLE, _EXEMPT (unknown, under the robot), _UNKNOWN
    ground: np.ndarray  # (wi, wj) known cells: the lowest known min z of their 3x3 neighbourhood
    zmean: np.ndarray  # (wi, wj) known cells: their mean height (0 elsewhere)
    xc: np.ndarray  # (wj,) x of the columns' cell centres
    yc: np.ndarray  # (wi,) y of the rows' cell centres
    n_obstacle: int  # cells of class _OBSTACLE


class _FineTest(NamedTuple):
    """The fine obstacle squares against a footprint (:func:`_fine_contact`)."""

    h: float  # half side of a fine square
    r_hit: float  # centre distances beyond which a square cannot touch the footprint
    r_clear: float  # ... nor the footprint grown by clear_m
    clear_m: float  # the clearance ring's width
    use_clear: bool  # whether the ring costs anything


# what a footprint's fine obstacle squares say (_fine_contact)
_CLEAR, _RING, _HIT = 0, 1, 2


@nb.njit(cache=True, inline="always")
def _rect(x: float, y: float, c: float, s: float, hl: float, hw: float) -> _Rect:
    """The :class:`_Rect` of half sides hl, hw at (x, y) with heading cos/sin (c, s)."""
    ac = abs(c)
    as_ = abs(s)
    return _Rect(x, y, c, s, hl, hw, hl * ac + hw * as_, hl * as_ + hw * ac)


@nb.njit(cache=True, inline="always")
def _footprint_box(r: _Rect, g: _Grid) -> tuple[float, int, int, int, int]:
    """Of a footprint: a cell's half-diagonal projection ``proj`` on its axes, and the range of
    cells its bounding box covers (j0, j1, i0, i1). Scalars only (cheap to inline in hot loops)."""
    j0 = int(math.floor((r.x - r.ex - g.ox) / g.cell))
    j1 = int(math.floor((r.x + r.ex - g.ox) / g.cell))
    i0 = int(math.floor((r.y - r.ey - g.oy) / g.cell))
    i1 = int(math.floor((r.y + r.ey - g.oy) / g.cell))
    proj = 0.5 * g.cell * (abs(r.c) + abs(r.s))
    return proj, j0, j1, i0, i1


@nb.njit(cache=True)
def _footprint_cells(cx: float, cy: float, yaw: float, hl: float, hw: float, g: _Grid, out_i: np.ndarray,
                     out_j: np.ndarray) -> int:
    """Cells whose square overlaps the oriented rectangle with positive area (separating-axis
    test). Returns their count, or -1 if the rectangle reaches outside the grid or overflows."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    r = _rect(cx, cy, c, s, hl, hw)
    proj, j0, j1, i0, i1 = _footprint_box(r, g)
    ex, ey, ox, oy, cell = r.ex, r.ey, g.ox, g.oy, g.cell
    half = 0.5 * cell
    n = 0
    for i in range(i0, i1 + 1):
        y0 = oy + i * cell
        if not (cy - ey < y0 + cell - _EPS and cy + ey > y0 + _EPS):
            continue
        for j in range(j0, j1 + 1):
            x0 = ox + j * cell
            if not (cx - ex < x0 + cell - _EPS and cx + ex > x0 + _EPS):
                continue
            dx = x0 + half - cx
            dy = y0 + half - cy
            if abs(dx * c + dy * s) >= hl + proj - _EPS:
                continue
            if abs(-dx * s + dy * c) >= hw + proj - _EPS:
                continue
            if i < 0 or j < 0 or i >= g.rows or j >= g.cols or n >= out_i.shape[0]:
                return -1
            out_i[n] = i
            out_j[n] = j
            n += 1
    return n


@nb.njit(cache=True)
def _map_footprint_cells(consts: np.ndarray, stats: np.ndarray, x: float, y: float, yaw: float, hl: float, hw: float,
                         out: np.ndarray) -> int:
    """:func:`_footprint_cells` on a :class:`TerrainMap` (its :attr:`~TerrainMap.constants` and
    ``stats``), into the rows of ``out`` (2, K): rows i, columns j."""
    mc = consts[0]
    g = _Grid(mc.ox, mc.oy, mc.cell, stats.shape[0], stats.shape[1], mc.sub)
    return _footprint_cells(x, y, yaw, hl, hw, g, out[0], out[1])


@nb.njit(cache=True)
def _fan_nodes(p: Any, curv: np.ndarray, out: np.ndarray, trig: np.ndarray) -> None:
    """Fill ``out`` (A, N, 3) with the fan's node poses from the :data:`CYCLE` record ``p``: the
    arcs of ``curv`` (as :func:`arc_nodes`), then, when ``p.spin_dir != 0``, the turn on the spot
    (``p.spin_angle`` covered by its N nodes); ``trig`` (A, N, 2) gets each node's (cos, sin)
    heading (the arcs' own sin/cos, reused)."""
    x, y, yaw, length, spin_dir, spin_angle = p.rx, p.ry, p.ryaw, p.length, p.spin_dir, p.spin_angle
    n_nodes = out.shape[1]
    cy0 = math.cos(yaw)
    sy0 = math.sin(yaw)
    for a in range(curv.shape[0]):
        k = curv[a]
        for n in range(n_nodes):
            s = length * (n + 1) / n_nodes
            th = yaw + k * s
            if abs(k) < 1e-9:
                out[a, n, 0] = x + s * cy0
                out[a, n, 1] = y + s * sy0
                trig[a, n, 0] = math.cos(th)
                trig[a, n, 1] = math.sin(th)
            else:
                st = math.sin(th)
                ct = math.cos(th)
                out[a, n, 0] = x + (st - sy0) / k
                out[a, n, 1] = y - (ct - cy0) / k
                trig[a, n, 0] = ct
                trig[a, n, 1] = st
            out[a, n, 2] = th
    if spin_dir != 0:
        a = curv.shape[0]
        for n in range(n_nodes):
            out[a, n, 0] = x
            out[a, n, 1] = y
            th = yaw + spin_dir * spin_angle * (n + 1) / n_nodes
            out[a, n, 2] = th
            trig[a, n, 0] = math.cos(th)
            trig[a, n, 1] = math.sin(th)


@nb.njit(cache=True)
def _node_trig(nodes: np.ndarray, trig: np.ndarray) -> None:
    """``trig[a, n]`` = (cos, sin) of the heading ``nodes[a, n, 2]``."""
    for a in range(nodes.shape[0]):
        for n in range(nodes.shape[1]):
            trig[a, n, 0] = math.cos(nodes[a, n, 2])
            trig[a, n, 1] = math.sin(nodes[a, n, 2])


@nb.njit(cache=True, inline="always")
def _rect_hits_square(dx: float, dy: float, r: _Rect, h: float) -> bool:
    """Separating-axis test: the rectangle ``r`` and the axis-aligned square of half side ``h``
    whose centre is (dx, dy) from the rectangle's overlap with positive area."""
    if abs(dx) >= r.ex + h - _EPS or abs(dy) >= r.ey + h - _EPS:
        return False
    pad = h * (abs(r.c) + abs(r.s))
    return abs(dx * r.c + dy * r.s) < r.hl + pad - _EPS and abs(-dx * r.s + dy * r.c) < r.hw + pad - _EPS


@nb.njit(cache=True)
def _window_bounds(g: _Grid, nodes: np.ndarray, rx: float, ry: float, reach: float) -> tuple[int, int, int, int]:
    """(i0, i1, j0, j1): the rows and columns of the map within ``reach`` of the bounding box of
    the fan's nodes and of its start (rx, ry), clipped to the map (i1 < i0 or j1 < j0: none)."""
    xlo = rx
    xhi = rx
    ylo = ry
    yhi = ry
    for a in range(nodes.shape[0]):
        for k in range(nodes.shape[1]):
            xlo = min(xlo, nodes[a, k, 0])
            xhi = max(xhi, nodes[a, k, 0])
            ylo = min(ylo, nodes[a, k, 1])
            yhi = max(yhi, nodes[a, k, 1])
    i0 = max(0, int(math.floor((ylo - reach - g.oy) / g.cell)))
    i1 = min(g.rows - 1, int(math.floor((yhi + reach - g.oy) / g.cell)))
    j0 = max(0, int(math.floor((xlo - reach - g.ox) / g.cell)))
    j1 = min(g.cols - 1, int(math.floor((xhi + reach - g.ox) / g.cell)))
    return i0, i1, j0, j1


@nb.njit(cache=True)
def _classify(maps: TerrainArrays, g: _Grid, i0: int, i1: int, j0: int, j1: int, step: float) -> _Window:
    """The window of rows i0..i1, columns j0..j1: per cell its class (known ground, obstacle:
    more than ``step`` above its ground, or unknown), its ground (the 3x3 minimum of the known
    cells' min z, computed separably: a row minimum, then a column minimum) and mean height."""
    nr, nc = g.rows, g.cols
    zmin, zmax, zsum, count = maps.zmin, maps.zmax, maps.zsum, maps.hits
    wi = max(0, i1 - i0 + 1)
    wj = max(0, j1 - j0 + 1)
    # the window's 3x3 ground minimum: row minima over a one-cell halo, then column minima
    hi0 = max(0, i0 - 1)
    hi1 = min(nr - 1, i1 + 1)
    rowmin = np.empty((max(0, hi1 - hi0 + 1), wj))
    for r in range(hi1 - hi0 + 1):
        i = hi0 + r
        for lj in range(wj):
            j = j0 + lj
            z = math.inf
            for b in range(max(0, j - 1), min(nc, j + 2)):
                if count[i, b] > 0 and zmin[i, b] < z:
                    z = zmin[i, b]
            rowmin[r, lj] = z
    cls = np.full((wi, wj), _UNKNOWN, dtype=np.int8)
    ground = np.empty((wi, wj))
    zmean = np.zeros((wi, wj))
    n_obst = 0
    for li in range(wi):
        i = i0 + li
        for lj in range(wj):
            j = j0 + lj
            if count[i, j] > 0:
                zmean[li, lj] = zsum[i, j] / count[i, j]
                z = math.inf
                for r in range(max(0, i - 1) - hi0, min(nr, i + 2) - hi0):
                    if rowmin[r, lj] < z:
                        z = rowmin[r, lj]
                ground[li, lj] = z
                if zmax[i, j] - z > step:
                    cls[li, lj] = _OBSTACLE
                    n_obst += 1
                else:
                    cls[li, lj] = _KNOWN
    # cell centres of the window's columns and rows (as the fit's moments need them)
    xc = np.empty(wj)
    for lj in range(wj):
        xc[lj] = g.ox + (j0 + lj + 0.5) * g.cell
    yc = np.empty(wi)
    for li in range(wi):
        yc[li] = g.oy + (i0 + li + 0.5) * g.cell
    return _Window(i0, j0, cls, ground, zmean, xc, yc, n_obst)


@nb.njit(cache=True)
def _fine_squares(fine: np.ndarray, win: _Window, g: _Grid, step: float, robot: _Rect,
                  exempt: bool) -> tuple[np.ndarray, int]:
    """(centres, n): the fine obstacle cells of the window as squares (their centres in the first
    n rows), from its coarse obstacle cells only (the fine ones lie inside); with ``exempt``,
    not those overlapping the footprint ``robot`` (the robot already stands there)."""
    sub, ox, oy, i0, j0 = g.sub, g.ox, g.oy, win.i0, win.j0
    cls, ground = win.cls, win.ground
    fcell = g.cell / sub
    h = 0.5 * fcell
    wi, wj = cls.shape
    pts = np.empty((win.n_obstacle * sub * sub, 2))
    n_pts = 0
    for li in range(wi):
        for lj in range(wj):
            if cls[li, lj] != _OBSTACLE:
                continue
            z = ground[li, lj]
            for u in range(sub):
                fi = (i0 + li) * sub + u
                for v in range(sub):
                    fj = (j0 + lj) * sub + v
                    if fine[i0 + li, j0 + lj, u * sub + v] - z > step:
                        px = ox + (fj + 0.5) * fcell
                        py = oy + (fi + 0.5) * fcell
                        if exempt and _rect_hits_square(px - robot.x, py - robot.y, robot, h):
                            continue
                        pts[n_pts, 0] = px
                        pts[n_pts, 1] = py
                        n_pts += 1
    return pts, n_pts


@nb.njit(cache=True)
def _exempt_cells(win: _Window, g: _Grid, x: float, y: float, yaw: float, hl: float, hw: float) -> None:
    """The unknown cells of the window under the footprint at (x, y, yaw) become _EXEMPT (none
    when that footprint leaves the map)."""
    buf_i = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    buf_j = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    n = _footprint_cells(x, y, yaw, hl, hw, g, buf_i, buf_j)
    cls, i0, j0 = win.cls, win.i0, win.j0
    for k in range(max(n, 0)):
        li = buf_i[k] - i0
        lj = buf_j[k] - j0
        if cls[li, lj] == _UNKNOWN:
            cls[li, lj] = _EXEMPT


@nb.njit(cache=True, inline="always")
def _squares_near(pts: np.ndarray, arc: np.ndarray, r: float, out: np.ndarray) -> int:
    """Copy into ``out`` the squares of ``pts`` whose centre lies within ``r`` of the bounding
    box of the nodes ``arc`` (N, 3) (strictly); returns how many."""
    axlo = arc[0, 0]
    axhi = axlo
    aylo = arc[0, 1]
    ayhi = aylo
    for k in range(1, arc.shape[0]):
        axlo = min(axlo, arc[k, 0])
        axhi = max(axhi, arc[k, 0])
        aylo = min(aylo, arc[k, 1])
        ayhi = max(ayhi, arc[k, 1])
    n = 0
    for q in range(pts.shape[0]):
        if axlo - r < pts[q, 0] < axhi + r and aylo - r < pts[q, 1] < ayhi + r:
            out[n, 0] = pts[q, 0]
            out[n, 1] = pts[q, 1]
            n += 1
    return n


@nb.njit(cache=True, inline="always")
def _fine_contact(foot: _Rect, near: np.ndarray, n_near: int, test: _FineTest) -> int:
    """_HIT when a fine obstacle square among ``near[:n_near]`` overlaps the footprint, else
    _RING when one overlaps the footprint grown by the clearance ring (and the ring costs), else
    _CLEAR."""
    x, y, h, r_hit, r_clear, use_clear = foot.x, foot.y, test.h, test.r_hit, test.r_clear, test.use_clear
    grown = _rect(x, y, foot.c, foot.s, foot.hl + test.clear_m, foot.hw + test.clear_m)
    ring = False
    for q in range(n_near):
        dx = near[q, 0] - x
        dy = near[q, 1] - y
        d2 = dx * dx + dy * dy
        if d2 < r_hit * r_hit and _rect_hits_square(dx, dy, foot, h):
            return _HIT
        if use_clear and not ring and d2 < r_clear * r_clear:
            ring = _rect_hits_square(dx, dy, grown, h)
    return _RING if ring else _CLEAR


@nb.njit(cache=True)
def _fan_costs(nodes: np.ndarray, trig: np.ndarray, g: _Grid, win: _Window, pts: np.ndarray, p: Any,
               out: FanCosts) -> None:
    """The node and arc costs of the fan (:func:`_evaluate_fan`, step 3) on the classified window
    ``win``, with the fine obstacle squares ``pts`` (centres) and the constants of the
    :data:`CYCLE` record ``p``.

    Per arc, the squares near it (:func:`_squares_near`); per node (footprint ``foot``):

    a. the coarse footprint cells, enumerated as :func:`_footprint_cells` does (each row's cells
       are contiguous, so a row stops at its first miss after a hit) and classified as they come:
       outside the map, or unknown with an infinite ``unknown_cost`` -> inf; each other unknown
       cell costs ``unknown_cost``; the known ground cells' centres (relative to the node) and
       mean heights are kept (obstacle cells are not ground: their obstacle part is the fine
       layer's business; exempt cells are left out too);
    b. the least-squares plane through the kept cells: slope = its tilt, roughness = the largest
       absolute residual; inf above either maximum, else the weighted sum;
    c. the fine squares (:func:`_fine_contact`): inf on a collision with the footprint, plus
       ``clear_cost`` when one overlaps the footprint grown by ``clear_m``.

    An arc stops at its first infinite node (the rest: inf, NaN slope and roughness).

    The node's steps are written out here, not called: a call that takes arrays makes numba count
    references to them at every node (about 10 % of a cycle; the helpers that stay are free of it).
    """
    hl, hw, clear_m, clear_cost, unknown_cost = p.hl, p.hw, p.clear_m, p.clear_cost, p.unknown_cost
    max_slope_tan, max_rough, w_s, w_r = p.max_slope_tan, p.max_rough, p.w_s, p.w_r
    ox, oy, cell, nr, nc = g.ox, g.oy, g.cell, g.rows, g.cols
    cls, xc, yc, zmean, wi0, wj0 = win.cls, win.xc, win.yc, win.zmean, win.i0, win.j0
    n_arcs = nodes.shape[0]
    n_nodes = nodes.shape[1]
    h = 0.5 * (cell / g.sub)
    r_hit = math.hypot(hl, hw) + h * math.sqrt(2.0)
    r_clear = math.hypot(hl + clear_m, hw + clear_m) + h * math.sqrt(2.0)
    use_clear = clear_m > 0.0 and clear_cost > 0.0
    test = _FineTest(h, r_hit, r_clear, clear_m, use_clear)
    r_max = r_clear if use_clear else r_hit
    inf_unknown = math.isinf(unknown_cost)
    atan_max = math.atan(max_slope_tan)
    half = 0.5 * cell
    buf_x = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    buf_y = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    buf_z = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    n_col = int(2.0 * (hl + hw) / cell) + 3  # more than a footprint's bounding box spans
    col_c = np.empty(n_col)
    col_s = np.empty(n_col)
    near = np.empty((max(pts.shape[0], 1), 2))
    for a in range(n_arcs):
        n_near = _squares_near(pts, nodes[a], r_max, near)
        total = 0.0
        for k in range(n_nodes):
            x = nodes[a, k, 0]
            y = nodes[a, k, 1]
            c = trig[a, k, 0]
            s = trig[a, k, 1]
            foot = _rect(x, y, c, s, hl, hw)
            cst = 0.0
            slope_tan = math.nan
            rough = math.nan
            # a. the coarse cells under the footprint
            proj, fj0, fj1, fi0, fi1 = _footprint_box(foot, g)
            lim_l = hl + proj - _EPS
            lim_w = hw + proj - _EPS
            extra = 0.0
            m = 0
            n = 0
            sx = 0.0
            sy = 0.0
            sz = 0.0
            blocked = False
            # the columns passing the bounding-box test (the same for every row; contiguous),
            # and their centres' projections on the footprint axes
            ja = fj1 + 1
            jb = fj0 - 1
            for j in range(fj0, fj1 + 1):
                x0 = ox + j * cell
                if x - foot.ex < x0 + cell - _EPS and x + foot.ex > x0 + _EPS:
                    if ja > fj1:
                        ja = j
                    jb = j
                    dxc = x0 + half - x
                    col_c[j - fj0] = dxc * c
                    col_s[j - fj0] = -dxc * s
            for i in range(fi0, fi1 + 1):
                y0 = oy + i * cell
                if not (y - foot.ey < y0 + cell - _EPS and y + foot.ey > y0 + _EPS):
                    continue
                dyc = y0 + half - y
                dys = dyc * s
                dyc_ = dyc * c
                hit = False
                for j in range(ja, jb + 1):
                    if abs(col_c[j - fj0] + dys) >= lim_l or abs(col_s[j - fj0] + dyc_) >= lim_w:
                        if hit:
                            break  # a row's footprint cells are contiguous
                        continue
                    hit = True
                    if i < 0 or j < 0 or i >= nr or j >= nc or n >= _MAX_FP_CELLS:
                        blocked = True
                        break
                    n += 1
                    li = i - wi0
                    lj = j - wj0
                    kind = cls[li, lj]
                    if kind == _KNOWN:
                        dx = xc[lj] - x
                        dy = yc[li] - y
                        z = zmean[li, lj]
                        buf_x[m] = dx
                        buf_y[m] = dy
                        buf_z[m] = z
                        sx += dx
                        sy += dy
                        sz += z
                        m += 1
                    elif kind == _UNKNOWN:
                        if inf_unknown:
                            blocked = True
                            break
                        extra += unknown_cost
                if blocked:
                    break
            if blocked:
                cst = math.inf
            else:
                # b. the plane fit: moments about the kept cells' mean, then the residuals
                slope_tan = 0.0
                rough = 0.0
                if m > 0:
                    mx = sx / m
                    my = sy / m
                    mz = sz / m
                    cxx = 0.0
                    cxy = 0.0
                    cyy = 0.0
                    cxz = 0.0
                    cyz = 0.0
                    for q in range(m):
                        dx = buf_x[q] - mx
                        dy = buf_y[q] - my
                        dz = buf_z[q] - mz
                        cxx += dx * dx
                        cxy += dx * dy
                        cyy += dy * dy
                        cxz += dx * dz
                        cyz += dy * dz
                    det = cxx * cyy - cxy * cxy
                    gb = 0.0
                    gc = 0.0
                    if det > 1e-12 * (cxx + cyy + 1e-12) ** 2:
                        gb = (cxz * cyy - cyz * cxy) / det
                        gc = (cyz * cxx - cxz * cxy) / det
                    for q in range(m):
                        r = abs(buf_z[q] - mz - gb * (buf_x[q] - mx) - gc * (buf_y[q] - my))
                        if r > rough:
                            rough = r
                    slope_tan = math.sqrt(gb * gb + gc * gc)
                if slope_tan > max_slope_tan or rough > max_rough:
                    cst = math.inf
                else:
                    cst = w_s * math.atan(slope_tan) / atan_max + w_r * rough / max_rough + extra
            # c. the fine obstacle squares
            if not math.isinf(cst) and n_near > 0:
                contact = _fine_contact(foot, near, n_near, test)
                if contact == _HIT:
                    cst = math.inf
                    slope_tan = math.nan
                    rough = math.nan
                elif contact == _RING:
                    cst += clear_cost
            out.node[a, k] = cst
            out.slope[a, k] = slope_tan
            out.rough[a, k] = rough
            total += cst
            if math.isinf(total):
                for r in range(k + 1, n_nodes):
                    out.node[a, r] = math.inf
                    out.slope[a, r] = math.nan
                    out.rough[a, r] = math.nan
                break
        out.arc[a] = total


@nb.njit(cache=True)
def _evaluate_fan(maps: TerrainArrays, nodes: np.ndarray, trig: np.ndarray, p: Any, out: FanCosts) -> int:
    """One planning cycle's terrain costs, in one call (module doc): the fan's nodes ``nodes``
    (A, N, 3) with each node's (cos, sin) heading in ``trig``, the constants in the :data:`CYCLE`
    record ``p``, the costs into ``out``. Returns the number of fine obstacle cells considered.

    1. A window of coarse cells covering every node's (clearance-grown) footprint
       (:func:`_window_bounds`), classified once (:func:`_classify`); the fine obstacle cells
       inside its coarse obstacle cells collected as a list of squares (:func:`_fine_squares`).
    2. With ``p.exempt``: the coarse cells and the fine obstacle cells under the footprint at
       (rx, ry, ryaw) are not checked (the robot already stands there; :func:`_fine_squares`,
       :func:`_exempt_cells`).
    3. The node and arc costs (:func:`_fan_costs`).
    """
    hl, hw, rx, ry, ryaw, clear_m, step = p.hl, p.hw, p.rx, p.ry, p.ryaw, p.clear_m, p.step
    g = _Grid(p.ox, p.oy, p.cell, maps.zmin.shape[0], maps.zmin.shape[1], p.sub)
    exempt = p.exempt != 0
    reach = math.hypot(hl + clear_m, hw + clear_m) + g.cell
    i0, i1, j0, j1 = _window_bounds(g, nodes, rx, ry, reach)
    win = _classify(maps, g, i0, i1, j0, j1, step)
    robot = _rect(rx, ry, math.cos(ryaw), math.sin(ryaw), hl, hw)
    pts, n_pts = _fine_squares(maps.fine, win, g, step, robot, exempt)
    if exempt:
        _exempt_cells(win, g, rx, ry, ryaw, hl, hw)
    _fan_costs(nodes, trig, g, win, pts[:n_pts], p, out)
    return n_pts


@nb.njit(cache=True)
def _plan_cycle(stats: np.ndarray, fine: np.ndarray, curv: np.ndarray, cycle: np.ndarray, nodes: np.ndarray,
                out_node: np.ndarray, out_sr: np.ndarray, out_cost: np.ndarray) -> int:
    """One whole planning cycle in one call, with the constants of the one-record :data:`CYCLE`
    array ``cycle``: the fan's node poses into ``nodes`` (A, N, 3), then :func:`_evaluate_fan`
    (``out_sr`` holds slope tangents and roughness, (2, A, N))."""
    p = cycle[0]
    trig = np.empty((nodes.shape[0], nodes.shape[1], 2))
    _fan_nodes(p, curv, nodes, trig)
    maps = TerrainArrays(stats[:, :, 0], stats[:, :, 1], stats[:, :, 2], stats[:, :, 3], fine)
    return _evaluate_fan(maps, nodes, trig, p, FanCosts(out_node, out_sr[0], out_sr[1], out_cost))


@nb.njit(cache=True)
def _evaluate_one(stats: np.ndarray, fine: np.ndarray, cycle: np.ndarray) -> tuple[float, float, float]:
    """(cost, slope tangent, roughness) of one footprint, at the pose (rx, ry, ryaw) of the
    one-record :data:`CYCLE` array ``cycle`` (give it no exemption and no clearance)."""
    p = cycle[0]
    nodes = np.empty((1, 1, 3))
    nodes[0, 0, 0] = p.rx
    nodes[0, 0, 1] = p.ry
    nodes[0, 0, 2] = p.ryaw
    trig = np.empty((1, 1, 2))
    _node_trig(nodes, trig)
    out = FanCosts(np.empty((1, 1)), np.empty((1, 1)), np.empty((1, 1)), np.empty(1))
    maps = TerrainArrays(stats[:, :, 0], stats[:, :, 1], stats[:, :, 2], stats[:, :, 3], fine)
    _evaluate_fan(maps, nodes, trig, p, out)
    return out.node[0, 0], out.slope[0, 0], out.rough[0, 0]


def _single(terrain: TerrainMap, x: float, y: float, yaw: float, half_length: float, half_width: float,
            **costs: float) -> tuple[float, float, float]:
    """(cost, slope tangent, roughness) of one footprint at (x, y, yaw): no exemption, no
    clearance; ``costs``: the :data:`CYCLE` fields max_slope_tan, max_rough, w_s, w_r, unknown_cost."""
    cycle = new_cycle(ox=terrain.origin[0], oy=terrain.origin[1], cell=terrain.cell_m, step=terrain.step_m,
                      sub=terrain.sub, hl=half_length, hw=half_width, rx=x, ry=y, ryaw=yaw, exempt=0, clear_m=0.0,
                      clear_cost=0.0, length=0.0, spin_dir=0, spin_angle=0.0, **costs)
    c, st, r = _evaluate_one(terrain.stats, terrain.fine, cycle)
    return float(c), float(st), float(r)


def footprint_cells(x: float, y: float, yaw: float, half_length: float, half_width: float,
                    terrain: TerrainMap) -> tuple[np.ndarray, np.ndarray] | None:
    """(rows, cols) of the cells the oriented footprint overlaps; None if it leaves the map."""
    out = np.empty((2, _MAX_FP_CELLS), dtype=np.int64)
    n = _map_footprint_cells(terrain.constants, terrain.stats, x, y, yaw, half_length, half_width, out)
    if n < 0:
        return None
    return out[0, :n].copy(), out[1, :n].copy()


def footprint_slope_roughness(terrain: TerrainMap, x: float, y: float, yaw: float, half_length: float,
                              half_width: float) -> tuple[float, float]:
    """(slope in degrees, roughness in meters) of the plane fitted under a footprint (NaN if blocked)."""
    _, st, r = _single(terrain, x, y, yaw, half_length, half_width, max_slope_tan=1e9, max_rough=1e9, w_s=1.0,
                       w_r=1.0, unknown_cost=math.inf)
    return math.degrees(math.atan(st)) if math.isfinite(st) else math.nan, r


def node_cost(planner: "ArcPlanner", terrain: TerrainMap, x: float, y: float, yaw: float,
              unknown_cost: float | None = None) -> float:
    """Cost of the planner's footprint at one pose (inf if blocked); ``unknown_cost`` overrides the config's."""
    cfg = planner.config
    uc = float(cfg.unknown_cell_cost if unknown_cost is None else unknown_cost)
    c, _, _ = _single(terrain, x, y, yaw, planner.half_length, planner.half_width,
                      max_slope_tan=math.tan(math.radians(cfg.max_slope_deg)), max_rough=planner.max_rough,
                      w_s=cfg.slope_weight, w_r=cfg.roughness_weight, unknown_cost=uc)
    return c


def arc_nodes(x: float, y: float, yaw: float, curvatures: np.ndarray, length: float, n_nodes: int) -> np.ndarray:
    """(A, N, 3) node poses (x, y, heading) at arc lengths ``length * k / N``, k = 1..N."""
    s = length * np.arange(1, n_nodes + 1) / n_nodes
    k = np.asarray(curvatures, dtype=np.float64)[:, None]
    th = yaw + k * s
    small = np.abs(k) < 1e-9
    ks = np.where(small, 1.0, k)
    dx = np.where(small, s * math.cos(yaw), (np.sin(th) - math.sin(yaw)) / ks)
    dy = np.where(small, s * math.sin(yaw), -(np.cos(th) - math.cos(yaw)) / ks)
    return np.stack([x + dx, y + dy, th], axis=-1)


@dataclass(frozen=True, eq=False)
class ArcEvaluation:
    """One cycle's fan: node poses (A, N, 3), curvature per arc (NaN for the turn in place),
    the turn-in-place direction (+1 CCW, -1 CW, 0 when absent), terrain cost per arc and per node."""

    nodes: np.ndarray
    curvatures: np.ndarray
    spin_dir: int
    terrain_cost: np.ndarray
    node_cost: np.ndarray

    @property
    def is_spin(self) -> np.ndarray:
        out: np.ndarray = np.isnan(self.curvatures)
        return out


def footprint_half_extents(robot: RobotSpec) -> tuple[float, float]:
    """(half length, half width) of the rectangle the planner checks for the believed ``robot``:
    the smallest rectangle centred on ``base_link`` and aligned with it that holds the whole
    footprint. A box footprint is that rectangle (``length_m / 2``, ``width_m / 2``); a circle
    of radius r gives (r, r); a convex polygon (max |x|, max |y|) of its points: conservative (the
    rectangle never leaves out a part of the robot; it covers more than the robot where the
    shape is round or off-centre).

        >>> footprint_half_extents(RobotSpec())
        (0.57, 0.335)
        >>> footprint_half_extents(RobotSpec(footprint={"shape": "polygon", "points": [(0.4, 0), (-0.2, 0.3), (-0.2, -0.1)]}))
        (0.4, 0.3)
    """
    if robot.footprint.shape == "box":
        return 0.5 * robot.length_m, 0.5 * robot.width_m
    pts = robot.footprint_points() if robot.footprint.shape == "polygon" else None
    if pts is None:
        r = float(robot.footprint.radius_m or 0.5 * robot.length_m)
        return r, r
    return float(np.max(np.abs(pts[:, 0]))), float(np.max(np.abs(pts[:, 1])))


class ArcPlanner:
    """The P3D arc fan and election for a believed robot (module doc).

    >>> p = ArcPlanner(ReferenceConfig(), RobotSpec())
    >>> p.curvatures.shape, float(p.curvatures[9])
    ((19,), 0.0)
    """

    def __init__(self, config: ReferenceConfig, robot: RobotSpec) -> None:
        self.config = for_robot(config, robot)  # the thresholds it leaves to the robot, set
        assert self.config.max_roughness_m is not None
        self.max_rough: float = self.config.max_roughness_m
        self.robot = robot
        hl, hw = footprint_half_extents(robot)  # a circle or a polygon: its bounding rectangle (conservative)
        self.half_length = hl + config.footprint_margin_m
        self.half_width = hw + config.footprint_margin_m
        kmax = config.max_curvature_per_m
        u = np.linspace(-1.0, 1.0, config.forward_arcs)
        self.curvatures = kmax * (u * np.abs(u) if config.curvature_spacing == "quadratic" else u)
        self.curvatures[config.forward_arcs // 2] = 0.0
        self.max_speed = min(config.max_speed_mps, robot.max_speed_mps)
        self._max_slope_tan = math.tan(math.radians(config.max_slope_deg))
        self._fan_curvatures = (np.concatenate([self.curvatures, [math.nan]]) if config.turn_in_place
                                else self.curvatures.copy())
        self._cycle_terrain: TerrainMap | None = None
        self._cycle = np.empty(0, CYCLE)

    def _cycle_on(self, terrain: TerrainMap) -> np.ndarray:
        """This planner's :data:`CYCLE` record on ``terrain`` (a map's geometry is fixed when it is
        made), every field named once per map; :meth:`evaluate` then writes the pose and the turn's
        direction into it each cycle (cheaper than a new record: the planner is not reentrant)."""
        if terrain is not self._cycle_terrain:
            cfg = self.config
            self._cycle = new_cycle(ox=terrain.origin[0], oy=terrain.origin[1], cell=terrain.cell_m,
                                    step=terrain.step_m, sub=terrain.sub, hl=self.half_length, hw=self.half_width,
                                    rx=0.0, ry=0.0, ryaw=0.0, exempt=int(cfg.exempt_current_footprint),
                                    max_slope_tan=self._max_slope_tan, max_rough=self.max_rough,
                                    w_s=cfg.slope_weight, w_r=cfg.roughness_weight,
                                    unknown_cost=float(cfg.unknown_cell_cost), clear_m=cfg.clearance_margin_m,
                                    clear_cost=cfg.clearance_cost, length=cfg.arc_length_m, spin_dir=0,
                                    spin_angle=math.radians(cfg.turn_in_place_angle_deg))
            self._cycle_terrain = terrain
        return self._cycle

    def evaluate(self, terrain: TerrainMap, x: float, y: float, yaw: float, spin_dir: int) -> ArcEvaluation:
        """Node poses and terrain costs of the fan at (x, y, yaw), in one compiled call. With
        ``exempt_current_footprint`` the coarse cells and fine obstacle cells under the current
        (margined) footprint are not checked: the robot already stands there; every cell a node
        newly covers is still checked."""
        cfg = self.config
        na = cfg.forward_arcs + (1 if cfg.turn_in_place else 0)
        n = cfg.nodes_per_arc
        d = (1 if spin_dir >= 0 else -1) if cfg.turn_in_place else 0
        nodes = np.empty((na, n, 3))
        node_cost = np.empty((na, n))
        sr = np.empty((2, na, n))
        cost = np.empty(na)
        cycle = self._cycle_on(terrain)
        cycle["rx"], cycle["ry"], cycle["ryaw"], cycle["spin_dir"] = x, y, yaw, d  # what changes each cycle
        _plan_cycle(terrain.stats, terrain.fine, self.curvatures, cycle, nodes, node_cost, sr, cost)
        return ArcEvaluation(nodes, self._fan_curvatures, d, cost, node_cost)

    def elect(self, ev: ArcEvaluation, goal_terms: np.ndarray, jitter: np.ndarray | None = None) -> int:
        """Index of the elected arc, or -1 when no arc's terrain cost is finite and within the
        election threshold. Ties go to the lowest index (deterministic)."""
        ok = np.isfinite(ev.terrain_cost) & (ev.terrain_cost <= self.config.election_threshold) & np.isfinite(goal_terms)
        if not ok.any():
            return -1
        total = ev.terrain_cost + goal_terms
        if jitter is not None:
            total = total + jitter
        total = np.where(ok, total, np.inf)
        return int(np.argmin(total))

    def command(self, ev: ArcEvaluation, idx: int) -> tuple[float, float]:
        """(v, omega) following arc ``idx``: slower on costly arcs, yaw rate within the robot's limit."""
        cfg = self.config
        wmax = self.robot.max_yaw_rate_rps
        if ev.is_spin[idx]:
            return 0.0, ev.spin_dir * min(wmax, cfg.scan_yaw_rate_rps)
        mean = float(ev.terrain_cost[idx]) / cfg.nodes_per_arc
        v = self.max_speed * (1.0 - min(0.7, cfg.slowdown_per_cost * mean))
        k = float(ev.curvatures[idx])
        if abs(k) * v > wmax:
            v = wmax / abs(k)
        return v, v * k
