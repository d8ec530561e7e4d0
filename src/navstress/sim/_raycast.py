"""Numba kernels of the lidar ray caster (internal; use :mod:`navstress.sim.lidar`).

Coordinates: x, y in *cell units* (world metres / cell_m), z in metres, ray parameter ``t``
in metres along a unit world direction (so ``dx = dir_x / cell_m``). Cell (cx, cy) spans
[cx, cx+1] x [cy, cy+1] and is split by the diagonal from vertex (cy, cx) to (cy+1, cx+1),
the triangulation MuJoCo uses for an hfield (checked against ``mujoco.mj_ray``).

The terrain is the solid {(x, y) in the map, z <= h(x, y)}: top triangles plus vertical side
walls under the map edge (extending down without a base). Faces are two-sided, as in MuJoCo.
Boxes are rows ``[x, y, yaw, hx, hy, zb, zt, cos(yaw), sin(yaw)]`` (centre, yaw, half sides,
bottom, top), also two-sided (a ray starting inside a box hits where it leaves it, as ``mj_ray`` does).

Speed notes (measured, see docs/performance.md): a call to another ``@njit`` function that takes
arrays costs atomic reference-count updates per call, even when inlined by numba; in the hot
loops of :func:`scan_kernel` the plane march is therefore written out and the helpers it uses
(:func:`_cell_hit`, :func:`_ray_box`) take scalars only. Level 0 of the mipmap is read from the
four corner heights (which the cell test needs anyway) rather than from the mipmap array.
With ``simd``, :func:`terrain_kernel` queues each channel's walks for the native AVX-512 walk
(``_march_avx512.c``, called by symbol name through :func:`_march_channel_native`), which
repeats the walk below operation for operation: bit-identical ranges.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.sim import native

INF = np.inf
# the AVX-512 walk of the terrain marches is usable (navstress.sim.native); kernels take it as the
# ``simd`` argument, never as this global (numba would freeze its value into the cached code)
NATIVE = native.AVAILABLE


@intrinsic
def _march_channel_native(typingctx: Any, h: Any, w: Any, ncx: Any, ncy: Any, oz: Any, oxc: Any, oyc: Any,
                          nq: Any, q: Any, qi: Any, qs: Any, r: Any) -> Any:  # pragma: no cover - compile time
    """``nv_march_channel`` (``_march_avx512.c``) with array addresses as int64."""
    i64, f64, ptr = ir.IntType(64), ir.DoubleType(), ir.IntType(8).as_pointer()
    kinds = (ptr, i64, i64, i64, f64, f64, f64, i64, ptr, ptr, i64, ptr)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fn = cgutils.get_or_insert_function(  # type: ignore[no-untyped-call]
            builder.module, ir.FunctionType(ir.VoidType(), list(kinds)), native.SYMBOL)
        builder.call(fn, [builder.inttoptr(v, ptr) if k is ptr else v for v, k in zip(args, kinds)])
        return context.get_dummy_value()

    sig = types.void(*[types.int64 if k is not f64 else types.float64 for k in kinds])
    return sig, codegen


TWO_PI = 2.0 * math.pi


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
def _cell_hit(h00: float, h10: float, h01: float, h11: float, cx: int, cy: int, ox: float, oy: float,
              oz: float, dx: float, dy: float, dz: float, ta: float, tb: float, sgn: float) -> float:
    """First t in [ta, tb] where the ray crosses the surface in cell (cx, cy) (corner heights
    h00 = h[cy, cx], h10 = h[cy, cx+1], h01 = h[cy+1, cx], h11 = h[cy+1, cx+1]) from side ``sgn``
    (+1: from above, -1: from below); inf if none. Exact: F = z - h is linear on each triangle.
    Scalars only, so that inlining it adds no array reference counting to the caller's loop."""
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
def march_terrain(h: np.ndarray, mip: np.ndarray, moff: np.ndarray, mnx: np.ndarray,
                  ox: float, oy: float, oz: float, dx: float, dy: float, dz: float,
                  t0: float, t1: float, above: bool) -> tuple[float, float]:
    """First terrain hit of the ray in [t0, t1]: returns (t_hit or inf, t_clear).

    ``t_clear``: the ray is known free of terrain on [t0, t_clear) (t1, or where it leaves the
    map). ``above=True`` asserts the ray is above the surface at t0 (plane marching): a start
    at or below the surface (rounding) is then a hit at t0. ``mip[0]`` holds max-height
    mipmap levels (blocks the ray passes over are skipped), ``mip[1]`` the min heights (a block
    whose min equals its max is a flat plane: the hit is solved directly).
    """
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
            th = _cell_hit(np.float64(h[cy, cx]), np.float64(h[cy, cx + 1]), np.float64(h[cy + 1, cx]),
                           np.float64(h[cy + 1, cx + 1]), cx, cy, ox, oy, oz, dx, dy, dz, t, te, sgn)
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
def _ray_box(bx: float, by: float, c: float, s: float, hx: float, hy: float, zb: float, zt: float,
             ox: float, oy: float, oz: float, dx: float, dy: float, dz: float) -> float:
    """Distance along unit ray (world metres) to the box centred (bx, by), yaw cos/sin (c, s),
    half sides hx, hy, from zb to zt (two-sided slab test); inf if missed. Scalars only."""
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
def ray_box(b: np.ndarray, i: int, ox: float, oy: float, oz: float,
            dx: float, dy: float, dz: float) -> float:
    """Distance along unit ray (world metres) to box row i of ``b`` (see :func:`_ray_box`)."""
    return _ray_box(b[i, 0], b[i, 1], b[i, 7], b[i, 8], b[i, 3], b[i, 4], b[i, 5], b[i, 6],
                    ox, oy, oz, dx, dy, dz)


@njit(cache=True, nogil=True, error_model="numpy")
def cast_rays_kernel(h: np.ndarray, cell: float, mip: np.ndarray, moff: np.ndarray, mnx: np.ndarray,
                     boxes: np.ndarray, origins: np.ndarray, dirs: np.ndarray, max_range: float,
                     out: np.ndarray) -> None:
    """Per-ray reference path: terrain march from t=0 plus every box (pruned by distance)."""
    nb = boxes.shape[0]
    for r in range(origins.shape[0]):
        ox, oy, oz = origins[r, 0], origins[r, 1], origins[r, 2]
        dx, dy, dz = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        best = INF
        for i in range(nb):
            tb = ray_box(boxes, i, ox, oy, oz, dx, dy, dz)
            if tb < best:
                best = tb
        tend = min(best, max_range)
        th, _ = march_terrain(h, mip, moff, mnx, ox / cell, oy / cell, oz, dx / cell, dy / cell, dz,
                              0.0, tend, False)
        if th < best:
            best = th
        out[r] = best if best <= max_range else INF


@njit(cache=True, nogil=True, error_model="numpy")
def terrain_kernel(h: np.ndarray, cell: float, mip: np.ndarray, mipf: np.ndarray, moff: np.ndarray, mnx: np.ndarray,
                  grad_max: float, origin: np.ndarray, rot: np.ndarray, cos_el: np.ndarray, sin_el: np.ndarray,
                  cos_az: np.ndarray, sin_az: np.ndarray, max_range: float, plane_march: bool,
                  out: np.ndarray, simd: bool = False) -> None:
    """Terrain-only ranges of one scan: out[channel, azimuth] = first terrain hit (inf: none
    within max_range; no min_range filter). Channels ascending in elevation. ``simd``: each
    channel's cell walks run in the native AVX-512 walk (only when :data:`NATIVE`; bit-identical).

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
    a plain cell walk (the per-cell max of ``mipf`` level 0 decides whether the exact test
    runs): marches start where the channel below hit, so they are short, and the mipmap's block
    skipping measured slower than the plain walk here. A march also starts no earlier than where
    a descending ray comes down to the highest terrain point and ends where a rising ray climbs
    above it (1e-6 m of margin): 40 % fewer cells walked on the s=4 d=2 benchmark world.
    """
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
    qd = np.empty((9, qs) if simd else (0, 0))
    qi = np.empty((4, qs) if simd else (0, 0), np.int64)
    qr = np.empty(qs if simd else 0)
    qa = np.empty(naz if simd else 0, np.int64)
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
                    th, _ = march_terrain(h, mip, moff, mnx, oxc, oyc, oz, sdx[a], sdy[a], rz,
                                          0.0, max_range, False)
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
            # march_terrain(..., above=True) from tstart, written out (a call would add array
            # reference counting per ray), without the mipmap's block skipping, and with the
            # cell exits stepped incrementally (t += 1/|d|: ranges within ~1e-12 m of
            # march_terrain's recomputed exits, measured)
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
                if simd:  # queued for the native walk (below), which computes the same th, tc
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
                    qi[2, nq] = 1 if dx > 0.0 else -1
                    qi[3, nq] = 1 if dy > 0.0 else -1
                    nq += 1
                    continue
                sx = 1 if dx > 0.0 else -1
                sy = 1 if dy > 0.0 else -1
                tmx = stmx[a]  # where the ray leaves the cell in x
                tmy = stmy[a]
                tdx = abs(idx)  # t per cell in x (with dx = 0: tmx stays inf)
                tdy = abs(idy)
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
                                th = ts
                                tc = ts
                                break
                        tcell = _cell_hit(h00, h10, h01, h11, cx, cy, oxc, oyc, oz, dx, dy, dz, t, te, 1.0)
                        if tcell <= te:
                            th = tcell
                            tc = tcell
                            break
                    if te >= tend:
                        break
                    stx = tmx <= tmy
                    sty = tmy <= tmx
                    if stx:  # incremental: one add on the loop's dependency chain (not an
                        cx += sx  # int->float conversion, a subtraction and a product)
                        tmx += tdx
                    if sty:
                        cy += sy
                        tmy += tdy
                    if cx < 0 or cx >= ncx or cy < 0 or cy >= ncy:
                        break
                    t = te
            out[k, a] = th
            pcl[a] = max(p_clear, min(th, tc) * rl)
        if nq > 0:
            _march_channel_native(h.ctypes.data, ncx + 1, ncx, ncy, oz, oxc, oyc, nq, qd.ctypes.data,  # type: ignore[call-arg]
                                  qi.ctypes.data, qs, qr.ctypes.data)
            for q in range(nq):  # (a hit is <= thi; no hit: clear up to thi, as in the walk above)
                a = qa[q]
                out[k, a] = qr[q]
                pcl[a] = max(pcl[a], min(qr[q], sthi[a]) * srl[a])


@njit(cache=True, nogil=True, error_model="numpy")
def scan_kernel(h: np.ndarray, cell: float, mip: np.ndarray, mipf: np.ndarray, moff: np.ndarray, mnx: np.ndarray,
                grad_max: float, boxes: np.ndarray, origin: np.ndarray, rot: np.ndarray,
                cos_el: np.ndarray, sin_el: np.ndarray, cos_az: np.ndarray, sin_az: np.ndarray,
                max_range: float, min_range: float, plane_march: bool, out: np.ndarray) -> None:
    """One scan: out[channel, azimuth] = range (inf: no return). Channels ascending in elevation.

    The terrain ranges come from :func:`terrain_kernel` (one plane per azimuth column, lowest
    channel first). Boxes come from world-heading sector bins (built per scan), each tested only
    on the contiguous channel range whose world slope can reach it, nearer than the terrain hit.

    :class:`~navstress.sim.lidar.Lidar` calls this with no boxes (terrain only) and then the
    faster box-major :func:`navstress.sim._raybox.box_pass`; the per-column box code here is kept
    as the independent all-in-one reference that tests and ``benchmarks/bench_lidar_boxes.py``
    compare ``box_pass`` against (bit-identical).
    """
    nch = cos_el.shape[0]
    naz = cos_az.shape[0]
    ox, oy, oz = origin[0], origin[1], origin[2]
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    icell = 1.0 / cell
    tr = np.empty((nch, naz))
    terrain_kernel(h, cell, mip, mipf, moff, mnx, grad_max, origin, rot, cos_el, sin_el, cos_az, sin_az,
                  max_range, plane_march, tr)
    # ---- per-scan box preparation: distances, reachable slopes, heading intervals, bins --
    nb = boxes.shape[0]
    nsec = 360
    sec_w = 2.0 * math.pi / nsec
    dmin = np.empty(nb)
    mlo = np.empty(nb)
    mhi = np.empty(nb)
    alo = np.empty(nb)
    ahi = np.empty(nb)
    for i in range(nb):
        c = boxes[i, 7]
        s = boxes[i, 8]
        px = ox - boxes[i, 0]
        py = oy - boxes[i, 1]
        lx = abs(c * px + s * py)
        ly = abs(-s * px + c * py)
        hx = boxes[i, 3]
        hy = boxes[i, 4]
        qx = max(lx - hx, 0.0)
        qy = max(ly - hy, 0.0)
        dn = math.sqrt(qx * qx + qy * qy)
        df = math.sqrt((lx + hx) ** 2 + (ly + hy) ** 2)
        dmin[i] = dn
        if dn > max_range:
            continue
        cb = boxes[i, 5] - oz
        ct = boxes[i, 6] - oz
        if dn <= 0.0:
            mlo[i] = -INF if cb < 0.0 else cb / df
            mhi[i] = INF if ct >= 0.0 else ct / df
        else:
            mlo[i] = cb / df if cb >= 0.0 else cb / dn
            mhi[i] = ct / dn if ct >= 0.0 else ct / df
        mlo[i] -= 1e-9 * (1.0 + abs(mlo[i]))
        mhi[i] += 1e-9 * (1.0 + abs(mhi[i]))
        rc = math.sqrt(px * px + py * py)
        rad = math.sqrt(hx * hx + hy * hy)
        if rc <= rad * 1.000001 + 1e-9:
            alo[i] = -4.0 * math.pi  # all headings
            ahi[i] = 4.0 * math.pi
        else:
            th = math.atan2(-py, -px)
            dl = min(rad / math.sqrt(rc * rc - rad * rad), math.pi) + 1e-9  # tan(asin) >= asin
            alo[i] = th - dl
            ahi[i] = th + dl
    counts = np.zeros(nsec + 1, np.int64)
    for i in range(nb):
        if dmin[i] > max_range:
            continue
        q0 = int(math.floor(alo[i] / sec_w))
        q1 = min(int(math.floor(ahi[i] / sec_w)), q0 + nsec - 1)
        for q in range(q0, q1 + 1):
            counts[(q % nsec) + 1] += 1
    for q in range(nsec):
        counts[q + 1] += counts[q]
    nbinned = counts[nsec]
    fill = counts[:nsec].copy()
    bins = np.empty(counts[nsec], np.int64)
    for i in range(nb):
        if dmin[i] > max_range:
            continue
        q0 = int(math.floor(alo[i] / sec_w))
        q1 = min(int(math.floor(ahi[i] / sec_w)), q0 + nsec - 1)
        for q in range(q0, q1 + 1):
            qq = q % nsec
            bins[fill[qq]] = i
            fill[qq] += 1
    for q in range(nsec):  # sort each bin by dmin (insertion sort: bins are short)
        for e in range(counts[q] + 1, counts[q + 1]):
            i = bins[e]
            f = e - 1
            while f >= counts[q] and dmin[bins[f]] > dmin[i]:
                bins[f + 1] = bins[f]
                f -= 1
            bins[f + 1] = i
    # ---- columns: boxes over the terrain ranges ---------------------------------------
    if nbinned == 0:  # no box within range: the terrain ranges are the scan
        for k in range(nch):
            for a in range(naz):
                r = tr[k, a]
                out[k, a] = r if (min_range <= r <= max_range) else INF
        return
    stamp = np.full(nb, -1, np.int64)
    dirs = np.empty((nch, 3))
    slope = np.empty(nch)
    hxy = np.empty(nch)
    best = np.empty(nch)
    uwx, uwy, uwz = rot[0, 2], rot[1, 2], rot[2, 2]
    for a in range(naz):
        ca = cos_az[a]
        sa = sin_az[a]
        awx = rot[0, 0] * ca + rot[0, 1] * sa
        awy = rot[1, 0] * ca + rot[1, 1] * sa
        awz = rot[2, 0] * ca + rot[2, 1] * sa
        reach = 0.0
        for k in range(nch):
            ce = cos_el[k]
            se = sin_el[k]
            rx = ce * awx + se * uwx
            ry = ce * awy + se * uwy
            rz = ce * awz + se * uwz
            dirs[k, 0] = rx
            dirs[k, 1] = ry
            dirs[k, 2] = rz
            hh = math.sqrt(rx * rx + ry * ry)
            hxy[k] = hh
            slope[k] = rz / hh if hh > 0.0 else (INF if rz > 0.0 else -INF)
            best[k] = tr[k, a]
            reach = max(reach, min(best[k], max_range) * hh)
        # boxes: candidates from the sectors spanned by the column's headings, nearest first.
        # Headings vary monotonically with elevation (while no ray is vertical); slopes do for
        # moderate tilts: checked, else every sector and channel is a candidate (still exact).
        if nbinned > 0:  # (no box within range: nothing to do)
            ordered = hxy[0] > 1e-9
            for k in range(1, nch):
                if slope[k] < slope[k - 1] or hxy[k] <= 1e-9:
                    ordered = False
            if ordered:
                th0 = math.atan2(dirs[0, 1], dirs[0, 0])
                th1 = math.atan2(dirs[nch - 1, 1], dirs[nch - 1, 0])
                d = (th1 - th0 + math.pi) % TWO_PI - math.pi
                lo = min(th0, th0 + d) - 1e-9
                hi = max(th0, th0 + d) + 1e-9
                q0 = int(math.floor(lo / sec_w))
                q1 = int(math.floor(hi / sec_w))
            else:
                lo = -math.pi
                hi = 3.0 * math.pi
                q0 = 0
                q1 = nsec - 1
            for q in range(q0, q1 + 1):
                qq = q % nsec
                for e in range(counts[qq], counts[qq + 1]):
                    i = bins[e]
                    if dmin[i] > reach:
                        break
                    if stamp[i] == a:
                        continue
                    stamp[i] = a
                    # heading overlap of the box's interval with the column's
                    w0 = alo[i] - lo  # the box's heading interval, shifted to start in [lo, lo + 2 pi)
                    if w0 < 0.0:
                        w0 += TWO_PI
                        if w0 < 0.0:
                            w0 += TWO_PI
                    elif w0 >= TWO_PI:
                        w0 -= TWO_PI
                    if w0 > hi - lo and w0 + (ahi[i] - alo[i]) < TWO_PI:
                        continue
                    # channels whose world slope lies in [mlo, mhi] (slopes ascend with k)
                    if ordered:  # binary searches (written out: no array passed to a helper in the loop)
                        v = mlo[i]
                        lo_ = 0
                        hi_ = nch
                        while lo_ < hi_:
                            mid = (lo_ + hi_) >> 1
                            if slope[mid] < v:
                                lo_ = mid + 1
                            else:
                                hi_ = mid
                        k0 = lo_
                        v = math.nextafter(mhi[i], INF)
                        hi_ = nch
                        while lo_ < hi_:
                            mid = (lo_ + hi_) >> 1
                            if slope[mid] < v:
                                lo_ = mid + 1
                            else:
                                hi_ = mid
                        k1 = lo_ - 1
                    else:
                        k0 = 0
                        k1 = nch - 1
                    b0, b1, b3, b4 = boxes[i, 0], boxes[i, 1], boxes[i, 3], boxes[i, 4]
                    b5, b6, b7, b8 = boxes[i, 5], boxes[i, 6], boxes[i, 7], boxes[i, 8]
                    for k in range(k0, k1 + 1):
                        if dmin[i] > best[k] * hxy[k]:
                            continue
                        tb = _ray_box(b0, b1, b7, b8, b3, b4, b5, b6, ox, oy, oz, dirs[k, 0], dirs[k, 1], dirs[k, 2])
                        if tb < best[k]:
                            best[k] = tb
        for k in range(nch):
            r = best[k]
            out[k, a] = r if (min_range <= r <= max_range) else INF


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
