"""Mover placement: each mover's size, cruise speed, start pose and path, from the map seed.

Movers are placed after the static world is complete (terrain, mission, obstacles), each mover
type from its own sub-stream ``rng(seed, "movers", type)`` (types in name order), so a world's
static part draws exactly what it drew before movers existed and adding movers changes none of
it.

* **Clearance raster.** A raster of cell ``r`` <= 0.2 m (coarser above 4 M cells) marks every
  cell that a static footprint touches (a box not turned: its bounding box; a turned box, a long
  wall, a cylinder: the cells its footprint touches, :mod:`navstress.world.shapes`) and every cell the start and goal free
  discs touch; beyond the map edge counts as occupied. ``clear[c]`` = the Euclidean distance
  from cell c's centre to the nearest marked cell's centre minus the cell diagonal: a lower
  bound of the distance from any point of cell c to any obstacle, free disc or the map's edge.
* **A point is free for a mover** of radius R (:attr:`MoverType.radius_m`, the top of the
  type's size envelope, for every mover of the type) when its cell has ``clear >= R +``
  :data:`MARGIN_M`: the mover's disc lies inside the map, touches no obstacle and stays out of
  the free discs.
* **A segment is free** when points along it every half cell are free (so every point of it has
  clearance >= R + MARGIN_M - r/4).
* **Start**: a point drawn uniformly among the free cells (position uniform in the cell), at
  least ``R_i + R_j +`` :data:`GAP_M` from every mover placed before it; up to
  :data:`MAX_TRIES` draws, then :class:`GenerationError`.
* **Waypoints** (``crossing``, ``patrol``, ``intercept``): ``waypoints`` points, each drawn from
  the previous one (the first from the start) at a distance ``U(MIN_LEG_M, LEG_MAX_M)`` in a
  uniform direction, kept when it is a free point joined to the previous one by a free segment;
  a patrol's last point must also have a free segment back to the start. Up to
  :data:`MAX_TRIES` draws per point; a patrol loop that cannot be closed is drawn again from
  its first point, up to :data:`MAX_LOOPS` times; then GenerationError. ``still-then-move``
  has none.
* **Size** (disc: one diameter draw; box: length and width), height and cruise speed
  ``U(speed_min, speed_max)`` (capped by the behaviour's own ``speed_m_s``) are drawn per mover;
  the start yaw points at the first waypoint (none: drawn uniformly).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from navstress.errors import GenerationError
from navstress.seeding import rng
from navstress.world import shapes
from navstress.world.spec import BEHAVIOUR_PARAMS, MoverType, WorldSpec
from navstress.world.world import Mission, Mover, Obstacle

#: Clearance kept between a mover's path and any obstacle, free disc or map edge, beyond its radius (m).
MARGIN_M = 0.1
#: Least gap between two movers' start discs (m).
GAP_M = 0.2
#: Draws tried for one start point or one waypoint before giving up.
MAX_TRIES = 500
#: Shortest and longest leg between two successive points of a path (m).
MIN_LEG_M = 1.0
LEG_MAX_M = 25.0
#: Draws of a whole patrol loop before giving up.
MAX_LOOPS = 20
MAX_CELL_M = 0.2
MAX_RASTER_CELLS = 4_000_000


class _Clearance:
    """The clearance raster of a world's static part (see the module docstring)."""

    def __init__(self, size_m: tuple[float, float], obstacles: tuple[Obstacle, ...], mission: Mission) -> None:
        sx, sy = size_m
        r = max(MAX_CELL_M, math.sqrt(sx * sy / MAX_RASTER_CELLS))
        nx, ny = max(1, math.ceil(sx / r)), max(1, math.ceil(sy / r))
        self.rx, self.ry, self.nx, self.ny = sx / nx, sy / ny, nx, ny
        occ = np.zeros((ny + 2, nx + 2), bool)  # a ring of marked cells: the map's edge
        occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
        for o in obstacles:
            if not shapes.is_axis_box(o):  # a turned box, a cylinder: the cells its footprint touches
                shapes.mark(occ[1:-1, 1:-1], self.rx, self.ry, o, True)
                continue
            c = o.corners()
            a0, a1 = int(math.floor(c[:, 0].min() / self.rx)), int(math.floor(c[:, 0].max() / self.rx))
            b0, b1 = int(math.floor(c[:, 1].min() / self.ry)), int(math.floor(c[:, 1].max() / self.ry))
            occ[max(b0, -1) + 1:min(b1, ny) + 2, max(a0, -1) + 1:min(a1, nx) + 2] = True
        xs = (np.arange(nx) + 0.5) * self.rx
        ys = (np.arange(ny) + 0.5) * self.ry
        half = 0.5 * math.hypot(self.rx, self.ry)
        for cx, cy in ((mission.start[0], mission.start[1]), mission.goal):
            d2 = (xs[None, :] - cx) ** 2 + (ys[:, None] - cy) ** 2
            occ[1:-1, 1:-1] |= d2 <= (mission.free_radius_m + half) ** 2
        from scipy import ndimage  # here: 0.3-0.5 s to import (descriptors.py)

        edt = ndimage.distance_transform_edt(~occ, sampling=(self.ry, self.rx))[1:-1, 1:-1]
        self.clear = edt - math.hypot(self.rx, self.ry)

    def free_cells(self, radius: float) -> np.ndarray:
        """Flat indices of the cells free for a mover of ``radius``."""
        out: np.ndarray = np.flatnonzero(self.clear.ravel() >= radius + MARGIN_M)
        return out

    def point(self, cells: np.ndarray, gen: np.random.Generator) -> tuple[float, float]:
        """A point uniform in a cell drawn uniformly from ``cells``."""
        k = int(cells[gen.integers(0, cells.size)])
        u = gen.random(2)
        return (float((k % self.nx + u[0]) * self.rx), float((k // self.nx + u[1]) * self.ry))

    def point_free(self, p: tuple[float, float], radius: float) -> bool:
        a, b = int(math.floor(p[0] / self.rx)), int(math.floor(p[1] / self.ry))
        return 0 <= a < self.nx and 0 <= b < self.ny and bool(self.clear[b, a] >= radius + MARGIN_M)

    def segment_free(self, a: tuple[float, float], b: tuple[float, float], radius: float) -> bool:
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = int(math.ceil(length / (0.5 * min(self.rx, self.ry)))) + 1
        t = np.linspace(0.0, 1.0, n)
        ia = np.clip(((a[0] + t * (b[0] - a[0])) / self.rx).astype(np.int64), 0, self.nx - 1)
        ib = np.clip(((a[1] + t * (b[1] - a[1])) / self.ry).astype(np.int64), 0, self.ny - 1)
        return bool(np.all(self.clear[ib, ia] >= radius + MARGIN_M))


class _Which(NamedTuple):
    """The mover being placed (for the error): the 0-based ``position`` among ``total`` of type ``kind``."""

    kind: str
    position: int
    total: int
    mover_type: MoverType


def _fail(which: _Which, what: str) -> GenerationError:
    return GenerationError(
        f"movers: could not place {what} of mover {which.position + 1} of {which.total} of type '{which.kind}' (radius "
        f"up to {which.mover_type.radius_m:.3g} m) in {MAX_TRIES} draws: no room left clear of obstacles, the start and "
        "goal free discs and the other movers; lower movers.count, the obstruction or the waypoints, or use a larger "
        "map")


def _path(ras: _Clearance, gen: np.random.Generator, start: tuple[float, float], count: int, loop: bool,
          radius: float, which: _Which) -> list[tuple[float, float]]:
    """``count`` waypoints from ``start`` (see the module docstring); a closed loop when ``loop``."""
    for _ in range(MAX_LOOPS if loop else 1):
        path: list[tuple[float, float]] = []
        prev = start
        for k in range(count):
            last = loop and k == count - 1
            for _ in range(MAX_TRIES):
                u = gen.random(2)
                leg = MIN_LEG_M + u[0] * (LEG_MAX_M - MIN_LEG_M)
                a = 2 * math.pi * float(u[1])
                q = (prev[0] + float(leg) * math.cos(a), prev[1] + float(leg) * math.sin(a))
                if (ras.point_free(q, radius) and ras.segment_free(prev, q, radius)
                        and (not last or (math.hypot(q[0] - start[0], q[1] - start[1]) >= MIN_LEG_M
                                          and ras.segment_free(q, start, radius)))):
                    path.append(q)
                    prev = q
                    break
            else:
                if last:
                    break  # draw the loop again
                raise _fail(which, f"waypoint {k + 1}")
        else:
            return path
    raise _fail(which, f"a closed patrol loop ({count} waypoints, {MAX_LOOPS} loops drawn)")


def place_movers(spec: WorldSpec, mission: Mission, obstacles: tuple[Obstacle, ...], seed: int) -> tuple[Mover, ...]:
    """The movers of ``spec`` for map seed ``seed`` (see the module docstring); () without movers."""
    counts = {k: n for k, n in spec.movers.counts(spec.size_m).items() if n > 0}
    if not counts:
        return ()
    types = spec.movers.all_types()
    ras = _Clearance(spec.size_m, obstacles, mission)
    placed: list[Mover] = []
    for kind, n in counts.items():
        t = types[kind]
        b = spec.movers.behaviour_of(kind)
        gen = rng(seed, "movers", kind)
        radius_max = t.radius_m
        cells = ras.free_cells(radius_max)
        if cells.size == 0:
            raise _fail(_Which(kind, 0, n, t), "the start")
        v = t.variability
        speed_max = b.speed_m_s if b.speed_m_s is not None else t.speed_max_m_s
        accel = b.accel_m_s2 if b.accel_m_s2 is not None else t.accel_m_s2
        params = tuple(sorted((p, getattr(b, p) if p == "aim" else float(getattr(b, p)))
                              for p in BEHAVIOUR_PARAMS[b.kind] if p not in ("speed_m_s", "accel_m_s2")))
        for i in range(n):
            length = float(gen.uniform(t.length_m * (1 - v), t.length_m * (1 + v)))
            width = length if t.shape == "disc" else float(gen.uniform(t.width_m * (1 - v), t.width_m * (1 + v)))
            height = float(gen.uniform(t.height_m * (1 - v), t.height_m * (1 + v)))
            cruise = min(float(gen.uniform(t.speed_min_m_s, t.speed_max_m_s)), speed_max)
            start = None
            for _ in range(MAX_TRIES):
                p = ras.point(cells, gen)
                if all(math.hypot(p[0] - m.start[0], p[1] - m.start[1]) >= radius_max + m.radius_m + GAP_M
                       for m in placed):
                    start = p
                    break
            if start is None:
                raise _fail(_Which(kind, i, n, t), "the start")
            path: list[tuple[float, float]] = []
            if b.kind in ("crossing", "patrol", "intercept"):
                path = _path(ras, gen, start, b.waypoints, b.kind == "patrol", radius_max, _Which(kind, i, n, t))
                yaw = math.atan2(path[0][1] - start[1], path[0][0] - start[0])
            else:
                yaw = float(gen.uniform(-math.pi, math.pi))
            placed.append(Mover(id=len(placed), kind=kind, shape=t.shape, size=(length, width, height),
                                start=(start[0], start[1], yaw), speed_m_s=cruise, speed_max_m_s=float(speed_max),
                                accel_m_s2=float(accel), behaviour=b.kind, params=params, waypoints=tuple(path)))
    return tuple(placed)


def mover_descriptors(spec: WorldSpec, movers: tuple[Mover, ...]) -> dict[str, object]:
    """The movers' descriptors: ``n_movers`` {type: count}, ``movers_total`` and
    ``mover_density_per_ha`` (movers per hectare of the map)."""
    by_kind: dict[str, int] = {k: 0 for k in spec.movers.counts(spec.size_m)}
    for m in movers:
        by_kind[m.kind] = by_kind.get(m.kind, 0) + 1
    ha = spec.size_m[0] * spec.size_m[1] / 10_000.0
    return {"n_movers": dict(sorted(by_kind.items())), "movers_total": len(movers),
            "mover_density_per_ha": len(movers) / ha}
