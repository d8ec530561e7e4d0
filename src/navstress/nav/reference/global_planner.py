"""GlobalNavigator (``reference-global-v1``): the P3D local planner guided by a global planner.

Every ``replan_period_s`` a Dijkstra wavefront from the goal over the current DTM gives every
cell its cost-to-go along the best 8-connected grid path (obstacle cells forbidden, cells within
the believed footprint's half width + ``inflation_margin_m`` of an obstacle ``inflated_cost_factor``
times dearer, never-seen cells optimistic at ``unknown_cost_factor``). The arc election's goal
term is then that cost-to-go at the arc's end (the distance *along* the global path) instead of the
straight-line distance: the paper's remedy for dead ends and U-shapes. The turn-in-place direction
follows the global path ``carrot_m`` ahead. When the robot's own cell has no finite cost-to-go
(the goal is walled off in the map) the straight-line goal term is used, as in ``reference-v1``.

Approximation: 8-connected grid distances overestimate Euclidean length by up to ~8%.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.nav.api import NavMission
from navstress.nav.reference.config import GlobalConfig, ReferenceConfig
from navstress.nav.reference.navigator import ReferenceNavigator
from navstress.nav.reference.planner import ArcEvaluation, footprint_half_extents
from navstress.nav.reference.pose import Pose, wrap_angle
from navstress.nav.reference.terrain_map import TerrainMap
from navstress.robot import RobotSpec

__all__ = ["GlobalNavigator", "cell_costs", "cost_to_go", "descend"]


@nb.njit(cache=True)
def _inflate(obst: np.ndarray, radius_cells: float) -> np.ndarray:
    nr, nc = obst.shape
    out = obst.copy()
    r = int(math.ceil(radius_cells))
    r2 = radius_cells * radius_cells
    for i in range(nr):
        for j in range(nc):
            if not obst[i, j]:
                continue
            for a in range(max(0, i - r), min(nr, i + r + 1)):
                for b in range(max(0, j - r), min(nc, j + r + 1)):
                    if (a - i) ** 2 + (b - j) ** 2 <= r2:
                        out[a, b] = True
    return out


@nb.njit(cache=True, inline="always")
def _push(hk: np.ndarray, hv: np.ndarray, n: int, key: float, val: int) -> int:
    k = n
    while k > 0:
        parent = (k - 1) >> 1
        if hk[parent] <= key:
            break
        hk[k] = hk[parent]
        hv[k] = hv[parent]
        k = parent
    hk[k] = key
    hv[k] = val
    return n + 1


@nb.njit(cache=True, inline="always")
def _pop(hk: np.ndarray, hv: np.ndarray, n: int) -> int:
    n -= 1
    key = hk[n]
    val = hv[n]
    k = 0
    while True:
        c = 2 * k + 1
        if c >= n:
            break
        if c + 1 < n and hk[c + 1] < hk[c]:
            c += 1
        if key <= hk[c]:
            break
        hk[k] = hk[c]
        hv[k] = hv[c]
        k = c
    hk[k] = key
    hv[k] = val
    return n


@nb.njit(cache=True)
def _dijkstra(cost: np.ndarray, gi: int, gj: int, cell: float) -> np.ndarray:
    """Dijkstra with a lazy-deletion binary heap on flat arrays (a cell is pushed at most 8 times)."""
    nr, nc = cost.shape
    dist = np.full((nr, nc), np.inf)
    if gi < 0 or gj < 0 or gi >= nr or gj >= nc:
        return dist
    cap = 8 * nr * nc + 1
    hk = np.empty(cap, dtype=np.float64)
    hv = np.empty(cap, dtype=np.int64)
    dist[gi, gj] = 0.0
    n = _push(hk, hv, 0, 0.0, gi * nc + gj)
    diag = math.sqrt(2.0) * cell
    while n > 0:
        d = hk[0]
        idx = hv[0]
        n = _pop(hk, hv, n)
        i = idx // nc
        j = idx - i * nc
        if d > dist[i, j]:
            continue
        ci = cost[i, j]
        for di in range(-1, 2):
            a = i + di
            if a < 0 or a >= nr:
                continue
            for dj in range(-1, 2):
                b = j + dj
                if (di == 0 and dj == 0) or b < 0 or b >= nc:
                    continue
                cn = cost[a, b]
                if math.isinf(cn):
                    continue
                if di != 0 and dj != 0:
                    if math.isinf(cost[i, b]) or math.isinf(cost[a, j]):
                        continue  # no corner cutting between obstacles
                    step = diag
                else:
                    step = cell
                nd = d + step * 0.5 * (ci + cn)
                if nd < dist[a, b]:
                    dist[a, b] = nd
                    n = _push(hk, hv, n, nd, a * nc + b)
    return dist


def cell_costs(terrain: TerrainMap, inflation_m: float, inflated_factor: float, unknown_factor: float) -> np.ndarray:
    """Per-cell traversal cost multiplier: inf on obstacles, ``inflated_factor`` within
    ``inflation_m`` of one, ``unknown_factor`` on never-seen cells, 1 elsewhere."""
    obst = terrain.obstacles()
    cost = np.where(terrain.known(), 1.0, float(unknown_factor))
    infl = _inflate(obst, inflation_m / terrain.cell_m)
    cost[infl] = np.maximum(cost[infl], float(inflated_factor))
    cost[obst] = np.inf
    return cost


def cost_to_go(cost: np.ndarray, goal_cell: tuple[int, int], cell_m: float) -> np.ndarray:
    """Dijkstra from ``goal_cell`` (8-connected, edge = length x mean of the two cells' costs)."""
    return np.asarray(_dijkstra(np.ascontiguousarray(cost, dtype=np.float64), int(goal_cell[0]),
                                int(goal_cell[1]), float(cell_m)))


def descend(field: np.ndarray, start: tuple[int, int], max_steps: int) -> list[tuple[int, int]]:
    """The global path: steepest descent of ``field`` from ``start`` (at most ``max_steps`` cells)."""
    nr, nc = field.shape
    i, j = start
    path = [(i, j)]
    if not (0 <= i < nr and 0 <= j < nc) or not math.isfinite(field[i, j]):
        return path
    for _ in range(max_steps):
        best, bi, bj = field[i, j], i, j
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                a, b = i + di, j + dj
                if 0 <= a < nr and 0 <= b < nc and field[a, b] < best:
                    best, bi, bj = field[a, b], a, b
        if (bi, bj) == (i, j):
            break
        i, j = bi, bj
        path.append((i, j))
    return path


class GlobalNavigator(ReferenceNavigator):
    """``reference-global-v1`` (module doc). ``config`` defaults to :class:`GlobalConfig`."""

    name = "reference-global-v1"

    def __init__(self, config: ReferenceConfig | None = None) -> None:
        cfg = config if config is not None else GlobalConfig()
        if not isinstance(cfg, GlobalConfig):
            cfg = GlobalConfig.model_validate(cfg.model_dump())
        super().__init__(cfg)
        self.gconfig: GlobalConfig = cfg

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        super().reset(mission, robot, seed=seed)
        self.field: np.ndarray | None = None
        self._next_replan = -math.inf
        self.replans = 0

    def _on_cycle(self, t: float, pose: Pose) -> None:
        if t >= self._next_replan:
            g = self.gconfig
            infl = footprint_half_extents(self.robot)[1] + g.footprint_margin_m + g.inflation_margin_m
            cost = cell_costs(self.terrain, infl, g.inflated_cost_factor, g.unknown_cost_factor)
            gi, gj = self.terrain.cell_of(*self.mission.goal)
            self.field = cost_to_go(cost, (gi, gj), self.terrain.cell_m)
            self._next_replan = t + g.replan_period_s
            self.replans += 1

    def _field_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        assert self.field is not None
        ox, oy = self.terrain.origin
        c = self.terrain.cell_m
        i = np.floor((y - oy) / c).astype(np.int64)
        j = np.floor((x - ox) / c).astype(np.int64)
        nr, nc = self.field.shape
        inside = (i >= 0) & (j >= 0) & (i < nr) & (j < nc)
        out = np.full(np.shape(x), np.inf)
        out[inside] = self.field[i[inside], j[inside]]
        return out

    def _goal_terms(self, ev: ArcEvaluation, pose: Pose) -> np.ndarray:
        here = self._field_at(np.array([pose.x]), np.array([pose.y]))[0]
        if self.field is None or not math.isfinite(here):
            return super()._goal_terms(ev, pose)
        ends = ev.nodes[:, -1, :2]
        d = self._field_at(ends[:, 0], ends[:, 1])
        d = np.where(ev.is_spin, here + self.config.turn_in_place_penalty_m, d)
        return self.config.goal_weight * d

    def _target_bearing(self, pose: Pose) -> float:
        """Signed angle from the heading to the global path ``carrot_m`` ahead (to the goal when
        there is no path yet)."""
        if self.field is None:
            return super()._target_bearing(pose)
        start = self.terrain.cell_of(pose.x, pose.y)
        path = descend(self.field, start, max(1, int(self.gconfig.carrot_m / self.terrain.cell_m)))
        if len(path) < 2:
            return super()._target_bearing(pose)
        cx, cy = self.terrain.cell_center(*path[-1])
        return wrap_angle(math.atan2(cy - pose.y, cx - pose.x) - pose.yaw)

    def global_path(self, max_len_m: float = 500.0) -> np.ndarray:
        """(K, 2) map-frame points of the current global path from the perceived position."""
        self._require_reset()
        if self.field is None:
            return np.zeros((0, 2))
        p = self.pom.current
        cells = descend(self.field, self.terrain.cell_of(p.x, p.y), int(max_len_m / self.terrain.cell_m))
        return np.array([self.terrain.cell_center(i, j) for i, j in cells], dtype=np.float64)
