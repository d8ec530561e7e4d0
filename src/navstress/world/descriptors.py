"""A-priori descriptors of a world (stored in ``World.descriptors``; plain JSON, no NaN).

All lengths in meters, angles in degrees, obstruction in percent of the map area.

* ``obstruction_pct`` {type: achieved}, ``obstruction_total_pct`` (the sum of footprint areas,
  a cylinder's pi r^2: the union's area when obstacles do not overlap, which generation
  guarantees except at the joints of a wall polyline's own segments, counted twice), ``obstruction_target_pct``,
  ``n_obstacles`` {type: count}; with generation bookkeeping: ``placement_attempts``,
  ``placement_rounds``, ``placement_trimmed`` {type: int}.
* Terrain: ``height_min_m``, ``height_max_m``, ``height_std_m``; ``slope_mean_deg``,
  ``slope_p95_deg``, ``slope_max_deg`` (slope at every vertex from central differences);
  ``roughness_m``: standard deviation of ``h - G_1m * h``, the height residual after a Gaussian
  smoothing of sigma = 1 m (features smaller than about the robot, which shake it rather than
  tilt it).
* BARN-style metrics (after Perille et al., "Benchmarking Metric Ground Navigation", 2020,
  adapted to a continuous map: computed over the free cells of an occupancy grid of cell
  :data:`BARN_CELL_M` (footprints rasterised: boxes as rotated rectangles, cylinders as discs; a
  cell is occupied when its centre is inside a footprint), not along a path):
  ``barn_dist_closest_m``: mean over free cells of the distance to the nearest occupied cell
  (Euclidean distance transform; approximate to one cell); ``barn_visibility_m``: mean length
  of 16 rays (every 22.5 degrees) cast from each free cell, capped at :data:`BARN_RAY_M`;
  ``barn_dispersion``: mean over free cells of the number of alternations between capped
  (no hit) and blocked rays, going round the 16 rays; ``barn_characteristic_dim_m``: mean over
  free cells of the smallest "axis visibility" (ray length in direction k plus in direction
  k + 180 degrees, minimised over the 8 axes), i.e. the width of the narrowest passage through
  the cell. On a map with no obstacles they are None (distance, dispersion 0) or the cap.
* Movers (only for a spec with a ``movers`` field: :func:`navstress.world.movers.mover_descriptors`):
  ``n_movers`` {type: count}, ``movers_total``, ``mover_density_per_ha``.
* Path: ``path_length_m`` (shortest 8-connected path on the terrain vertex grid from start to
  goal, edges weighted by their 3-D length), ``path_ratio`` (path / straight distance),
  ``feasible`` (bool), ``infeasible_reason`` (str or None). A vertex is impassable when the
  nominal robot's centre there would be closer than half its width to a footprint (exact
  distance to the box, or to a cylinder's disc) or to the map edge, or when the slope there exceeds
  ``max_slope_deg`` (default :data:`MAX_SLOPE_DEG`); diagonal moves need both orthogonal
  neighbours passable. Grids over :data:`MAX_PATH_NODES` vertices are decimated (a block is
  impassable if any vertex in it is), which makes the length approximate.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.robot import RobotSpec
from navstress.world.spec import WorldSpec
from navstress.world.terrain import slope_deg
from navstress.world.movers import mover_descriptors
from navstress.world.placement import PlacementResult
from navstress.world.world import Mission, Obstacle, Terrain, World

MAX_SLOPE_DEG = 25.0
ROUGHNESS_SIGMA_M = 1.0
BARN_CELL_M = 0.5
BARN_RAY_M = 10.0
MAX_PATH_NODES = 1_000_000


def _finite_or_none(x: float | np.floating[Any]) -> float | None:
    """``x`` as a float, None when it is not finite (the descriptors are JSON without NaN)."""
    v = float(x)
    return v if math.isfinite(v) else None


class Boxes(NamedTuple):
    """Oriented box footprints as arrays, one entry per obstacle (:func:`_box_distance`)."""

    x: np.ndarray  # centres (m)
    y: np.ndarray
    hx: np.ndarray  # half sides along the box's own axes (m)
    hy: np.ndarray
    c: np.ndarray  # cos and sin of the yaw
    s: np.ndarray
    disc: np.ndarray  # bool: a cylinder's disc of radius hx (c, s, hy unused)


def _box_arrays(obstacles: tuple[Obstacle, ...]) -> Boxes:
    return Boxes(np.array([o.x for o in obstacles], np.float64), np.array([o.y for o in obstacles], np.float64),
                 np.array([o.size[0] / 2 for o in obstacles], np.float64),
                 np.array([o.size[1] / 2 for o in obstacles], np.float64),
                 np.array([math.cos(o.yaw) for o in obstacles], np.float64),
                 np.array([math.sin(o.yaw) for o in obstacles], np.float64),
                 np.array([o.is_cylinder for o in obstacles], np.bool_))


@numba.njit(cache=True)
def _box_distance(rows: int, cols: int, cell: float, boxes: Boxes, reach: float) -> np.ndarray:
    """Exact distance from each grid point (j*cell, i*cell) to the nearest footprint (an oriented
    box, or a cylinder's disc; 0 inside), ``inf`` where farther than ``reach``."""
    xs, ys, hx, hy, c, s, disc = boxes.x, boxes.y, boxes.hx, boxes.hy, boxes.c, boxes.s, boxes.disc
    out = np.full((rows, cols), np.inf)
    for k in range(xs.shape[0]):
        if disc[k]:
            ex = hx[k] + reach
            j0 = max(0, int(math.floor((xs[k] - ex) / cell)))
            j1 = min(cols - 1, int(math.ceil((xs[k] + ex) / cell)))
            i0 = max(0, int(math.floor((ys[k] - ex) / cell)))
            i1 = min(rows - 1, int(math.ceil((ys[k] + ex) / cell)))
            for i in range(i0, i1 + 1):
                py = i * cell - ys[k]
                for j in range(j0, j1 + 1):
                    px = j * cell - xs[k]
                    d = max(math.sqrt(px * px + py * py) - hx[k], 0.0)
                    if d < out[i, j]:
                        out[i, j] = d
            continue
        ex = abs(c[k]) * hx[k] + abs(s[k]) * hy[k] + reach
        ey = abs(s[k]) * hx[k] + abs(c[k]) * hy[k] + reach
        j0 = max(0, int(math.floor((xs[k] - ex) / cell)))
        j1 = min(cols - 1, int(math.ceil((xs[k] + ex) / cell)))
        i0 = max(0, int(math.floor((ys[k] - ey) / cell)))
        i1 = min(rows - 1, int(math.ceil((ys[k] + ey) / cell)))
        for i in range(i0, i1 + 1):
            py = i * cell - ys[k]
            for j in range(j0, j1 + 1):
                px = j * cell - xs[k]
                lx = c[k] * px + s[k] * py
                ly = -s[k] * px + c[k] * py
                dx = max(abs(lx) - hx[k], 0.0)
                dy = max(abs(ly) - hy[k], 0.0)
                d = math.sqrt(dx * dx + dy * dy)
                if d < out[i, j]:
                    out[i, j] = d
    return out


def obstacle_distance(shape: tuple[int, int], cell_m: float, obstacles: tuple[Obstacle, ...],
                      reach: float) -> np.ndarray:
    """Distance (m) from each vertex of a grid to the nearest footprint, ``inf`` beyond ``reach``."""
    if not obstacles:
        return np.full(shape, np.inf)
    out: np.ndarray = _box_distance(shape[0], shape[1], float(cell_m), _box_arrays(obstacles), float(reach))
    return out


@numba.njit(cache=True)
def _rays(occ: np.ndarray, cell: float, max_len: float) -> tuple[float, float, float, int]:
    """BARN-style ray statistics over the free cells of ``occ`` (16 rays per cell, stepping
    a quarter cell). Returns (mean visibility, mean dispersion, mean characteristic dim, n)."""
    ny, nx = occ.shape
    nd = 16
    step = cell / 4.0
    nsteps = int(max_len / step)
    vis_sum = 0.0
    disp_sum = 0.0
    cd_sum = 0.0
    n = 0
    lens = np.empty(nd)
    for b in range(ny):
        for a in range(nx):
            if occ[b, a]:
                continue
            x0 = (a + 0.5) * cell
            y0 = (b + 0.5) * cell
            for k in range(nd):
                th = 2.0 * math.pi * k / nd
                dx = math.cos(th) * step
                dy = math.sin(th) * step
                length = max_len
                for t in range(1, nsteps + 1):
                    x = x0 + dx * t
                    y = y0 + dy * t
                    ia = int(math.floor(x / cell))
                    ib = int(math.floor(y / cell))
                    if ia < 0 or ib < 0 or ia >= nx or ib >= ny or occ[ib, ia]:
                        length = step * t
                        break
                lens[k] = length
            vis = 0.0
            alt = 0
            for k in range(nd):
                vis += lens[k]
                if (lens[k] < max_len) != (lens[(k + 1) % nd] < max_len):
                    alt += 1
            cd = 1e300
            for k in range(nd // 2):
                w = lens[k] + lens[k + nd // 2]
                if w < cd:
                    cd = w
            vis_sum += vis / nd
            disp_sum += alt
            cd_sum += cd
            n += 1
    if n == 0:
        return 0.0, 0.0, 0.0, 0
    return vis_sum / n, disp_sum / n, cd_sum / n, n


def barn_metrics(size_m: tuple[float, float], obstacles: tuple[Obstacle, ...],
                 cell_m: float = BARN_CELL_M, ray_m: float = BARN_RAY_M) -> dict[str, float | None]:
    """BARN-style metrics over the free cells of an occupancy grid (see module docstring).

    The map edge blocks rays like an obstacle (the robot cannot leave the map)."""
    nx = max(1, round(size_m[0] / cell_m))
    ny = max(1, round(size_m[1] / cell_m))
    cx, cy = size_m[0] / nx, size_m[1] / ny
    cell = min(cx, cy)
    none: dict[str, float | None] = {"barn_dist_closest_m": None, "barn_visibility_m": None,
                                     "barn_dispersion": None, "barn_characteristic_dim_m": None}
    if not obstacles:
        return none
    boxes = _box_arrays(obstacles)
    # occupied when the cell centre is inside a footprint (grid point (i, j) := centre of cell (i, j))
    d = _box_distance(ny, nx, cell, boxes._replace(x=boxes.x - 0.5 * cell, y=boxes.y - 0.5 * cell), 0.0)
    occ = (d <= 0.0).astype(np.uint8)
    if not occ.any():
        return none
    from scipy import ndimage  # here: 0.3-0.5 s to import, and a process that only runs missions never needs it

    edt = ndimage.distance_transform_edt(occ == 0) * cell
    free = occ == 0
    vis, disp, cd, n = _rays(occ, cell, float(ray_m))
    return {"barn_dist_closest_m": _finite_or_none(edt[free].mean()) if free.any() else None,
            "barn_visibility_m": _finite_or_none(vis) if n else None,
            "barn_dispersion": _finite_or_none(disp) if n else None,
            "barn_characteristic_dim_m": _finite_or_none(cd) if n else None}


def traversable(terrain: Terrain, obstacles: tuple[Obstacle, ...], robot: RobotSpec,
                max_slope_deg: float = MAX_SLOPE_DEG) -> np.ndarray:
    """Boolean grid (terrain vertex grid) of where the robot's centre may be."""
    h = terrain.heights
    rows, cols = h.shape
    cell = terrain.cell_m
    half = robot.width_m / 2
    ok = slope_deg(h, cell) <= max_slope_deg
    ok &= ~(obstacle_distance((rows, cols), cell, obstacles, half) < half)
    xs = np.arange(cols) * cell
    ys = np.arange(rows) * cell
    sx, sy = (cols - 1) * cell, (rows - 1) * cell
    ok &= ((xs >= half) & (xs <= sx - half))[None, :]
    ok &= ((ys >= half) & (ys <= sy - half))[:, None]
    return ok


def shortest_path_length(terrain: Terrain, ok: np.ndarray, start: tuple[float, float],
                         goal: tuple[float, float]) -> tuple[float | None, str | None]:
    """Shortest 8-connected path length (m, 3-D edge lengths) on the passable vertices ``ok``;
    (None, reason) when there is none."""
    h = np.asarray(terrain.heights, np.float64)
    cell = terrain.cell_m
    rows, cols = h.shape
    stride = max(1, math.ceil(math.sqrt(rows * cols / MAX_PATH_NODES)))
    if stride > 1:
        r2, c2 = -(-rows // stride), -(-cols // stride)
        pad = np.zeros((r2 * stride, c2 * stride), bool)
        pad[:rows, :cols] = ~ok
        ok = np.asarray(~pad.reshape(r2, stride, c2, stride).any(axis=(1, 3)))
        h = h[::stride, ::stride]
        cell = cell * stride
        rows, cols = ok.shape
    si = (min(rows - 1, round(start[1] / cell)), min(cols - 1, round(start[0] / cell)))
    gi = (min(rows - 1, round(goal[1] / cell)), min(cols - 1, round(goal[0] / cell)))
    if not ok[si]:
        return None, "start is not traversable (obstacle, slope or map edge)"
    if not ok[gi]:
        return None, "goal is not traversable (obstacle, slope or map edge)"
    idx = np.arange(rows * cols).reshape(rows, cols)
    src: list[np.ndarray] = []
    dst: list[np.ndarray] = []
    wts: list[np.ndarray] = []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = (slice(0, rows - di), slice(max(0, -dj), cols - max(0, dj)))
        b = (slice(di, rows), slice(max(0, -dj) + dj, cols - max(0, dj) + dj))
        m = ok[a] & ok[b]
        if di and dj:  # no corner cutting
            m &= ok[a[0], b[1]] & ok[b[0], a[1]]
        planar = cell * math.hypot(di, dj)
        dz = h[b] - h[a]
        src.append(idx[a][m])
        dst.append(idx[b][m])
        wts.append(np.sqrt(planar * planar + dz[m] ** 2))
    from scipy.sparse import coo_matrix  # here, as ndimage above
    from scipy.sparse.csgraph import dijkstra

    n = rows * cols
    g = coo_matrix((np.concatenate(wts), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
    dist = dijkstra(g, directed=False, indices=int(idx[si]))
    d = float(dist[idx[gi]])
    if not math.isfinite(d):
        return None, "no traversable path from start to goal"
    return d, None


def describe(spec: WorldSpec, terrain: Terrain, obstacles: tuple[Obstacle, ...], mission: Mission, *,
             robot: RobotSpec | None = None, placement: PlacementResult | None = None,
             max_slope_deg: float = MAX_SLOPE_DEG) -> dict[str, Any]:
    """All descriptors of a world's parts (see module docstring)."""
    robot = robot or RobotSpec()
    sx, sy = spec.size_m
    area = sx * sy
    kinds = sorted({o.kind for o in obstacles} | set(spec.obstacles.targets()))
    by_kind = {k: [o for o in obstacles if o.kind == k] for k in kinds}
    out: dict[str, Any] = {
        "obstruction_pct": {k: 100.0 * sum(o.area for o in v) / area for k, v in by_kind.items()},
        "obstruction_target_pct": dict(spec.obstacles.targets()),
        "n_obstacles": {k: len(v) for k, v in by_kind.items()},
    }
    out["obstruction_total_pct"] = float(sum(out["obstruction_pct"].values()))
    if placement is not None:
        out["placement_attempts"] = dict(placement.attempts)
        out["placement_rounds"] = dict(placement.rounds)
        out["placement_trimmed"] = dict(placement.trimmed)
        out["placement_raster_m"] = float(placement.raster_cell_m)
    h = np.asarray(terrain.heights, np.float64)
    sl = slope_deg(h, terrain.cell_m)
    sigma = ROUGHNESS_SIGMA_M / terrain.cell_m
    from scipy import ndimage  # here, as above

    resid = h - ndimage.gaussian_filter(h, sigma, mode="nearest")
    out.update({
        "height_min_m": _finite_or_none(h.min()), "height_max_m": _finite_or_none(h.max()),
        "height_std_m": _finite_or_none(h.std()),
        "slope_mean_deg": _finite_or_none(sl.mean()), "slope_p95_deg": _finite_or_none(np.percentile(sl, 95)),
        "slope_max_deg": _finite_or_none(sl.max()), "roughness_m": _finite_or_none(resid.std()),
    })
    out.update(barn_metrics(spec.size_m, obstacles))
    ok = traversable(terrain, obstacles, robot, max_slope_deg)
    length, reason = shortest_path_length(terrain, ok, mission.start[:2], mission.goal)
    out["path_length_m"] = _finite_or_none(length) if length is not None else None
    straight = mission.straight_distance_m
    out["path_ratio"] = _finite_or_none(length / straight) if length is not None and straight > 0 else None
    out["feasible"] = length is not None
    out["infeasible_reason"] = reason
    out["traversability"] = {"robot": robot.name, "half_width_m": robot.width_m / 2,
                             "max_slope_deg": float(max_slope_deg)}
    return out


def describe_world(world: World, *, robot: RobotSpec | None = None,
                   max_slope_deg: float = MAX_SLOPE_DEG) -> dict[str, Any]:
    """Recompute the geometric descriptors of an existing (e.g. loaded) world (with the movers'
    when its spec has a ``movers`` field, as :func:`~navstress.world.generate.generate` adds them)."""
    out = describe(world.spec, world.terrain, world.obstacles, world.mission, robot=robot,
                   max_slope_deg=max_slope_deg)
    if not world.spec.movers.empty:
        out.update(mover_descriptors(world.spec, world.movers))
    return out
