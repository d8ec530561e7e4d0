"""The compiled hot paths of ``reference-2d-v1``: raytracing scans into the occupancy grid,
inflation, A* and the scoring of DWB rollouts (numba, ``cache=True``).

Grids are indexed ``[row, column]`` = ``[iy, ix]``: cell ``(iy, ix)`` covers
``x0 + ix*cell <= x < x0 + (ix+1)*cell`` (and likewise y). Occupancy: ``UNKNOWN`` (-1), ``FREE``
(0), ``OCCUPIED`` (1). Costs (uint8, as Nav2's costmap_2d): 0 free .. 252 inflated,
``INSCRIBED`` (253: the robot's centre here puts an obstacle inside its inscribed circle),
``LETHAL`` (254: an obstacle), ``NO_INFORMATION`` (255: never seen and no obstacle near).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
import numba as nb
import numpy as np

UNKNOWN, FREE, OCCUPIED = -1, 0, 1
INSCRIBED, LETHAL, NO_INFORMATION = 253, 254, 255


class Grid(NamedTuple):
    """Where a grid lies: the map-frame corner (x0, y0) of cell (0, 0) and the cell size (m)."""

    x0: float
    y0: float
    cell: float


class Footprint(NamedTuple):
    """The footprint check's data: the cost from which an obstacle is within the circumscribed
    radius, and the outline's points (n, 2) in the body frame."""

    circ_cost: int
    outline: np.ndarray


class Inflation(NamedTuple):
    """An inflation kernel (:func:`inflation_kernel`): offsets, their costs, its radius in cells."""

    di: np.ndarray
    dj: np.ndarray
    cost: np.ndarray
    r: int


class Rollouts(NamedTuple):
    """How the rollouts run and are scored: ``n_steps`` of ``dt``, the cost of a never-seen cell,
    the speed cap, the previous command's yaw rate (the oscillation critic)."""

    n_steps: int
    dt: float
    unknown_cost: float
    vmax: float
    prev_w: float


@nb.njit(cache=True)
def _trace(occ: np.ndarray, grid: Grid, ox: float, oy: float, ex: float, ey: float, mark: bool) -> None:
    """Clear the cells a segment crosses (Amanatides-Woo), its end cell excluded; mark the end
    cell occupied when ``mark``. Cells outside the grid are skipped."""
    x0, y0, cell = grid
    ny, nx = occ.shape
    fx, fy = (ox - x0) / cell, (oy - y0) / cell
    tx, ty = (ex - x0) / cell, (ey - y0) / cell
    ix, iy = int(math.floor(fx)), int(math.floor(fy))
    jx, jy = int(math.floor(tx)), int(math.floor(ty))
    dx, dy = tx - fx, ty - fy
    sx = 1 if dx > 0 else -1
    sy = 1 if dy > 0 else -1
    tdx = abs(1.0 / dx) if dx != 0 else 1e30
    tdy = abs(1.0 / dy) if dy != 0 else 1e30
    tmx = ((ix + 1 - fx) if dx > 0 else (fx - ix)) * tdx if dx != 0 else 1e30
    tmy = ((iy + 1 - fy) if dy > 0 else (fy - iy)) * tdy if dy != 0 else 1e30
    n = abs(jx - ix) + abs(jy - iy)
    for _ in range(n):
        if 0 <= ix < nx and 0 <= iy < ny:
            occ[iy, ix] = 0
        if tmx < tmy:
            tmx += tdx
            ix += sx
        else:
            tmy += tdy
            iy += sy
    if 0 <= jx < nx and 0 <= jy < ny:
        if mark:
            occ[jy, jx] = 1
        elif occ[jy, jx] != 1:
            occ[jy, jx] = 0


@nb.njit(cache=True)
def integrate_scan(occ: np.ndarray, grid: Grid, ox: np.ndarray, oy: np.ndarray, ex: np.ndarray, ey: np.ndarray,
                   mark: np.ndarray) -> None:
    """Raytrace beams from (ox, oy) to (ex, ey) (map frame, meters): every beam clears first,
    then the beams with ``mark`` set mark their end cell (Nav2's obstacle layer: clearing, then
    marking, so one beam's clearing never erases another's hit)."""
    x0, y0, cell = grid
    for b in range(ex.shape[0]):
        _trace(occ, grid, ox[b], oy[b], ex[b], ey[b], False)
    ny, nx = occ.shape
    for b in range(ex.shape[0]):
        if mark[b]:
            jx = int(math.floor((ex[b] - x0) / cell))
            jy = int(math.floor((ey[b] - y0) / cell))
            if 0 <= jx < nx and 0 <= jy < ny:
                occ[jy, jx] = 1


def inflation_kernel(cell: float, inscribed_m: float, radius_m: float, factor: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(di, dj, cost) of every offset within ``radius_m`` of a cell (Nav2's inflation layer):
    254 at the obstacle, 253 within the inscribed radius, ``252 exp(-factor (d - inscribed))``
    beyond, 0 past the radius (left out)."""
    r = int(math.ceil(radius_m / cell))
    di, dj = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij")
    d = np.hypot(di, dj) * cell
    keep = d <= radius_m + 1e-9
    di, dj, d = di[keep], dj[keep], d[keep]
    cost = np.where(d <= inscribed_m, INSCRIBED,
                    np.floor(252.0 * np.exp(-factor * np.maximum(d - inscribed_m, 0.0)))).astype(np.int64)
    cost[d == 0] = LETHAL
    pos = cost > 0
    return di[pos].astype(np.int64), dj[pos].astype(np.int64), cost[pos]


@nb.njit(cache=True)
def inflate_window(occ: np.ndarray, cost: np.ndarray, window: tuple[int, int, int, int], kernel: Inflation) -> None:
    """Recompute ``cost[i0:i1, j0:j1]`` (``window``) from ``occ``: the maximum of every kernel
    stamped at an obstacle within the window grown by the kernel's radius ``kr`` cells; a
    never-seen cell with no obstacle near is NO_INFORMATION. Exact: an obstacle that reaches a
    window cell lies in the grown window."""
    i0, i1, j0, j1 = window
    kdi, kdj, kcost, kr = kernel
    ny, nx = occ.shape
    i0, j0 = max(i0, 0), max(j0, 0)
    i1, j1 = min(i1, ny), min(j1, nx)
    if i1 <= i0 or j1 <= j0:
        return
    h, w = i1 - i0, j1 - j0
    infl = np.zeros((h, w), np.int64)
    for oi in range(max(i0 - kr, 0), min(i1 + kr, ny)):
        for oj in range(max(j0 - kr, 0), min(j1 + kr, nx)):
            if occ[oi, oj] != 1:
                continue
            for k in range(kdi.shape[0]):
                a = oi + kdi[k] - i0
                b = oj + kdj[k] - j0
                if 0 <= a < h and 0 <= b < w and kcost[k] > infl[a, b]:
                    infl[a, b] = kcost[k]
    for a in range(h):
        for b in range(w):
            c = infl[a, b]
            if c == 0 and occ[i0 + a, j0 + b] == -1:
                c = 255
            cost[i0 + a, j0 + b] = c


@nb.njit(cache=True)
def cell_step_cost(c: int, unknown_cost: float, cost_weight: float) -> float:
    """Multiplier of a step's length entering a cell of cost ``c`` (inf when impassable)."""
    if c == 255:
        return 1.0 + cost_weight * unknown_cost / 252.0
    if c >= 253:
        return np.inf
    return 1.0 + cost_weight * c / 252.0


def astar(cost: np.ndarray, si: int, sj: int, gi: float, gj: float, goal_r: float,
          unknown_cost: float, cost_weight: float, *, work: "AStarWork | None" = None,
          heuristic_weight: float = 1.0, escape_r: float = 0.0) -> np.ndarray:
    """A* over the 8-connected grid from cell (si, sj) to any cell whose centre lies within
    ``goal_r`` cells of (gi, gj) (fractional cell coordinates). A step costs its length (cells)
    x :func:`cell_step_cost` of the cell entered; INSCRIBED and LETHAL cells are impassable,
    except that the start's own connected INSCRIBED region within ``escape_r`` cells of the start
    may be crossed to leave it (a robot next to an obstacle can drive away; never through a wall
    whose scan left gaps). The heuristic is the straight-line distance to the goal
    circle x the multiplier of a never-seen cell (weighted A*: exact across unknown ground, so a
    plan through it expands about the cells of its path; at most that factor longer than the
    best path over known ground), times ``heuristic_weight``. Returns the path's cells (n, 2) from start to goal, (0, 2)
    when there is none. Deterministic (ties by insertion order). ``work``: buffers reused
    between calls on grids of one shape (:class:`AStarWork`)."""
    if work is None or work.g.shape[0] != cost.size:
        work = AStarWork(cost.shape)
    hw = max(1.0, 1.0 + cost_weight * unknown_cost / 252.0) * heuristic_weight
    return _astar(cost, (si, sj), (gi, gj, goal_r), (unknown_cost, cost_weight, hw, escape_r),
                  (work.g, work.parent, work.closed))


class AStarWork:
    """A* buffers for a grid of ``shape``: left as found (g = inf, no parent, nothing closed)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        n = int(np.prod(shape))
        self.g = np.full(n, np.inf)
        self.parent = np.full(n, -1, np.int64)
        self.closed = np.zeros(n, np.bool_)


@nb.njit(cache=True)
def _astar(cost: np.ndarray, start: tuple[int, int], goal: tuple[float, float, float],
           costs: tuple[float, float, float, float], work: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """:func:`astar` on (si, sj), (gi, gj, goal_r), (unknown_cost, cost_weight, hw, escape_r) and
    the buffers (g, parent, closed)."""
    si, sj = start
    gi, gj, goal_r = goal
    unknown_cost, cost_weight, hw, escape_r = costs
    g, parent, closed = work
    ny, nx = cost.shape
    s = si * nx + sj
    touched = [s]
    g[s] = 0.0
    h0 = hw * max(math.hypot(si - gi, sj - gj) - goal_r, 0.0)
    heap = [(h0, 0, s)]
    count = 1
    found = -1
    di = np.array([-1, -1, -1, 0, 0, 1, 1, 1])
    dj = np.array([-1, 0, 1, -1, 1, -1, 0, 1])
    while len(heap) > 0:
        f, _, u = heapq_pop(heap)
        if closed[u]:
            continue
        closed[u] = True
        ui, uj = u // nx, u % nx
        if math.hypot(ui - gi, uj - gj) <= goal_r:
            found = u
            break
        cu = cost[ui, uj]
        escaping = u == s or (cu == 253)
        for k in range(8):
            vi, vj = ui + di[k], uj + dj[k]
            if vi < 0 or vj < 0 or vi >= ny or vj >= nx:
                continue
            v = vi * nx + vj
            if closed[v]:
                continue
            c = cost[vi, vj]
            m = cell_step_cost(c, unknown_cost, cost_weight)
            if not math.isfinite(m):
                if c == 253 and escaping and math.hypot(vi - si, vj - sj) <= escape_r:
                    m = 1.0 + cost_weight  # leaving the start's inscribed zone: as the costliest free cell
                else:
                    continue
            step = (1.4142135623730951 if di[k] != 0 and dj[k] != 0 else 1.0) * m
            ng = g[u] + step
            if ng < g[v]:
                if g[v] == np.inf:
                    touched.append(v)
                g[v] = ng
                parent[v] = u
                hv = hw * max(math.hypot(vi - gi, vj - gj) - goal_r, 0.0)
                heapq_push(heap, (ng + hv, count, v))
                count += 1
    m = 0
    u = found
    while u >= 0:
        m += 1
        u = parent[u]
    out = np.zeros((m, 2), np.int64)
    u = found
    for k in range(m - 1, -1, -1):
        out[k, 0], out[k, 1] = u // nx, u % nx
        u = parent[u]
    for t in touched:  # leave the buffers as found
        g[t] = np.inf
        parent[t] = -1
        closed[t] = False
    return out


@nb.njit(cache=True)
def heapq_push(heap: list[tuple[float, int, int]], item: tuple[float, int, int]) -> None:
    heap.append(item)
    pos = len(heap) - 1
    while pos > 0:
        par = (pos - 1) >> 1
        if item < heap[par]:
            heap[pos] = heap[par]
            pos = par
        else:
            break
    heap[pos] = item


@nb.njit(cache=True)
def heapq_pop(heap: list[tuple[float, int, int]]) -> tuple[float, int, int]:
    last = heap.pop()
    if len(heap) == 0:
        return last
    top = heap[0]
    n = len(heap)
    pos = 0
    while True:
        c = 2 * pos + 1
        if c >= n:
            break
        if c + 1 < n and heap[c + 1] < heap[c]:
            c += 1
        if heap[c] < last:
            heap[pos] = heap[c]
            pos = c
        else:
            break
    heap[pos] = last
    return top


@nb.njit(cache=True)
def _cost_at(cost: np.ndarray, grid: Grid, x: float, y: float) -> int:
    x0, y0, cell = grid
    j = int(math.floor((x - x0) / cell))
    i = int(math.floor((y - y0) / cell))
    if i < 0 or j < 0 or i >= cost.shape[0] or j >= cost.shape[1]:
        return 255
    return int(cost[i, j])


@nb.njit(cache=True)
def footprint_overlap(cost: np.ndarray, grid: Grid, x: float, y: float, yaw: float, fp: Footprint) -> int:
    """How much the footprint at (x, y, yaw) collides, 0 when it does not: ``1000 + the centre's
    cost`` when the centre lies within the inscribed radius of an obstacle (cost >= INSCRIBED),
    else, when an obstacle is within the circumscribed radius (cost >= ``circ_cost``), the number
    of points of its ``outline`` (n, 2, body frame) on obstacle cells (Nav2's footprint check
    with the possibly-inscribed shortcut). Never-seen ground does not collide."""
    circ_cost, outline = fp
    c = _cost_at(cost, grid, x, y)
    if c == 255 or c < circ_cost:
        return 0
    if c >= 253:
        return 1000 + c
    cy, sy = math.cos(yaw), math.sin(yaw)
    n = 0
    for k in range(outline.shape[0]):
        px = x + cy * outline[k, 0] - sy * outline[k, 1]
        py = y + sy * outline[k, 0] + cy * outline[k, 1]
        if _cost_at(cost, grid, px, py) == 254:
            n += 1
    return n


@nb.njit(cache=True)
def footprint_hits(cost: np.ndarray, grid: Grid, x: float, y: float, yaw: float, fp: Footprint) -> bool:
    """Whether the footprint at (x, y, yaw) collides (:func:`footprint_overlap` > 0)."""
    return footprint_overlap(cost, grid, x, y, yaw, fp) > 0


@nb.njit(cache=True)
def _nearest(path: np.ndarray, x: float, y: float) -> tuple[int, float]:
    best, bd = 0, np.inf
    for k in range(path.shape[0]):
        d = math.hypot(path[k, 0] - x, path[k, 1] - y)
        if d < bd:
            bd, best = d, k
    return best, bd


@nb.njit(cache=True)
def score_rollouts(cost: np.ndarray, grid: Grid, pose: tuple[float, float, float],
                   samples: tuple[np.ndarray, np.ndarray], fp: Footprint, plan: tuple[np.ndarray, np.ndarray],
                   weights: np.ndarray, ro: Rollouts) -> np.ndarray:
    """DWB: each sample (vs[k], ws[k]) rolled out at constant velocity for ``n_steps`` of ``dt``
    from (px, py, pyaw) and scored by its critics (lower is better; inf: a pose collides, see
    :func:`footprint_hits`). ``path`` (m, 2): the global path's points ahead (map frame, meters),
    ``togo`` (m,): the path length left from each to the goal. ``weights``: obstacle, path
    distance, path alignment, goal distance, speed, oscillation, forward point (m). A robot
    whose footprint already collides (an obstacle seen late, pose error) may move as long as the
    collision gets no worse (:func:`footprint_overlap` never above the start's): it can back
    out of where it is. ``pose``: (px, py, pyaw); ``samples``: (vs, ws); ``plan``: (path, togo);
    ``ro``: :class:`Rollouts`."""
    px, py, pyaw = pose
    vs, ws = samples
    path, togo = plan
    n_steps, dt, unknown_cost, vmax, prev_w = ro
    out = np.empty(vs.shape[0])
    start = footprint_overlap(cost, grid, px, py, pyaw, fp)
    for k in range(vs.shape[0]):
        v, w = vs[k], ws[k]
        x, y, th = px, py, pyaw
        csum = 0.0
        bad = False
        for _ in range(n_steps):
            if abs(w) > 1e-9:
                nth = th + w * dt
                x += v / w * (math.sin(nth) - math.sin(th))
                y -= v / w * (math.cos(nth) - math.cos(th))
                th = nth
            else:
                x += v * dt * math.cos(th)
                y += v * dt * math.sin(th)
            hit = footprint_overlap(cost, grid, x, y, th, fp)
            if hit > 0 and (start == 0 or hit > start):
                bad = True
                break
            c = _cost_at(cost, grid, x, y)
            csum += unknown_cost if c == 255 else c
        if bad:
            out[k] = np.inf
            continue
        j, dpath = _nearest(path, x, y)
        fx = x + weights[6] * math.cos(th)
        fy = y + weights[6] * math.sin(th)
        _, dalign = _nearest(path, fx, fy)
        goal = togo[j] + dpath
        osc = 1.0 if (prev_w * w < 0.0 and abs(w) > 0.05 and abs(prev_w) > 0.05) else 0.0
        out[k] = (weights[0] * csum / n_steps / 252.0 + weights[1] * dpath + weights[2] * dalign
                  + weights[3] * goal + weights[4] * (1.0 - v / vmax) + weights[5] * osc)
    return out
