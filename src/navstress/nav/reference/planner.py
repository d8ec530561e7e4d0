"""P3D: the local arc planner.

Each cycle a fan of arcs starts at the perceived pose: ``forward_arcs`` arcs of length
``arc_length_m`` with curvatures evenly spaced in ``[-k_max, +k_max]`` (straight included), plus
optionally a turn on the spot (its nodes are the current position at headings rotating toward
the goal side). At each of the ``nodes_per_arc`` nodes the believed footprint (RobotSpec length x
width plus margin, oriented along the arc) is laid on the map; the cells it overlaps (exactly:
positive-area overlap of the oriented rectangle with the cell square) give the node's cost:

* infinite if any cell is an obstacle, or never seen (with the default ``unknown_cell_cost``),
  or outside the map;
* otherwise ``w_s * slope / max_slope + w_r * roughness / max_roughness``, where a plane is fitted
  (least squares) to the cells' mean heights: slope = its tilt, roughness = the largest absolute
  residual; infinite above either maximum.

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

from navstress.nav.reference.config import ReferenceConfig
from navstress.nav.reference.terrain_map import TerrainMap, cell_is_obstacle
from navstress.robot import RobotSpec

__all__ = ["ArcEvaluation", "ArcPlanner", "arc_nodes", "footprint_cells", "footprint_slope_roughness", "node_cost"]

_MAX_FP_CELLS = 4096
_NO_EXEMPT = np.zeros((1, 1), dtype=np.bool_)


@nb.njit(cache=True)
def _footprint_cells(cx: float, cy: float, yaw: float, hl: float, hw: float, ox: float, oy: float,
                     cell: float, nr: int, nc: int, out_i: np.ndarray, out_j: np.ndarray) -> int:
    """Cells whose square overlaps the oriented rectangle with positive area (separating-axis
    test). Returns their count, or -1 if the rectangle reaches outside the grid or overflows."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    ac = abs(c)
    as_ = abs(s)
    ex = hl * ac + hw * as_
    ey = hl * as_ + hw * ac
    j0 = int(math.floor((cx - ex - ox) / cell))
    j1 = int(math.floor((cx + ex - ox) / cell))
    i0 = int(math.floor((cy - ey - oy) / cell))
    i1 = int(math.floor((cy + ey - oy) / cell))
    half = 0.5 * cell
    proj = half * (ac + as_)
    n = 0
    for i in range(i0, i1 + 1):
        y0 = oy + i * cell
        if not (cy - ey < y0 + cell and cy + ey > y0):
            continue
        for j in range(j0, j1 + 1):
            x0 = ox + j * cell
            if not (cx - ex < x0 + cell and cx + ex > x0):
                continue
            dx = x0 + half - cx
            dy = y0 + half - cy
            if abs(dx * c + dy * s) >= hl + proj:
                continue
            if abs(-dx * s + dy * c) >= hw + proj:
                continue
            if i < 0 or j < 0 or i >= nr or j >= nc or n >= out_i.shape[0]:
                return -1
            out_i[n] = i
            out_j[n] = j
            n += 1
    return n


@nb.njit(cache=True)
def _node_cost(zmin: np.ndarray, zmax: np.ndarray, zsum: np.ndarray, count: np.ndarray,
               ox: float, oy: float, cell: float, step: float, x: float, y: float, yaw: float,
               hl: float, hw: float, max_slope_tan: float, max_rough: float, w_s: float, w_r: float,
               unknown_cost: float, buf_i: np.ndarray, buf_j: np.ndarray, buf_z: np.ndarray,
               exempt: np.ndarray) -> tuple[float, float, float]:
    """(cost, slope tangent, roughness) of the footprint at (x, y, yaw); cost inf if blocked.
    Cells flagged in ``exempt`` (same shape as the map, or (1, 1) for none) are ignored."""
    nr, nc = zmin.shape
    n = _footprint_cells(x, y, yaw, hl, hw, ox, oy, cell, nr, nc, buf_i, buf_j)
    if n < 0:
        return math.inf, math.nan, math.nan
    extra = 0.0
    m = 0
    sx = 0.0
    sy = 0.0
    sz = 0.0
    use_exempt = exempt.shape[0] == nr and exempt.shape[1] == nc
    for k in range(n):
        i = buf_i[k]
        j = buf_j[k]
        if use_exempt and exempt[i, j]:
            # already under the robot: not a reason to refuse, but known ground still shapes the plane
            if count[i, j] == 0 or cell_is_obstacle(zmin, zmax, count, i, j, step):
                continue
        elif count[i, j] == 0:
            if math.isinf(unknown_cost):
                return math.inf, math.nan, math.nan
            extra += unknown_cost
            continue
        elif cell_is_obstacle(zmin, zmax, count, i, j, step):
            return math.inf, math.nan, math.nan
        buf_i[m] = i
        buf_j[m] = j
        buf_z[m] = zsum[i, j] / count[i, j]
        sx += ox + (j + 0.5) * cell
        sy += oy + (i + 0.5) * cell
        sz += buf_z[m]
        m += 1
    if m == 0:
        return extra, 0.0, 0.0
    mx = sx / m
    my = sy / m
    mz = sz / m
    cxx = 0.0
    cxy = 0.0
    cyy = 0.0
    cxz = 0.0
    cyz = 0.0
    for k in range(m):
        dx = ox + (buf_j[k] + 0.5) * cell - mx
        dy = oy + (buf_i[k] + 0.5) * cell - my
        dz = buf_z[k] - mz
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
    rough = 0.0
    for k in range(m):
        dx = ox + (buf_j[k] + 0.5) * cell - mx
        dy = oy + (buf_i[k] + 0.5) * cell - my
        r = abs(buf_z[k] - mz - gb * dx - gc * dy)
        if r > rough:
            rough = r
    slope_tan = math.sqrt(gb * gb + gc * gc)
    if slope_tan > max_slope_tan or rough > max_rough:
        return math.inf, slope_tan, rough
    cost = w_s * math.atan(slope_tan) / math.atan(max_slope_tan) + w_r * rough / max_rough + extra
    return cost, slope_tan, rough


@nb.njit(cache=True)
def _near_obstacle(zmin: np.ndarray, zmax: np.ndarray, count: np.ndarray, ox: float, oy: float,
                   cell: float, step: float, x: float, y: float, yaw: float, hl: float, hw: float,
                   buf_i: np.ndarray, buf_j: np.ndarray, exempt: np.ndarray) -> bool:
    """True if a known obstacle cell (not exempt) overlaps the rectangle (the clearance ring)."""
    nr, nc = zmin.shape
    n = _footprint_cells(x, y, yaw, hl, hw, ox, oy, cell, nr, nc, buf_i, buf_j)
    if n < 0:
        return False
    use_exempt = exempt.shape[0] == nr and exempt.shape[1] == nc
    for k in range(n):
        i = buf_i[k]
        j = buf_j[k]
        if use_exempt and exempt[i, j]:
            continue
        if count[i, j] > 0 and cell_is_obstacle(zmin, zmax, count, i, j, step):
            return True
    return False


@nb.njit(cache=True)
def _evaluate(zmin: np.ndarray, zmax: np.ndarray, zsum: np.ndarray, count: np.ndarray,
              ox: float, oy: float, cell: float, step: float, nodes: np.ndarray, hl: float, hw: float,
              max_slope_tan: float, max_rough: float, w_s: float, w_r: float, unknown_cost: float,
              out_node: np.ndarray, exempt: np.ndarray, clear_m: float, clear_cost: float) -> np.ndarray:
    n_arcs = nodes.shape[0]
    n_nodes = nodes.shape[1]
    out = np.zeros(n_arcs)
    buf_i = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    buf_j = np.empty(_MAX_FP_CELLS, dtype=np.int64)
    buf_z = np.empty(_MAX_FP_CELLS, dtype=np.float64)
    for a in range(n_arcs):
        total = 0.0
        for k in range(n_nodes):
            cst, _, _ = _node_cost(zmin, zmax, zsum, count, ox, oy, cell, step, nodes[a, k, 0],
                                   nodes[a, k, 1], nodes[a, k, 2], hl, hw, max_slope_tan, max_rough,
                                   w_s, w_r, unknown_cost, buf_i, buf_j, buf_z, exempt)
            if clear_m > 0.0 and clear_cost > 0.0 and not math.isinf(cst):
                if _near_obstacle(zmin, zmax, count, ox, oy, cell, step, nodes[a, k, 0], nodes[a, k, 1],
                                  nodes[a, k, 2], hl + clear_m, hw + clear_m, buf_i, buf_j, exempt):
                    cst += clear_cost
            out_node[a, k] = cst
            total += cst
            if math.isinf(total):
                for r in range(k + 1, n_nodes):
                    out_node[a, r] = math.inf
                break
        out[a] = total
    return out


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
    buf = np.empty(_MAX_FP_CELLS, dtype=np.int64), np.empty(_MAX_FP_CELLS, dtype=np.int64), np.empty(_MAX_FP_CELLS)
    _, st, r = _node_cost(terrain.zmin, terrain.zmax, terrain.zsum, terrain.count, terrain.origin[0],
                          terrain.origin[1], terrain.cell_m, terrain.step_m, x, y, yaw, half_length,
                          half_width, 1e9, 1e9, 1.0, 1.0, math.inf, *buf, _NO_EXEMPT)
    return math.degrees(math.atan(st)) if math.isfinite(st) else math.nan, r


def node_cost(planner: "ArcPlanner", terrain: TerrainMap, x: float, y: float, yaw: float,
              unknown_cost: float | None = None) -> float:
    """Cost of the planner's footprint at one pose (inf if blocked); ``unknown_cost`` overrides the config's."""
    cfg = planner.config
    uc = float(cfg.unknown_cell_cost if unknown_cost is None else unknown_cost)
    buf = np.empty(_MAX_FP_CELLS, dtype=np.int64), np.empty(_MAX_FP_CELLS, dtype=np.int64), np.empty(_MAX_FP_CELLS)
    c, _, _ = _node_cost(terrain.zmin, terrain.zmax, terrain.zsum, terrain.count, terrain.origin[0],
                         terrain.origin[1], terrain.cell_m, terrain.step_m, x, y, yaw, planner.half_length,
                         planner.half_width, math.tan(math.radians(cfg.max_slope_deg)), cfg.max_roughness_m,
                         cfg.slope_weight, cfg.roughness_weight, uc, *buf, _NO_EXEMPT)
    return float(c)


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
        return np.isnan(self.curvatures)


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
        self.curvatures = np.linspace(-kmax, kmax, config.forward_arcs)
        self.curvatures[config.forward_arcs // 2] = 0.0
        self.max_speed = min(config.max_speed_mps, robot.max_speed_mps)
        self._exempt = np.zeros((1, 1), dtype=np.bool_)

    def evaluate(self, terrain: TerrainMap, x: float, y: float, yaw: float, spin_dir: int) -> ArcEvaluation:
        """Node poses and terrain costs of the fan at (x, y, yaw). With
        ``exempt_current_footprint`` the cells under the current (margined) footprint are not
        checked: the robot already stands there, so an obstacle cell dilated into its margin does
        not forbid driving away; every cell a node newly covers is still checked."""
        cfg = self.config
        nodes = arc_nodes(x, y, yaw, self.curvatures, cfg.arc_length_m, cfg.nodes_per_arc)
        curv = self.curvatures
        if cfg.turn_in_place:
            d = 1 if spin_dir >= 0 else -1
            ang = yaw + d * math.radians(cfg.turn_in_place_angle_deg) * np.arange(1, cfg.nodes_per_arc + 1) / cfg.nodes_per_arc
            spin = np.stack([np.full_like(ang, x), np.full_like(ang, y), ang], axis=-1)[None]
            nodes = np.concatenate([nodes, spin], axis=0)
            curv = np.concatenate([curv, [math.nan]])
            spin_dir = d
        else:
            spin_dir = 0
        node_cost = np.empty(nodes.shape[:2])
        exempt = _NO_EXEMPT
        here = None
        if cfg.exempt_current_footprint:
            here = footprint_cells(x, y, yaw, self.half_length, self.half_width, terrain)
            if here is not None:
                if self._exempt.shape != terrain.shape:
                    self._exempt = np.zeros(terrain.shape, dtype=np.bool_)
                exempt = self._exempt
                exempt[here] = True
        cost = _evaluate(terrain.zmin, terrain.zmax, terrain.zsum, terrain.count, terrain.origin[0],
                         terrain.origin[1], terrain.cell_m, terrain.step_m, np.ascontiguousarray(nodes),
                         self.half_length, self.half_width, math.tan(math.radians(cfg.max_slope_deg)),
                         cfg.max_roughness_m, cfg.slope_weight, cfg.roughness_weight,
                         float(cfg.unknown_cell_cost), node_cost, exempt, cfg.clearance_margin_m,
                         cfg.clearance_cost)
        if here is not None and exempt is self._exempt:
            exempt[here] = False
        return ArcEvaluation(nodes, curv, spin_dir, cost, node_cost)

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
