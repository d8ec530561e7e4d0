"""What navstress publishes to a ROS 2 stack, as ROS 2 messages (rosbags' classes of the
distribution's standard types), and what it reads back from it.

The sensors are converted by their kind, as the ROS 2 bag export does: a reading becomes the
kind's trace messages (``SensorKind.trace``), which its ``ros2`` converters turn into ROS 2
messages; the topic of each is the configured one (:func:`sensor_topics`). Frames are REP 105's:
``map -> odom -> base_link -> <sensor name>`` (a camera's ``<name> -> <name>_optical`` too).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from navstress.nav.api import NavMission, Odometry, PoseReading
from navstress.nav.ros2 import rmw
from navstress.nav.ros2.config import Ros2Config
from navstress.sensors import Sensor, encode
from navstress.sensors.registry import kind as sensor_kind

__all__ = ["Encoder", "Twist", "sensor_topics"]

TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"

#: a kind's default topic for its first sensor (Nav2's and the drivers' usual names)
_FIRST_TOPIC = {"lidar2d": "/scan", "lidar3d": "/points", "imu": "/imu"}


def _ns(t: float) -> int:
    return encode.ns(t)


def sensor_topics(sensors: Iterable[Sensor], cfg: Ros2Config) -> dict[str, str]:
    """The base topic of each declared sensor (its trace topic ``/sensors/<name>`` becomes this):
    the configured one, else the first of a kind on its kind's usual name, else ``/<name>``."""
    out: dict[str, str] = {}
    seen: set[str] = set()
    for s in sensors:
        if s.name in cfg.topics.sensors:
            out[s.name] = cfg.topics.sensors[s.name]
        elif s.kind in _FIRST_TOPIC and s.kind not in seen:
            out[s.name] = _FIRST_TOPIC[s.kind]
        else:
            out[s.name] = "/" + s.name
        seen.add(s.kind)
    return out


def _quat(types: Any, roll: float, pitch: float, yaw: float) -> Any:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return types["geometry_msgs/msg/Quaternion"](
        x=sr * cp * cy - cr * sp * sy, y=cr * sp * cy + sr * cp * sy,
        z=cr * cp * sy - sr * sp * cy, w=cr * cp * cy + sr * sp * sy)


@dataclass(frozen=True)
class Twist:
    """A command read from ``/cmd_vel``: body velocities, and its stamp (ns) when it was a
    ``TwistStamped``."""

    v: float
    omega: float
    stamp_ns: int | None


class Encoder:
    """Builds the messages of one run (its distribution's types, its frames and topics)."""

    def __init__(self, cfg: Ros2Config, sensors: tuple[Sensor, ...]) -> None:
        self.cfg = cfg
        self.types = rmw.typestore(cfg.distro).types
        self.sensors = {s.name: s for s in sensors}
        self.topics = sensor_topics(sensors, cfg)

    # ----------------------------------------------------------- building blocks
    def header(self, t: float, frame: str) -> Any:
        T = self.types
        n = _ns(t)
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=n // 1_000_000_000,
                                                                              nanosec=n % 1_000_000_000),
                                        frame_id=frame)

    def transform(self, t: float, parent: str, child: str, xyz: tuple[float, float, float],
                  rpy: tuple[float, float, float]) -> Any:
        T = self.types
        return T["geometry_msgs/msg/TransformStamped"](
            header=self.header(t, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
                rotation=_quat(T, *rpy)))

    # ----------------------------------------------------------- messages
    def clock(self, t: float) -> Any:
        T = self.types
        n = _ns(t)
        return T["rosgraph_msgs/msg/Clock"](clock=T["builtin_interfaces/msg/Time"](
            sec=n // 1_000_000_000, nanosec=n % 1_000_000_000))

    def tf_static(self) -> Any:
        """``base_link -> <sensor>`` for every declared sensor (and a camera's optical frame)."""
        f = self.cfg.frames
        out = []
        for s in self.sensors.values():
            x, r = s.mount.xyz, s.mount.rpy
            out.append(self.transform(0.0, f.base, s.name, (x[0], x[1], x[2]), (r[0], r[1], r[2])))
            extra = sensor_kind(s.kind).extra.get("frames")
            if callable(extra):
                for parent, child, xyz, rpy in extra(s):
                    if parent != f.base or child != s.name:
                        out.append(self.transform(0.0, parent, child, xyz, rpy))
        return self.types["tf2_msgs/msg/TFMessage"](transforms=out)

    def tf(self, t: float, odom: Odometry, pose: PoseReading | None) -> Any:
        """``odom -> base_link`` from the wheel odometry, and ``map -> odom`` from the pose
        sensor when it has a new reading and the configuration asks for it."""
        f = self.cfg.frames
        out = [self.transform(t, f.odom, f.base, (odom.x, odom.y, 0.0), (0.0, 0.0, odom.yaw))]
        if pose is not None and self.cfg.map_to_odom == "pose":
            # map_T_odom = map_T_base * inverse(odom_T_base), in the plane
            yaw = pose.yaw - odom.yaw
            c, s = math.cos(yaw), math.sin(yaw)
            x = pose.x - (c * odom.x - s * odom.y)
            y = pose.y - (s * odom.x + c * odom.y)
            out.append(self.transform(t, f.map, f.odom, (x, y, 0.0), (0.0, 0.0, yaw)))
        return self.types["tf2_msgs/msg/TFMessage"](transforms=out)

    def odometry(self, odom: Odometry) -> Any:
        T, f = self.types, self.cfg.frames
        cov = np.zeros(36, dtype=np.float64)
        return T["nav_msgs/msg/Odometry"](
            header=self.header(odom.t, f.odom), child_frame_id=f.base,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=float(odom.x), y=float(odom.y), z=0.0),
                orientation=_quat(T, 0.0, 0.0, odom.yaw)), covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=T[TWIST](
                linear=T["geometry_msgs/msg/Vector3"](x=float(odom.v), y=0.0, z=0.0),
                angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=float(odom.omega))), covariance=cov))

    def goal(self, t: float, mission: NavMission) -> Any:
        """The mission's goal as a ``geometry_msgs/PoseStamped`` in the map frame, facing from the
        start towards the goal."""
        T = self.types
        yaw = math.atan2(mission.goal[1] - mission.start[1], mission.goal[0] - mission.start[0])
        return T["geometry_msgs/msg/PoseStamped"](header=self.header(t, self.cfg.frames.map),
                                                  pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(mission.goal[0]), y=float(mission.goal[1]), z=0.0),
            orientation=_quat(T, 0.0, 0.0, yaw)))

    def sensor(self, name: str, reading: Any) -> list[tuple[str, str, Any]]:
        """A declared sensor's reading as ``(topic, ROS type, message)`` items (its kind's trace
        messages converted by its kind's ``ros2`` converters, on the configured topics)."""
        s = self.sensors.get(name)
        if s is None:
            return []
        k = sensor_kind(s.kind)
        if k.trace is None:
            return []
        base_in = encode.topic(name)
        base_out = self.topics[name]
        out = []
        for topic, pb in k.trace(reading, s):
            conv = k.ros2.get(pb.DESCRIPTOR.full_name)
            if conv is None:
                continue
            for t_out, msg in conv(self.types, topic, pb, s):
                t_ros = base_out + t_out[len(base_in):] if t_out.startswith(base_in) else t_out
                out.append((t_ros, msg.__msgtype__, msg))
        return out

    @staticmethod
    def twist(ros_type: str, msg: Any) -> Twist:
        """The command in a ``Twist`` or ``TwistStamped``."""
        if ros_type == TWIST_STAMPED:
            st = msg.header.stamp
            return Twist(float(msg.twist.linear.x), float(msg.twist.angular.z),
                         int(st.sec) * 1_000_000_000 + int(st.nanosec))
        return Twist(float(msg.linear.x), float(msg.angular.z), None)
