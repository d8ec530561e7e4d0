"""Numba kernel of the lidar's box pass (internal; use :mod:`navstress.sim.lidar`).

:func:`box_pass` lowers a scan's terrain ranges with the exact hits on the boxes (rows
``[x, y, yaw, hx, hy, zb, zt, cos(yaw), sin(yaw)]``, as in :mod:`navstress.sim._raycast`).
Every ray direction is computed with the same arithmetic as the all-in-one scan ``scan_kernel`` (``tests/oracles/scan.py``) and every hit with
the same scalar :func:`navstress.sim._raycast._ray_box`, so the result is bit-identical to the
minimum over all boxes (and to ``scan_kernel`` with the boxes): the culling below only skips
(box, ray) pairs that a conservative bound, with margins far above rounding, proves cannot hit
before the ray's current range.

Work is box-major: per box, the sensor azimuths it can span (from its bounding rectangle in the
sensor's xy plane), then per azimuth column an exact plane test (does the column's plane cut the
box?) and, in the column plane's own coordinates (alpha along the column's horizontal direction,
beta along the sensor's z axis: a ray is (t cos el, t sin el)), the channels whose elevation
slope can reach the box and whose current range reaches its near side. Boxes are visited near
first (bucketed by distance), so rays already stopped by a nearer box or the ground skip the
boxes behind. Speed notes as in ``_raycast``: the hot loops call only scalar helpers.

The kernels take the records of ``_raycast`` (:class:`~navstress.sim._raycast.Beams`, a
:data:`~navstress.sim._raycast.SCAN_PARAMS` record, :class:`~navstress.sim._raycast.TerrainGrid`).
The two per-scan entries that Python calls, :func:`scan_ranges` (a sensor pose) and
:func:`body_scan_ranges` (a body pose), take the groups flattened (``*arrays``: a
``TerrainGrid``'s fields, a ``Beams``' fields, then the ranges; see :func:`scan_arrays`) and
regroup them: numba dispatches tuples of arrays microseconds slower per call.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.sim._raycast import (Beams, Box, Ray, TerrainGrid, _ray_box, cast_rays_kernel, count_finite,
                                    rotation_error,
                                    terrain_kernel)

INF = np.inf
TWO_PI = 2.0 * math.pi
NBUCKET = 64
# where each group ends in the per-scan entries' flat argument list (scan_arrays)
_E_GRID = len(TerrainGrid._fields)
_E_BEAMS = _E_GRID + len(Beams._fields)


class Cylinder(NamedTuple):
    """An upright solid cylinder (a disc mover): centre (x, y), radius, bottom and top z."""

    x: float
    y: float
    r: float
    zb: float
    zt: float


def scan_arrays(grid: TerrainGrid, beams: Beams, ranges: np.ndarray) -> tuple[np.ndarray | float, ...]:
    """The groups as :func:`scan_ranges` and :func:`body_scan_ranges` take them (``*arrays``):
    the grid's fields, the beams' fields, then ``ranges`` (channels, azimuths), the output."""
    if type(grid) is not TerrainGrid or type(beams) is not Beams:
        raise TypeError(f"expected TerrainGrid and Beams, got {type(grid).__name__} and {type(beams).__name__}")
    return (*grid, *beams, ranges)


@njit(cache=True, nogil=True, error_model="numpy")
def box_pass(boxes: np.ndarray, beams: Beams, params: np.ndarray, origin: np.ndarray, rot: np.ndarray,
             out: np.ndarray, circle: int = 0) -> None:
    """Lower ``out[channel, azimuth]`` (terrain ranges, inf = none, any value > max_range is
    treated as none) with the box hits, then keep ``min_range <= r <= max_range`` (else inf)
    (``params``: a one-record :data:`~navstress.sim._raycast.SCAN_PARAMS` array).

    Preconditions (as :class:`~navstress.sim.lidar.Lidar` guarantees): channel elevations in
    (-90, 90) degrees (``cos_el > 0``); azimuth ``a`` at ``2 pi a / circle`` (``circle`` 0: the
    number of columns ``naz``; more: the columns are the first ``naz`` of a circle of ``circle``
    steps, as a ``lidar2d`` fan's, and the culling skips the others); ``rot`` a rotation up to
    rounding (the margins scale with its orthonormality error).
    """
    cos_el, sin_el, cos_az, sin_az = beams
    max_range, min_range = params[0].max_range, params[0].min_range
    nch = cos_el.shape[0]
    naz = cos_az.shape[0]
    nb = boxes.shape[0]
    ncirc = naz if circle <= 0 else circle
    ox, oy, oz = origin[0], origin[1], origin[2]
    uwx, uwy, uwz = rot[0, 2], rot[1, 2], rot[2, 2]
    if nb > 0:
        # orthonormality error of rot: bounds how far a column's rays stray from its azimuth
        err = 0.0
        for i in range(3):
            for j in range(3):
                d = rot[0, i] * rot[0, j] + rot[1, i] * rot[1, j] + rot[2, i] * rot[2, j]
                err = max(err, abs(d - (1.0 if i == j else 0.0)))
        # channel slopes tan(el), ascending (else every channel is a candidate)
        slope = np.empty(nch)
        tmax = 0.0
        ordered = True
        for k in range(nch):
            slope[k] = sin_el[k] / cos_el[k]
            tmax = max(tmax, abs(slope[k]))
            if k > 0 and slope[k] < slope[k - 1]:
                ordered = False
        ang_margin = 1e-7 + 8.0 * err * (1.0 + tmax)
        # per column: the plane's normal n = aw x uw and the dual basis (as, us) of (aw, uw)
        col = np.empty((naz, 12))
        for a in range(naz):
            ca = cos_az[a]
            sa = sin_az[a]
            awx = rot[0, 0] * ca + rot[0, 1] * sa  # (the same arithmetic as scan_kernel)
            awy = rot[1, 0] * ca + rot[1, 1] * sa
            awz = rot[2, 0] * ca + rot[2, 1] * sa
            nx = awy * uwz - awz * uwy
            ny = awz * uwx - awx * uwz
            nz = awx * uwy - awy * uwx
            ga = awx * awx + awy * awy + awz * awz
            gc = awx * uwx + awy * uwy + awz * uwz
            gu = uwx * uwx + uwy * uwy + uwz * uwz
            idet = 1.0 / (ga * gu - gc * gc)  # (bounds only: rounding is far inside the margins)
            col[a, 0] = awx
            col[a, 1] = awy
            col[a, 2] = awz
            col[a, 3] = nx
            col[a, 4] = ny
            col[a, 5] = nz
            col[a, 6] = (gu * awx - gc * uwx) * idet  # as: as.aw = 1, as.uw = 0
            col[a, 7] = (gu * awy - gc * uwy) * idet
            col[a, 8] = (gu * awz - gc * uwz) * idet
            col[a, 9] = (ga * uwx - gc * awx) * idet  # us: us.aw = 0, us.uw = 1
            col[a, 10] = (ga * uwy - gc * awy) * idet
            col[a, 11] = (ga * uwz - gc * awz) * idet
        # per box: near distance in the sensor's xy plane, azimuth interval -> column range
        rn = np.empty(nb)
        c0 = np.empty(nb, np.int64)
        c1 = np.empty(nb, np.int64)
        cnt = np.zeros(NBUCKET + 1, np.int64)
        step = TWO_PI / ncirc
        bscale = NBUCKET / max_range
        r00, r10, r20 = rot[0, 0], rot[1, 0], rot[2, 0]
        r01, r11, r21 = rot[0, 1], rot[1, 1], rot[2, 1]
        far = max_range * (1.0 + 8.0 * err) + 1e-9
        for i in range(nb):
            c = boxes[i, 7]
            s = boxes[i, 8]
            hx = boxes[i, 3]
            hy = boxes[i, 4]
            hz = 0.5 * (boxes[i, 6] - boxes[i, 5])
            px = boxes[i, 0] - ox
            py = boxes[i, 1] - oy
            if circle > 0 and max(abs(px), abs(py)) - (hx + hy) > far:
                # (a fan: cull by range first, cheaply: every point of the box is farther than
                # max_range in x or y, so any hit is past max_range and filtered out below)
                c0[i] = 0
                c1[i] = -1
                rn[i] = far
                continue
            pz = 0.5 * (boxes[i, 5] + boxes[i, 6]) - oz
            # centre and half-axes in the sensor frame's x, y (R^T applied)
            sx = r00 * px + r10 * py + r20 * pz
            sy = r01 * px + r11 * py + r21 * pz
            g1x = hx * (r00 * c + r10 * s)
            g1y = hx * (r01 * c + r11 * s)
            g2x = hy * (r10 * c - r00 * s)
            g2y = hy * (r11 * c - r01 * s)
            g3x = hz * r20
            g3y = hz * r21
            rho = math.sqrt(sx * sx + sy * sy)
            if rho > 0.0:
                irho = 1.0 / rho
                ux = sx * irho
                uy = sy * irho
                epar = abs(ux * g1x + uy * g1y) + abs(ux * g2x + uy * g2y) + abs(ux * g3x + uy * g3y)
                wid = abs(ux * g1y - uy * g1x) + abs(ux * g2y - uy * g2x) + abs(ux * g3y - uy * g3x)
                near = rho - epar
            else:
                near = -1.0
                wid = 0.0
            near -= 1e-9 * (1.0 + rho + max_range)
            rn[i] = near
            if near > max_range * (1.0 + 8.0 * err) + 1e-9:
                c0[i] = 0
                c1[i] = -1  # out of range
                continue
            if near <= 0.0:
                c0[i] = 0
                c1[i] = ncirc - 1
            else:
                dl = wid / near + ang_margin  # tan(angle) >= angle
                if dl >= math.pi:
                    c0[i] = 0
                    c1[i] = ncirc - 1
                else:
                    th = math.atan2(sy, sx)
                    q0 = int(math.ceil((th - dl) / step - 1e-9))
                    q1 = int(math.floor((th + dl) / step + 1e-9))
                    if q1 - q0 >= ncirc - 1:
                        q0 = 0
                        q1 = ncirc - 1
                    c0[i] = q0
                    c1[i] = q1
            if c1[i] >= c0[i]:  # (between two columns: none)
                bk = int(max(near, 0.0) * bscale)
                cnt[min(bk, NBUCKET - 1) + 1] += 1
        for q in range(NBUCKET):
            cnt[q + 1] += cnt[q]
        order = np.empty(cnt[NBUCKET], np.int64)
        for i in range(nb):
            if c1[i] >= c0[i]:
                bk = min(int(max(rn[i], 0.0) * bscale), NBUCKET - 1)
                order[cnt[bk]] = i
                cnt[bk] += 1
        ce_m = np.empty(nch)  # cos(el) with the margin of the reach test below
        for k in range(nch):
            ce_m[k] = cos_el[k] * (1.0 + 1e-9)
        cand = np.empty(nch, np.int64)
        # boxes near first: columns, exact plane test, channels, exact ray-box test
        for e in range(order.shape[0]):
            i = order[e]
            bx = boxes[i, 0]
            by = boxes[i, 1]
            c = boxes[i, 7]
            s = boxes[i, 8]
            hx = boxes[i, 3]
            hy = boxes[i, 4]
            zb = boxes[i, 5]
            zt = boxes[i, 6]
            box = Box(bx, by, c, s, hx, hy, zb, zt)
            hz = 0.5 * (zt - zb)
            px = bx - ox
            py = by - oy
            pz = 0.5 * (zb + zt) - oz
            pmarg = 1e-9 * (1.0 + abs(px) + abs(py) + abs(pz) + max_range)
            for q in range(c0[i], c1[i] + 1):
                a = q % ncirc
                if a >= naz:  # (a column of the circle that the fan does not cast)
                    continue
                nx = col[a, 3]
                ny = col[a, 4]
                nz = col[a, 5]
                # the column's plane must cut the box
                if abs(nx * px + ny * py + nz * pz) > (hx * abs(nx * c + ny * s) + hy * abs(ny * c - nx * s)
                                                       + hz * abs(nz)) + pmarg:
                    continue
                # alpha, beta bounds of the box (rays: alpha = t cos el, beta = t sin el)
                ax = col[a, 6]
                ay = col[a, 7]
                az = col[a, 8]
                vx = col[a, 9]
                vy = col[a, 10]
                vz = col[a, 11]
                ac = ax * px + ay * py + az * pz
                ar = hx * abs(ax * c + ay * s) + hy * abs(ay * c - ax * s) + hz * abs(az)
                bc = vx * px + vy * py + vz * pz
                br = hx * abs(vx * c + vy * s) + hy * abs(vy * c - vx * s) + hz * abs(vz)
                alo = ac - ar - pmarg
                ahi = ac + ar + pmarg
                if ahi < 0.0:
                    continue
                blo = bc - br - pmarg
                bhi = bc + br + pmarg
                k0 = 0
                k1 = nch - 1
                if ordered and alo > 0.0:
                    mlo = blo / ahi if blo >= 0.0 else blo / alo
                    mhi = bhi / alo if bhi >= 0.0 else bhi / ahi
                    mlo -= 1e-9 * (1.0 + abs(mlo))
                    mhi += 1e-9 * (1.0 + abs(mhi))
                    # the channels with mlo <= slope <= mhi: counted branch-free (a binary search
                    # mispredicts about every step)
                    n_lo = 0
                    n_hi = 0
                    for k in range(nch):
                        n_lo += 1 if slope[k] < mlo else 0
                        n_hi += 1 if slope[k] <= mhi else 0
                    k0 = n_lo
                    k1 = n_hi - 1
                awx = col[a, 0]
                awy = col[a, 1]
                awz = col[a, 2]
                nc = 0
                for k in range(k0, k1 + 1):  # rays that reach the box's near side (branch-free)
                    cand[nc] = k
                    nc += 1 if alo <= min(out[k, a], max_range) * ce_m[k] else 0
                for j in range(nc):
                    k = cand[j]
                    ce = cos_el[k]
                    se = sin_el[k]
                    rx = ce * awx + se * uwx
                    ry = ce * awy + se * uwy
                    rz = ce * awz + se * uwz
                    tb = _ray_box(box, Ray(ox, oy, oz, rx, ry, rz))
                    if tb < out[k, a]:
                        out[k, a] = tb
    for k in range(nch):
        for a in range(naz):
            r = out[k, a]
            out[k, a] = r if (min_range <= r <= max_range) else INF



@njit(cache=True, nogil=True, error_model="numpy")
def scan_ranges(params: np.ndarray, origin: np.ndarray, rot: np.ndarray, boxes: np.ndarray, discs: np.ndarray,
                *arrays: Any) -> None:
    """One scan's ranges (terrain, then upright cylinders ``discs``, then boxes) from the sensor at
    ``origin``, oriented ``rot``: :func:`~navstress.sim._raycast.terrain_kernel`, :func:`disc_pass`
    then :func:`box_pass` in one compiled call
    (``params``: a one-record :data:`~navstress.sim._raycast.SCAN_PARAMS` array; ``arrays``:
    :func:`scan_arrays`, the ranges written)."""
    grid = TerrainGrid(*arrays[:_E_GRID])
    beams = Beams(*arrays[_E_GRID:_E_BEAMS])
    out = arrays[_E_BEAMS]
    terrain_kernel(grid, beams, params, origin, rot, out)
    if discs.shape[0] > 0:
        disc_pass(discs, beams, params, origin, rot, out)
    box_pass(boxes, beams, params, origin, rot, out)


@njit(cache=True, nogil=True, error_model="numpy")
def body_scan_ranges(params: np.ndarray, qpos: np.ndarray, mount: np.ndarray, rot: np.ndarray, origin: np.ndarray,
                     boxes: np.ndarray, discs: np.ndarray, *arrays: Any) -> int:
    """One scan's ranges (terrain, then upright cylinders ``discs``, then boxes) from a body pose ``qpos[:7]`` = (x, y, z, qw, qx,
    qy, qz) with the sensor at ``mount`` in the body frame and oriented as the body; returns the
    number of returns, or -1 (nothing computed) if the pose is not finite or not a rotation.

    One compiled call instead of the pose arithmetic, validation, terrain kernel, box pass and
    count made separately from Python (each call pays the dispatcher); ``params`` and
    ``arrays`` as in :func:`scan_ranges`. ``rot`` (3, 3) and
    ``origin`` (3,) receive the sensor pose: ``rot`` with the formula of MuJoCo's
    ``mju_quat2Mat`` (MuJoCo's build contracts some products into fused multiply-adds, so
    entries may differ from it in the last bit), ``origin = qpos[:3] + rot @ mount``."""
    grid = TerrainGrid(*arrays[:_E_GRID])
    beams = Beams(*arrays[_E_GRID:_E_BEAMS])
    out = arrays[_E_BEAMS]
    q0, q1, q2, q3 = qpos[3], qpos[4], qpos[5], qpos[6]
    if q0 == 1.0 and q1 == 0.0 and q2 == 0.0 and q3 == 0.0:
        for i in range(3):
            for j in range(3):
                rot[i, j] = 1.0 if i == j else 0.0
    else:
        q00, q01, q02, q03 = q0 * q0, q0 * q1, q0 * q2, q0 * q3
        q11, q12, q13 = q1 * q1, q1 * q2, q1 * q3
        q22, q23, q33 = q2 * q2, q2 * q3, q3 * q3
        rot[0, 0] = q00 + q11 - q22 - q33
        rot[1, 1] = q00 - q11 + q22 - q33
        rot[2, 2] = q00 - q11 - q22 + q33
        rot[0, 1] = 2.0 * (q12 - q03)
        rot[0, 2] = 2.0 * (q13 + q02)
        rot[1, 0] = 2.0 * (q12 + q03)
        rot[1, 2] = 2.0 * (q23 - q01)
        rot[2, 0] = 2.0 * (q13 - q02)
        rot[2, 1] = 2.0 * (q23 + q01)
    for i in range(3):
        origin[i] = qpos[i] + (rot[i, 0] * mount[0] + rot[i, 1] * mount[1] + rot[i, 2] * mount[2])
    ok = math.isfinite(origin[0]) and math.isfinite(origin[1]) and math.isfinite(origin[2])
    if not (ok and rotation_error(rot) <= 1e-6):  # (a NaN rotation fails the comparison)
        return -1
    terrain_kernel(grid, beams, params, origin, rot, out)
    if discs.shape[0] > 0:
        disc_pass(discs, beams, params, origin, rot, out)
    box_pass(boxes, beams, params, origin, rot, out)
    return count_finite(out)


@njit(cache=True, nogil=True, error_model="numpy")
def _ray_cylinder(cyl: Cylinder, ray: Ray) -> float:
    """Distance along the unit ray to the upright solid cylinder ``cyl``, inf if none; surfaces
    two-sided (a ray from inside hits its exit)."""
    cx, cy, r, zb, zt = cyl
    ox, oy, oz, dx, dy, dz = ray
    best = INF
    ex, ey = ox - cx, oy - cy
    a = dx * dx + dy * dy
    if a > 1e-18:
        b = ex * dx + ey * dy
        c = ex * ex + ey * ey - r * r
        disc = b * b - a * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            for t in ((-b - sq) / a, (-b + sq) / a):
                if t >= 0.0:
                    z = oz + t * dz
                    if zb <= z <= zt:
                        best = min(best, t)
                        break
    if dz != 0.0:
        for zc in (zb, zt):
            t = (zc - oz) / dz
            if 0.0 <= t < best:
                x, y = ex + t * dx, ey + t * dy
                if x * x + y * y <= r * r:
                    best = t
    return best


@njit(cache=True, nogil=True, error_model="numpy")
def disc_pass(discs: np.ndarray, beams: Beams, params: np.ndarray, origin: np.ndarray, rot: np.ndarray,
              out: np.ndarray, circle: int = 0) -> None:
    """Lower ``out[channel, azimuth]`` with the hits on upright cylinders (rows ``[x, y, r, zb,
    zt]``: the cylinder obstacles, then the disc movers); the ray directions as :func:`box_pass`
    computes them. Per cylinder only the azimuth columns its bounding circle in the sensor's xy
    plane can span and the channels whose elevation its bounding sphere can reach (each with a
    margin) are tested; cylinders are visited near first (bucketed by the near side of their
    bounding sphere) and a ray whose current range is already below that near side skips the
    cylinder: the same ranges as testing every ray against every cylinder. No range filter (the
    box pass applies it; ``params``: a one-record :data:`~navstress.sim._raycast.SCAN_PARAMS`
    array, its ``max_range`` read; ``circle`` as in :func:`box_pass`)."""
    cos_el, sin_el, cos_az, sin_az = beams
    max_range = params[0].max_range
    nch = cos_el.shape[0]
    naz = cos_az.shape[0]
    nd = discs.shape[0]
    ox, oy, oz = origin[0], origin[1], origin[2]
    uwx, uwy, uwz = rot[0, 2], rot[1, 2], rot[2, 2]
    ncirc = naz if circle <= 0 else circle
    step = TWO_PI / ncirc
    tilt = math.sqrt(rot[2, 0] ** 2 + rot[2, 1] ** 2)
    # per cylinder: columns q0..q1 (of the circle), channels k0..k1, near side; bucketed by near
    span = np.empty((nd, 4), np.int64)
    nears = np.empty(nd)
    cnt = np.zeros(NBUCKET + 1, np.int64)
    bscale = NBUCKET / max_range
    for i in range(nd):
        r, zb, zt = discs[i, 2], discs[i, 3], discs[i, 4]
        hz = 0.5 * (zt - zb)
        px, py, pz = discs[i, 0] - ox, discs[i, 1] - oy, 0.5 * (zb + zt) - oz
        sx = rot[0, 0] * px + rot[1, 0] * py + rot[2, 0] * pz
        sy = rot[0, 1] * px + rot[1, 1] * py + rot[2, 1] * pz
        sz = rot[0, 2] * px + rot[1, 2] * py + rot[2, 2] * pz
        wid = r + hz * tilt + 1e-6
        rho = math.sqrt(sx * sx + sy * sy)
        span[i, 0] = 0
        span[i, 1] = -1  # (none)
        if rho - wid > max_range:
            continue
        if rho <= wid * 1.001:
            q0, q1 = 0, ncirc - 1
        else:
            dl = math.asin(wid / rho) * 1.001 + 1e-6
            th = math.atan2(sy, sx)
            q0 = int(math.floor((th - dl) / step))
            q1 = int(math.ceil((th + dl) / step))
            if q1 - q0 >= ncirc - 1:
                q0, q1 = 0, ncirc - 1
        # channels: a ray meets the bounding sphere (centre s, radius rb) only if its elevation is
        # within asin(rb / |s|) of the centre's; nothing on it is nearer than |s| - rb
        rb = math.sqrt(r * r + hz * hz) * 1.001 + 1e-6
        dist = math.sqrt(rho * rho + sz * sz)
        k0, k1 = 0, nch - 1
        near = -INF
        if dist > rb:
            near = (dist - rb) * (1.0 - 1e-9) - 1e-9
            el = math.asin(max(-1.0, min(1.0, sz / dist)))
            de = math.asin(rb / dist) * 1.001 + 1e-6
            lo = math.sin(max(-0.5 * math.pi, el - de))
            hi = math.sin(min(0.5 * math.pi, el + de))
            while k0 < nch and sin_el[k0] < lo:
                k0 += 1
            while k1 >= 0 and sin_el[k1] > hi:
                k1 -= 1
            if k0 > k1:
                continue
        span[i, 0] = q0
        span[i, 1] = q1
        span[i, 2] = k0
        span[i, 3] = k1
        nears[i] = near
        cnt[min(int(max(near, 0.0) * bscale), NBUCKET - 1) + 1] += 1
    for q in range(NBUCKET):
        cnt[q + 1] += cnt[q]
    order = np.empty(cnt[NBUCKET], np.int64)
    for i in range(nd):
        if span[i, 1] >= span[i, 0]:
            bk = min(int(max(nears[i], 0.0) * bscale), NBUCKET - 1)
            order[cnt[bk]] = i
            cnt[bk] += 1
    for e in range(order.shape[0]):
        i = order[e]
        cyl = Cylinder(discs[i, 0], discs[i, 1], discs[i, 2], discs[i, 3], discs[i, 4])
        near = nears[i]
        k0 = span[i, 2]
        k1 = span[i, 3]
        for q in range(span[i, 0], span[i, 1] + 1):
            a = q % ncirc
            if a >= naz:  # (a column of the circle that the fan does not cast)
                continue
            ca = cos_az[a]
            sa = sin_az[a]
            awx = rot[0, 0] * ca + rot[0, 1] * sa
            awy = rot[1, 0] * ca + rot[1, 1] * sa
            awz = rot[2, 0] * ca + rot[2, 1] * sa
            for k in range(k0, k1 + 1):
                if out[k, a] < near:  # (stopped before the cylinder's bounding sphere)
                    continue
                ce = cos_el[k]
                se = sin_el[k]
                t = _ray_cylinder(cyl, Ray(ox, oy, oz, ce * awx + se * uwx, ce * awy + se * uwy, ce * awz + se * uwz))
                if t < out[k, a]:
                    out[k, a] = t


@njit(cache=True, nogil=True, error_model="numpy")
def _mounted_pose(qpos: np.ndarray, mount: np.ndarray, mrot: np.ndarray, rot: np.ndarray, origin: np.ndarray) -> bool:
    """World-from-sensor ``rot`` (the body's rotation from ``qpos``, as :func:`body_scan_ranges`
    computes it, times the body-from-sensor ``mrot``) and ``origin = qpos[:3] + body @ mount``;
    False if the pose is not finite or not a rotation."""
    q0, q1, q2, q3 = qpos[3], qpos[4], qpos[5], qpos[6]
    b = np.empty((3, 3))
    q00, q01, q02, q03 = q0 * q0, q0 * q1, q0 * q2, q0 * q3
    q11, q12, q13 = q1 * q1, q1 * q2, q1 * q3
    q22, q23, q33 = q2 * q2, q2 * q3, q3 * q3
    b[0, 0] = q00 + q11 - q22 - q33
    b[1, 1] = q00 - q11 + q22 - q33
    b[2, 2] = q00 - q11 - q22 + q33
    b[0, 1] = 2.0 * (q12 - q03)
    b[0, 2] = 2.0 * (q13 + q02)
    b[1, 0] = 2.0 * (q12 + q03)
    b[1, 2] = 2.0 * (q23 - q01)
    b[2, 0] = 2.0 * (q13 - q02)
    b[2, 1] = 2.0 * (q23 + q01)
    for i in range(3):
        origin[i] = qpos[i] + (b[i, 0] * mount[0] + b[i, 1] * mount[1] + b[i, 2] * mount[2])
        for j in range(3):
            rot[i, j] = b[i, 0] * mrot[0, j] + b[i, 1] * mrot[1, j] + b[i, 2] * mrot[2, j]
    ok = math.isfinite(origin[0]) and math.isfinite(origin[1]) and math.isfinite(origin[2])
    return ok and rotation_error(rot) <= 1e-6


@njit(cache=True, nogil=True, error_model="numpy")
def mounted_scan_ranges(params: np.ndarray, qpos: np.ndarray, mount: np.ndarray, mrot: np.ndarray, rot: np.ndarray,
                        origin: np.ndarray, boxes: np.ndarray, discs: np.ndarray, *arrays: Any) -> int:
    """:func:`body_scan_ranges` with the sensor turned on the body: ``mrot`` (3, 3) is the
    body-from-sensor rotation (the mount's roll, pitch, yaw), ``rot`` receives world-from-sensor
    (the body's rotation, as :func:`body_scan_ranges` computes it, times ``mrot``)."""
    grid = TerrainGrid(*arrays[:_E_GRID])
    beams = Beams(*arrays[_E_GRID:_E_BEAMS])
    out = arrays[_E_BEAMS]
    if not _mounted_pose(qpos, mount, mrot, rot, origin):
        return -1
    terrain_kernel(grid, beams, params, origin, rot, out)
    if discs.shape[0] > 0:
        disc_pass(discs, beams, params, origin, rot, out)
    box_pass(boxes, beams, params, origin, rot, out)
    return count_finite(out)


@njit(cache=True, nogil=True, error_model="numpy")
def above_terrain(grid: TerrainGrid, beams: Beams, params: np.ndarray, origin: np.ndarray, rot: np.ndarray) -> bool:
    """Whether every ray of the scan stays above the terrain's highest point over [0, max_range]
    (the sensor above it, and ``oz + dz * max_range`` above it for every ray direction's ``dz``,
    computed with :func:`~navstress.sim._raycast.terrain_kernel`'s arithmetic): then no ray can meet
    the terrain (its top nor the side walls below the map's edge) and
    :func:`~navstress.sim._raycast.terrain_kernel` gives inf for every ray, as its own tests of the
    same values decide (a ray's march ends at ``thi <= max_range``, and ``oz + dz * t`` rounds
    monotonically in ``t``). A level fan above flat ground is the common case: one multiply-add
    per ray instead of the kernel's per-column set-up."""
    mip, moff = grid.mip, grid.mip_offsets
    gmax = mip[0, moff[moff.shape[0] - 1]]
    cos_el, sin_el, cos_az, sin_az = beams
    max_range = params[0].max_range
    oz = origin[2]
    if not oz > gmax:
        return False
    uwz = rot[2, 2]
    for a in range(cos_az.shape[0]):
        awz = rot[2, 0] * cos_az[a] + rot[2, 1] * sin_az[a]
        for k in range(cos_el.shape[0]):
            dz = cos_el[k] * awz + sin_el[k] * uwz
            if dz < 0.0 and not oz + dz * max_range > gmax:
                return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def fan_scan_ranges(params: np.ndarray, circle: int, qpos: np.ndarray, mpose: np.ndarray, rot: np.ndarray,
                    origin: np.ndarray, boxes: np.ndarray, discs: np.ndarray, *arrays: Any) -> int:
    """:func:`mounted_scan_ranges` for a lidar whose ``naz`` columns are the first of a circle of
    ``circle`` azimuth steps (a ``lidar2d`` fan: only its own beams are cast; the box and disc
    culling maps each obstacle's azimuth interval onto the circle and skips the columns past the
    fan). The same ranges, bit for bit, as the full circle's first ``naz`` columns. ``mpose`` (4,
    3): the mount's body-from-sensor rotation (rows 0-2) and position (row 3); the terrain pass is
    skipped when :func:`above_terrain` says no ray can reach the terrain."""
    grid = TerrainGrid(*arrays[:_E_GRID])
    beams = Beams(*arrays[_E_GRID:_E_BEAMS])
    out = arrays[_E_BEAMS]
    if not _mounted_pose(qpos, mpose[3], mpose[:3], rot, origin):
        return -1
    if above_terrain(grid, beams, params, origin, rot):
        out[:] = INF  # what terrain_kernel gives these rays
    else:
        terrain_kernel(grid, beams, params, origin, rot, out)
    if discs.shape[0] > 0:
        disc_pass(discs, beams, params, origin, rot, out, circle)
    box_pass(boxes, beams, params, origin, rot, out, circle)
    return count_finite(out)


@njit(cache=True, nogil=True, error_model="numpy")
def rays_ranges(grid: TerrainGrid, boxes: np.ndarray, discs: np.ndarray, origin: np.ndarray, dirs: np.ndarray,
                max_range: float, min_range: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Per-ray path for fans the scan kernels cannot take (beams not evenly around the circle):
    every ray from ``origin`` along the unit world ``dirs`` (N, 3): terrain and boxes as
    :func:`~navstress.sim._raycast.cast_rays_kernel`, then the upright cylinders ``discs``; ranges
    outside [min_range, max_range] are inf."""
    n = dirs.shape[0]
    origins = np.empty((n, 3))
    for r in range(n):
        origins[r, 0], origins[r, 1], origins[r, 2] = origin[0], origin[1], origin[2]
    cast_rays_kernel(grid, boxes, origins, dirs, max_range, out)
    for r in range(n):
        t = out[r]
        ray = Ray(origin[0], origin[1], origin[2], dirs[r, 0], dirs[r, 1], dirs[r, 2])
        for i in range(discs.shape[0]):
            tc = _ray_cylinder(Cylinder(discs[i, 0], discs[i, 1], discs[i, 2], discs[i, 3], discs[i, 4]), ray)
            if tc < t:
                t = tc
        out[r] = t if (min_range <= t <= max_range) else INF


@njit(cache=True, nogil=True, error_model="numpy")
def lower_with_discs(discs: np.ndarray, origins: np.ndarray, dirs: np.ndarray, max_range: float,
                     out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Lower the per-ray ranges ``out`` (:func:`~navstress.sim._raycast.cast_rays_kernel`'s,
    inf = none) with the hits on the upright cylinders ``discs`` within ``max_range``."""
    for r in range(origins.shape[0]):
        ray = Ray(origins[r, 0], origins[r, 1], origins[r, 2], dirs[r, 0], dirs[r, 1], dirs[r, 2])
        t = out[r]
        for i in range(discs.shape[0]):
            tc = _ray_cylinder(Cylinder(discs[i, 0], discs[i, 1], discs[i, 2], discs[i, 3], discs[i, 4]), ray)
            if tc < t and tc <= max_range:
                t = tc
        out[r] = t


@njit(cache=True, nogil=True, error_model="numpy")
def noisy_ranges32(r: np.ndarray, z: np.ndarray, std: float, min_range: float, max_range: float,
                   out: np.ndarray) -> None:  # pragma: no cover - compiled
    """A ``lidar2d`` scan's range noise: ``out`` (float32) = ``r + std * z[j]`` for the j-th
    return of ``r`` (float64, inf = none; ``z`` one standard normal per return), inf where that
    falls outside [min_range, max_range] or where ``r`` has none (the arithmetic of numpy's
    ``r[hit] += std * z``, the range filter and ``astype(float32)``, bit for bit)."""
    j = 0
    for i in range(r.shape[0]):
        v = r[i]
        if v < INF:
            v = v + std * z[j]
            j += 1
            if v < min_range or v > max_range:
                v = INF
        out[i] = v
