"""P3D: the local arc planner.

Each cycle a fan of arcs starts at the perceived pose: ``forward_arcs`` arcs of length
``arc_length_m`` with curvatures evenly spaced in ``[-k_max, +k_max]`` (straight included), plus
optionally a turn on the spot (its nodes are the current position at headings rotating toward
the goal side). At each of the ``nodes_per_arc`` nodes the believed footprint (RobotSpec length x
width plus margin, oriented along the arc) is laid on the map; the cells it overlaps (exactly:
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
all node costs) is one compiled call (:func:`_evaluate_fan`): the obstacle test is done once per
window cell, not once per footprint cell.

An arc's terrain cost is the sum of its node costs (infinite as soon as one node is). The
navigator adds a goal term per arc and elects the cheapest arc whose terrain cost is at most the
election threshold (:meth:`ArcPlanner.elect`). Approximation: the footprint is evaluated at the
nodes only (15 per 3 m arc: 0.2 m apart, less than a cell), not swept continuously.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.nav.reference.config import ReferenceConfig
from navstress.nav.reference.terrain_map import TerrainMap, cell_ground
from navstress.robot import RobotSpec

__all__ = ["ArcEvaluation", "ArcPlanner", "arc_nodes", "footprint_cells", "footprint_slope_roughness", "node_cost"]

_MAX_FP_CELLS = 4096
_EPS = 1e-9  # touching within this (rounding) is not a positive-area overlap


@nb.njit(cache=True, inline="always")
def _footprint_box(x: float, y: float, c: float, s: float, hl: float, hw: float, ox: float, oy: float,
                   cell: float) -> tuple[float, float, float, int, int, int, int]:
    """Of a footprint (half sides hl, hw) at (x, y) with heading cos/sin (c, s): its half extents
    (ex, ey) on the grid axes, a cell's half-diagonal projection ``proj`` on its axes, and the range
    of cells its bounding box covers (j0, j1, i0, i1). Scalars only (cheap to inline in hot loops)."""
    ac = abs(c)
    as_ = abs(s)
    ex = hl * ac + hw * as_
    ey = hl * as_ + hw * ac
    j0 = int(math.floor((x - ex - ox) / cell))
    j1 = int(math.floor((x + ex - ox) / cell))
    i0 = int(math.floor((y - ey - oy) / cell))
    i1 = int(math.floor((y + ey - oy) / cell))
    proj = 0.5 * cell * (ac + as_)
    return ex, ey, proj, j0, j1, i0, i1


@nb.njit(cache=True)
def _footprint_cells(cx: float, cy: float, yaw: float, hl: float, hw: float, ox: float, oy: float,
                     cell: float, nr: int, nc: int, out_i: np.ndarray, out_j: np.ndarray) -> int:
    """Cells whose square overlaps the oriented rectangle with positive area (separating-axis
    test). Returns their count, or -1 if the rectangle reaches outside the grid or overflows."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    ex, ey, proj, j0, j1, i0, i1 = _footprint_box(cx, cy, c, s, hl, hw, ox, oy, cell)
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
            if i < 0 or j < 0 or i >= nr or j >= nc or n >= out_i.shape[0]:
                return -1
            out_i[n] = i
            out_j[n] = j
            n += 1
    return n


@nb.njit(cache=True)
def _fan_nodes(x: float, y: float, yaw: float, curv: np.ndarray, length: float, n_nodes: int,
               spin_dir: int, spin_angle: float, out: np.ndarray, trig: np.ndarray) -> None:
    """Fill ``out`` (A, N, 3) with the fan's node poses: the arcs of ``curv`` (as :func:`arc_nodes`),
    then, when ``spin_dir != 0``, the turn on the spot (``spin_angle`` covered by its N nodes);
    ``trig`` (A, N, 2) gets each node's (cos, sin) heading (the arcs' own sin/cos, reused)."""
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
def _rect_hits_square(dx: float, dy: float, c: float, s: float, hl: float, hw: float, ex: float, ey: float,
                      h: float) -> bool:
    """Separating-axis test: the rectangle (half sizes hl x hw, axis (c, s), AABB half extents
    ex, ey) and the axis-aligned square of half side ``h`` whose centre is (dx, dy) from the
    rectangle's overlap with positive area."""
    if abs(dx) >= ex + h - _EPS or abs(dy) >= ey + h - _EPS:
        return False
    pad = h * (abs(c) + abs(s))
    return abs(dx * c + dy * s) < hl + pad - _EPS and abs(-dx * s + dy * c) < hw + pad - _EPS


@nb.njit(cache=True)
def _evaluate_fan(zmin: np.ndarray, zmax: np.ndarray, zsum: np.ndarray, count: np.ndarray,
                  fine: np.ndarray, sub: int, ox: float, oy: float, cell: float, step: float,
                  nodes: np.ndarray, trig: np.ndarray, hl: float, hw: float, rx: float, ry: float, ryaw: float,
                  exempt_on: bool, max_slope_tan: float, max_rough: float, w_s: float, w_r: float,
                  unknown_cost: float, clear_m: float, clear_cost: float, out_node: np.ndarray,
                  out_slope: np.ndarray, out_rough: np.ndarray, out_cost: np.ndarray) -> int:
    """One planning cycle's terrain costs, in one call (module doc); ``trig`` holds each node's
    (cos, sin) heading. Returns the number of fine obstacle cells considered.

    1. A window of coarse cells covering every node's (clearance-grown) footprint: per cell one
       class (known ground, obstacle, unknown exempt, unknown) and its mean height, computed once
       (the 3x3 ground minimum separably: a row minimum, then a column minimum); the fine
       obstacle cells inside the coarse obstacle cells collected as a list of squares.
    2. With ``exempt_on``: the coarse cells and the fine obstacle cells under the footprint at
       (rx, ry, ryaw) are not checked (the robot already stands there).
    3. Per node: the coarse footprint cells (those of :func:`_footprint_cells`, same order;
       each row's cells are contiguous, so a row stops at its first miss after a hit), classified
       as they are enumerated -> unknown / outside check and the plane fit (coarse obstacle cells
       left out of the fit); fine obstacle squares -> collision (inf) with the footprint, or
       ``clear_cost`` when one overlaps the footprint grown by ``clear_m``.
    """
    nr, nc = zmin.shape
    n_arcs = nodes.shape[0]
    n_nodes = nodes.shape[1]
    reach = math.hypot(hl + clear_m, hw + clear_m) + cell
    xlo = rx
    xhi = rx
    ylo = ry
    yhi = ry
    for a in range(n_arcs):
        for k in range(n_nodes):
            xlo = min(xlo, nodes[a, k, 0])
            xhi = max(xhi, nodes[a, k, 0])
            ylo = min(ylo, nodes[a, k, 1])
            yhi = max(yhi, nodes[a, k, 1])
    i0 = max(0, int(math.floor((ylo - reach - oy) / cell)))
    i1 = min(nr - 1, int(math.floor((yhi + reach - oy) / cell)))
    j0 = max(0, int(math.floor((xlo - reach - ox) / cell)))
    j1 = min(nc - 1, int(math.floor((xhi + reach - ox) / cell)))
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
            g = math.inf
            for b in range(max(0, j - 1), min(nc, j + 2)):
                if count[i, b] > 0 and zmin[i, b] < g:
                    g = zmin[i, b]
            rowmin[r, lj] = g
    # per window cell: 0 known ground, 1 obstacle, 2 unknown exempt, 3 unknown
    cls = np.full((wi, wj), 3, dtype=np.int8)
    ground = np.empty((wi, wj))
    zmean = np.zeros((wi, wj))
    n_obst = 0
    for li in range(wi):
        i = i0 + li
        for lj in range(wj):
            j = j0 + lj
            if count[i, j] > 0:
                zmean[li, lj] = zsum[i, j] / count[i, j]
                g = math.inf
                for r in range(max(0, i - 1) - hi0, min(nr, i + 2) - hi0):
                    if rowmin[r, lj] < g:
                        g = rowmin[r, lj]
                ground[li, lj] = g
                if zmax[i, j] - g > step:
                    cls[li, lj] = 1
                    n_obst += 1
                else:
                    cls[li, lj] = 0
    # cell centres of the window's columns and rows (as the fit's moments need them)
    xc = np.empty(wj)
    for lj in range(wj):
        xc[lj] = ox + (j0 + lj + 0.5) * cell
    yc = np.empty(wi)
    for li in range(wi):
        yc[li] = oy + (i0 + li + 0.5) * cell
    # fine obstacle squares (centres), from the coarse obstacle cells only (fine ones lie inside)
    fcell = cell / sub
    h = 0.5 * fcell
    pts = np.empty((n_obst * sub * sub, 2))
    n_pts = 0
    cr = math.cos(ryaw)
    sr = math.sin(ryaw)
    rex = hl * abs(cr) + hw * abs(sr)
    rey = hl * abs(sr) + hw * abs(cr)
    for li in range(wi):
        for lj in range(wj):
            if cls[li, lj] != 1:
                continue
            g = ground[li, lj]
            for u in range(sub):
                fi = (i0 + li) * sub + u
                for v in range(sub):
                    fj = (j0 + lj) * sub + v
                    if fine[i0 + li, j0 + lj, u * sub + v] - g > step:
                        px = ox + (fj + 0.5) * fcell
                        py = oy + (fi + 0.5) * fcell
                        if exempt_on and _rect_hits_square(px - rx, py - ry, cr, sr, hl, hw, rex, rey, h):
                            continue
                        pts[n_pts, 0] = px
                        pts[n_pts, 1] = py
                        n_pts += 1
    buf_x = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    buf_y = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    buf_z = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    if exempt_on:
        buf_i = np.empty(_MAX_FP_CELLS, dtype=np.int64)
        buf_j = np.empty(_MAX_FP_CELLS, dtype=np.int64)
        n = _footprint_cells(rx, ry, ryaw, hl, hw, ox, oy, cell, nr, nc, buf_i, buf_j)
        for k in range(max(n, 0)):
            li = buf_i[k] - i0
            lj = buf_j[k] - j0
            if cls[li, lj] == 3:
                cls[li, lj] = 2
    r_hit = math.hypot(hl, hw) + h * math.sqrt(2.0)
    r_clear = math.hypot(hl + clear_m, hw + clear_m) + h * math.sqrt(2.0)
    use_clear = clear_m > 0.0 and clear_cost > 0.0
    r_max = r_clear if use_clear else r_hit
    inf_unknown = math.isinf(unknown_cost)
    atan_max = math.atan(max_slope_tan)
    half = 0.5 * cell
    n_col = int(2.0 * (hl + hw) / cell) + 3  # more than a footprint's bounding box spans
    col_c = np.empty(n_col)
    col_s = np.empty(n_col)
    sub_pts = np.empty((max(n_pts, 1), 2))
    for a in range(n_arcs):
        # the fine squares near this arc (its nodes' bounding box + the largest ring radius)
        axlo = nodes[a, 0, 0]
        axhi = axlo
        aylo = nodes[a, 0, 1]
        ayhi = aylo
        for k in range(1, n_nodes):
            axlo = min(axlo, nodes[a, k, 0])
            axhi = max(axhi, nodes[a, k, 0])
            aylo = min(aylo, nodes[a, k, 1])
            ayhi = max(ayhi, nodes[a, k, 1])
        n_sub = 0
        for q in range(n_pts):
            if axlo - r_max < pts[q, 0] < axhi + r_max and aylo - r_max < pts[q, 1] < ayhi + r_max:
                sub_pts[n_sub, 0] = pts[q, 0]
                sub_pts[n_sub, 1] = pts[q, 1]
                n_sub += 1
        total = 0.0
        for k in range(n_nodes):
            x = nodes[a, k, 0]
            y = nodes[a, k, 1]
            c = trig[a, k, 0]
            s = trig[a, k, 1]
            cst = 0.0
            slope_tan = math.nan
            rough = math.nan
            # coarse layer, as the footprint cells are enumerated (as _footprint_cells): outside
            # the map or unknown -> inf; else moments about the node of the known non-obstacle
            # cells (one pass), residuals in a second pass
            ex, ey, proj, fj0, fj1, fi0, fi1 = _footprint_box(x, y, c, s, hl, hw, ox, oy, cell)
            ac = abs(c)  # (the clearance ring below)
            as_ = abs(s)
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
                if x - ex < x0 + cell - _EPS and x + ex > x0 + _EPS:
                    if ja > fj1:
                        ja = j
                    jb = j
                    dxc = x0 + half - x
                    col_c[j - fj0] = dxc * c
                    col_s[j - fj0] = -dxc * s
            for i in range(fi0, fi1 + 1):
                y0 = oy + i * cell
                if not (y - ey < y0 + cell - _EPS and y + ey > y0 + _EPS):
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
                    li = i - i0
                    lj = j - j0
                    kind = cls[li, lj]
                    if kind == 0:
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
                    elif kind == 3:
                        if inf_unknown:
                            blocked = True
                            break
                        extra += unknown_cost
                    # kind 1: its obstacle part is the fine layer's business; its heights are not
                    # ground; kind 2: unknown under the current footprint
                if blocked:
                    break
            if blocked:
                cst = math.inf
            else:
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
            if not math.isinf(cst) and n_sub > 0:
                # fine layer: obstacle squares against the footprint and its clearance ring
                exc = (hl + clear_m) * ac + (hw + clear_m) * as_
                eyc = (hl + clear_m) * as_ + (hw + clear_m) * ac
                near = False
                for q in range(n_sub):
                    dx = sub_pts[q, 0] - x
                    dy = sub_pts[q, 1] - y
                    d2 = dx * dx + dy * dy
                    if d2 < r_hit * r_hit and _rect_hits_square(dx, dy, c, s, hl, hw, ex, ey, h):
                        cst = math.inf
                        slope_tan = math.nan
                        rough = math.nan
                        break
                    if use_clear and not near and d2 < r_clear * r_clear:
                        near = _rect_hits_square(dx, dy, c, s, hl + clear_m, hw + clear_m, exc, eyc, h)
                if near and not math.isinf(cst):
                    cst += clear_cost
            out_node[a, k] = cst
            out_slope[a, k] = slope_tan
            out_rough[a, k] = rough
            total += cst
            if math.isinf(total):
                for r in range(k + 1, n_nodes):
                    out_node[a, r] = math.inf
                    out_slope[a, r] = math.nan
                    out_rough[a, r] = math.nan
                break
        out_cost[a] = total
    return n_pts


# parameters of one planning cycle, packed in a float64 vector (one cheap argument to dispatch)
_P_OX, _P_OY, _P_CELL, _P_STEP, _P_SUB, _P_HL, _P_HW, _P_RX, _P_RY, _P_RYAW, _P_EXEMPT, _P_SLOPE, _P_ROUGH, \
    _P_WS, _P_WR, _P_UNKNOWN, _P_CLEAR_M, _P_CLEAR_COST, _P_LENGTH, _P_SPIN_DIR, _P_SPIN_ANGLE, _P_N = range(22)


@nb.njit(cache=True)
def _plan_cycle(stats: np.ndarray, fine: np.ndarray, curv: np.ndarray, p: np.ndarray, nodes: np.ndarray,
                out_node: np.ndarray, out_sr: np.ndarray, out_cost: np.ndarray) -> int:
    """One whole planning cycle in one call: the fan's node poses into ``nodes`` (A, N, 3), then
    :func:`_evaluate_fan` (``out_sr`` holds slope tangents and roughness, (2, A, N))."""
    trig = np.empty((nodes.shape[0], nodes.shape[1], 2))
    _fan_nodes(p[_P_RX], p[_P_RY], p[_P_RYAW], curv, p[_P_LENGTH], nodes.shape[1], int(p[_P_SPIN_DIR]),
               p[_P_SPIN_ANGLE], nodes, trig)
    return _evaluate_fan(stats[:, :, 0], stats[:, :, 1], stats[:, :, 2], stats[:, :, 3], fine, int(p[_P_SUB]),
                         p[_P_OX], p[_P_OY], p[_P_CELL], p[_P_STEP], nodes, trig, p[_P_HL], p[_P_HW], p[_P_RX],
                         p[_P_RY], p[_P_RYAW], p[_P_EXEMPT] != 0.0, p[_P_SLOPE], p[_P_ROUGH], p[_P_WS], p[_P_WR],
                         p[_P_UNKNOWN], p[_P_CLEAR_M], p[_P_CLEAR_COST], out_node, out_sr[0], out_sr[1], out_cost)


def _params(terrain: TerrainMap, hl: float, hw: float, x: float, y: float, yaw: float, exempt: bool,
            max_slope_tan: float, max_rough: float, w_s: float, w_r: float, unknown_cost: float, clear_m: float,
            clear_cost: float, length: float, spin_dir: int, spin_angle: float) -> np.ndarray:
    p = np.empty(_P_N)
    p[_P_OX], p[_P_OY], p[_P_CELL], p[_P_STEP], p[_P_SUB] = (terrain.origin[0], terrain.origin[1], terrain.cell_m,
                                                            terrain.step_m, terrain.sub)
    p[_P_HL], p[_P_HW], p[_P_RX], p[_P_RY], p[_P_RYAW], p[_P_EXEMPT] = hl, hw, x, y, yaw, float(exempt)
    p[_P_SLOPE], p[_P_ROUGH], p[_P_WS], p[_P_WR], p[_P_UNKNOWN] = max_slope_tan, max_rough, w_s, w_r, unknown_cost
    p[_P_CLEAR_M], p[_P_CLEAR_COST], p[_P_LENGTH], p[_P_SPIN_DIR], p[_P_SPIN_ANGLE] = (clear_m, clear_cost, length,
                                                                                    spin_dir, spin_angle)
    return p


def _single(terrain: TerrainMap, x: float, y: float, yaw: float, hl: float, hw: float, max_slope_tan: float,
            max_rough: float, w_s: float, w_r: float, unknown_cost: float) -> tuple[float, float, float]:
    """(cost, slope tangent, roughness) of one footprint, no exemption, no clearance."""
    nodes = np.array([[[x, y, yaw]]], dtype=np.float64)
    trig = np.empty((1, 1, 2))
    _node_trig(nodes, trig)
    on, os_, or_ = np.empty((1, 1)), np.empty((1, 1)), np.empty((1, 1))
    oc = np.empty(1)
    _evaluate_fan(terrain.zmin, terrain.zmax, terrain.zsum, terrain.count, terrain.fine, terrain.sub,
                  terrain.origin[0], terrain.origin[1], terrain.cell_m, terrain.step_m, nodes, trig, hl, hw,
                  x, y, yaw, False, max_slope_tan, max_rough, w_s, w_r, unknown_cost, 0.0, 0.0, on, os_,
                  or_, oc)
    return float(on[0, 0]), float(os_[0, 0]), float(or_[0, 0])


def footprint_cells(x: float, y: float, yaw: float, half_length: float, half_width: float,
                    terrain: TerrainMap) -> tuple[np.ndarray, np.ndarray] | None:
    """(rows, cols) of the cells the oriented footprint overlaps; None if it leaves the map."""
    bi = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    bj = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    n = _footprint_cells(x, y, yaw, half_length, half_width, terrain.origin[0], terrain.origin[1],
                         terrain.cell_m, terrain.shape[0], terrain.shape[1], bi, bj)
    if n < 0:
        return None
    return bi[:n].copy(), bj[:n].copy()


def footprint_slope_roughness(terrain: TerrainMap, x: float, y: float, yaw: float, half_length: float,
                              half_width: float) -> tuple[float, float]:
    """(slope in degrees, roughness in meters) of the plane fitted under a footprint (NaN if blocked)."""
    _, st, r = _single(terrain, x, y, yaw, half_length, half_width, 1e9, 1e9, 1.0, 1.0, math.inf)
    return math.degrees(math.atan(st)) if math.isfinite(st) else math.nan, r


def node_cost(planner: "ArcPlanner", terrain: TerrainMap, x: float, y: float, yaw: float,
              unknown_cost: float | None = None) -> float:
    """Cost of the planner's footprint at one pose (inf if blocked); ``unknown_cost`` overrides the config's."""
    cfg = planner.config
    uc = float(cfg.unknown_cell_cost if unknown_cost is None else unknown_cost)
    c, _, _ = _single(terrain, x, y, yaw, planner.half_length, planner.half_width,
                      math.tan(math.radians(cfg.max_slope_deg)), cfg.max_roughness_m, cfg.slope_weight,
                      cfg.roughness_weight, uc)
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


class ArcPlanner:
    """The P3D arc fan and election for a believed robot (module doc).

    >>> p = ArcPlanner(ReferenceConfig(), RobotSpec())
    >>> p.curvatures.shape, float(p.curvatures[9])
    ((19,), 0.0)
    """

    def __init__(self, config: ReferenceConfig, robot: RobotSpec) -> None:
        self.config = config
        self.robot = robot
        self.half_length = 0.5 * robot.length_m + config.footprint_margin_m
        self.half_width = 0.5 * robot.width_m + config.footprint_margin_m
        kmax = config.max_curvature_per_m
        u = np.linspace(-1.0, 1.0, config.forward_arcs)
        self.curvatures = kmax * (u * np.abs(u) if config.curvature_spacing == "quadratic" else u)
        self.curvatures[config.forward_arcs // 2] = 0.0
        self.max_speed = min(config.max_speed_mps, robot.max_speed_mps)
        self._max_slope_tan = math.tan(math.radians(config.max_slope_deg))
        self._fan_curvatures = (np.concatenate([self.curvatures, [math.nan]]) if config.turn_in_place
                                else self.curvatures.copy())

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
        p = _params(terrain, self.half_length, self.half_width, x, y, yaw, cfg.exempt_current_footprint,
                    self._max_slope_tan, cfg.max_roughness_m, cfg.slope_weight, cfg.roughness_weight,
                    float(cfg.unknown_cell_cost), cfg.clearance_margin_m, cfg.clearance_cost, cfg.arc_length_m, d,
                    math.radians(cfg.turn_in_place_angle_deg))
        _plan_cycle(terrain.stats, terrain.fine, self.curvatures, p, nodes, node_cost, sr, cost)
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
