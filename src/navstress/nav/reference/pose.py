"""POM: the perceived pose, fused from odometry increments and the pose sensor, with a history.

Frames: map (the pose sensor's frame, x east, y north, z up), robot (x forward, y left, z up),
sensor (axes as the robot's, origin at the lidar mount). Attitude is Z-Y-X Euler
(``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``), the convention of the run traces.

The filter is a complementary filter on (x, y, z, yaw): every odometry increment, expressed in
the robot frame, is applied to the estimate (x, y at the estimated heading; z along the current
pitch and roll), so wheel slip and odometry noise accumulate as drift; every pose reading pulls
the estimate toward it with gain ``1 - exp(-dt / tau)`` (``dt`` the time since the previous
reading; z with the x/y time constant, the first reading sets z), so noise in the pose sensor is
smoothed but still moves the estimate. Roll and pitch come from the IMU (the pose sensor's when
no IMU reading is newer). The perceived trajectory therefore differs from the real one.

    >>> est = PoseEstimator(start=(0.0, 0.0, 0.0), tau_xy_s=2.0, tau_yaw_s=2.0)
    >>> from navstress.nav.api import Odometry
    >>> est.update(0.0, Odometry(0.0, 0.0, 0.0, 0.0, 1.0, 0.0), None, None).x  # the first reading: the reference
    0.0
    >>> est.update(1.0, Odometry(1.0, 1.0, 0.0, 0.0, 1.0, 0.0), None, None).x  # then its increments
    1.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navstress.nav.api import Imu, Odometry, PoseReading

__all__ = ["Pose", "PoseEstimator", "map_to_sensor", "rotation_matrix", "sensor_to_map", "wrap_angle"]


def wrap_angle(a: float) -> float:
    """``a`` wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def rotation_matrix(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """3x3 rotation robot -> map: ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


@dataclass(frozen=True)
class Pose:
    """A full pose in the map frame at time ``t``."""

    t: float
    x: float
    y: float
    z: float
    yaw: float
    pitch: float
    roll: float

    def as_row(self) -> tuple[float, float, float, float, float, float, float]:
        return (self.t, self.x, self.y, self.z, self.yaw, self.pitch, self.roll)

    def sensor_transform(self, mount: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) such that ``p_map = R @ p_sensor + t`` for a sensor at ``mount`` (robot frame)."""
        rot = rotation_matrix(self.yaw, self.pitch, self.roll)
        trans = np.array([self.x, self.y, self.z]) + rot @ np.asarray(mount, dtype=np.float64)
        return rot, trans


def sensor_to_map(points: np.ndarray, mount: tuple[float, float, float], pose: Pose) -> np.ndarray:
    """(N, 3) sensor-frame points to the map frame (float64)."""
    rot, trans = pose.sensor_transform(mount)
    out: np.ndarray = np.asarray(points, dtype=np.float64) @ rot.T + trans
    return out


def map_to_sensor(points: np.ndarray, mount: tuple[float, float, float], pose: Pose) -> np.ndarray:
    """Inverse of :func:`sensor_to_map`."""
    rot, trans = pose.sensor_transform(mount)
    out: np.ndarray = (np.asarray(points, dtype=np.float64) - trans) @ rot
    return out


class PoseEstimator:
    """Complementary filter on (x, y, yaw) plus a time-indexed pose history (see module doc)."""

    def __init__(self, start: tuple[float, float, float], tau_xy_s: float, tau_yaw_s: float,
                 history_s: float = 30.0) -> None:
        self.x, self.y, self.yaw = float(start[0]), float(start[1]), float(start[2])
        self.z = 0.0
        self.pitch = 0.0
        self.roll = 0.0
        self._tau_xy = tau_xy_s
        self._tau_yaw = tau_yaw_s
        self._history_s = history_s
        self._last_odom: Odometry | None = None
        self._last_imu: Imu | None = None
        self._last_pose_t: float | None = None
        self._hist: list[tuple[float, float, float, float, float, float, float]] = []
        self._all: list[tuple[float, float, float, float, float, float, float]] = []

    @property
    def current(self) -> Pose:
        t = self._hist[-1][0] if self._hist else 0.0
        return Pose(t, self.x, self.y, self.z, self.yaw, self.pitch, self.roll)

    def update(self, t: float, odom: Odometry, imu: Imu | None, pose: PoseReading | None) -> Pose:
        """Fuse one cycle's readings; record and return the estimate at time ``t``."""
        if self._last_odom is not None:
            lo = self._last_odom
            dxo, dyo = odom.x - lo.x, odom.y - lo.y
            c, s = math.cos(lo.yaw), math.sin(lo.yaw)
            fwd, left = c * dxo + s * dyo, -s * dxo + c * dyo  # increment in the robot frame
            # the odometry displacement is rigidly re-expressed at the estimated heading
            dyaw = wrap_angle(odom.yaw - lo.yaw)
            if imu is not None and self._last_imu is not None and math.isfinite(imu.yaw) and imu.t > self._last_imu.t:
                # the gyro's heading increment: skid steering makes the odometry's heading unreliable
                dyaw = wrap_angle(imu.yaw - self._last_imu.yaw)
            h = self.yaw
            c2, s2 = math.cos(h), math.sin(h)
            self.x += c2 * fwd - s2 * left
            self.y += s2 * fwd + c2 * left
            # height change of the increment along the tilted robot frame (third row of R)
            self.z += -math.sin(self.pitch) * fwd + math.cos(self.pitch) * math.sin(self.roll) * left
            self.yaw = wrap_angle(self.yaw + dyaw)
        self._last_odom = odom
        if imu is not None and math.isfinite(imu.yaw):
            self._last_imu = imu
        if pose is not None and all(math.isfinite(v) for v in (pose.x, pose.y, pose.z, pose.yaw)):
            # time since the previous reading (since the first cycle for the first reading)
            ref = self._last_pose_t if self._last_pose_t is not None else (self._hist[0][0] if self._hist else pose.t)
            dt = max(0.0, pose.t - ref)
            a_xy = 1.0 - math.exp(-dt / self._tau_xy)
            a_yaw = 1.0 - math.exp(-dt / self._tau_yaw)
            self.x += a_xy * (pose.x - self.x)
            self.y += a_xy * (pose.y - self.y)
            self.yaw = wrap_angle(self.yaw + a_yaw * wrap_angle(pose.yaw - self.yaw))
            # z: odometry along the attitude, pulled toward the sensor like x/y (the first reading sets it)
            self.z = pose.z if self._last_pose_t is None else self.z + a_xy * (pose.z - self.z)
            self._last_pose_t = pose.t
            self.pitch, self.roll = pose.pitch, pose.roll
        if imu is not None and math.isfinite(imu.pitch) and math.isfinite(imu.roll):
            self.pitch, self.roll = imu.pitch, imu.roll
        row = (float(t), self.x, self.y, self.z, self.yaw, self.pitch, self.roll)
        if self._hist and t < self._hist[-1][0]:
            raise ValueError(f"observation time went backwards: {t} < {self._hist[-1][0]}")
        self._hist.append(row)
        self._all.append(row)
        while len(self._hist) > 2 and self._hist[1][0] < t - self._history_s:
            self._hist.pop(0)
        return self.current

    def pose_at(self, t: float) -> Pose:
        """The estimate at time ``t``, linearly interpolated in the history (yaw along the short
        way); clamped to the oldest/newest entry outside the kept history."""
        h = self._hist
        if not h:
            return Pose(t, self.x, self.y, self.z, self.yaw, self.pitch, self.roll)
        if t <= h[0][0]:
            return Pose(*h[0])
        if t >= h[-1][0]:
            return Pose(*h[-1])
        lo, hi = 0, len(h) - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if h[mid][0] <= t:
                lo = mid
            else:
                hi = mid
        a, b = h[lo], h[hi]
        w = (t - a[0]) / (b[0] - a[0]) if b[0] > a[0] else 0.0
        lin = [a[k] + w * (b[k] - a[k]) for k in range(1, 7)]
        for k in (4, 5, 6):  # angles
            lin[k - 1] = wrap_angle(a[k] + w * wrap_angle(b[k] - a[k]))
        return Pose(t, *lin)

    def trajectory(self) -> np.ndarray:
        """(N, 7) float64: t, x, y, z, yaw, pitch, roll of every cycle since reset."""
        if not self._all:
            return np.zeros((0, 7))
        return np.asarray(self._all, dtype=np.float64)
