"""A synthetic closed loop for ``reference-2d-v1``: analytic layouts (circles and wall segments),
exact LaserScans cast against them, and the robot moved by the commanded velocities (a
unicycle; an ackermann base's commands are checked against its steering limit). No simulator:
the unit tests of the navigator's behaviour run in well under a second each."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from navstress.nav.api import Command, Imu, LaserScan, NavMission, Observation, Odometry, PoseReading, Status
from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.sensors.kinds.lidar2d import Lidar2dParams


def jackal(**sensor: object) -> RobotSpec:
    return with_sensors(profile("jackal"), sensors=[{"name": "front_laser", "kind": "lidar2d", "profile": "ust10",
                                                     **sensor}])


def f1tenth() -> RobotSpec:
    return with_sensors(profile("f1tenth"), sensors=[{"name": "laser", "kind": "lidar2d", "profile": "ust10"}])


@dataclass
class Layout:
    """Circles (x, y, r) and segments (x1, y1, x2, y2)."""

    circles: list[tuple[float, float, float]] = field(default_factory=list)
    segments: list[tuple[float, float, float, float]] = field(default_factory=list)

    def box(self, x0: float, y0: float, x1: float, y1: float, gap: tuple[float, float] | None = None) -> "Layout":
        """The four walls of a rectangle (no gap), or with a gap [a, b] in its bottom wall's x."""
        if gap is None:
            self.segments.append((x0, y0, x1, y0))
        else:
            self.segments += [(x0, y0, gap[0], y0), (gap[1], y0, x1, y0)]
        self.segments += [(x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]
        return self

    def cast(self, ox: float, oy: float, angles: np.ndarray) -> np.ndarray:
        """The distance along each ray from (ox, oy) to the first surface (inf: none)."""
        dx, dy = np.cos(angles), np.sin(angles)
        best = np.full(angles.shape, np.inf)
        for cx, cy, r in self.circles:
            fx, fy = ox - cx, oy - cy
            b = fx * dx + fy * dy
            c = fx * fx + fy * fy - r * r
            disc = b * b - c
            t = -b - np.sqrt(np.maximum(disc, 0.0))
            best = np.where((disc >= 0) & (t > 0) & (t < best), t, best)
        for x1, y1, x2, y2 in self.segments:
            ex, ey = x2 - x1, y2 - y1
            den = dx * ey - dy * ex
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((x1 - ox) * ey - (y1 - oy) * ex) / den
                u = ((x1 - ox) * dy - (y1 - oy) * dx) / den
            ok = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1) & (t < best)
            best = np.where(ok, t, best)
        return best

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest surface."""
        d = math.inf
        for cx, cy, r in self.circles:
            d = min(d, math.hypot(x - cx, y - cy) - r)
        for x1, y1, x2, y2 in self.segments:
            ex, ey = x2 - x1, y2 - y1
            u = min(1.0, max(0.0, ((x - x1) * ex + (y - y1) * ey) / (ex * ex + ey * ey)))
            d = min(d, math.hypot(x - x1 - u * ex, y - y1 - u * ey))
        return d


@dataclass
class Outcome:
    status: Status | None
    t: float
    poses: np.ndarray  # (n, 3) x, y, yaw
    commands: list[tuple[float, float]]
    min_clearance: float


def scan_of(layout: Layout, robot: RobotSpec, x: float, y: float, yaw: float, t: float) -> LaserScan:
    """The scan of the robot's first lidar2d sensor at (x, y, yaw), noise-free."""
    sensor = next(s for s in robot.sensors or () if s.kind == "lidar2d")
    p = Lidar2dParams(**sensor.params)
    mx, my, mz = sensor.mount.xyz
    ox, oy = x + mx * math.cos(yaw) - my * math.sin(yaw), y + mx * math.sin(yaw) + my * math.cos(yaw)
    ang = p.angle_min + p.angle_increment * np.arange(p.beams)
    r = layout.cast(ox, oy, yaw + sensor.mount.rpy[2] + ang)
    r = np.where((r >= p.min_range_m) & (r <= p.max_range_m), r, np.inf).astype(np.float32)
    return LaserScan(t, r, p.angle_min, p.angle_increment, p.min_range_m, p.max_range_m,
                     (mx, my, mz), tuple(sensor.mount.rpy), sensor.name)  # type: ignore[arg-type]


def drive(nav: object, layout: Layout, robot: RobotSpec, start: tuple[float, float, float],
          goal: tuple[float, float], *, seed: int = 0, timeout_s: float = 60.0, tolerance: float = 0.5,
          rate_hz: float = 10.0) -> Outcome:
    """Reset ``nav`` and run it in the synthetic loop until it answers a Status or time runs out."""
    nav.reset(NavMission(start, goal, tolerance), robot, seed=seed)  # type: ignore[attr-defined]
    x, y, yaw = start
    dt = 1.0 / rate_hz
    poses, cmds = [(x, y, yaw)], []
    clear = layout.clearance(x, y)
    name = next(s.name for s in robot.sensors or () if s.kind == "lidar2d")
    t = 0.0
    v = w = 0.0
    while t <= timeout_s:
        scan = scan_of(layout, robot, x, y, yaw, t)
        obs = Observation(t, Odometry(t, x - start[0], y - start[1], yaw, v, w), Imu(t, 0.0, 0.0, yaw, (0.0, 0.0, w)),
                          PoseReading(t, x, y, robot.wheel_radius_m, yaw, 0.0, 0.0),
                          readings={name: (scan,)})
        out = nav.step(obs)  # type: ignore[attr-defined]
        if isinstance(out, Status):
            return Outcome(out, t, np.array(poses), cmds, clear)
        assert isinstance(out, Command)
        v, w = out.v, out.omega
        cmds.append((v, w))
        if abs(w) > 1e-9:
            x += v / w * (math.sin(yaw + w * dt) - math.sin(yaw))
            y -= v / w * (math.cos(yaw + w * dt) - math.cos(yaw))
        else:
            x += v * dt * math.cos(yaw)
            y += v * dt * math.sin(yaw)
        yaw = math.remainder(yaw + w * dt, math.tau)
        poses.append((x, y, yaw))
        clear = min(clear, layout.clearance(x, y))
        t += dt
    return Outcome(None, t, np.array(poses), cmds, clear)
