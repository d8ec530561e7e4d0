"""Synthetic observations for navigator tests: analytic scenes (a plane ground z = c + a x + b y,
axis-aligned boxes) ray-cast in numpy, and a tiny kinematic closed loop (unicycle on the plane).

Independent of the navigator's own frame code: ray directions are rotated with scipy's
``Rotation.from_euler("ZYX", [yaw, pitch, roll])``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from navstress.nav.api import Command, Imu, LidarScan, NavMission, Observation, Odometry, PoseReading, Status
from navstress.robot import RobotSpec

MOUNT = (0.35, 0.0, 0.75)
BASE_H = 0.265  # robot frame origin above the ground in these scenes


@dataclass(frozen=True)
class Scene:
    """Ground plane z = c + a x + b y, boxes (xmin, ymin, zmin, xmax, ymax, zmax)."""

    a: float = 0.0
    b: float = 0.0
    c: float = 0.0
    boxes: tuple[tuple[float, float, float, float, float, float], ...] = ()

    def ground_z(self, x: float, y: float) -> float:
        return self.c + self.a * x + self.b * y


def ray_dirs(channels: int = 32, azimuths: int = 360) -> np.ndarray:
    el = np.radians(np.linspace(-30.7, 10.7, channels))
    az = np.radians(np.arange(azimuths) * 360.0 / azimuths)
    E, A = np.meshgrid(el, az, indexing="ij")
    return np.stack([np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E)], -1).reshape(-1, 3)


def scan_points(scene: Scene, x: float, y: float, z: float, yaw: float, pitch: float = 0.0, roll: float = 0.0,
                *, channels: int = 32, azimuths: int = 360, max_range: float = 40.0,
                noise: float = 0.0, gen: np.random.Generator | None = None) -> np.ndarray:
    """Sensor-frame hit points (float32) of a lidar at MOUNT on a robot at the given map pose."""
    rot = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
    d_s = ray_dirs(channels, azimuths)
    d = d_s @ rot.T
    o = np.array([x, y, z]) + rot @ np.array(MOUNT)
    t = np.full(len(d), np.inf)
    den = d[:, 2] - scene.a * d[:, 0] - scene.b * d[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        tg = (scene.c + scene.a * o[0] + scene.b * o[1] - o[2]) / den
    t = np.where((tg > 0) & np.isfinite(tg), tg, t)
    for bx in scene.boxes:
        lo, hi = np.array(bx[:3]), np.array(bx[3:])
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - o) / d
            t2 = (hi - o) / d
        tn = np.nanmax(np.minimum(t1, t2), axis=1)
        tf = np.nanmin(np.maximum(t1, t2), axis=1)
        hit = (tn <= tf) & (tf > 0) & (tn > 0)
        t = np.where(hit & (tn < t), tn, t)
    keep = t <= max_range
    r = t[keep]
    if noise > 0 and gen is not None:
        r = r + gen.normal(0.0, noise, r.shape)
    return (d_s[keep] * r[:, None]).astype(np.float32)


def grid_points(scene: Scene, x0: float, x1: float, y0: float, y1: float, step: float = 0.05,
                skip: tuple[float, float, float, float] | None = None) -> np.ndarray:
    """Dense map-frame ground points over a rectangle (minus ``skip``), plus every box's surface."""
    xs, ys = np.meshgrid(np.arange(x0, x1, step) + step / 2, np.arange(y0, y1, step) + step / 2)
    xs, ys = xs.ravel(), ys.ravel()
    if skip is not None:
        m = ~((xs >= skip[0]) & (xs < skip[1]) & (ys >= skip[2]) & (ys < skip[3]))
        xs, ys = xs[m], ys[m]
    pts = [np.stack([xs, ys, scene.c + scene.a * xs + scene.b * ys], 1)]
    for bx in scene.boxes:
        bxs, bys = np.meshgrid(np.arange(bx[0], bx[3] + 1e-9, step), np.arange(bx[1], bx[4] + 1e-9, step))
        for zz in np.arange(bx[2], bx[5] + 1e-9, 0.2):
            pts.append(np.stack([bxs.ravel(), bys.ravel(), np.full(bxs.size, zz)], 1))
    return np.concatenate(pts)


def to_sensor(points_map: np.ndarray, x: float, y: float, z: float, yaw: float) -> np.ndarray:
    """Map-frame points into the sensor frame of a level robot at (x, y, z, yaw)."""
    rot = Rotation.from_euler("ZYX", [yaw, 0.0, 0.0]).as_matrix()
    o = np.array([x, y, z]) + rot @ np.array(MOUNT)
    return ((points_map - o) @ rot).astype(np.float32)


def box_hits_footprint(scene: Scene, x: float, y: float, yaw: float, robot: RobotSpec) -> bool:
    """True footprint (real robot) overlaps a box's base (sampled at 2 cm)."""
    u = np.linspace(-robot.length_m / 2, robot.length_m / 2, 57)
    v = np.linspace(-robot.width_m / 2, robot.width_m / 2, 34)
    U, V = np.meshgrid(u, v)
    px = x + U * math.cos(yaw) - V * math.sin(yaw)
    py = y + U * math.sin(yaw) + V * math.cos(yaw)
    return any(bool(((px > b[0]) & (px < b[3]) & (py > b[1]) & (py < b[4])).any()) for b in scene.boxes)


@dataclass
class LoopResult:
    true: np.ndarray  # (N, 4) t, x, y, yaw
    commands: list[Command | Status] = field(default_factory=list)
    observations: list[Observation] = field(default_factory=list)
    collided: bool = False

    @property
    def final(self) -> Command | Status:
        return self.commands[-1]


def closed_loop(nav: object, scene: Scene, mission: NavMission, *, seconds: float, seed: int = 0,
                robot: RobotSpec | None = None, believed: RobotSpec | None = None, pose_noise: float = 0.0,
                odom_scale: float = 1.0, channels: int = 16, azimuths: int = 180, keep_obs: bool = False,
                dt: float = 0.1) -> LoopResult:
    """Drive ``nav`` (already constructed) in ``scene`` with a perfect unicycle; odometry may
    under-read distances (``odom_scale``), the pose sensor may be noisy."""
    robot = robot or RobotSpec()
    gen = np.random.default_rng(seed)
    nav.reset(mission, believed or robot, seed=seed)  # type: ignore[attr-defined]
    x, y, yaw = mission.start
    ox = oy = oyaw = 0.0
    res = LoopResult(true=np.zeros((0, 4)))
    rows = []
    v = w = 0.0
    t = 0.0
    while t <= seconds + 1e-9:
        z = scene.ground_z(x, y) + BASE_H
        pts = scan_points(scene, x, y, z, yaw, channels=channels, azimuths=azimuths)
        pr = None
        if pose_noise > 0:
            pr = PoseReading(t, x + gen.normal(0, pose_noise), y + gen.normal(0, pose_noise), z,
                             yaw + gen.normal(0, pose_noise / 5), 0.0, 0.0)
        else:
            pr = PoseReading(t, x, y, z, yaw, 0.0, 0.0)
        obs = Observation(t, Odometry(t, ox, oy, oyaw, v, w), Imu(t, 0.0, 0.0, yaw, (0.0, 0.0, w)), pr,
                          (LidarScan(t, pts, MOUNT),))
        out = nav.step(obs)  # type: ignore[attr-defined]
        res.commands.append(out)
        if keep_obs:
            res.observations.append(obs)
        rows.append((t, x, y, yaw))
        if isinstance(out, Status):
            break
        v = float(np.clip(out.v, -robot.max_speed_mps, robot.max_speed_mps))
        w = float(np.clip(out.omega, -robot.max_yaw_rate_rps, robot.max_yaw_rate_rps))
        nx = x + v * dt * math.cos(yaw + w * dt / 2)
        ny = y + v * dt * math.sin(yaw + w * dt / 2)
        # odometry frame: starts at 0, under-reads distances by odom_scale
        ox += odom_scale * v * dt * math.cos(oyaw + w * dt / 2)
        oy += odom_scale * v * dt * math.sin(oyaw + w * dt / 2)
        oyaw += w * dt
        x, y, yaw = nx, ny, yaw + w * dt
        if box_hits_footprint(scene, x, y, yaw, robot):
            res.collided = True
        t = round(t + dt, 9)
    res.true = np.array(rows)
    return res
