"""A run's trace as a ROS 2 bag (rosbag2, MCAP storage, CDR messages of ROS 2 Humble's standard
types), written with ``rosbags``, so that ``ros2 bag play`` feeds RViz and a team's own nodes.

    navstress trace export RUN.mcap --format ros2 -o RUN_bag/

What the bag holds (every stamp and bag time is the run's *simulated* time, as in the trace):

| topic | type | from the trace |
|---|---|---|
| ``/tf`` | ``tf2_msgs/msg/TFMessage`` | ``/tf`` (``map -> base_link``, ``map -> perceived/base_link``) |
| ``/tf_static`` | ``tf2_msgs/msg/TFMessage`` (transient local) | the sensor mounts (``base_link -> lidar``, ``base_link -> <mount name>``, ``base_link -> <sensor name>``, ``<camera> -> <camera>_optical``, and the same below ``perceived/base_link``) |
| ``/truth/odom``, ``/perceived/odom`` | ``nav_msgs/msg/Odometry`` | the poses (twist left zero: the trace has no velocities) |
| ``/rosout`` | ``rcl_interfaces/msg/Log`` | ``/events`` |
| ``/world/markers`` | ``visualization_msgs/msg/MarkerArray`` (transient local) | ``/world/scene``: obstacles, start, goal |
| ``/robot/markers`` | ``visualization_msgs/msg/MarkerArray`` (transient local) | ``/robot/body``: the body (a CUBE for a box footprint, a TRIANGLE_LIST prism for a circle or a polygon) and the footprint's outline on the ground (a LINE_STRIP) |
| ``/world/movers`` | ``visualization_msgs/msg/MarkerArray`` | ``/world/movers`` |
| ``/world/terrain`` | ``sensor_msgs/msg/PointCloud2`` (transient local) | ``/world/terrain``: one point (x, y, z) per height sample |
| ``/cmd_vel`` | ``geometry_msgs/msg/TwistStamped`` | ``/nav/cmd`` |
| ``/nav/debug`` | ``visualization_msgs/msg/MarkerArray`` | ``/nav/debug`` (runs that record the navigator's view): a DELETEALL, then a LINE_STRIP per line, a SPHERE per point, a TEXT_VIEW_FACING per text |
| ``/nav/map`` | ``nav_msgs/msg/OccupancyGrid`` | ``/nav/map``, the perceived elevation: -1 unknown, else 0..100 over the grid's lowest..highest known cell (the metres are in ``/nav/map_points``) |
| ``/nav/map_points`` | ``sensor_msgs/msg/PointCloud2`` | ``/nav/map``: one point per known cell, z its height |
| ``/lidar`` | ``sensor_msgs/msg/PointCloud2`` | ``/lidar`` (frame ``map``) |
| ``/sensors/<name>`` | ``sensor_msgs/msg/LaserScan`` (a ``lidar2d``), ``sensor_msgs/msg/PointCloud2`` (a ``lidar3d``) | ``/sensors/<name>`` (frame ``<name>``) |
| ``/sensors/<name>/depth`` | ``sensor_msgs/msg/Image`` (``32FC1``) | ``/sensors/<name>/depth`` (frame ``<name>_optical``) |
| ``/sensors/<name>/camera_info`` | ``sensor_msgs/msg/CameraInfo`` | ``/sensors/<name>/calibration`` |

The sensors' topics are converted by their kind (``SensorKind.ros2``: Foxglove schema name ->
converter, in the kind's module under ``navstress.sensors.kinds``); the sensor is found by the
name in its topic among the trace's robot's sensors (its parameters give a scan's range limits and
scan time). Every sensor frame (``base_link -> <name>``, a camera's ``<name> -> <name>_optical``)
is in ``/tf_static``.

The bag directory is written beside its destination under a temporary name and renamed into
place when complete.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion

from navstress import _files
from navstress.errors import SpecError
from navstress.run.trace import (FRAME, TOPIC_CMD, TOPIC_DEBUG, TOPIC_EVENTS, TOPIC_LIDAR, TOPIC_MAP, TOPIC_MOVERS, TOPIC_PERCEIVED,
                                 TOPIC_ROBOT, TOPIC_SCENE, TOPIC_TERRAIN, TOPIC_TERRAIN_MESH, TOPIC_TF,
                                 TOPIC_TRUTH, _messages, read_robot)
from navstress.sensors import Sensor, kinds
from navstress.sensors.encode import sensor_of_topic


def _latched() -> Any:
    """The QoS of the latched topics (reliable, transient local, keep last 1: what ``ros2 bag
    play`` offers late subscribers such as RViz, as a static transform publisher does)."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    never = QosTime(sec=2147483647, nsec=4294967295)
    return Qos(history=QosHistory.KEEP_LAST, depth=1, reliability=QosReliability.RELIABLE,
               durability=QosDurability.TRANSIENT_LOCAL, deadline=never, lifespan=never,
               liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=never,
               avoid_ros_namespace_conventions=False)


_IDENTITY = Pose(orientation=Quaternion(w=1.0))
_ODOM = {TOPIC_TRUTH: ("/truth/odom", "base_link"), TOPIC_PERCEIVED: ("/perceived/odom", "perceived/base_link")}
_LEVEL = {1: 10, 2: 20, 3: 30, 4: 40, 5: 50}  # foxglove.Log level -> rcl_interfaces/Log level


class _Bag:
    """The typestore and the bag's connections, one per (topic, type)."""

    def __init__(self, writer: Any, ts: Any) -> None:
        self.w, self.ts, self.t = writer, ts, ts.types
        self.conns: dict[str, Any] = {}
        self.counts: dict[str, int] = {}

    def put(self, topic: str, msg: Any, t_ns: int, latched: bool = False) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.w.add_connection(topic, msg.__msgtype__, typestore=self.ts,
                                                      offered_qos_profiles=[_latched()] if latched else [])
        self.w.write(self.conns[topic], t_ns, self.ts.serialize_cdr(msg, msg.__msgtype__))
        self.counts[topic] = self.counts.get(topic, 0) + 1

    # -- builders --------------------------------------------------------------------------
    def stamp(self, t_ns: int) -> Any:
        return self.t["builtin_interfaces/msg/Time"](sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)

    def header(self, t_ns: int, frame: str) -> Any:
        return self.t["std_msgs/msg/Header"](stamp=self.stamp(t_ns), frame_id=frame)

    def vec(self, v: Any) -> Any:
        return self.t["geometry_msgs/msg/Vector3"](x=v.x, y=v.y, z=v.z)

    def point(self, v: Any) -> Any:
        return self.t["geometry_msgs/msg/Point"](x=v.x, y=v.y, z=v.z)

    def quat(self, q: Any) -> Any:
        return self.t["geometry_msgs/msg/Quaternion"](x=q.x, y=q.y, z=q.z, w=q.w)

    def pose(self, p: Any) -> Any:
        return self.t["geometry_msgs/msg/Pose"](position=self.point(p.position), orientation=self.quat(p.orientation))

    def cloud(self, t_ns: int, frame: str, xyz: np.ndarray) -> Any:
        pts = np.ascontiguousarray(xyz, dtype="<f4").reshape(-1, 3)
        field = self.t["sensor_msgs/msg/PointField"]
        return self.t["sensor_msgs/msg/PointCloud2"](
            header=self.header(t_ns, frame), height=1, width=len(pts),
            fields=[field(name=n, offset=4 * i, datatype=field.FLOAT32, count=1) for i, n in enumerate("xyz")],
            is_bigendian=False, point_step=12, row_step=12 * len(pts), data=np.frombuffer(pts.tobytes(), np.uint8),
            is_dense=True)

    def rgba(self, c: Any, alpha: float | None = None) -> Any:
        return self.t["std_msgs/msg/ColorRGBA"](r=c.r, g=c.g, b=c.b, a=c.a if alpha is None else alpha)

    def marker(self, ent: Any, t_ns: int, k: int, kind: int, pose: Any, scale: Any, color: Any, *,
               points: list[Any] | None = None, colors: list[Any] | None = None, text: str = "",
               action: int | None = None) -> Any:
        """One ``visualization_msgs/Marker`` of entity ``ent`` (every field set: CDR needs them)."""
        m = self.t["visualization_msgs/msg/Marker"]
        return m(header=self.header(t_ns, ent.frame_id), ns=ent.id, id=k, type=kind,
                 action=m.ADD if action is None else action,
                 pose=self.pose(pose), scale=scale, color=color,
                 lifetime=self.t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
                 frame_locked=ent.frame_locked, points=points or [], colors=colors or [], texture_resource="",
                 texture=self.t["sensor_msgs/msg/CompressedImage"](header=self.header(0, ""), format="",
                                                                   data=np.zeros(0, np.uint8)),
                 uv_coordinates=[], text=text, mesh_resource="",
                 mesh_file=self.t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
                 mesh_use_embedded_materials=False)

    def markers(self, update: Any, t_ns: int, *, replace: bool = False) -> Any:
        """A SceneUpdate as markers, one namespace per entity; ``replace``: a DELETEALL first, so
        that the array replaces everything shown before (as each debug drawing does)."""
        m = self.t["visualization_msgs/msg/Marker"]
        out = []
        if replace and update.entities:
            out.append(self.marker(update.entities[0], t_ns, 0, m.CUBE, _IDENTITY, self.t["geometry_msgs/msg/Vector3"](
                x=1.0, y=1.0, z=1.0), self.t["std_msgs/msg/ColorRGBA"](r=0.0, g=0.0, b=0.0, a=0.0),
                action=m.DELETEALL))
        for ent in update.entities:
            shapes = [(m.CUBE, c) for c in ent.cubes] + [(m.SPHERE, s) for s in ent.spheres] + \
                     [(m.CYLINDER, c) for c in ent.cylinders]
            for k, (kind, prim) in enumerate(shapes):
                out.append(self.marker(ent, t_ns, k, kind, prim.pose, self.vec(prim.size), self.rgba(prim.color)))
            for k, tri in enumerate(ent.triangles, start=len(shapes)):
                # a TRIANGLE_LIST marker has no indices: every three points are one triangle
                idx = list(tri.indices) if len(tri.indices) else list(range(len(tri.points)))
                cols = [self.rgba(tri.colors[i]) for i in idx] if len(tri.colors) else []
                out.append(self.marker(ent, t_ns, k, m.TRIANGLE_LIST, tri.pose,
                                       self.t["geometry_msgs/msg/Vector3"](x=1.0, y=1.0, z=1.0),
                                       self.rgba(tri.color, None if not cols else 1.0),
                                       points=[self.point(tri.points[i]) for i in idx], colors=cols))
            k = len(shapes) + len(ent.triangles)
            for ln in ent.lines:  # a line strip's scale.x is its width
                out.append(self.marker(ent, t_ns, k, m.LINE_STRIP, ln.pose, self.t["geometry_msgs/msg/Vector3"](
                    x=ln.thickness, y=0.0, z=0.0), self.rgba(ln.color), points=[self.point(p) for p in ln.points]))
                k += 1
            for tx in ent.texts:  # a text's scale.z is its height
                out.append(self.marker(ent, t_ns, k, m.TEXT_VIEW_FACING, tx.pose, self.t["geometry_msgs/msg/Vector3"](
                    x=0.0, y=0.0, z=tx.font_size), self.rgba(tx.color), text=tx.text))
                k += 1
        return self.t["visualization_msgs/msg/MarkerArray"](markers=out)


def _grid(m: Any) -> tuple[np.ndarray, float, float, float]:
    vals = np.frombuffer(m.data, dtype="<f4").reshape(-1, m.column_count)
    return vals, m.pose.position.x, m.pose.position.y, m.cell_size.x


def _cells(vals: np.ndarray, x0: float, y0: float, cell: float) -> np.ndarray:
    """(x, y, value) of every finite cell, at the cell's centre."""
    i, j = np.nonzero(np.isfinite(vals))
    return np.column_stack([x0 + (j + 0.5) * cell, y0 + (i + 0.5) * cell, vals[i, j]])


def _convert(bag: _Bag, topic: str, t_ns: int, m: Any, sensors: dict[str, Sensor] | None = None) -> None:
    T = bag.t
    name = sensor_of_topic(topic)
    if name is not None:
        _convert_sensor(bag, topic, t_ns, m, (sensors or {}).get(name))
    elif topic == TOPIC_TF:
        tf = T["geometry_msgs/msg/TransformStamped"](
            header=bag.header(t_ns, m.parent_frame_id), child_frame_id=m.child_frame_id,
            transform=T["geometry_msgs/msg/Transform"](translation=bag.vec(m.translation), rotation=bag.quat(m.rotation)))
        static = m.parent_frame_id != FRAME  # base_link -> a sensor mount (lidar, ...): fixed on the robot
        bag.put("/tf_static" if static else "/tf", T["tf2_msgs/msg/TFMessage"](transforms=[tf]), t_ns, latched=static)
    elif topic in _ODOM:
        name, child = _ODOM[topic]
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        bag.put(name, T["nav_msgs/msg/Odometry"](
            header=bag.header(t_ns, m.frame_id), child_frame_id=child,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=bag.pose(m.pose), covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                                                             covariance=np.zeros(36))), t_ns)
    elif topic == TOPIC_EVENTS:
        bag.put("/rosout", T["rcl_interfaces/msg/Log"](stamp=bag.stamp(t_ns), level=_LEVEL.get(m.level, 20), name=m.name,
                                                        msg=m.message, file="", function="", line=0), t_ns)
    elif topic == TOPIC_DEBUG:
        bag.put("/nav/debug", bag.markers(m, t_ns, replace=True), t_ns)
    elif topic in (TOPIC_SCENE, TOPIC_ROBOT, TOPIC_MOVERS, TOPIC_TERRAIN_MESH):
        name = {TOPIC_SCENE: "/world/markers", TOPIC_ROBOT: "/robot/markers", TOPIC_MOVERS: "/world/movers",
                TOPIC_TERRAIN_MESH: "/world/terrain_mesh"}[topic]
        bag.put(name, bag.markers(m, t_ns), t_ns, latched=topic != TOPIC_MOVERS)
    elif topic == TOPIC_CMD:
        vec = bag.t["geometry_msgs/msg/Vector3"]
        twist = bag.t["geometry_msgs/msg/Twist"](linear=vec(x=m.linear, y=0.0, z=0.0),
                                                 angular=vec(x=0.0, y=0.0, z=m.angular))
        bag.put("/cmd_vel", bag.t["geometry_msgs/msg/TwistStamped"](header=bag.header(t_ns, m.frame_id), twist=twist), t_ns)
    elif topic == TOPIC_TERRAIN:
        vals, x0, y0, cell = _grid(m)
        rows, cols = vals.shape  # one point per height sample: the grid's cells are centred on the samples
        j, i = np.meshgrid(np.arange(cols), np.arange(rows))
        xyz = np.column_stack([x0 + (j.ravel() + 0.5) * cell, y0 + (i.ravel() + 0.5) * cell, vals.ravel()])
        bag.put("/world/terrain", bag.cloud(t_ns, m.frame_id, xyz), t_ns, latched=True)
    elif topic == TOPIC_MAP:
        vals, x0, y0, cell = _grid(m)
        known = np.isfinite(vals)
        occ = np.full(vals.shape, -1, np.int8)
        if known.any():
            lo, hi = float(vals[known].min()), float(vals[known].max())
            occ[known] = np.rint((vals[known] - lo) / (hi - lo) * 100 if hi > lo else 0).astype(np.int8)
        origin = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x0, y=y0, z=0.0),
                                             orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
        info = T["nav_msgs/msg/MapMetaData"](map_load_time=bag.stamp(t_ns), resolution=cell, width=vals.shape[1],
                                             height=vals.shape[0], origin=origin)
        bag.put("/nav/map", T["nav_msgs/msg/OccupancyGrid"](header=bag.header(t_ns, m.frame_id), info=info,
                                                            data=occ.ravel()), t_ns)
        bag.put("/nav/map_points", bag.cloud(t_ns, m.frame_id, _cells(vals, x0, y0, cell)), t_ns)
    elif topic == TOPIC_LIDAR:
        pts = np.frombuffer(m.data, dtype="<f4").reshape(-1, 3)
        bag.put("/lidar", bag.cloud(t_ns, m.frame_id or FRAME, pts), t_ns)


def _convert_sensor(bag: _Bag, topic: str, t_ns: int, m: Any, sensor: Sensor | None) -> None:
    """A sensor's message through its kind's converter (by the message's Foxglove schema); a
    sensor the robot does not name: the first kind that converts the schema; none: left out."""
    schema = m.DESCRIPTOR.full_name
    ks = kinds()
    convert = ks[sensor.kind].ros2.get(schema) if sensor is not None and sensor.kind in ks else None
    if convert is None:
        convert = next((k.ros2[schema] for k in ks.values() if schema in k.ros2), None)
    if convert is None:
        return
    for out, msg in convert(bag.t, topic, m, sensor):
        bag.put(out, msg, t_ns)


def _sensor_topics(path: Path) -> list[str]:
    """The trace's topics under ``/sensors/`` (from its summary; [] when it has none)."""
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
    except Exception:  # the full read below says what is wrong with the file
        return []
    if summary is None:
        return []
    return sorted({ch.topic for ch in summary.channels.values() if sensor_of_topic(ch.topic) is not None})


_TOPICS = [TOPIC_TF, TOPIC_TRUTH, TOPIC_PERCEIVED, TOPIC_EVENTS, TOPIC_SCENE, TOPIC_ROBOT, TOPIC_MOVERS, TOPIC_TERRAIN,
           TOPIC_TERRAIN_MESH, TOPIC_CMD, TOPIC_DEBUG, TOPIC_MAP, TOPIC_LIDAR]


def export_ros2(trace: str | os.PathLike[str], out: str | os.PathLike[str]) -> dict[str, int]:
    """Write the run at ``trace`` (a navstress MCAP trace) as a ROS 2 bag directory ``out`` (which
    must not exist); returns the message count per bag topic."""
    from rosbags.rosbag2 import StoragePlugin, Writer  # local: only this command needs rosbags
    from rosbags.typesys import Stores, get_typestore

    src, dest = Path(trace), Path(out)
    if dest.exists() or dest.is_symlink():
        raise SpecError("--output", str(dest), "a path that does not exist yet (a ROS 2 bag is a new directory)")
    messages = list(_messages(src, _TOPICS + _sensor_topics(src)))  # reads (and checks) the whole trace first
    sensors = {s.name: s for s in read_robot(src).sensors or ()} if any(
        sensor_of_topic(t) is not None for t, _n, _m in messages) else {}
    tmp = _files.temp_dir_beside(dest)
    try:
        bag_dir = tmp / dest.name
        with Writer(bag_dir, version=8, storage_plugin=StoragePlugin.MCAP) as w:
            bag = _Bag(w, get_typestore(Stores.ROS2_HUMBLE))
            for topic, t_ns, m in messages:
                _convert(bag, topic, t_ns, m, sensors)
        _files.rename_into_place(bag_dir, dest)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return dict(sorted(bag.counts.items()))

