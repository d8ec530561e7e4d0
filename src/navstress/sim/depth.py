"""Depth camera: a pinhole ray caster against the lidar's scene (terrain, boxes) and the disc movers.

A pixel's value is its depth, the distance along the sensor's +x (the optical axis) to the first
surface through the pixel's centre (``navstress.sensors.kinds.depth``); ``inf`` where the first
surface is nearer than ``min_range_m`` or farther than ``max_range_m`` (or there is none). The
geometry is the lidar's, exact to what MuJoCo simulates (:mod:`navstress.sim.lidar`): the
heightfield's triangles and side walls, the upright boxes (two-sided), the disc movers as upright
cylinders.

Casting: the pixel (u, v) looks along d = (1, y_u, z_v) in the sensor frame (``rays(params)``),
so a ray point ``o + s R d`` lies at depth ``s``: every hit test runs on the unnormalised world
direction ``R d`` and returns the depth itself (no division by the ray's length). Two paths, same
results (the tests compare them to the bit):

* ``fast=False`` (the plain path): per pixel, the terrain march of the per-ray lidar path
  (:func:`navstress.sim._raycast.march_terrain`, the mipmap march from the sensor), every box and
  every disc;
* ``fast=True`` (default): the terrain per pixel (on a flat map the march's own closed form,
  written out here with its operations in its order, so that no call is made), then box-major
  passes for the discs and the boxes: each shape is culled once per frame (behind the camera,
  beyond ``max_range_m`` of depth, or outside one of the four planes of the field of view, each
  tested on the 8 corners of its bounding box in the sensor frame with a margin), and a shape
  wholly in front of the camera is tested only on the pixels whose centres fall in the bounding
  rectangle of its corners' projections (widened by 1e-6 pixel), which holds every pixel whose ray
  can meet it (the image of a convex solid in front of the camera is the hull of its corners'
  images); a pixel is tested only while its current depth exceeds the shape's nearest depth.

Noise (``noise_rng``): depth + N(0, ``noise_std_at_1m_m`` x depth^2), one standard normal per
valid pixel in row-major order from the ziggurat of :mod:`navstress.sim._noise` (the lidar's:
raw words of the generator's bit generator), clamped at 0. Dropouts (``dropout_rng``, drawn only
when ``dropout_prob`` > 0): one ``random()`` per valid pixel in row-major order, the pixel lost
(``inf``) where it is below ``dropout_prob``. Same generator states -> same image.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress.errors import SpecError
from navstress.sensors.base import Mount
from navstress.sensors.kinds.depth import DepthParams, rays
from navstress.sim import _noise
from navstress.sim._raybox import Cylinder, _mounted_pose, _ray_cylinder
from navstress.sim._raycast import INF, Box, Ray, TerrainGrid, _ray_box, march_terrain
from navstress.sim.lidar import LidarScene

__all__ = ["DepthCamera"]

_E_GRID = len(TerrainGrid._fields)


class Camera(NamedTuple):
    """A camera's constants as the kernels read them: the pixel directions' y (per column,
    descending) and z (per row, descending) in the sensor frame (x = 1), the intrinsics, the depth
    limits and the path (``fast``)."""

    ys: np.ndarray
    zs: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    min_depth: float
    max_depth: float
    fast: bool


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _flat_terrain(ray: Ray, t1: float, W: float, H: float, gtop: float) -> tuple[float, bool]:
    """:func:`march_terrain` (``t0 = 0``, ``above=False``) on a flat map (every height ``gtop``),
    with its operations in its order: (t, True), or (inf, False) where the march would go on to its
    cell walk (the ray starts inside the map below the surface), which the caller then runs."""
    ox, oy, oz, dx, dy, dz = ray
    tlo = 0.0
    thi = t1
    idx = 1.0 / dx if dx != 0.0 else 0.0
    idy = 1.0 / dy if dy != 0.0 else 0.0
    if dx != 0.0:
        ta = -ox * idx
        tb = (W - ox) * idx
        if ta > tb:
            ta, tb = tb, ta
        tlo = max(tlo, ta)
        thi = min(thi, tb)
    elif ox < 0.0 or ox > W:
        return INF, True
    if dy != 0.0:
        ta = -oy * idy
        tb = (H - oy) * idy
        if ta > tb:
            ta, tb = tb, ta
        tlo = max(tlo, ta)
        thi = min(thi, tb)
    elif oy < 0.0 or oy > H:
        return INF, True
    if tlo > thi:
        return INF, True
    if oz + dz * (tlo if dz >= 0.0 else thi) > gtop:
        return INF, True
    if tlo > 0.0 or oz + tlo * dz >= gtop:
        ts = tlo if dz >= 0.0 else max(tlo, (gtop - oz) / dz)
        return ts, True
    return INF, False


@njit(cache=True, nogil=True, error_model="numpy")
def _terrain_pass(grid: TerrainGrid, cam: Camera, origin: np.ndarray, rot: np.ndarray, out: np.ndarray) -> None:
    """out[v, u] = the terrain's first hit (depth) through pixel (u, v), inf if none by max_depth."""
    h, cell, mip, moff, mnx = grid.heights, grid.cell, grid.mip, grid.mip_offsets, grid.mip_widths
    ys, zs, max_depth, fast = cam.ys, cam.zs, cam.max_depth, cam.fast
    ox, oy, oz = origin[0], origin[1], origin[2]
    oxc = ox / cell
    oyc = oy / cell
    ncx = h.shape[1] - 1
    ncy = h.shape[0] - 1
    top = moff[moff.shape[0] - 1]
    gtop = mip[0, top]
    flat = fast and mip[1, top] == gtop
    W = float(ncx)
    H = float(ncy)
    if flat and 0.0 <= oxc <= W and 0.0 <= oyc <= H and oz > gtop:
        # the common case in closed form: from above a flat map, inside it, a ray meets the
        # ground where it comes down to gtop, if that point is inside the map and within range
        # (the march's answer up to rounding at the map's edge and at max_depth)
        wm = W * cell
        hm = H * cell
        gz = gtop - oz
        for v in range(out.shape[0]):
            zv = zs[v]
            for u in range(out.shape[1]):
                yu = ys[u]
                dx = rot[0, 0] + yu * rot[0, 1] + zv * rot[0, 2]
                dy = rot[1, 0] + yu * rot[1, 1] + zv * rot[1, 2]
                dz = rot[2, 0] + yu * rot[2, 1] + zv * rot[2, 2]
                ts = gz / dz
                x = ox + ts * dx
                y = oy + ts * dy
                hit = (dz < 0.0) & (ts <= max_depth) & (x >= 0.0) & (x <= wm) & (y >= 0.0) & (y <= hm)
                out[v, u] = ts if hit else INF
        return
    for v in range(out.shape[0]):
        zv = zs[v]
        for u in range(out.shape[1]):
            yu = ys[u]
            dx = rot[0, 0] + yu * rot[0, 1] + zv * rot[0, 2]
            dy = rot[1, 0] + yu * rot[1, 1] + zv * rot[1, 2]
            dz = rot[2, 0] + yu * rot[2, 1] + zv * rot[2, 2]
            ray = Ray(oxc, oyc, oz, dx / cell, dy / cell, dz)
            if flat:
                th, done = _flat_terrain(ray, max_depth, W, H, gtop)
                if not done:
                    th, _ = march_terrain(h, mip, moff, mnx, ray, 0.0, max_depth, False)
            else:
                th, _ = march_terrain(h, mip, moff, mnx, ray, 0.0, max_depth, False)
            out[v, u] = th


@njit(cache=True, nogil=True, error_model="numpy")
def _plain_shapes(boxes: np.ndarray, discs: np.ndarray, origin: np.ndarray, rot: np.ndarray, ys: np.ndarray,
                  zs: np.ndarray, out: np.ndarray) -> None:
    """Lower out[v, u] with every box's and every disc's hit through pixel (u, v)."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    for v in range(out.shape[0]):
        zv = zs[v]
        for u in range(out.shape[1]):
            yu = ys[u]
            dx = rot[0, 0] + yu * rot[0, 1] + zv * rot[0, 2]
            dy = rot[1, 0] + yu * rot[1, 1] + zv * rot[1, 2]
            dz = rot[2, 0] + yu * rot[2, 1] + zv * rot[2, 2]
            ray = Ray(ox, oy, oz, dx, dy, dz)
            best = out[v, u]
            for i in range(discs.shape[0]):
                t = _ray_cylinder(Cylinder(discs[i, 0], discs[i, 1], discs[i, 2], discs[i, 3], discs[i, 4]), ray)
                if t < best:
                    best = t
            for i in range(boxes.shape[0]):
                t = _ray_box(Box(boxes[i, 0], boxes[i, 1], boxes[i, 7], boxes[i, 8], boxes[i, 3], boxes[i, 4],
                                 boxes[i, 5], boxes[i, 6]), ray)
                if t < best:
                    best = t
            out[v, u] = best


@njit(cache=True, nogil=True, error_model="numpy")
def _footprint(corners: np.ndarray, origin: np.ndarray, rot: np.ndarray, cam: Camera, win: np.ndarray,
               scratch: np.ndarray) -> float:
    """The pixels a convex shape inside the box hull of ``corners`` (8, 3, world) can be seen
    through: ``win`` = (u0, u1, v0, v1) inclusive (empty when u1 < u0); returns the shape's
    nearest possible depth (with a margin). Culled (empty): behind the camera, beyond max_depth, or
    outside one of the field of view's four planes through the pixel centres at the image's edges."""
    ys, zs, fx, fy, cx, cy, max_depth = cam.ys, cam.zs, cam.fx, cam.fy, cam.cx, cam.cy, cam.max_depth
    n = corners.shape[0]
    xmin = INF
    xmax = -INF
    scale = 0.0
    ylo = ys[ys.shape[0] - 1]  # ys descending (u = 0 looks left: y > 0)
    yhi = ys[0]
    zlo = zs[zs.shape[0] - 1]
    zhi = zs[0]
    out_l = True
    out_r = True
    out_t = True
    out_b = True
    pxs = scratch[0]
    pys = scratch[1]
    pzs = scratch[2]
    for k in range(n):
        px = corners[k, 0] - origin[0]
        py = corners[k, 1] - origin[1]
        pz = corners[k, 2] - origin[2]
        sx = rot[0, 0] * px + rot[1, 0] * py + rot[2, 0] * pz
        sy = rot[0, 1] * px + rot[1, 1] * py + rot[2, 1] * pz
        sz = rot[0, 2] * px + rot[1, 2] * py + rot[2, 2] * pz
        pxs[k] = sx
        pys[k] = sy
        pzs[k] = sz
        xmin = min(xmin, sx)
        xmax = max(xmax, sx)
        scale = max(scale, abs(sx) + abs(sy) + abs(sz))
    m = 1e-9 * (1.0 + scale)
    for k in range(n):
        sx = pxs[k]
        sy = pys[k]
        sz = pzs[k]
        out_l = out_l and sy - yhi * sx > m * (1.0 + abs(yhi))
        out_r = out_r and sy - ylo * sx < -m * (1.0 + abs(ylo))
        out_t = out_t and sz - zhi * sx > m * (1.0 + abs(zhi))
        out_b = out_b and sz - zlo * sx < -m * (1.0 + abs(zlo))
    win[0] = 0
    win[1] = -1
    win[2] = 0
    win[3] = -1
    if xmax < -m or xmin > max_depth + m or out_l or out_r or out_t or out_b:
        return INF
    nw = ys.shape[0]
    nh = zs.shape[0]
    if xmin <= m:  # (partly) beside or behind the camera: every pixel
        win[1] = nw - 1
        win[3] = nh - 1
        return -INF
    ymn = INF
    ymx = -INF
    zmn = INF
    zmx = -INF
    for k in range(n):
        iy = pys[k] / pxs[k]
        iz = pzs[k] / pxs[k]
        ymn = min(ymn, iy)
        ymx = max(ymx, iy)
        zmn = min(zmn, iz)
        zmx = max(zmx, iz)
    e = 1e-6  # pixels
    # pixel u's centre: u + 0.5 = cx - fx * y
    u0 = max(int(math.ceil(cx - fx * ymx - 0.5 - e)), 0)
    u1 = min(int(math.floor(cx - fx * ymn - 0.5 + e)), nw - 1)
    v0 = max(int(math.ceil(cy - fy * zmx - 0.5 - e)), 0)
    v1 = min(int(math.floor(cy - fy * zmn - 0.5 + e)), nh - 1)
    win[0] = u0
    win[1] = u1
    win[2] = v0
    win[3] = v1
    return xmin - m


@njit(cache=True, nogil=True, error_model="numpy")
def _fast_shapes(boxes: np.ndarray, discs: np.ndarray, origin: np.ndarray, rot: np.ndarray, cam: Camera,
                 out: np.ndarray) -> None:
    """Lower out[v, u] with the discs' and boxes' hits, shape-major over each shape's footprint."""
    ys, zs, max_depth = cam.ys, cam.zs, cam.max_depth
    ox, oy, oz = origin[0], origin[1], origin[2]
    corners = np.empty((8, 3))
    win = np.empty(4, np.int64)
    scratch = np.empty((3, 8))
    # a hit within max_depth is within reach = max_depth * |the longest pixel direction| of the
    # camera: shapes whose bounding sphere lies farther are skipped before their footprint
    ymax = max(abs(ys[0]), abs(ys[ys.shape[0] - 1]))
    zmax = max(abs(zs[0]), abs(zs[zs.shape[0] - 1]))
    reach = max_depth * math.sqrt(1.0 + ymax * ymax + zmax * zmax) * (1.0 + 1e-9) + 1e-9
    for i in range(discs.shape[0]):
        r = discs[i, 2]
        hz = 0.5 * (discs[i, 4] - discs[i, 3])
        ex = discs[i, 0] - ox
        ey = discs[i, 1] - oy
        ez = 0.5 * (discs[i, 3] + discs[i, 4]) - oz
        if math.sqrt(ex * ex + ey * ey + ez * ez) - math.sqrt(2.0 * r * r + hz * hz) > reach:
            continue
        for k in range(8):
            corners[k, 0] = discs[i, 0] + (r if k & 1 else -r)
            corners[k, 1] = discs[i, 1] + (r if k & 2 else -r)
            corners[k, 2] = discs[i, 4] if k & 4 else discs[i, 3]
        near = _footprint(corners, origin, rot, cam, win, scratch)
        cyl = Cylinder(discs[i, 0], discs[i, 1], r, discs[i, 3], discs[i, 4])
        for v in range(win[2], win[3] + 1):
            zv = zs[v]
            for u in range(win[0], win[1] + 1):
                if out[v, u] <= near:
                    continue
                yu = ys[u]
                dx = rot[0, 0] + yu * rot[0, 1] + zv * rot[0, 2]
                dy = rot[1, 0] + yu * rot[1, 1] + zv * rot[1, 2]
                dz = rot[2, 0] + yu * rot[2, 1] + zv * rot[2, 2]
                t = _ray_cylinder(cyl, Ray(ox, oy, oz, dx, dy, dz))
                if t < out[v, u]:
                    out[v, u] = t
    # boxes: footprints first, then the boxes near first (pixels already nearer skip them)
    nb = boxes.shape[0]
    nears = np.empty(nb)
    wins = np.empty((nb, 4), np.int64)
    live = np.empty(nb, np.int64)
    nl = 0
    for i in range(nb):
        c = boxes[i, 7]
        s = boxes[i, 8]
        hx = boxes[i, 3]
        hy = boxes[i, 4]
        hz = 0.5 * (boxes[i, 6] - boxes[i, 5])
        ex = boxes[i, 0] - ox
        ey = boxes[i, 1] - oy
        ez = 0.5 * (boxes[i, 5] + boxes[i, 6]) - oz
        if math.sqrt(ex * ex + ey * ey + ez * ez) - math.sqrt(hx * hx + hy * hy + hz * hz) > reach:
            continue
        for k in range(8):
            ax = hx if k & 1 else -hx
            ay = hy if k & 2 else -hy
            corners[k, 0] = boxes[i, 0] + c * ax - s * ay
            corners[k, 1] = boxes[i, 1] + s * ax + c * ay
            corners[k, 2] = boxes[i, 6] if k & 4 else boxes[i, 5]
        # (the corners are the box's up to rounding: the footprint's margins cover it)
        nears[i] = _footprint(corners, origin, rot, cam, win, scratch)
        if win[1] >= win[0] and win[3] >= win[2]:
            wins[i, :] = win
            live[nl] = i
            nl += 1
    order = live[:nl][np.argsort(nears[live[:nl]], kind="mergesort")]
    for e in range(nl):
        i = order[e]
        _box_window(boxes, i, origin, rot, cam, wins[i], nears[i], out)


@njit(cache=True, nogil=True, error_model="numpy")
def _box_window(boxes: np.ndarray, i: int, origin: np.ndarray, rot: np.ndarray, cam: Camera, win: np.ndarray,
                near: float, out: np.ndarray) -> None:
    """Lower out[v0:v1+1, u0:u1+1] (``win`` = u0, u1, v0, v1) with box ``i``'s hits. The slab test of :func:`_ray_box` in
    the box's frame, the pixel's direction there linear in (y_u, z_v) and one reciprocal per axis
    (hits within rounding of ``_ray_box``'s); rows whose pixels all are nearer than ``near`` are
    skipped. A sensor exactly on one of the box's face planes takes ``_ray_box`` itself (a ray
    parallel to that face would give 0 x inf there)."""
    ys, zs = cam.ys, cam.zs
    u0, u1, v0, v1 = win[0], win[1], win[2], win[3]
    ox, oy, oz = origin[0], origin[1], origin[2]
    c = boxes[i, 7]
    s = boxes[i, 8]
    hx = boxes[i, 3]
    hy = boxes[i, 4]
    zb = boxes[i, 5]
    zt = boxes[i, 6]
    px = ox - boxes[i, 0]
    py = oy - boxes[i, 1]
    lx = c * px + s * py
    ly = -s * px + c * py
    if lx == hx or lx == -hx or ly == hy or ly == -hy or oz == zb or oz == zt:
        box = Box(boxes[i, 0], boxes[i, 1], c, s, hx, hy, zb, zt)
        for v in range(v0, v1 + 1):
            zv = zs[v]
            for u in range(u0, u1 + 1):
                yu = ys[u]
                dx = rot[0, 0] + yu * rot[0, 1] + zv * rot[0, 2]
                dy = rot[1, 0] + yu * rot[1, 1] + zv * rot[1, 2]
                dz = rot[2, 0] + yu * rot[2, 1] + zv * rot[2, 2]
                t = _ray_box(box, Ray(ox, oy, oz, dx, dy, dz))
                if t < out[v, u]:
                    out[v, u] = t
        return
    a0 = c * rot[0, 0] + s * rot[1, 0]
    a1 = c * rot[0, 1] + s * rot[1, 1]
    a2 = c * rot[0, 2] + s * rot[1, 2]
    b0 = -s * rot[0, 0] + c * rot[1, 0]
    b1 = -s * rot[0, 1] + c * rot[1, 1]
    b2 = -s * rot[0, 2] + c * rot[1, 2]
    g0 = rot[2, 0]
    g1 = rot[2, 1]
    g2 = rot[2, 2]
    xl = -hx - lx
    xh = hx - lx
    yl = -hy - ly
    yh = hy - ly
    zl = zb - oz
    zh = zt - oz
    for v in range(v0, v1 + 1):
        zv = zs[v]
        row = out[v]
        far = False
        for u in range(u0, u1 + 1):
            far |= row[u] > near
        if not far:
            continue
        ax = a0 + zv * a2
        bx = b0 + zv * b2
        gx = g0 + zv * g2
        for u in range(u0, u1 + 1):  # branch-free: vectorised
            yu = ys[u]
            ix = 1.0 / (ax + yu * a1)
            iy = 1.0 / (bx + yu * b1)
            iz = 1.0 / (gx + yu * g1)
            tx1 = xl * ix
            tx2 = xh * ix
            ty1 = yl * iy
            ty2 = yh * iy
            tz1 = zl * iz
            tz2 = zh * iz
            tn = max(max(min(tx1, tx2), min(ty1, ty2)), min(tz1, tz2))
            tf = min(min(max(tx1, tx2), max(ty1, ty2)), max(tz1, tz2))
            t = tn if tn >= 0.0 else tf
            t = t if (tn <= tf) & (tf >= 0.0) else INF
            row[u] = min(row[u], t)


@njit(cache=True, nogil=True, error_model="numpy")
def render_kernel(qpos: np.ndarray, mxyz: np.ndarray, mrot: np.ndarray, boxes: np.ndarray, discs: np.ndarray,
                  rot: np.ndarray, origin: np.ndarray, out: np.ndarray, *arrays: Any) -> int:
    """One frame's noise-free depths into ``out`` (H, W) float64 (inf: no return); returns the
    number of valid pixels, or -1 (nothing computed) if the pose is bad. ``rot``, ``origin``
    receive the sensor's world pose; ``arrays``: a :class:`TerrainGrid`'s fields, then a
    :class:`Camera`'s (flattened as ``_raybox``'s entries take them: numba dispatches tuples of
    arrays slower)."""
    grid = TerrainGrid(*arrays[:_E_GRID])
    cam = Camera(*arrays[_E_GRID:])
    if not _mounted_pose(qpos, mxyz, mrot, rot, origin):
        return -1
    return _cast(grid, cam, boxes, discs, rot, origin, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _cast(grid: TerrainGrid, cam: Camera, boxes: np.ndarray, discs: np.ndarray, rot: np.ndarray, origin: np.ndarray,
          out: np.ndarray) -> int:
    _terrain_pass(grid, cam, origin, rot, out)
    if cam.fast:
        _fast_shapes(boxes, discs, origin, rot, cam, out)
    else:
        _plain_shapes(boxes, discs, origin, rot, cam.ys, cam.zs, out)
    min_depth, max_depth = cam.min_depth, cam.max_depth
    n = 0
    for v in range(out.shape[0]):
        for u in range(out.shape[1]):
            d = out[v, u]
            if min_depth <= d <= max_depth:
                n += 1
            else:
                out[v, u] = INF
    return n


@njit(cache=True, nogil=True, error_model="numpy")
def _finish(depth: np.ndarray, noise: np.ndarray, std: float, drop: np.ndarray, p: float, img: np.ndarray) -> None:
    """img = depth as float32 with noise[k] * std * d^2 added to the k-th valid pixel (clamped at
    0) and the pixels with drop[k] < p lost (empty arrays: none)."""
    k = 0
    use_noise = noise.shape[0] > 0
    use_drop = drop.shape[0] > 0
    for v in range(depth.shape[0]):
        for u in range(depth.shape[1]):
            d = depth[v, u]
            if d < INF:
                if use_noise:
                    d = max(d + std * d * d * noise[k], 0.0)
                if use_drop and drop[k] < p:
                    d = INF
                k += 1
            img[v, u] = d


class DepthCamera:
    """A depth camera on a scene (:class:`~navstress.sim.lidar.LidarScene`), with ``params``
    (:class:`~navstress.sensors.kinds.depth.DepthParams`). ``fast=False``: the plain path (every
    shape per pixel, see the module docstring); same images."""

    def __init__(self, scene: LidarScene, params: DepthParams, *, fast: bool = True) -> None:
        if not isinstance(scene, LidarScene):
            raise SpecError("scene", type(scene).__name__, "a LidarScene")
        if not isinstance(params, DepthParams):
            raise SpecError("params", type(params).__name__, "DepthParams")
        self.scene = scene
        self.params = params
        self.fast = bool(fast)
        r = rays(params)
        self._ys = np.ascontiguousarray(r[0, :, 1])
        self._zs = np.ascontiguousarray(r[:, 0, 2])
        fx, fy, cx, cy = params.intrinsics()
        self._cam = Camera(self._ys, self._zs, float(fx), float(fy), float(cx), float(cy), float(params.min_range_m),
                           float(params.max_range_m), self.fast)
        self._out = np.empty((params.height, params.width))
        self.rotation = np.empty((3, 3))  # the last frame's sensor pose (world from sensor)
        self.origin = np.empty(3)
        self._mount_key: Any = None
        self._mxyz = np.zeros(3)
        self._mrot = np.eye(3)

    def _mount(self, mount: Mount) -> None:
        key = (mount.xyz, mount.rpy)
        if key != self._mount_key:
            self._mxyz = np.array(mount.xyz, dtype=np.float64)
            self._mrot = np.ascontiguousarray(mount.rotation(), dtype=np.float64)
            self._mount_key = key

    def depths(self, qpos: np.ndarray, mount: Mount, *, discs: np.ndarray | None = None,
               scene_boxes: np.ndarray | None = None) -> np.ndarray:
        """Noise-free depths (height, width) float64 (a view of an internal buffer, valid until the
        next call), inf where there is no return."""
        self._cast(qpos, mount, discs, scene_boxes)
        return self._out

    def _cast(self, qpos: np.ndarray, mount: Mount, discs: np.ndarray | None,
              scene_boxes: np.ndarray | None) -> int:
        if not isinstance(mount, Mount):
            raise SpecError("mount", mount, "a navstress.sensors.Mount")
        self._mount(mount)
        s = self.scene
        q = np.asarray(qpos)
        if q.dtype != np.float64 or q.ndim != 1 or q.shape[0] < 7:
            raise SpecError("qpos", getattr(qpos, "shape", qpos), "a float64 (>= 7,) body pose")
        boxes = s.boxes if scene_boxes is None else scene_boxes
        if boxes.ndim != 2 or boxes.shape[1] != 9 or boxes.dtype != np.float64:
            raise SpecError("scene_boxes", getattr(boxes, "shape", None), "float64 rows of LidarScene.boxes' 9 columns")
        d = self.scene.discs if discs is None else np.ascontiguousarray(discs, dtype=np.float64).reshape(-1, 5)
        g = s.grid
        n: int = render_kernel(q, self._mxyz, self._mrot, boxes, d, self.rotation, self.origin, self._out, *g,
                               *self._cam)
        if n < 0:
            raise SpecError("qpos", q[:7].tolist(), "a finite position and a unit quaternion (w, x, y, z)")
        return n

    def render(self, qpos: np.ndarray, mount: Mount, noise_rng: np.random.Generator | None,
               dropout_rng: np.random.Generator | None, *, discs: np.ndarray | None = None,
               scene_boxes: np.ndarray | None = None) -> np.ndarray:
        """One frame from the body pose ``qpos[:7]`` = (x, y, z, qw, qx, qy, qz) (MuJoCo's), the
        camera at ``mount`` on the body: (height, width) float32 depths, inf = no return. ``discs``
        (rows x, y, radius, z bottom, z top) and ``scene_boxes`` (``LidarScene.boxes``' 9 columns:
        every box at render time) as :meth:`navstress.sim.lidar.Lidar.scan_body` takes them.
        Noise from ``noise_rng`` and dropouts from ``dropout_rng`` (module docstring); None: none."""
        n = self._cast(qpos, mount, discs, scene_boxes)
        p = self.params
        noise = _EMPTY
        if noise_rng is not None and p.noise_std_at_1m_m > 0 and n > 0:
            noise = _noise.standard_normals(noise_rng, n)
        drop = _EMPTY
        if dropout_rng is not None and p.dropout_prob > 0 and n > 0:
            drop = dropout_rng.random(n)
        img = np.empty(self._out.shape, np.float32)
        _finish(self._out, noise, float(p.noise_std_at_1m_m), drop, float(p.dropout_prob), img)
        return img


_EMPTY = np.zeros(0)
