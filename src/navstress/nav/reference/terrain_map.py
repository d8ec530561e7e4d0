"""DTM: an elevation grid in the perceived (map) frame built from lidar points.

Cell ``[i, j]`` covers ``x in [ox + j*c, ox + (j+1)*c)``, ``y in [oy + i*c, oy + (i+1)*c)``
(rows along +y, ``(ox, oy)`` the corner of cell ``[0, 0]``), the layout of the run traces.
Each cell keeps min, max and sum of z and a hit count; a cell with no hit is unknown (NaN in
:meth:`TerrainMap.elevation`).

A cell is an **obstacle** when its max z rises above the lowest min z of its known 3x3
neighbourhood by more than ``step_threshold = obstacle_height + tan(max_slope) * 2*sqrt(2)*c``:
the second term is the rise a traversable slope can produce across two cells diagonally, so that
slopes up to ``max_slope`` are never taken for obstacles (the price: on flat ground a step must be
that much taller to be flagged; lower steps are caught by the planner's roughness cost).

**Fine obstacle layer.** Besides the coarse statistics, every point also raises the max z of
its cell in a grid ``obstacle_subcells`` times finer (0.1 m with the defaults), and each coarse
cell remembers the last scan that hit it. A fine cell is an obstacle when the *last scan that hit
its coarse cell* also hit the fine cell, with a max z above the coarse ground estimate (the
lowest known min z of the coarse 3x3 neighbourhood) by more than the same ``step_threshold``.
So fine obstacle cells lie only inside coarse obstacle cells, and they locate an obstacle's face
to within a fine cell plus the error of one scan's pose, instead of the union of every scan's
pose error (the accumulated max smeared faces by 0.1-0.2 m while turning, with POM errors of
5-10 cm). Approximation: a cell whose latest scan saw only its ground part (the obstacle part
hidden from that view) counts as free at the fine level; with static obstacles and a 360 deg
lidar this happens only at grazing views. The planner checks footprints against this layer; the
coarse map stays for slope, roughness and unknown ground.

Points are placed with the pose estimate at the scan's time (sensor -> robot via the mount ->
map via the pose, roll and pitch included). Integration is a compiled loop (numba).
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import cgutils
from numba.extending import intrinsic

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress._records import full_record
from navstress.nav.reference.pose import Pose

__all__ = ["MAP_CONSTANTS", "SCAN_POINT", "TerrainMap", "new_map_constants", "step_threshold"]

#: The constants of a :class:`TerrainMap` that its kernels read (:func:`_integrate`,
#: :func:`_fill_unknown`): a record (numpy structured dtype, one field a line);
#: :func:`new_map_constants` demands every field.
MAP_CONSTANTS = np.dtype([
    ("ox", np.float64), ("oy", np.float64),  # corner of cell [0, 0] (TerrainMap.origin)
    ("cell", np.float64),  # cell side (m)
    ("sub", np.int64),  # fine obstacle cells per cell side
    ("step", np.float64),  # obstacle step threshold (m)
    ("max_range2", np.float64),  # squared range beyond which lidar points are dropped (m^2)
], align=True)
MAP_CONSTANTS_FIELDS: frozenset[str] = frozenset(MAP_CONSTANTS.names or ())


def new_map_constants(**values: float) -> np.ndarray:
    """A one-record :data:`MAP_CONSTANTS` array; every field must be given."""
    return full_record(MAP_CONSTANTS, "MAP_CONSTANTS", values)


#: What :func:`_integrate`'s first pass keeps per point (a record; its scratch is an array of them,
#: at least as long as the scan).
SCAN_POINT = np.dtype([
    ("cell", np.int64),  # the point's coarse cell, flat (i * columns + j)
    ("z", np.float64),  # its z in the map frame
    ("sub", np.int64),  # its fine sub-cell in that cell (u * sub + v)
])


def step_threshold(obstacle_height_m: float, max_slope_deg: float, cell_m: float) -> float:
    """Height step above the neighbourhood ground that marks a cell as an obstacle (module doc)."""
    return obstacle_height_m + math.tan(math.radians(max_slope_deg)) * 2.0 * math.sqrt(2.0) * cell_m


@intrinsic
def _prefetch(typingctx: Any, arr: Any, idx: Any) -> Any:
    """Prefetch (for writing) the element ``idx`` of the 1-D array ``arr`` into the caches
    (``llvm.prefetch``; a hint: no effect on results)."""
    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        i8p = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [i8p, ir.IntType(32), ir.IntType(32), ir.IntType(32)])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0i8")  # type: ignore[no-untyped-call]
        i32 = ir.IntType(32)
        builder.call(fn, [builder.bitcast(builder.gep(ary.data, [args[1]]), i8p), ir.Constant(i32, 1),
                          ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()
    return nb.types.void(arr, nb.types.intp), codegen


_AHEAD = 32  # points between a record's prefetch and its update (measured: 8 too few, 16-64 alike)


@nb.njit(cache=True)
def _integrate(points: np.ndarray, rot: np.ndarray, trans: np.ndarray, consts: np.ndarray, stats: np.ndarray,
               fine: np.ndarray, scan: int, buf: np.ndarray) -> int:
    """Bin one scan (points in the sensor frame, placed by ``rot @ p + trans``; the map's
    :data:`MAP_CONSTANTS` in ``consts``): per coarse cell min/max/sum/count (``stats[i, j]``, one
    cache line), and the fine max z of this scan per sub-cell (``fine[i, j, :sub*sub]``), reset
    when the scan (number ``scan``) is the first to hit the cell since the last one
    (``fine[i, j, sub*sub]`` keeps that scan's number).

    Two passes: the points' cells, z and sub-cells into ``buf`` (:data:`SCAN_POINT` records), then the record updates in
    point order with the records ``_AHEAD`` points ahead prefetched (the map is far larger than
    the caches: the updates waited on memory)."""
    mc = consts[0]
    ox, oy, cell, sub, max_range2 = mc.ox, mc.oy, mc.cell, mc.sub, mc.max_range2
    nr = stats.shape[0]
    nc = stats.shape[1]
    inv = 1.0 / cell
    finv = sub * inv
    nsub = sub * sub
    fscan = np.float32(scan)
    n = 0
    for k in range(points.shape[0]):
        px = np.float64(points[k, 0])
        py = np.float64(points[k, 1])
        pz = np.float64(points[k, 2])
        if not (px * px + py * py + pz * pz <= max_range2):  # also drops NaN
            continue
        x = rot[0, 0] * px + rot[0, 1] * py + rot[0, 2] * pz + trans[0]
        y = rot[1, 0] * px + rot[1, 1] * py + rot[1, 2] * pz + trans[1]
        fj = (x - ox) * inv
        fi = (y - oy) * inv
        if not (fi >= 0.0 and fj >= 0.0 and fi < nr and fj < nc):
            continue
        i = int(fi)
        j = int(fj)
        # the sub-cell, kept inside coarse cell (i, j) whatever the rounding
        u = min(max(int((y - oy) * finv) - i * sub, 0), sub - 1)
        v = min(max(int((x - ox) * finv) - j * sub, 0), sub - 1)
        pt = buf[n]
        pt.cell = i * nc + j
        pt.z = rot[2, 0] * px + rot[2, 1] * py + rot[2, 2] * pz + trans[2]
        pt.sub = u * sub + v
        n += 1
    sf = stats.reshape(-1)
    ff = fine.reshape(-1)
    fstride = fine.shape[2]
    for k in range(n):
        if k + _AHEAD < n:
            ahead = buf[k + _AHEAD]
            ca = ahead.cell
            _prefetch(sf, 4 * ca)  # type: ignore[call-arg]
            _prefetch(ff, ca * fstride + ahead.sub)
            _prefetch(ff, ca * fstride + nsub)
        pt = buf[k]
        c = pt.cell
        z = pt.z
        b = 4 * c
        sf[b] = min(sf[b], z)  # unknown cells hold +inf / -inf: no branch on the count
        sf[b + 1] = max(sf[b + 1], z)
        sf[b + 2] += z
        sf[b + 3] += 1.0
        fb = c * fstride
        if ff[fb + nsub] != fscan:
            ff[fb + nsub] = fscan
            for q in range(nsub):
                ff[fb + q] = -np.inf
        q = fb + pt.sub
        ff[q] = max(ff[q], np.float32(z))
    return n


@nb.njit(cache=True, inline="always")
def cell_is_obstacle(zmin: np.ndarray, zmax: np.ndarray, count: np.ndarray, i: int, j: int,
                     step: float) -> bool:
    """True if known cell (i, j) rises more than ``step`` above its known 3x3 neighbourhood's min."""
    nr, nc = zmin.shape
    ground = zmin[i, j]
    for a in range(max(0, i - 1), min(nr, i + 2)):
        for b in range(max(0, j - 1), min(nc, j + 2)):
            if count[a, b] > 0 and zmin[a, b] < ground:
                ground = zmin[a, b]
    return bool(zmax[i, j] - ground > step)


@nb.njit(cache=True)
def _obstacle_grid(zmin: np.ndarray, zmax: np.ndarray, count: np.ndarray, step: float) -> np.ndarray:
    nr, nc = zmin.shape
    out = np.zeros((nr, nc), dtype=np.bool_)
    for i in range(nr):
        for j in range(nc):
            if count[i, j] > 0:
                out[i, j] = cell_is_obstacle(zmin, zmax, count, i, j, step)
    return out


@nb.njit(cache=True, inline="always")
def cell_ground(zmin: np.ndarray, count: np.ndarray, i: int, j: int) -> float:
    """Lowest known min z of the 3x3 neighbourhood of (i, j) (inf if none is known)."""
    nr, nc = zmin.shape
    ground = math.inf
    for a in range(max(0, i - 1), min(nr, i + 2)):
        for b in range(max(0, j - 1), min(nc, j + 2)):
            if count[a, b] > 0 and zmin[a, b] < ground:
                ground = zmin[a, b]
    return ground


@nb.njit(cache=True)
def _fine_obstacle_grid(zmin: np.ndarray, count: np.ndarray, fine: np.ndarray, sub: int,
                        step: float) -> np.ndarray:
    nr, nc = zmin.shape
    out = np.zeros((nr * sub, nc * sub), dtype=np.bool_)
    for i in range(nr):
        for j in range(nc):
            if count[i, j] == 0:
                continue
            g = cell_ground(zmin, count, i, j)
            for u in range(sub):
                for v in range(sub):
                    out[i * sub + u, j * sub + v] = fine[i, j, u * sub + v] - g > step
    return out


@nb.njit(cache=True)
def _fill_unknown(cells_i: np.ndarray, cells_j: np.ndarray, consts: np.ndarray, stats: np.ndarray, cx: float,
                  cy: float, radius_cells: int, fallback_z: float) -> int:
    """Give never-seen cells (cells_i/j) of the map (``stats``, its :data:`MAP_CONSTANTS`
    ``consts``) the height of a plane fitted to the known, non-obstacle cells within
    ``radius_cells`` of (cx, cy); ``fallback_z`` if fewer than 6."""
    mc = consts[0]
    ox, oy, cell, step = mc.ox, mc.oy, mc.cell, mc.step
    zmin, zmax, zsum, count = stats[:, :, 0], stats[:, :, 1], stats[:, :, 2], stats[:, :, 3]
    n = cells_i.shape[0]
    nr, nc = zmin.shape
    unknown = False
    for k in range(n):  # nothing to fill: skip the plane fit (the common case once moving)
        if count[cells_i[k], cells_j[k]] == 0:
            unknown = True
            break
    if not unknown:
        return 0
    ci = int((cy - oy) / cell)
    cj = int((cx - ox) / cell)
    # least squares z = a + b dx + c dy on cell centres (centred on cx, cy)
    sw = 0.0
    sx = 0.0
    sy = 0.0
    sz = 0.0
    sxx = 0.0
    sxy = 0.0
    syy = 0.0
    sxz = 0.0
    syz = 0.0
    for a in range(max(0, ci - radius_cells), min(nr, ci + radius_cells + 1)):
        for b in range(max(0, cj - radius_cells), min(nc, cj + radius_cells + 1)):
            if count[a, b] == 0 or (a - ci) ** 2 + (b - cj) ** 2 > radius_cells ** 2:
                continue
            if cell_is_obstacle(zmin, zmax, count, a, b, step):
                continue
            dx = ox + (b + 0.5) * cell - cx
            dy = oy + (a + 0.5) * cell - cy
            z = zsum[a, b] / count[a, b]
            sw += 1.0
            sx += dx
            sy += dy
            sz += z
            sxx += dx * dx
            sxy += dx * dy
            syy += dy * dy
            sxz += dx * z
            syz += dy * z
    za = fallback_z
    gb = 0.0
    gc = 0.0
    if sw >= 6.0:
        mx = sx / sw
        my = sy / sw
        mz = sz / sw
        cxx = sxx / sw - mx * mx
        cxy = sxy / sw - mx * my
        cyy = syy / sw - my * my
        cxz = sxz / sw - mx * mz
        cyz = syz / sw - my * mz
        det = cxx * cyy - cxy * cxy
        if det > 1e-9:
            gb = (cxz * cyy - cyz * cxy) / det
            gc = (cyz * cxx - cxz * cxy) / det
        za = mz - gb * mx - gc * my
    filled = 0
    for k in range(n):
        a = cells_i[k]
        b = cells_j[k]
        if count[a, b] > 0:
            continue
        dx = ox + (b + 0.5) * cell - cx
        dy = oy + (a + 0.5) * cell - cy
        z = za + gb * dx + gc * dy
        zmin[a, b] = z
        zmax[a, b] = z
        zsum[a, b] = z
        count[a, b] = 1
        filled += 1
    return filled


class TerrainMap:
    """Elevation grid with per-cell min/max/sum/count (see module doc).

    >>> m = TerrainMap((0.0, 0.0), (10, 20), 0.5)
    >>> m.cell_of(1.2, 3.1)
    (6, 2)
    >>> bool(np.isnan(m.elevation()).all())
    True
    """

    def __init__(self, origin_xy: tuple[float, float], shape: tuple[int, int], cell_m: float,
                 step_m: float = 0.5, max_range_m: float = 40.0, obstacle_subcells: int = 3) -> None:
        if shape[0] < 1 or shape[1] < 1 or not cell_m > 0:
            raise ValueError(f"bad map geometry: shape={shape}, cell_m={cell_m}")
        if not 1 <= obstacle_subcells <= 10:
            raise ValueError(f"obstacle_subcells={obstacle_subcells} must be in [1, 10]")
        self.origin = (float(origin_xy[0]), float(origin_xy[1]))
        self.cell_m = float(cell_m)
        self.step_m = float(step_m)
        self.max_range_m = float(max_range_m)
        #: per cell [min z, max z, sum z, hit count] (+inf, -inf, 0, 0 when unknown); zmin, zmax,
        #: zsum and count are views of it
        self.stats = np.zeros((*shape, 4), dtype=np.float64)
        self.stats[:, :, 0] = np.inf
        self.stats[:, :, 1] = -np.inf
        self.sub = int(obstacle_subcells)
        #: fine layer, per coarse cell: the max z per sub-cell (row-major, sub x sub) of the latest
        #: scan that hit the cell (-inf: that scan did not hit the sub-cell), then that scan's
        #: number (float32: exact up to 2**24 scans, 19 days at 10 Hz)
        self.fine = np.full((*shape, self.sub * self.sub + 1), -np.inf, dtype=np.float32)
        self.fine[:, :, -1] = 0.0
        self.scans = 0
        #: what the kernels read (the geometry is fixed at construction)
        self._consts = new_map_constants(ox=self.origin[0], oy=self.origin[1], cell=self.cell_m, sub=self.sub,
                                         step=self.step_m, max_range2=self.max_range_m ** 2)
        # per-point scratch of integrate (grown to the largest scan)
        self._scan_points = np.empty(0, dtype=SCAN_POINT)

    @property
    def constants(self) -> np.ndarray:
        """The one-record :data:`MAP_CONSTANTS` array of this map (what its kernels read)."""
        return self._consts

    @property
    def zmin(self) -> np.ndarray:
        """Lowest z hit per cell (view; +inf where unknown)."""
        return self.stats[:, :, 0]

    @property
    def zmax(self) -> np.ndarray:
        """Highest z hit per cell (view; -inf where unknown)."""
        return self.stats[:, :, 1]

    @property
    def zsum(self) -> np.ndarray:
        """Sum of the z of the hits per cell (view)."""
        return self.stats[:, :, 2]

    @property
    def count(self) -> np.ndarray:
        """Hits per cell (view, float64; 0 = unknown)."""
        return self.stats[:, :, 3]

    @property
    def fine_cell_m(self) -> float:
        """Side of a fine obstacle-layer cell (``cell_m / obstacle_subcells``)."""
        return self.cell_m / self.sub

    @classmethod
    def covering(cls, points_xy: list[tuple[float, float]], margin_m: float, cell_m: float,
                 step_m: float, max_range_m: float, obstacle_subcells: int = 3) -> "TerrainMap":
        """A map covering the bounding box of ``points_xy`` plus ``margin_m`` on every side."""
        xs = [p[0] for p in points_xy]
        ys = [p[1] for p in points_xy]
        ox, oy = min(xs) - margin_m, min(ys) - margin_m
        nc = int(math.ceil((max(xs) + margin_m - ox) / cell_m))
        nr = int(math.ceil((max(ys) + margin_m - oy) / cell_m))
        return cls((ox, oy), (nr, nc), cell_m, step_m, max_range_m, obstacle_subcells)

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.stats.shape[0]), int(self.stats.shape[1]))

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row i, col j) of the cell holding (x, y); may be outside the grid."""
        return (int(math.floor((y - self.origin[1]) / self.cell_m)),
                int(math.floor((x - self.origin[0]) / self.cell_m)))

    def cell_center(self, i: int, j: int) -> tuple[float, float]:
        return (self.origin[0] + (j + 0.5) * self.cell_m, self.origin[1] + (i + 0.5) * self.cell_m)

    def integrate(self, points: np.ndarray, mount: tuple[float, float, float], pose: Pose) -> int:
        """Add a scan's sensor-frame points placed with ``pose``; returns how many landed in the grid."""
        pts = np.asarray(points)
        if pts.ndim != 2 or pts.shape[0] == 0:
            return 0
        if pts.shape[1] != 3:
            raise ValueError(f"lidar points must be (N, 3), got {pts.shape}")
        if pts.dtype != np.float32 and pts.dtype != np.float64:
            pts = pts.astype(np.float64)
        rot, trans = pose.sensor_transform(mount)
        self.scans += 1
        if len(self._scan_points) < len(pts):
            self._scan_points = np.empty(len(pts), dtype=SCAN_POINT)
        return int(_integrate(np.ascontiguousarray(pts), rot, trans, self._consts, self.stats, self.fine, self.scans,
                              self._scan_points))

    def known(self) -> np.ndarray:
        return self.count > 0

    def elevation(self) -> np.ndarray:
        """Mean height per cell, NaN where never seen (float32, rows along +y)."""
        out = np.full(self.shape, np.nan, dtype=np.float32)
        k = self.count > 0
        out[k] = (self.zsum[k] / self.count[k]).astype(np.float32)
        return out

    def obstacles(self) -> np.ndarray:
        """Bool grid: known cells that are obstacles (module doc)."""
        return np.asarray(_obstacle_grid(self.zmin, self.zmax, self.count, self.step_m))

    def fine_obstacles(self) -> np.ndarray:
        """Bool grid of the fine layer (``obstacle_subcells`` x the coarse shape): obstacle sub-cells."""
        return np.asarray(_fine_obstacle_grid(self.zmin, self.count, self.fine, self.sub, self.step_m))

    def fill_unknown(self, cells_i: np.ndarray, cells_j: np.ndarray, center_xy: tuple[float, float],
                     radius_m: float, fallback_z: float) -> int:
        """Give the never-seen cells among ``cells`` the ground plane fitted around ``center_xy``
        (the robot stands there, so the ground under it exists). Returns cells filled."""
        return int(_fill_unknown(cells_i, cells_j, self._consts, self.stats, center_xy[0], center_xy[1],
                                 max(1, int(round(radius_m / self.cell_m))), fallback_z))
