"""Analytic ranges of a ``lidar2d`` fan (and of any set of rays: the ``lidar3d`` oracle uses the same
intersections) in scenes whose answer geometry gives in closed form: a ground plane
``z = a x + b y + c``, oriented boxes (yaw about z) and upright cylinders. Plain numpy, one ray at a
time, independent of the scan kernels. Test code only."""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def quat_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(w, x, y, z) of Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy])


def rot_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll) written out from the three elementary rotations."""
    cx, sx, cy_, sy_, cz, sz = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw),
                                math.sin(yaw))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy_, 0, sy_], [0, 1, 0], [-sy_, 0, cy_]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def qpos(x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """A body pose as MuJoCo's free joint holds it."""
    return np.concatenate([[x, y, z], quat_rpy(roll, pitch, yaw)]).astype(np.float64)


def fan(angle_min: float, increment: float, beams: int) -> np.ndarray:
    """(beams, 3) unit directions of a planar fan in the sensor frame."""
    a = angle_min + increment * np.arange(beams)
    return np.stack([np.cos(a), np.sin(a), np.zeros(beams)], axis=1)


def ray_plane(o: np.ndarray, d: np.ndarray, plane: tuple[float, float, float]) -> float:
    """Distance along unit ``d`` from ``o`` to the plane z = a x + b y + c (inf: parallel or behind)."""
    a, b, c = plane
    den = d[2] - a * d[0] - b * d[1]
    num = a * o[0] + b * o[1] + c - o[2]
    if den == 0.0:
        return math.inf
    t = num / den
    return t if t >= 0.0 else math.inf


def ray_box(o: np.ndarray, d: np.ndarray, box: tuple[float, ...]) -> float:
    """Slab test against a box (x, y, yaw, half x, half y, z bottom, z top), faces two-sided."""
    x, y, yaw, hx, hy, zb, zt = box
    c, s = math.cos(yaw), math.sin(yaw)
    px, py = o[0] - x, o[1] - y
    lo = np.array([-hx, -hy, zb])
    hi = np.array([hx, hy, zt])
    oo = np.array([c * px + s * py, -s * px + c * py, o[2]])
    dd = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])
    t0, t1 = -math.inf, math.inf
    for k in range(3):
        if dd[k] == 0.0:
            if not lo[k] <= oo[k] <= hi[k]:
                return math.inf
            continue
        a, b = (lo[k] - oo[k]) / dd[k], (hi[k] - oo[k]) / dd[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    if t1 < max(t0, 0.0):
        return math.inf
    return t0 if t0 >= 0.0 else t1


def ray_cylinder(o: np.ndarray, d: np.ndarray, cyl: tuple[float, float, float, float, float]) -> float:
    """Upright solid cylinder (x, y, radius, z bottom, z top), side and caps."""
    cx, cy, r, zb, zt = cyl
    best = math.inf
    ex, ey = o[0] - cx, o[1] - cy
    a = d[0] ** 2 + d[1] ** 2
    if a > 0:
        b = ex * d[0] + ey * d[1]
        disc = b * b - a * (ex * ex + ey * ey - r * r)
        if disc >= 0:
            for t in ((-b - math.sqrt(disc)) / a, (-b + math.sqrt(disc)) / a):
                if t >= 0 and zb <= o[2] + t * d[2] <= zt:
                    best = min(best, t)
    if d[2] != 0:
        for zc in (zb, zt):
            t = (zc - o[2]) / d[2]
            if 0 <= t < best and (ex + t * d[0]) ** 2 + (ey + t * d[1]) ** 2 <= r * r:
                best = t
    return best


def obstacle_shapes(obstacles: Any) -> dict[str, tuple[tuple[float, ...], ...]]:
    """The ``boxes`` and ``discs`` keywords of :func:`ranges` for world obstacles, from their own
    fields (``Obstacle.shape``: a box (x, y, yaw, half sides, z bottom, z top) or an upright
    cylinder (x, y, radius, z bottom, z top), base at ``z``), not from the lidar's scene."""
    boxes = tuple((o.x, o.y, o.yaw, o.size[0] / 2, o.size[1] / 2, o.z, o.z + o.size[2]) for o in obstacles
                  if o.shape == "box")
    discs = tuple((o.x, o.y, o.size[0] / 2, o.z, o.z + o.size[2]) for o in obstacles if o.shape == "cylinder")
    return {"boxes": boxes, "discs": discs}


def ranges(origin: np.ndarray, dirs_world: np.ndarray, *, plane: tuple[float, float, float] | None,
           boxes: tuple[tuple[float, ...], ...] = (), discs: tuple[tuple[float, ...], ...] = (),
           min_range: float, max_range: float, size: float = 40.0) -> np.ndarray:
    """The first hit along each unit world direction, inf outside [min_range, max_range]; the
    ground is the plane over the map [0, size] x [0, size] only (the sensor inside it)."""
    out = np.empty(dirs_world.shape[0])
    for i, d in enumerate(dirs_world):
        t = ray_plane(origin, d, plane) if plane is not None else math.inf
        if math.isfinite(t) and not all(0.0 <= origin[k] + t * d[k] <= size for k in (0, 1)):
            t = math.inf
        for b in boxes:
            t = min(t, ray_box(origin, d, b))
        for c in discs:
            t = min(t, ray_cylinder(origin, d, c))
        out[i] = t if min_range <= t <= max_range else math.inf
    return out


def sensor_pose(q: np.ndarray, mount_xyz: tuple[float, float, float],
                mount_rpy: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(origin, world-from-sensor rotation) of a sensor mounted on the body at ``q``."""
    w, x, y, z = q[3:7]
    rb = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                   [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                   [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return q[:3] + rb @ np.array(mount_xyz), rb @ rot_rpy(*mount_rpy)
