"""Numba kernels of the lidar ray caster (internal; use :mod:`navstress.sim.lidar`).

Coordinates: x, y in *cell units* (world metres / cell_m), z in metres, ray parameter ``t``
in metres along a unit world direction (so ``dx = dir_x / cell_m``). Cell (cx, cy) spans
[cx, cx+1] x [cy, cy+1] and is split by the diagonal from vertex (cy, cx) to (cy+1, cx+1),
the triangulation MuJoCo uses for an hfield (checked against ``mujoco.mj_ray``).

The terrain is the solid {(x, y) in the map, z <= h(x, y)}: top triangles plus vertical side
walls under the map edge (extending down without a base). Faces are two-sided, as in MuJoCo.
Boxes are rows ``[x, y, yaw, hx, hy, zb, zt, cos(yaw), sin(yaw)]`` (centre, yaw, half sides,
bottom, top), also two-sided (a ray starting inside a box hits where it leaves it, as ``mj_ray`` does).

Two terrain marches, each written once: :func:`march_terrain`, one ray from any start through
the max/min mipmap (blocks the ray passes over are skipped; cell exits recomputed from the
origin), for rays that plane marching cannot take; and :func:`walk_cells`, the plain cell walk
(exits stepped incrementally) that :func:`terrain_kernel` runs for plane-marched columns. They
round differently (ranges within ~1e-12 m of each other), so neither replaces the other without
changing results. ``_march_avx512.c`` is the native twin of :func:`walk_cells` (a channel's
queue of walks at a time, the same IEEE operations: bit-identical), called through its address
(:func:`_call_native_walk`; the ``walk`` field of :data:`SCAN_PARAMS`).

Named parameters: the kernels take records, never long lists of positional values. A ray is a
:class:`Ray` (origin, direction), a box a :class:`Box`, a terrain cell a :class:`Cell`, a cell
walk's start a :class:`CellWalk` (NamedTuples of scalars: numba keeps them in registers, free);
the scene's terrain is a :class:`TerrainGrid` and the lidar's beam angles :class:`Beams` (groups
of arrays), and a scan's constants the one-record array :data:`SCAN_PARAMS` (:func:`new_scan_params`
refuses a missing or unknown field). Python calls the per-scan entries of ``_raybox`` with the
groups flattened (``*arrays``, regrouped inside, as ``_step.run_steps``): numba dispatches tuples
of arrays microseconds slower than the same arrays one by one.

Speed notes (measured, see docs/performance.md): a call to another ``@njit`` function that takes
arrays costs atomic reference-count updates per call, even when inlined by numba; the helpers
that the hot loops call per cell (:func:`_cell_hit`, :func:`_ray_box`) take scalar records only;
:func:`walk_cells` (inlined, two arrays) measured as fast as the walk written out in the loop.
Record fields that a loop reads are read into locals at a kernel's top.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress._records import full_record

INF = np.inf


class Ray(NamedTuple):
    """A ray ``o + t d``: origin and direction (in the caller's units: x, y in cell units for the
    terrain tests, metres for the boxes; z always in metres)."""

    ox: float
    oy: float
    oz: float
    dx: float
    dy: float
    dz: float


class Box(NamedTuple):
    """An upright box: centre (x, y), yaw as cos/sin, half sides, bottom and top z (metres)."""

    x: float
    y: float
    cos_yaw: float
    sin_yaw: float
    hx: float
    hy: float
    zb: float
    zt: float


class Cell(NamedTuple):
    """Terrain cell (cx, cy) and its corner heights h00 = h[cy, cx], h10 = h[cy, cx+1],
    h01 = h[cy+1, cx], h11 = h[cy+1, cx+1]."""

    cx: int
    cy: int
    h00: float
    h10: float
    h01: float
    h11: float


class CellWalk(NamedTuple):
    """Where one ray's plain cell walk (:func:`walk_cells`) starts: at ``t`` in cell (cx, cy),
    leaving it at ``tmx`` in x and ``tmy`` in y, crossing a cell in ``tdx = |1/dx|``,
    ``tdy = |1/dy|``, stepping the cells by ``sx``, ``sy`` (+-1), ending at ``tend``."""

    t: float
    tmx: float
    tmy: float
    tdx: float
    tdy: float
    tend: float
    cx: int
    cy: int
    sx: int
    sy: int


class TerrainGrid(NamedTuple):
    """The terrain as the kernels read it (:class:`~navstress.sim.lidar.LidarScene`'s arrays)."""

    heights: np.ndarray  # (rows, cols) float32, row = y
    cell: float  # cell side (m)
    mip: np.ndarray  # (2, n) float64 max / min mipmap levels, flat
    mipf: np.ndarray  # (n0, 2) float32 level 0 max / min pairs (the scans' cell test)
    mip_offsets: np.ndarray  # (levels,) where each level starts in mip
    mip_widths: np.ndarray  # (levels,) blocks per row of each level
    grad_max: float  # steepest triangle (m/m)


class Beams(NamedTuple):
    """A lidar's beam angles in its own frame: channel elevations (ascending) and azimuths."""

    cos_el: np.ndarray
    sin_el: np.ndarray
    cos_az: np.ndarray
    sin_az: np.ndarray


_I, _F = np.int64, np.float64
#: A scan's constants (a one-record array, see :func:`new_scan_params`).
SCAN_PARAMS = np.dtype([
    ("max_range", _F), ("min_range", _F),  # returns kept: min_range <= r <= max_range (m)
    ("plane_march", _I),  # 1: march each azimuth column's plane (0: every ray from the sensor)
    ("walk", _I),  # address of the native walk (navstress.sim.native.load), 0: walk_cells
], align=True)
SCAN_PARAMS_FIELDS: frozenset[str] = frozenset(SCAN_PARAMS.names or ())


def new_scan_params(**values: Any) -> np.ndarray:
    """A one-record :data:`SCAN_PARAMS` array; every field must be given."""
    return full_record(SCAN_PARAMS, "SCAN_PARAMS", values)


class NativeWalkArgs(NamedTuple):
    """The arguments of ``nv_march_channel`` (``_march_avx512.c``), in its order: array addresses
    as integers (heights, queue rows of doubles and of integers, results)."""

    heights: int  # const float *h
    width: int  # W: vertices per row
    ncx: int
    ncy: int
    oz: float
    oxc: float
    oyc: float
    nq: int  # queued walks
    queue: int  # const double *Q: rows t, tmx, tmy, tdx, tdy, dx, dy, dz, tend
    queue_int: int  # const int64_t *I: rows cx, cy, sx, sy
    stride: int  # qs: row stride of both queues
    result: int  # double *R


@intrinsic
def _call_native_walk(typingctx: Any, fn: Any, args: Any) -> Any:  # pragma: no cover - compile time
    """Call the native walk ``nv_march_channel`` (``_march_avx512.c``) at address ``fn`` with a
    :class:`NativeWalkArgs` (its C arguments in order, array addresses as 64-bit integers). The
    address is an argument, not a linked symbol: the compiled (and cached) kernels need nothing
    registered before they load, and the walk is built only when a lidar asks for it
    (:func:`navstress.sim.native.load`)."""
    i64, f64, ptr = ir.IntType(64), ir.DoubleType(), ir.IntType(8).as_pointer()
    kinds = (ptr, i64, i64, i64, f64, f64, f64, i64, ptr, ptr, i64, ptr)
    if getattr(args, "instance_class", None) is not NativeWalkArgs:
        return None
    for t, k in zip(args.types, kinds):
        if (k is f64) != isinstance(t, types.Float) or getattr(t, "bitwidth", 0) != 64:
            return None

    def codegen(context: Any, builder: Any, signature: Any, call_args: Any) -> Any:
        fnty = ir.FunctionType(ir.VoidType(), list(kinds))
        target = builder.inttoptr(call_args[0], fnty.as_pointer())
        values = [builder.extract_value(call_args[1], i) for i in range(len(kinds))]
        builder.call(target, [builder.inttoptr(v, ptr) if k is ptr else v for v, k in zip(values, kinds)])
        return context.get_dummy_value()

    return types.void(types.int64, args), codegen


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _tri_height(h: np.ndarray, cx: int, cy: int, u: float, v: float) -> float:
    """Height at local (u, v) in cell (cx, cy) on the MuJoCo triangulation."""
    h00 = np.float64(h[cy, cx])
    h10 = np.float64(h[cy, cx + 1])
    h01 = np.float64(h[cy + 1, cx])
    h11 = np.float64(h[cy + 1, cx + 1])
    if u >= v:
        return h00 + u * (h10 - h00) + v * (h11 - h10)
    return h00 + v * (h01 - h00) + u * (h11 - h01)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def height_at_cells(h: np.ndarray, x: float, y: float) -> float:
    """Height at (x, y) in cell units, clamped to the map."""
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    x = min(max(x, 0.0), float(ncx))
    y = min(max(y, 0.0), float(ncy))
    cx = min(int(math.floor(x)), ncx - 1)
    cy = min(int(math.floor(y)), ncy - 1)
    return _tri_height(h, cx, cy, x - cx, y - cy)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cell_hit(cell: Cell, ray: Ray, ta: float, tb: float, sgn: float) -> float:
    """First t in [ta, tb] where the ray (x, y in cell units) crosses the surface in ``cell`` from
    side ``sgn`` (+1: from above, -1: from below); inf if none. Exact: F = z - h is linear on each
    triangle. Scalar records only, so that inlining it adds no array reference counting to the
    caller's loop."""
    cx, cy, h00, h10, h01, h11 = cell
    ox, oy, oz, dx, dy, dz = ray
    ua = ox + ta * dx - cx
    va = oy + ta * dy - cy
    ub = ox + tb * dx - cx
    vb = oy + tb * dy - cy
    wa = ua - va
    wb = ub - vb
    # split at the diagonal u == v when the segment crosses it
    n = 1
    td = tb
    if (wa > 0.0 and wb < 0.0) or (wa < 0.0 and wb > 0.0):
        td = ta + (tb - ta) * (wa / (wa - wb))
        n = 2
    p0 = ta
    u0 = ua
    v0 = va
    for k in range(n):
        if n == 2 and k == 0:
            p1 = td
            u1 = ox + td * dx - cx
            v1 = oy + td * dy - cy
        else:
            p1 = tb
            u1 = ub
            v1 = vb
        if (u0 - v0) + (u1 - v1) >= 0.0:  # the piece lies in the lower triangle (u >= v)
            g0 = h00 + u0 * (h10 - h00) + v0 * (h11 - h10)
            g1 = h00 + u1 * (h10 - h00) + v1 * (h11 - h10)
        else:
            g0 = h00 + v0 * (h01 - h00) + u0 * (h11 - h01)
            g1 = h00 + v1 * (h01 - h00) + u1 * (h11 - h01)
        f0 = sgn * (oz + p0 * dz - g0)
        f1 = sgn * (oz + p1 * dz - g1)
        if f0 <= 0.0:
            return p0
        if f1 <= 0.0:
            return p0 + (p1 - p0) * (f0 / (f0 - f1))
        p0 = p1
        u0 = u1
        v0 = v1
    return INF


@njit(cache=True, nogil=True, error_model="numpy")
def march_terrain(h: np.ndarray, mip: np.ndarray, moff: np.ndarray, mnx: np.ndarray, ray: Ray, t0: float, t1: float,
                  above: bool) -> tuple[float, float]:
    """First terrain hit of the ray (x, y in cell units) in [t0, t1] over the heights ``h`` and
    their mipmap (:class:`TerrainGrid`'s ``mip``, ``mip_offsets``, ``mip_widths``): returns
    (t_hit or inf, t_clear). (The four arrays, not the grid: a call is per ray, and the grid's
    other fields measured 3-5 % slower per-ray scans on flat ground.)

    ``t_clear``: the ray is known free of terrain on [t0, t_clear) (t1, or where it leaves the
    map). ``above=True`` asserts the ray is above the surface at t0 (plane marching): a start
    at or below the surface (rounding) is then a hit at t0. ``mip[0]`` holds max-height
    mipmap levels (blocks the ray passes over are skipped), ``mip[1]`` the min heights (a block
    whose min equals its max is a flat plane: the hit is solved directly).
    """
    ox, oy, oz, dx, dy, dz = ray
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    W = float(ncx)
    H = float(ncy)
    tlo = t0
    thi = t1
    idx = 1.0 / dx if dx != 0.0 else 0.0
    idy = 1.0 / dy if dy != 0.0 else 0.0
    # clip to the map rectangle
    if dx != 0.0:
        ta = -ox * idx
        tb = (W - ox) * idx
        if ta > tb:
            ta, tb = tb, ta
        tlo = max(tlo, ta)
        thi = min(thi, tb)
    elif ox < 0.0 or ox > W:
        return INF, t1
    if dy != 0.0:
        ta = -oy * idy
        tb = (H - oy) * idy
        if ta > tb:
            ta, tb = tb, ta
        tlo = max(tlo, ta)
        thi = min(thi, tb)
    elif oy < 0.0 or oy > H:
        return INF, t1
    if tlo > thi:
        return INF, t1
    nlev = moff.shape[0]
    gtop = mip[0, moff[nlev - 1]]
    if oz + dz * (tlo if dz >= 0.0 else thi) > gtop:
        return INF, thi  # passes over the highest point of the map
    if mip[1, moff[nlev - 1]] == gtop and (above or tlo > t0 or oz + tlo * dz >= gtop):
        # a flat map, ray above it at tlo (or entering through the wall): solve z = gtop
        ts = tlo if dz >= 0.0 else max(tlo, (gtop - oz) / dz)
        return ts, ts  # ts <= thi: the ray is at or below gtop by thi (test above)
    x = ox + tlo * dx
    y = oy + tlo * dy
    sgn = 1.0
    if tlo > t0:  # entered through a side wall: the wall is solid below the edge profile
        if oz + tlo * dz - height_at_cells(h, x, y) <= 0.0:
            return tlo, tlo
    elif not above:  # (above: a start at or below the surface is caught by the first cell test)
        f = oz + tlo * dz - height_at_cells(h, x, y)
        if f == 0.0:
            return tlo, tlo
        if f < 0.0:
            sgn = -1.0
    # starting cell, resolving boundaries by the direction of travel
    if dx < 0.0:
        cx = int(math.ceil(x)) - 1
    else:
        cx = int(math.floor(x))
    if dy < 0.0:
        cy = int(math.ceil(y)) - 1
    else:
        cy = int(math.floor(y))
    cx = min(max(cx, 0), ncx - 1)
    cy = min(max(cy, 0), ncy - 1)
    lev = 0
    t = tlo
    while True:
        bx = cx >> lev
        by = cy >> lev
        if dx > 0.0:
            xb = min((bx + 1) << lev, ncx)
            tx = (xb - ox) * idx
        elif dx < 0.0:
            xb = bx << lev
            tx = (xb - ox) * idx
        else:
            tx = INF
        if dy > 0.0:
            yb = min((by + 1) << lev, ncy)
            ty = (yb - oy) * idy
        elif dy < 0.0:
            yb = by << lev
            ty = (yb - oy) * idy
        else:
            ty = INF
        te = min(tx, ty, thi)
        if sgn > 0.0:
            zmin = oz + dz * (t if dz >= 0.0 else te)
            mi = moff[lev] + by * mnx[lev] + bx
            top = mip[0, mi]
            if zmin > top:
                skip = True
            elif mip[1, mi] == top:  # flat block: the surface is the plane z = top
                ts = t if dz >= 0.0 else max(t, (top - oz) / dz)
                if ts <= te:
                    return ts, ts
                skip = False
                if lev > 0:
                    lev -= 1
                    continue
            elif lev > 0:
                lev -= 1
                continue
            else:
                skip = False
        else:
            skip = False
        if not skip:
            th = _cell_hit(Cell(cx, cy, np.float64(h[cy, cx]), np.float64(h[cy, cx + 1]), np.float64(h[cy + 1, cx]),
                                np.float64(h[cy + 1, cx + 1])), ray, t, te, sgn)
            if th <= te:
                return th, th
        if te >= thi:
            break
        # step into the next block
        if tx <= ty:
            cx = (bx + 1) << lev if dx > 0.0 else (bx << lev) - 1
        if ty <= tx:
            cy = (by + 1) << lev if dy > 0.0 else (by << lev) - 1
        if tx < ty:
            yy = oy + te * dy
            ylo = by << lev
            yhi = min(((by + 1) << lev) - 1, ncy - 1)
            cy = min(max(int(math.ceil(yy)) - 1 if dy < 0.0 else int(math.floor(yy)), ylo), yhi)
        elif ty < tx:
            xx = ox + te * dx
            xlo = bx << lev
            xhi = min(((bx + 1) << lev) - 1, ncx - 1)
            cx = min(max(int(math.ceil(xx)) - 1 if dx < 0.0 else int(math.floor(xx)), xlo), xhi)
        if cx < 0 or cx >= ncx or cy < 0 or cy >= ncy:
            break
        t = te
        if skip and lev + 1 < nlev:
            # climb only when entering the parent block at its near edge (else its max
            # includes cells already passed and the test would usually fail)
            if tx <= ty:
                par = (cx >> lev) & 1
                if par == (0 if dx > 0.0 else 1):
                    lev += 1
            elif ((cy >> lev) & 1) == (0 if dy > 0.0 else 1):
                lev += 1
    # left the map (or reached t1) without crossing the top surface
    if sgn < 0.0 and thi < t1:
        return thi, thi  # below the surface all the way to the edge: the side wall, from inside
    return INF, thi


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _ray_box(box: Box, ray: Ray) -> float:
    """Distance along the unit ray (world metres) to ``box`` (two-sided slab test); inf if
    missed. Scalar records only."""
    bx, by, c, s, hx, hy, zb, zt = box
    ox, oy, oz, dx, dy, dz = ray
    px = ox - bx
    py = oy - by
    lx = c * px + s * py
    ly = -s * px + c * py
    ldx = c * dx + s * dy
    ldy = -s * dx + c * dy
    tn = -INF
    tf = INF
    if ldx != 0.0:
        a = (-hx - lx) / ldx
        bb = (hx - lx) / ldx
        if a > bb:
            a, bb = bb, a
        tn = max(tn, a)
        tf = min(tf, bb)
    elif lx < -hx or lx > hx:
        return INF
    if ldy != 0.0:
        a = (-hy - ly) / ldy
        bb = (hy - ly) / ldy
        if a > bb:
            a, bb = bb, a
        tn = max(tn, a)
        tf = min(tf, bb)
    elif ly < -hy or ly > hy:
        return INF
    if dz != 0.0:
        a = (zb - oz) / dz
        bb = (zt - oz) / dz
        if a > bb:
            a, bb = bb, a
        tn = max(tn, a)
        tf = min(tf, bb)
    elif oz < zb or oz > zt:
        return INF
    if tn > tf or tf < 0.0:
        return INF
    if tn >= 0.0:
        return tn
    return tf  # origin inside: the exit face


@njit(cache=True, nogil=True, error_model="numpy")
def ray_box(b: np.ndarray, i: int, ray: Ray) -> float:
    """Distance along the unit ray (world metres) to box row i of ``b`` (rows ``[x, y, yaw, hx, hy,
    zb, zt, cos(yaw), sin(yaw)]``; see :func:`_ray_box`)."""
    return _ray_box(Box(b[i, 0], b[i, 1], b[i, 7], b[i, 8], b[i, 3], b[i, 4], b[i, 5], b[i, 6]), ray)


@njit(cache=True, nogil=True, error_model="numpy")
def cast_rays_kernel(grid: TerrainGrid, boxes: np.ndarray, origins: np.ndarray, dirs: np.ndarray, max_range: float,
                     out: np.ndarray) -> None:
    """Per-ray reference path: terrain march from t=0 plus every box (pruned by distance)."""
    nb = boxes.shape[0]
    h, cell, mip, moff, mnx = grid.heights, grid.cell, grid.mip, grid.mip_offsets, grid.mip_widths
    for r in range(origins.shape[0]):
        ox, oy, oz = origins[r, 0], origins[r, 1], origins[r, 2]
        dx, dy, dz = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        ray = Ray(ox, oy, oz, dx, dy, dz)
        best = INF
        for i in range(nb):
            tb = ray_box(boxes, i, ray)
            if tb < best:
                best = tb
        tend = min(best, max_range)
        th, _ = march_terrain(h, mip, moff, mnx, Ray(ox / cell, oy / cell, oz, dx / cell, dy / cell, dz), 0.0, tend,
                              False)
        if th < best:
            best = th
        out[r] = best if best <= max_range else INF


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def walk_cells(h: np.ndarray, mipf: np.ndarray, ray: Ray, walk: CellWalk) -> float:
    """First terrain hit (t, or inf if none by ``walk.tend`` or the map's edge) of one ray's plain cell walk.

    ``ray`` (x, y in cell units) is above the terrain (heights ``h``) at the start ``walk.t`` (a
    :class:`CellWalk`: start cell, its exits, the steps). The walk visits the cells in order,
    stepping the exits incrementally (one add on the loop's dependency chain), and runs the exact
    test (:func:`_cell_hit`, or the plane of a flat cell) only where the ray comes down to the
    cell's max height (``mipf`` level 0). No mipmap block skipping:
    :func:`terrain_kernel` starts the walks where the channel below hit, so they are short.

    ``nv_march_channel`` in ``_march_avx512.c`` is this walk's native twin (a channel's queue of
    walks, eight rays at a time, the same IEEE operations): change both together; the tests
    compare them to the bit wherever the CPU has AVX-512 (``NAVSTRESS_REQUIRE_NATIVE=1``).
    """
    oxc, oyc, oz, dx, dy, dz = ray
    t, tmx, tmy, tdx, tdy, tend, cx, cy, sx, sy = walk
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    desc = dz < 0.0
    while True:
        te = min(tmx, tmy, tend)
        zlow = oz + dz * (te if desc else t)
        ci = cy * ncx + cx
        cmax = float(mipf[ci, 0])
        if zlow <= cmax:  # the ray may meet the surface in this cell: exact test
            h00 = np.float64(h[cy, cx])
            h10 = np.float64(h[cy, cx + 1])
            h01 = np.float64(h[cy + 1, cx])
            h11 = np.float64(h[cy + 1, cx + 1])
            if float(mipf[ci, 1]) == cmax:  # a flat cell: the plane z = cmax
                ts = max(t, (h00 - oz) / dz) if desc else t
                if ts <= te:
                    return ts
            tcell = _cell_hit(Cell(cx, cy, h00, h10, h01, h11), ray, t, te, 1.0)
            if tcell <= te:
                return tcell
        if te >= tend:
            return INF
        stx = tmx <= tmy
        sty = tmy <= tmx
        if stx:  # incremental: one add on the loop's dependency chain
            cx += sx
            tmx += tdx
        if sty:
            cy += sy
            tmy += tdy
        if cx < 0 or cx >= ncx or cy < 0 or cy >= ncy:
            return INF
        t = te


@njit(cache=True, nogil=True, error_model="numpy")
def terrain_kernel(grid: TerrainGrid, beams: Beams, params: np.ndarray, origin: np.ndarray, rot: np.ndarray,
                   out: np.ndarray) -> None:
    """Terrain-only ranges of one scan from the sensor at ``origin`` (3,), oriented ``rot`` (3, 3,
    world from sensor): out[channel, azimuth] = first terrain hit (inf: none within
    ``max_range``; no min_range filter). ``params``: a one-record :data:`SCAN_PARAMS` array. Its
    ``walk``: the address of the native walk (:func:`navstress.sim.native.load`), which then
    replaces :func:`walk_cells` (bit-identical); 0: :func:`walk_cells`.

    Per azimuth column, all channels lie in one plane through the sensor's z axis. The terrain
    is marched lowest channel first: channel k+1 starts where channel k hit or was proven clear
    (in the plane coordinate p along the plane's horizontal line L). This is exact when the
    terrain section is a graph over p in the column plane, which holds when tan(plane
    inclination) > the steepest terrain triangle's gradient, the sensor is inside the map above
    the ground, its z axis points up and every channel advances along L; otherwise that
    column's channels are each marched from the sensor by :func:`march_terrain` (still exact).

    Order of work (measured, docs/performance.md): channel-major, i.e. one channel over all
    columns, then the next. A column's channels depend on each other through p (a serial chain
    of divisions and loads); consecutive marches of one channel over neighbouring columns are
    independent and alike, so the CPU overlaps them and predicts their branches. Each march is
    a plain cell walk (:func:`walk_cells`, for the rays that the bounds here do not settle;
    with ``walk``, a channel's walks are queued for the native twin instead): marches start
    where the channel below hit, so they are short, and the mipmap's block skipping measured
    slower than the plain walk here. A march also starts no earlier than where
    a descending ray comes down to the highest terrain point and ends where a rising ray climbs
    above it (1e-6 m of margin): 40 % fewer cells walked on the s=4 d=2 benchmark world.
    """
    h, cell, mip, mipf, moff, mnx = grid.heights, grid.cell, grid.mip, grid.mipf, grid.mip_offsets, grid.mip_widths
    grad_max = grid.grad_max
    cos_el, sin_el, cos_az, sin_az = beams
    max_range, plane_march, walk = params[0].max_range, params[0].plane_march != 0, params[0].walk
    nch = cos_el.shape[0]
    naz = cos_az.shape[0]
    ox, oy, oz = origin[0], origin[1], origin[2]
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    icell = 1.0 / cell
    inside = 0.0 <= ox * icell <= ncx and 0.0 <= oy * icell <= ncy
    mono = plane_march and inside and (oz - height_at_cells(h, ox / cell, oy / cell) > 0.0)
    top = moff[moff.shape[0] - 1]
    gmax = mip[0, top]
    flat_map = mip[1, top] == gmax
    oxc = ox * icell
    oyc = oy * icell
    wc = float(ncx)
    hc = float(ncy)
    uwx, uwy, uwz = rot[0, 2], rot[1, 2], rot[2, 2]
    # per column: horizontal axis, whether the plane march applies, and p cleared so far
    cawx = np.empty(naz)
    cawy = np.empty(naz)
    cawz = np.empty(naz)
    clx = np.zeros(naz)
    cly = np.zeros(naz)
    plane = np.zeros(naz, np.bool_)
    pcl = np.zeros(naz)
    for a in range(naz):
        ca = cos_az[a]
        sa = sin_az[a]
        awx = rot[0, 0] * ca + rot[0, 1] * sa
        awy = rot[1, 0] * ca + rot[1, 1] * sa
        awz = rot[2, 0] * ca + rot[2, 1] * sa
        cawx[a] = awx
        cawy[a] = awy
        cawz[a] = awz
        if not mono:
            continue
        nx = awy * uwz - awz * uwy
        ny = awz * uwx - awx * uwz
        nz = awx * uwy - awy * uwx
        nn = math.sqrt(nx * nx + ny * ny + nz * nz)
        nxy = math.sqrt(nx * nx + ny * ny)
        if nxy > 1e-12 * nn and nxy > grad_max * abs(nz) * (1.0 + 1e-6) + 1e-12 * nn:
            lx = ny / nxy
            ly = -nx / nxy
            if lx * awx + ly * awy < 0.0:
                lx = -lx
                ly = -ly
            # every channel must advance along L (p > 0), and the sensor's z axis point up so
            # that elevation order is the in-plane angle order
            use_plane = uwz > 0.0
            for k in range(nch):
                rx = cos_el[k] * awx + sin_el[k] * uwx
                ry = cos_el[k] * awy + sin_el[k] * uwy
                if rx * lx + ry * ly <= 1e-9:
                    use_plane = False
            plane[a] = use_plane
            clx[a] = lx
            cly[a] = ly
    sdx = np.empty(naz)
    sdy = np.empty(naz)
    sdz = np.empty(naz)
    sidx = np.empty(naz)
    sidy = np.empty(naz)
    sthi = np.empty(naz)
    srl = np.empty(naz)
    sirl = np.empty(naz)
    # a march's start cell and the t where the ray leaves that cell in x / y
    scx = np.empty(naz, np.int64)
    scy = np.empty(naz, np.int64)
    stmx = np.empty(naz)
    stmy = np.empty(naz)
    sts = np.empty(naz)  # march start t
    # the native walk's queue (rows: t, tmx, tmy, tdx, tdy, dx, dy, dz, tend / cx, cy, sx, sy)
    # (rows padded to an odd stride: rows 4 KiB apart would share L1 sets)
    qs = naz + 9
    nat = walk != 0
    qd = np.empty((9, qs) if nat else (0, 0))
    qi = np.empty((4, qs) if nat else (0, 0), np.int64)
    qr = np.empty(qs if nat else 0)
    qa = np.empty(naz if nat else 0, np.int64)
    gtop = gmax + 1e-6  # (a margin above the highest point: the clips below stay conservative)
    for k in range(nch):
        ce = cos_el[k]
        se = sin_el[k]
        for a in range(naz):  # per-ray set-up, branch-free (vectorised: divisions off the march's path)
            rx = ce * cawx[a] + se * uwx
            ry = ce * cawy[a] + se * uwy
            dx = rx * icell
            dy = ry * icell
            idx = 1.0 / dx if dx != 0.0 else 0.0
            idy = 1.0 / dy if dy != 0.0 else 0.0
            ex = max(-oxc * idx, (wc - oxc) * idx)
            ey = max(-oyc * idy, (hc - oyc) * idy)
            sdx[a] = dx
            sdy[a] = dy
            sdz[a] = ce * cawz[a] + se * uwz
            sidx[a] = idx
            sidy[a] = idy
            sthi[a] = min(max_range, ex if dx != 0.0 else INF, ey if dy != 0.0 else INF)
            rl = rx * clx[a] + ry * cly[a]
            srl[a] = rl
            sirl[a] = (1.0 - 1e-12) / rl
        for a in range(naz if not flat_map else 0):  # march starts (p_clear is known for every column): branch-free
            dx = sdx[a]
            dy = sdy[a]
            tstart = pcl[a] * sirl[a] if plane[a] else 0.0  # (no plane: rl = 0, unused)
            # a descending ray cannot hit before it comes down to the highest terrain point
            dz = sdz[a]
            tstart = max(tstart, (gtop - oz) / dz if dz < 0.0 else 0.0)
            sts[a] = tstart
            x = oxc + tstart * dx
            y = oyc + tstart * dy
            fx = math.floor(x)
            fy = math.floor(y)
            cx = int(fx) - (1 if (dx < 0.0 and fx == x) else 0)  # ceil(x) - 1 when moving toward -x
            cy = int(fy) - (1 if (dy < 0.0 and fy == y) else 0)
            cx = min(max(cx, 0), ncx - 1)
            cy = min(max(cy, 0), ncy - 1)
            scx[a] = cx
            scy[a] = cy
            stmx[a] = (cx + (1.0 if dx > 0.0 else 0.0) - oxc) * sidx[a] if dx != 0.0 else INF
            stmy[a] = (cy + (1.0 if dy > 0.0 else 0.0) - oyc) * sidy[a] if dy != 0.0 else INF
        nq = 0
        for a in range(naz):
            rz = sdz[a]
            out[k, a] = INF
            if not plane[a]:  # each ray from the sensor
                if not (rz >= 0.0 and oz > gmax):
                    th, _ = march_terrain(h, mip, moff, mnx, Ray(oxc, oyc, oz, sdx[a], sdy[a], rz), 0.0, max_range,
                                          False)
                    out[k, a] = th
                continue
            rl = srl[a]
            p_clear = pcl[a]
            tstart = p_clear * sirl[a]  # (the same product as in the start loop above)
            if rz >= 0.0 and oz + rz * tstart > gmax:  # climbing above the highest terrain point
                pcl[a] = max(p_clear, max_range * rl)
                continue
            if not tstart < max_range:
                continue
            # the ray is above the terrain at tstart: walk it unless the bounds below settle it
            dx = sdx[a]
            dy = sdy[a]
            dz = rz
            idx = sidx[a]
            idy = sidy[a]
            thi = sthi[a]
            th = INF
            if tstart > thi:
                tc = max_range
            elif oz + dz * (tstart if dz >= 0.0 else thi) > gmax:
                tc = thi  # passes over the highest point of the map
            elif flat_map:
                th = tstart if dz >= 0.0 else max(tstart, (gmax - oz) / dz)
                tc = th
            else:
                tc = thi
                cx = scx[a]
                cy = scy[a]
                t = sts[a]
                # the walk ends where the ray leaves the map or range, or climbs above the highest
                # terrain point (no hit beyond; the ray is then clear up to thi all the same)
                tend = min(thi, (gtop - oz) / dz) if dz > 0.0 else thi
                sx = 1 if dx > 0.0 else -1
                sy = 1 if dy > 0.0 else -1
                if walk != 0:  # queued for the native walk (below), which computes the same th
                    qa[nq] = a
                    qd[0, nq] = t
                    qd[1, nq] = stmx[a]
                    qd[2, nq] = stmy[a]
                    qd[3, nq] = abs(idx)
                    qd[4, nq] = abs(idy)
                    qd[5, nq] = dx
                    qd[6, nq] = dy
                    qd[7, nq] = dz
                    qd[8, nq] = tend
                    qi[0, nq] = cx
                    qi[1, nq] = cy
                    qi[2, nq] = sx
                    qi[3, nq] = sy
                    nq += 1
                    continue
                th = walk_cells(h, mipf, Ray(oxc, oyc, oz, dx, dy, dz),
                                CellWalk(t, stmx[a], stmy[a], abs(idx), abs(idy), tend, cx, cy, sx, sy))
            out[k, a] = th
            pcl[a] = max(p_clear, min(th, tc) * rl)
        if nq > 0:
            native_args = NativeWalkArgs(h.ctypes.data, ncx + 1, ncx, ncy, oz, oxc, oyc, nq, qd.ctypes.data,
                                         qi.ctypes.data, qs, qr.ctypes.data)
            _call_native_walk(walk, native_args)  # type: ignore[call-arg]
            for q in range(nq):  # (a hit is <= thi; no hit: clear up to thi)
                a = qa[q]
                out[k, a] = qr[q]
                pcl[a] = max(pcl[a], min(qr[q], sthi[a]) * srl[a])


@njit(cache=True, nogil=True, error_model="numpy")
def rotation_error(r: np.ndarray) -> float:
    """max |R^T R - I| (inf if det <= 0): cheap validity check of a rotation matrix."""
    e = 0.0
    for i in range(3):
        for j in range(3):
            s = r[0, i] * r[0, j] + r[1, i] * r[1, j] + r[2, i] * r[2, j]
            e = max(e, abs(s - (1.0 if i == j else 0.0)))
    det = (r[0, 0] * (r[1, 1] * r[2, 2] - r[1, 2] * r[2, 1]) - r[0, 1] * (r[1, 0] * r[2, 2] - r[1, 2] * r[2, 0])
           + r[0, 2] * (r[1, 0] * r[2, 1] - r[1, 1] * r[2, 0]))
    return e if det > 0.0 else INF


@njit(cache=True, nogil=True, error_model="numpy")
def count_finite(r: np.ndarray) -> int:
    n = 0
    for v in r.ravel():
        if v < INF:
            n += 1
    return n


@njit(cache=True, nogil=True, error_model="numpy")
def points_from_ranges(r: np.ndarray, dirs: np.ndarray, noise: np.ndarray, std: float,
                       pts: np.ndarray) -> None:
    """Hit points (sensor frame) of the finite ranges, channel-major; noise[n] * std added."""
    n = 0
    use_noise = noise.shape[0] > 0
    for k in range(r.shape[0]):
        for a in range(r.shape[1]):
            d = r[k, a]
            if d < INF:
                if use_noise:
                    d = max(d + std * noise[n], 0.0)
                pts[n, 0] = dirs[k, a, 0] * d
                pts[n, 1] = dirs[k, a, 1] * d
                pts[n, 2] = dirs[k, a, 2] * d
                n += 1
