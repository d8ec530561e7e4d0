"""What navstress publishes to a ROS 2 stack, as ROS 2 messages (rosbags' classes of the
distribution's standard types), on which topics with which QoS, and what it reads back.

Every run publishes (topics and frames configurable, Nav2's names by default):

=====================  ==================================  ============================================
topic                  type                                what
=====================  ==================================  ============================================
``/clock``             ``rosgraph_msgs/msg/Clock``         simulated time t, first of each cycle
``/tf``                ``tf2_msgs/msg/TFMessage``          ``odom -> base_link`` (wheel odometry) and,
                                                           with ``map_to_odom: pose``, ``map -> odom``
``/tf_static``         ``tf2_msgs/msg/TFMessage``          ``base_link -> <sensor>`` for every sensor
                                                           (``imu`` too; a camera's ``<name>_optical``)
``/scan``, ...         ``sensor_msgs/msg/LaserScan``       each ``lidar2d`` (the first on ``/scan``)
``/points``, ...       ``sensor_msgs/msg/PointCloud2``     each ``lidar3d`` (the first on ``/points``)
``/<name>/depth/...``  ``sensor_msgs/msg/Image`` and       each ``depth`` camera: ``image_raw``
                       ``sensor_msgs/msg/CameraInfo``      (``32FC1``) and ``camera_info``
``/imu``               ``sensor_msgs/msg/Imu``             the built-in IMU (each new reading)
``/odom``              ``nav_msgs/msg/Odometry``           the wheel odometry, last of each cycle
``/goal_pose``         ``geometry_msgs/msg/PoseStamped``   the mission's goal, once (after ``/tf_static``)
``/map``               ``nav_msgs/msg/OccupancyGrid``      with ``map: world`` only, once, transient local
=====================  ==================================  ============================================

Order within a cycle of time t: ``/clock``, ``/tf``, every sensor reading taken since the
previous cycle (each stamped with its own time), ``/imu``, then ``/odom`` last, so that a stack
that acts on the odometry has the cycle's scans and transforms already. The sensors are
converted by their kind, as the ROS 2 bag export does (a reading becomes the kind's trace
messages, which its ``ros2`` converters turn into ROS 2 messages), except ``lidar2d``, which
has a direct path built from the reading (the same message, :meth:`Encoder.scan`; about 3x
faster: it is in every cycle of most stacks).

``map -> odom``: with ``map_to_odom: pose`` it is computed at each new pose-sensor reading from
that reading and the cycle's odometry (``map_T_odom = map_T_base * inverse(odom_T_base)``, in
the plane), and published in every cycle stamped t (as AMCL republishes its last estimate), so
that a lookup at t never extrapolates; before the first reading there is none. With ``none``
the stack localises itself (AMCL, SLAM) from the scans and the odometry.

QoS (:meth:`Encoder.qos`): every publisher is reliable (no sample dropped under congestion:
lockstep runs stay reproducible; a reliable publisher matches both reliable and best-effort
subscriptions, such as Nav2's SensorDataQoS ones) and volatile, keep last 10, except
``/clock`` (depth 1), ``/tf`` (100), the sensors (5, SensorDataQoS's depth), ``/tf_static``
and ``/map`` (transient local, depth 1: a stack that subscribes late still gets them); the
``/cmd_vel`` subscription is reliable, volatile, keep last 10. The configuration's ``qos:``
overrides any of these, by topic.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from navstress.nav.api import NavMission, Observation, Odometry, PoseReading, PriorMap
from navstress.nav.ros2 import rmw
from navstress.nav.ros2.config import Ros2Config
from navstress.sensors import Sensor, encode
from navstress.sensors.kinds.imu import Imu
from navstress.sensors.kinds.lidar2d import LaserScan, Lidar2dParams
from navstress.sensors.registry import kind as sensor_kind

__all__ = ["CLOCK", "IMU", "IMU_FRAME", "Encoder", "OCCUPANCY_GRID", "ODOMETRY", "POSE_STAMPED", "TF", "TWIST",
           "TWIST_STAMPED", "Twist", "sensor_topics"]

TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
CLOCK = "rosgraph_msgs/msg/Clock"
TF = "tf2_msgs/msg/TFMessage"
ODOMETRY = "nav_msgs/msg/Odometry"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
IMU = "sensor_msgs/msg/Imu"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
LASER_SCAN = "sensor_msgs/msg/LaserScan"

#: The built-in IMU's frame (its sensor name; it measures the body: at ``base_link``'s origin).
IMU_FRAME = "imu"
#: The IMU's default topic (``topics.sensors.imu`` moves it: no declared sensor may be named imu).
IMU_TOPIC = "/imu"

#: a kind's default topic for its first sensor (Nav2's and the drivers' usual names)
_FIRST_TOPIC = {"lidar2d": "/scan", "lidar3d": "/points"}
#: the ROS topics and types of the built-in kinds' sensors, below the sensor's base topic (what
#: ``publications`` declares before the first reading; a kind not listed here, e.g. a plug-in's,
#: gets a publisher at its first message)
_KIND_TOPICS: dict[str, tuple[tuple[str, str], ...]] = {
    "lidar2d": (("", LASER_SCAN),),
    "lidar3d": (("", "sensor_msgs/msg/PointCloud2"),),
    "depth": (("/depth/image_raw", "sensor_msgs/msg/Image"), ("/depth/camera_info", "sensor_msgs/msg/CameraInfo")),
}
#: a kind's trace sub-topics (below ``/sensors/<name>``, after its ``ros2`` converters) renamed
#: to the ROS drivers' names (realsense-ros: ``.../depth/image_raw``, ``.../depth/camera_info``)
_RENAME = {"depth": {"/depth": "/depth/image_raw", "/camera_info": "/depth/camera_info"}}

#: QoS depths by what a topic carries (see the module's text)
_DEPTH_SENSOR = 5


def sensor_topics(sensors: Iterable[Sensor], cfg: Ros2Config) -> dict[str, str]:
    """The base topic of each declared sensor (its trace topic ``/sensors/<name>`` becomes this):
    the configured one (``topics.sensors``), else the first of a kind on its kind's usual name
    (``/scan``, ``/points``), else ``/<name>``, else ``/sensors/<name>``: a default never takes a
    topic that is configured or that an earlier sensor (or the IMU) has."""
    sensors = list(sensors)
    out: dict[str, str] = {s.name: cfg.topics.sensors[s.name] for s in sensors if s.name in cfg.topics.sensors}
    taken = set(out.values()) | {cfg.topics.sensors.get(IMU_FRAME, IMU_TOPIC)}
    seen: set[str] = set()
    for s in sensors:
        if s.name not in out:
            first = _FIRST_TOPIC.get(s.kind) if s.kind not in seen else None
            choices = [c for c in (first, "/" + s.name, encode.topic(s.name)) if c is not None]
            out[s.name] = next((c for c in choices if c not in taken), choices[-1])
            taken.add(out[s.name])
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


#: One message to publish: (topic, ROS type, message, stamp in ns for the attachment).
Outgoing = tuple[str, str, Any, int]


class Encoder:
    """Builds the messages of one run (its distribution's types, its frames, topics and QoS).

    :meth:`publications` lists what the run publishes (declared before the stack starts),
    :meth:`latched` what is published once (``/tf_static``, ``/map``), :meth:`cycle` what each
    control cycle publishes; the other methods build one message each."""

    def __init__(self, cfg: Ros2Config, sensors: tuple[Sensor, ...], prior_map: PriorMap | None = None) -> None:
        self.cfg = cfg
        store = rmw.typestore(cfg.distro)
        self.types = store.types
        self.sensors = {s.name: s for s in sensors}
        self.topics = sensor_topics(sensors, cfg)
        self.imu_topic = cfg.topics.sensors.get(IMU_FRAME, IMU_TOPIC)
        self.prior_map = prior_map
        self._scan_params = {s.name: Lidar2dParams.model_validate(s.params) for s in sensors if s.kind == "lidar2d"}
        self._imu_t: float | None = None
        self._map_odom: tuple[float, float, float] | None = None
        # rosbags generates a type's CDR code at its first use (5-20 ms a type): here, before the
        # run, rather than in its first cycle
        for _, ros_type in [*self.publications(), (TWIST, TWIST), (TWIST_STAMPED, TWIST_STAMPED)]:
            store.get_msgdef(ros_type)

    # ----------------------------------------------------------- topics and QoS
    def publications(self) -> list[tuple[str, str]]:
        """Every ``(topic, ROS type)`` the run publishes on (a plug-in sensor kind's come at its
        first reading)."""
        t = self.cfg.topics
        out = [(t.clock, CLOCK), (t.tf, TF), (t.tf_static, TF), (t.odom, ODOMETRY), (t.goal, POSE_STAMPED),
               (self.imu_topic, IMU)]
        for name, s in self.sensors.items():
            out += [(self.topics[name] + sub, typ) for sub, typ in _KIND_TOPICS.get(s.kind, ())]
        if self.prior_map is not None:
            out.append((t.map, OCCUPANCY_GRID))
        return out

    def qos(self, topic: str) -> rmw.Qos:
        """The QoS of ``topic``'s publisher: the configuration's ``qos.<topic>``, else the
        default of what it carries (the module's text)."""
        q = self.cfg.qos.get(topic)
        if q is not None:
            return rmw.Qos(q.reliability, q.durability, q.depth)
        t = self.cfg.topics
        if topic in (t.tf_static, t.map):
            return rmw.Qos("reliable", "transient_local", 1)
        if topic == t.clock:
            return rmw.Qos("reliable", "volatile", 1)
        if topic == t.tf:
            return rmw.Qos("reliable", "volatile", 100)
        if topic in (t.odom, t.goal, t.cmd_vel):
            return rmw.Qos("reliable", "volatile", 10)
        return rmw.Qos("reliable", "volatile", _DEPTH_SENSOR)  # a sensor's (and the IMU's)

    # ----------------------------------------------------------- what is published when
    def latched(self) -> list[Outgoing]:
        """What is published once, at the start of the run (transient local): ``/tf_static``
        and, with a prior map, ``/map``."""
        out: list[Outgoing] = [(self.cfg.topics.tf_static, TF, self.tf_static(), 0)]
        if self.prior_map is not None:
            out.append((self.cfg.topics.map, OCCUPANCY_GRID, self.occupancy_grid(self.prior_map), 0))
        return out

    def cycle(self, obs: Observation) -> list[Outgoing]:
        """The messages of one control cycle, in the order they go out (the module's text)."""
        t = obs.t
        n = encode.ns(t)
        topics = self.cfg.topics
        out: list[Outgoing] = [(topics.clock, CLOCK, self.clock(t), n), (topics.tf, TF, self.tf(t, obs.odom, obs.pose), n)]
        for name, readings in obs.readings.items():
            if name not in self.sensors:
                continue  # odom, imu, pose: below
            for r in readings:
                rn = encode.ns(getattr(r, "t", t))
                out += [(topic, typ, msg, rn) for topic, typ, msg in self.sensor(name, r)]
        imu = obs.imu
        if imu is not None and imu.t != self._imu_t:
            self._imu_t = imu.t
            out.append((self.imu_topic, IMU, self.imu(imu), encode.ns(imu.t)))
        out.append((topics.odom, ODOMETRY, self.odometry(obs.odom), encode.ns(obs.odom.t)))
        return out

    # ----------------------------------------------------------- building blocks
    def time(self, n: int) -> Any:
        return self.types["builtin_interfaces/msg/Time"](sec=n // 1_000_000_000, nanosec=n % 1_000_000_000)

    def header(self, t: float, frame: str) -> Any:
        return self.types["std_msgs/msg/Header"](stamp=self.time(encode.ns(t)), frame_id=frame)

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
        return self.types["rosgraph_msgs/msg/Clock"](clock=self.time(encode.ns(t)))

    def tf_static(self) -> Any:
        """``base_link -> <sensor>`` for every declared sensor (and a camera's optical frame),
        and ``base_link -> imu`` (the built-in IMU, at the body's origin)."""
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
        out.append(self.transform(0.0, f.base, IMU_FRAME, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
        return self.types[TF](transforms=out)

    def tf(self, t: float, odom: Odometry, pose: PoseReading | None) -> Any:
        """``odom -> base_link`` from the wheel odometry, and ``map -> odom`` (when the
        configuration asks for it: from the latest pose-sensor reading, see the module's text)."""
        f = self.cfg.frames
        out = [self.transform(t, f.odom, f.base, (odom.x, odom.y, 0.0), (0.0, 0.0, odom.yaw))]
        if self.cfg.map_to_odom == "pose":
            if pose is not None:
                # map_T_odom = map_T_base * inverse(odom_T_base), in the plane
                yaw = pose.yaw - odom.yaw
                c, s = math.cos(yaw), math.sin(yaw)
                self._map_odom = (pose.x - (c * odom.x - s * odom.y), pose.y - (s * odom.x + c * odom.y), yaw)
            if self._map_odom is not None:
                x, y, yaw = self._map_odom
                out.append(self.transform(t, f.map, f.odom, (x, y, 0.0), (0.0, 0.0, yaw)))
        return self.types[TF](transforms=out)

    def odometry(self, odom: Odometry) -> Any:
        """``nav_msgs/Odometry`` in ``odom`` of ``base_link`` (covariances zero: unknown)."""
        T, f = self.types, self.cfg.frames
        cov = np.zeros(36, dtype=np.float64)
        return T[ODOMETRY](
            header=self.header(odom.t, f.odom), child_frame_id=f.base,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=float(odom.x), y=float(odom.y), z=0.0),
                orientation=_quat(T, 0.0, 0.0, odom.yaw)), covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=T[TWIST](
                linear=T["geometry_msgs/msg/Vector3"](x=float(odom.v), y=0.0, z=0.0),
                angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=float(odom.omega))), covariance=cov))

    def imu(self, r: Imu) -> Any:
        """The built-in IMU as ``sensor_msgs/Imu`` in frame ``imu``: orientation from its roll,
        pitch and (drifting) yaw, angular velocity from its body rates; it measures no linear
        acceleration (element 0 of that covariance -1, as the message's definition says for a
        missing estimate); the other covariances zero (unknown)."""
        T = self.types
        unknown = np.zeros(9, dtype=np.float64)
        missing = np.zeros(9, dtype=np.float64)
        missing[0] = -1.0
        v3 = T["geometry_msgs/msg/Vector3"]
        return T[IMU](header=self.header(r.t, IMU_FRAME), orientation=_quat(T, r.roll, r.pitch, r.yaw),
                      orientation_covariance=unknown,
                      angular_velocity=v3(x=float(r.rates[0]), y=float(r.rates[1]), z=float(r.rates[2])),
                      angular_velocity_covariance=unknown.copy(), linear_acceleration=v3(x=0.0, y=0.0, z=0.0),
                      linear_acceleration_covariance=missing)

    def occupancy_grid(self, m: PriorMap) -> Any:
        """A prior map as ``nav_msgs/OccupancyGrid`` in the map frame: 100 occupied, 0 free (map_server's
        trinary values; no cell is unknown), row-major from the origin, rows along +y."""
        T = self.types
        rows, cols = m.occupied.shape
        info = T["nav_msgs/msg/MapMetaData"](
            map_load_time=self.time(0), resolution=float(m.cell_m), width=int(cols), height=int(rows),
            origin=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=float(m.origin_xy[0]), y=float(m.origin_xy[1]), z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
        data = np.where(np.asarray(m.occupied, dtype=bool), np.int8(100), np.int8(0)).astype(np.int8).ravel()
        return T[OCCUPANCY_GRID](header=self.header(0.0, self.cfg.frames.map), info=info, data=data)

    def goal(self, t: float, mission: NavMission) -> Any:
        """The mission's goal as a ``geometry_msgs/PoseStamped`` in the map frame, facing from the
        start towards the goal."""
        T = self.types
        yaw = math.atan2(mission.goal[1] - mission.start[1], mission.goal[0] - mission.start[0])
        return T[POSE_STAMPED](header=self.header(t, self.cfg.frames.map), pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(mission.goal[0]), y=float(mission.goal[1]), z=0.0),
            orientation=_quat(T, 0.0, 0.0, yaw)))

    def scan(self, name: str, r: LaserScan) -> Any:
        """A ``lidar2d`` reading as ``sensor_msgs/LaserScan``, straight from the reading: the
        message the kind's trace -> ROS 2 converters give (``lidar2d.ros2_scan``: the same
        angles, the sensor's range limits and scan time, float32 ranges, no intensities)."""
        p = self._scan_params[name]
        n = int(r.ranges.shape[0])
        a0 = float(r.angle_min)
        a1 = a0 + float(r.angle_increment) * max(n - 1, 0)
        return self.types[LASER_SCAN](
            header=self.header(r.t, name), angle_min=a0, angle_max=a1,
            angle_increment=(a1 - a0) / (n - 1) if n > 1 else 0.0, time_increment=0.0, scan_time=1.0 / p.rate_hz,
            range_min=p.min_range_m, range_max=p.max_range_m,
            ranges=np.asarray(r.ranges, dtype=np.float32), intensities=np.zeros(0, np.float32))

    def sensor(self, name: str, reading: Any) -> list[tuple[str, str, Any]]:
        """A declared sensor's reading as ``(topic, ROS type, message)`` items on the configured
        topics: a ``lidar2d``'s by :meth:`scan`, every other kind's through its trace messages
        and its ``ros2`` converters."""
        s = self.sensors.get(name)
        if s is None:
            return []
        base_out = self.topics[name]
        if s.kind == "lidar2d" and isinstance(reading, LaserScan):
            return [(base_out, LASER_SCAN, self.scan(name, reading))]
        return self.sensor_via_trace(name, reading)

    def sensor_via_trace(self, name: str, reading: Any) -> list[tuple[str, str, Any]]:
        """:meth:`sensor` through the kind's trace messages and ``ros2`` converters (every kind;
        the ROS 2 bag export's path)."""
        s = self.sensors[name]
        k = sensor_kind(s.kind)
        if k.trace is None:
            return []
        base_in, base_out = encode.topic(name), self.topics[name]
        rename = _RENAME.get(s.kind, {})
        out = []
        for topic, pb in k.trace(reading, s):
            conv = k.ros2.get(pb.DESCRIPTOR.full_name)
            if conv is None:
                continue
            for t_out, msg in conv(self.types, topic, pb, s):
                if t_out.startswith(base_in):
                    sub = t_out[len(base_in):]
                    t_out = base_out + rename.get(sub, sub)
                out.append((t_out, msg.__msgtype__, msg))
        return out

    @staticmethod
    def twist(ros_type: str, msg: Any) -> Twist:
        """The command in a ``Twist`` or ``TwistStamped``."""
        if ros_type == TWIST_STAMPED:
            st = msg.header.stamp
            return Twist(float(msg.twist.linear.x), float(msg.twist.angular.z),
                         int(st.sec) * 1_000_000_000 + int(st.nanosec))
        return Twist(float(msg.linear.x), float(msg.angular.z), None)
