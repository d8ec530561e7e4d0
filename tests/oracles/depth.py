"""Analytic depth images (test code only): what a pinhole depth camera sees of planes, upright
boxes and upright cylinders, written from the geometry alone (numpy, no navstress kernels), for
``navstress.sim.depth.DepthCamera`` to be compared with.

Conventions (``navstress.sensors.kinds.depth``): pixel (u, v) of a W x H image with intrinsics
(fx, fy, cx, cy) looks along (1, -(u + 0.5 - cx) / fx, -(v + 0.5 - cy) / fy) in the sensor frame
(x forward, y left, z up); its value is the depth (sensor x) of the first surface, inf when that
depth is outside [min_depth, max_depth] or there is none. The sensor frame is placed by the body
pose (x, y, z, qw, qx, qy, qz) and the mount (xyz, rpy: R = Rz(yaw) Ry(pitch) Rx(roll)).
"""

from __future__ import annotations

import math

import numpy as np


def intrinsics(width: int, height: int, hfov_deg: float, vfov_deg: float | None = None) -> tuple[float, float,
                                                                                                  float, float]:
    fx = width / 2 / math.tan(math.radians(hfov_deg) / 2)
    fy = fx if vfov_deg is None else height / 2 / math.tan(math.radians(vfov_deg) / 2)
    return fx, fy, width / 2, height / 2


def pixel_dirs(width: int, height: int, hfov_deg: float, vfov_deg: float | None = None) -> np.ndarray:
    """(H, W, 3) directions in the sensor frame, x component 1."""
    fx, fy, cx, cy = intrinsics(width, height, hfov_deg, vfov_deg)
    d = np.empty((height, width, 3))
    d[..., 0] = 1.0
    d[..., 1] = -((np.arange(width) + 0.5 - cx) / fx)[None, :]
    d[..., 2] = -((np.arange(height) + 0.5 - cy) / fy)[:, None]
    return d


def quat_matrix(qw: float, qx: float, qy: float, qz: float) -> np.ndarray:
    """World-from-body rotation of a unit quaternion (w, x, y, z)."""
    n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    w, x, y, z = qw / n, qx / n, qy / n, qz / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) @ Ry(pitch) @ Rx(roll), from the three elementary rotations."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw),
                              math.sin(yaw))
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def sensor_pose(qpos: np.ndarray, xyz: tuple[float, float, float],
                rpy: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(origin, world-from-sensor rotation) of a camera at mount (xyz, rpy) on the body qpos[:7]."""
    rb = quat_matrix(*qpos[3:7])
    return np.asarray(qpos[:3], float) + rb @ np.asarray(xyz, float), rb @ rpy_matrix(*rpy)


def world_dirs(rot: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Pixel directions in the world (same scale: depth s reaches o + s * d)."""
    return dirs @ rot.T


def plane_z(origin: np.ndarray, d: np.ndarray, z: float, xlim: tuple[float, float] = (-math.inf, math.inf),
            ylim: tuple[float, float] = (-math.inf, math.inf)) -> np.ndarray:
    """Depth to the horizontal plane z (within the x/y limits), seen from above; inf if none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (z - origin[2]) / d[..., 2]
    x = origin[0] + s * d[..., 0]
    y = origin[1] + s * d[..., 1]
    ok = (d[..., 2] < 0) & (s >= 0) & (x >= xlim[0]) & (x <= xlim[1]) & (y >= ylim[0]) & (y <= ylim[1])
    return np.where(ok, s, np.inf)


def box(origin: np.ndarray, d: np.ndarray, x: float, y: float, yaw: float, hx: float, hy: float, zb: float,
        zt: float) -> np.ndarray:
    """Depth to an upright box (centre x, y, yaw, half sides, bottom, top): the first of its faces
    that the ray crosses (the exit face from inside); inf if none."""
    c, s = math.cos(yaw), math.sin(yaw)
    px, py = origin[0] - x, origin[1] - y
    lo = np.array([c * px + s * py, -s * px + c * py, origin[2]])
    ld = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], axis=-1)
    lows = np.array([-hx, -hy, zb])
    highs = np.array([hx, hy, zt])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lows - lo) / ld
        t2 = (highs - lo) / ld
    inside_slab = (lo >= lows) & (lo <= highs)
    tmin = np.where(ld == 0, np.where(inside_slab, -np.inf, np.inf), np.minimum(t1, t2))
    tmax = np.where(ld == 0, np.where(inside_slab, np.inf, -np.inf), np.maximum(t1, t2))
    tn = tmin.max(axis=-1)
    tf = tmax.min(axis=-1)
    hit = (tn <= tf) & (tf >= 0)
    return np.where(hit, np.where(tn >= 0, tn, tf), np.inf)


def cylinder(origin: np.ndarray, d: np.ndarray, x: float, y: float, r: float, zb: float, zt: float) -> np.ndarray:
    """Depth to an upright solid cylinder (outside it): side wall or caps, the nearest; inf if none."""
    ex, ey = origin[0] - x, origin[1] - y
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = ex * d[..., 0] + ey * d[..., 1]
    c = ex * ex + ey * ey - r * r
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
    z = origin[2] + t * d[..., 2]
    side = np.where((disc >= 0) & (a > 0) & (t >= 0) & (z >= zb) & (z <= zt), t, np.inf)
    best = side
    for zc in (zb, zt):
        with np.errstate(divide="ignore", invalid="ignore"):
            tc = (zc - origin[2]) / d[..., 2]
        cx = ex + tc * d[..., 0]
        cy = ey + tc * d[..., 1]
        best = np.where((tc >= 0) & (cx * cx + cy * cy <= r * r) & (tc < best), tc, best)
    return best


def cut(depth: np.ndarray, min_depth: float, max_depth: float) -> np.ndarray:
    """The first surface's depth where it is within [min_depth, max_depth], else inf."""
    return np.where((depth >= min_depth) & (depth <= max_depth), depth, np.inf)
