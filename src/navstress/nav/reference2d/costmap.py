"""The costmap of ``reference-2d-v1``: Nav2's obstacle layer (scans raytraced into an occupancy
grid: every beam clears the cells it crosses, its return marks its cell) and inflation layer
(costs decaying from each obstacle by the believed footprint), on one grid covering the
mission (the start-goal box plus a margin, cut to the mission area). Each scan updates the
cells within ``raytrace_max_range_m`` of its sensor, and the costs of that window only: the
update window rolls with the robot, the grid stays put.

    >>> import numpy as np
    >>> from navstress.robot import profile
    >>> from navstress.nav.reference2d.config import Reference2dConfig
    >>> cm = Costmap.covering([(0.0, 0.0), (4.0, 0.0)], Reference2dConfig(map_margin_m=2.0), profile("jackal"))
    >>> cm.occ.shape
    (40, 80)
    >>> cm.mark_points(np.array([[2.0, 0.05]]))
    >>> int(cm.cost_xy(2.0, 0.05)), int(cm.cost_xy(2.0, 0.25)) == 253, int(cm.cost_xy(2.0, 1.5))  # far from it: never seen
    (254, True, 255)
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from navstress.errors import NavigatorError
from navstress.nav.reference2d import kernels as K
from navstress.nav.reference2d.config import Reference2dConfig
from navstress.robot import RobotSpec

__all__ = ["MAX_CELLS", "Costmap", "footprint_radii"]

#: The most cells a costmap may hold (a 400 m x 400 m mission area at 0.1 m: 16 M).
MAX_CELLS = 16_000_000


def footprint_radii(robot: RobotSpec, padding_m: float) -> tuple[float, float, np.ndarray]:
    """(inscribed radius, circumscribed radius, outline points (n, 2)) of the believed footprint
    grown by ``padding_m``: the inscribed circle is the largest centred one inside the polygon,
    the outline samples its edges every 5 cm (body frame)."""
    pts = robot.footprint_points()
    nxt = np.roll(pts, -1, axis=0)
    edge = nxt - pts
    length = np.hypot(edge[:, 0], edge[:, 1])
    # distance from the origin to each edge's line (the polygon is star-shaped about its centre)
    inscribed = float(np.min(np.abs(pts[:, 0] * nxt[:, 1] - pts[:, 1] * nxt[:, 0]) / np.maximum(length, 1e-12)))
    norm = np.hypot(pts[:, 0], pts[:, 1])
    grown = pts * ((norm + padding_m) / np.maximum(norm, 1e-12))[:, None]
    gnext = np.roll(grown, -1, axis=0)
    outline = []
    for a, b in zip(grown, gnext):
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / 0.05)))
        t = np.arange(n)[:, None] / n
        outline.append(a + t * (b - a))
    return inscribed + padding_m, float(norm.max()) + padding_m, np.vstack(outline)


class Costmap:
    """Occupancy (``occ``: -1 unknown, 0 free, 1 occupied) and costs (``cost``, uint8 as in
    :mod:`~navstress.nav.reference2d.kernels`) on a grid of ``cell`` meters whose cell [0, 0]
    has its corner at ``origin``."""

    def __init__(self, origin: tuple[float, float], shape: tuple[int, int], config: Reference2dConfig,
                 robot: RobotSpec) -> None:
        if shape[0] * shape[1] > MAX_CELLS:
            raise NavigatorError(f"the mission needs a costmap of {shape[0]} x {shape[1]} cells, more than "
                                 f"{MAX_CELLS:,}: raise cell_m or lower map_margin_m")
        self.config = config
        self.cell = config.cell_m
        self.origin = (float(origin[0]), float(origin[1]))
        self.occ = np.full(shape, K.UNKNOWN, np.int8)
        self.cost = np.full(shape, K.NO_INFORMATION, np.uint8)
        self.inscribed_m, self.circumscribed_m, self.outline = footprint_radii(robot, config.footprint_padding_m)
        self.radius_m = max(config.inflation_radius_m, self.circumscribed_m + self.cell)
        self.kdi, self.kdj, self.kcost = K.inflation_kernel(self.cell, self.inscribed_m, self.radius_m,
                                                            config.cost_scaling_factor)
        self.kr = int(math.ceil(self.radius_m / self.cell))
        d = max(self.circumscribed_m - self.inscribed_m, 0.0)
        #: the cost at the circumscribed radius: at or above it an obstacle may touch the footprint
        self.circ_cost = int(math.floor(252.0 * math.exp(-config.cost_scaling_factor * d))) if d > 0 else 253

    @classmethod
    def covering(cls, points: Sequence[tuple[float, float]], config: Reference2dConfig, robot: RobotSpec,
                 bounds: tuple[float, float, float, float] | None = None) -> "Costmap":
        """The grid covering ``points`` plus ``map_margin_m`` on every side, cut to ``bounds``
        (grown by one meter) when given."""
        p = np.asarray(points, np.float64)
        m = config.map_margin_m
        lo, hi = p.min(axis=0) - m, p.max(axis=0) + m
        if bounds is not None:
            lo = np.maximum(lo, np.minimum(np.array(bounds[:2]) - 1.0, p.min(axis=0) - 1.0))
            hi = np.minimum(hi, np.maximum(np.array(bounds[2:]) + 1.0, p.max(axis=0) + 1.0))
        c = config.cell_m
        nx, ny = int(math.ceil((hi[0] - lo[0]) / c)), int(math.ceil((hi[1] - lo[1]) / c))
        return cls((float(lo[0]), float(lo[1])), (ny, nx), config, robot)

    # ----------------------------------------------------------------- coordinates
    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, column) of the cell holding (x, y) (possibly outside the grid)."""
        return (int(math.floor((y - self.origin[1]) / self.cell)), int(math.floor((x - self.origin[0]) / self.cell)))

    def centre(self, cells: np.ndarray) -> np.ndarray:
        """(n, 2) rows/columns -> (n, 2) x, y of the cells' centres."""
        c = self.cell
        return np.column_stack([self.origin[0] + (cells[:, 1] + 0.5) * c, self.origin[1] + (cells[:, 0] + 0.5) * c])

    def cost_xy(self, x: float, y: float) -> int:
        """The cost at (x, y) (NO_INFORMATION outside the grid)."""
        i, j = self.cell_of(x, y)
        if 0 <= i < self.cost.shape[0] and 0 <= j < self.cost.shape[1]:
            return int(self.cost[i, j])
        return K.NO_INFORMATION

    # ----------------------------------------------------------------- updates
    @property
    def grid(self) -> K.Grid:
        """Where the grid lies (the kernels' :class:`~navstress.nav.reference2d.kernels.Grid`)."""
        return K.Grid(float(self.origin[0]), float(self.origin[1]), float(self.cell))

    @property
    def footprint(self) -> K.Footprint:
        """The footprint check's data (the kernels' :class:`~navstress.nav.reference2d.kernels.Footprint`)."""
        return K.Footprint(int(self.circ_cost), self.outline)

    @property
    def inflation(self) -> K.Inflation:
        """The inflation kernel (the kernels' :class:`~navstress.nav.reference2d.kernels.Inflation`)."""
        return K.Inflation(self.kdi, self.kdj, self.kcost, int(self.kr))

    def integrate(self, origins: np.ndarray, ends: np.ndarray, mark: np.ndarray) -> None:
        """Raytrace beams from ``origins`` (n, 2) to ``ends`` (n, 2) (map x, y), marking the end
        cells where ``mark``; then recompute the costs around them."""
        if len(ends) == 0:
            return
        K.integrate_scan(self.occ, self.grid, np.ascontiguousarray(origins[:, 0]), np.ascontiguousarray(origins[:, 1]),
                         np.ascontiguousarray(ends[:, 0]), np.ascontiguousarray(ends[:, 1]), mark.astype(np.bool_))
        allp = np.vstack([origins, ends])
        self.update_costs(allp.min(axis=0), allp.max(axis=0))

    def mark_points(self, xy: np.ndarray) -> None:
        """Mark the cells of points (n, 2) occupied (no clearing) and update the costs: for tests."""
        for x, y in xy:
            i, j = self.cell_of(float(x), float(y))
            if 0 <= i < self.occ.shape[0] and 0 <= j < self.occ.shape[1]:
                self.occ[i, j] = K.OCCUPIED
        self.update_costs(xy.min(axis=0), xy.max(axis=0))

    def update_costs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Recompute the costs of the cells within the inflation radius of the box [lo, hi]."""
        i0, j0 = self.cell_of(float(lo[0]), float(lo[1]))
        i1, j1 = self.cell_of(float(hi[0]), float(hi[1]))
        r = self.kr + 1
        K.inflate_window(self.occ, self.cost, (i0 - r, i1 + r + 1, j0 - r, j1 + r + 1), self.inflation)

    def clear_beyond(self, x: float, y: float, keep_m: float) -> None:
        """Forget (set unknown) every cell whose centre is farther than ``keep_m`` from (x, y);
        recompute every cost (the clear-costmap recovery)."""
        ny, nx = self.occ.shape
        cx = self.origin[0] + (np.arange(nx) + 0.5) * self.cell
        cy = self.origin[1] + (np.arange(ny) + 0.5) * self.cell
        far = (cy[:, None] - y) ** 2 + (cx[None, :] - x) ** 2 > keep_m**2
        self.occ[far] = K.UNKNOWN
        K.inflate_window(self.occ, self.cost, (0, ny, 0, nx), self.inflation)
