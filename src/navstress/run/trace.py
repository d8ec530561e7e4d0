"""Run traces: one MCAP file per run, with Foxglove schemas (protobuf encoding).

Open a trace in Foxglove to see the run: ``/tf`` (``foxglove.FrameTransform``: the frame tree
``map -> base_link -> lidar`` (and ``base_link -> <mount name>`` for each sensor mount of the
robot) from the true pose, and ``map -> perceived/base_link -> perceived/lidar`` from the
navigator's belief, so a follow camera can ride ``base_link`` and the drift shows between the
two), ``/robot/body`` (``foxglove.SceneUpdate``: the robot's true shape locked to each
``base_link``, the belief's translucent: a cube for a box footprint, a prism of the outline for a
circle or a polygon, and the footprint's outline on the ground), ``/truth/pose`` and ``/perceived/pose``
(``foxglove.PoseInFrame``), ``/events`` (``foxglove.Log``: collisions, errors, end of run),
``/world/scene`` (``foxglove.SceneUpdate``: obstacles as cubes, cylinders as cylinders, start and goal),
``/world/movers`` (``foxglove.SceneUpdate``, one per run of the movers' controller (10 Hz): every
mover an entity ``mover/<id>``, a cylinder or a cube where it is; worlds with movers only),
``/nav/cmd`` (``navstress.VelocityCommand``, :func:`command_class`: the navigator's commands),
``/nav/debug`` (``foxglove.SceneUpdate``, runs that record the navigator's view: what it drew
after each step, :meth:`TraceWriter.debug`),
``/world/terrain_mesh`` (``foxglove.SceneUpdate``: the ground as a 3D surface, see
:func:`terrain_mesh`), ``/world/terrain`` (``foxglove.Grid``: ground heights), ``/nav/map`` (``foxglove.Grid``: the
navigator's final perceived elevation map, NaN = unknown; runs that record the navigator's view
have it once per simulated second before, each cut to its known cells), optionally ``/lidar``
(``foxglove.PointCloud``, world frame: the default lidar's, with ``record_lidar``), and every other
sensor of a robot that lists its sensors under ``/sensors/<name>``, written by its kind's ``trace``
encoder (:meth:`TraceMessages.reading`; which readings: :class:`SensorRecorder`), its frame
``base_link -> <name>`` in ``/tf``. All timestamps are *simulated* time, so the same
seeds give a byte-identical file. Each message's log time is the simulated time of what it
shows (a pose's measurement time, a scan's time), and messages are written to the file in
log-time order whatever order they were handed over in (``mcap doctor
--strict-message-order`` is clean): the writer buffers them and writes them sorted (stable,
by log time then order of submission) when the file is closed. The file is written under a
temporary name and renamed into place when complete (DESIGN invariant 4). Each channel's
messages carry sequence numbers 1, 2, 3, ... in file order.

The robot is the file's ``navstress.robot`` metadata (:func:`robot_metadata`: name, digest,
description, footprint, mounts; :func:`read_robot`; a trace without it is the rmp400's).

The analysis reads trajectories back with :func:`read_poses`, the movers with :func:`read_movers`.
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import zstandard
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CubePrimitive_pb2 import CubePrimitive
from foxglove_schemas_protobuf.CylinderPrimitive_pb2 import CylinderPrimitive
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TextPrimitive_pb2 import TextPrimitive
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from foxglove_schemas_protobuf.Vector2_pb2 import Vector2
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.writer import CompressionType
from mcap_protobuf.decoder import DecoderFactory
from mcap_protobuf.writer import Writer

from navstress._json import dumps
from navstress import _files
from navstress.errors import NavstressError, StoreError
from navstress.robot import PROFILES, Mount, RobotSpec
from navstress.sensors import Sensor, kinds
from navstress.nav.api import DebugDraw, DebugLine, DebugPoints, DebugText
from navstress.run.record import cap_message

FRAME = "map"
TOPIC_TRUTH = "/truth/pose"
TOPIC_PERCEIVED = "/perceived/pose"
TOPIC_EVENTS = "/events"
TOPIC_SCENE = "/world/scene"
TOPIC_TERRAIN = "/world/terrain"
TOPIC_MAP = "/nav/map"
TOPIC_LIDAR = "/lidar"
TOPIC_MOVERS = "/world/movers"
TOPIC_TF = "/tf"
TOPIC_ROBOT = "/robot/body"
TOPIC_TERRAIN_MESH = "/world/terrain_mesh"
TOPIC_CMD = "/nav/cmd"
TOPIC_DEBUG = "/nav/debug"
#: The entities of :data:`TOPIC_DEBUG`, one per frame a navigator draws in.
DEBUG_ENTITIES = {"map": "navigator/map", "robot": "navigator/robot"}
#: The ground surface in a trace spans at most this many triangle pairs along the map's longer side.
MESH_MAX_CELLS = 80
#: The robot's frames: the true pose's, and the navigator's belief (``perceived/`` prefixed).
FRAME_ROBOT, FRAME_LIDAR = "base_link", "lidar"
BELIEF = "perceived/"
#: The name of the trace's metadata record of the robot (:func:`robot_metadata`).
ROBOT_METADATA = "navstress.robot"
MOVER_COLOUR = Color(r=0.2, g=0.35, b=0.85, a=1.0)

LEVELS = {"debug": 1, "info": 2, "warning": 3, "error": 4, "fatal": 5}


def _ns(t: float) -> int:
    return int(round(t * 1e9))


def _stamp(t: float) -> Timestamp:
    ns = _ns(t)
    return Timestamp(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def quaternion(yaw: float, pitch: float, roll: float) -> Quaternion:
    """Z-Y-X (yaw, pitch, roll) Euler angles to a unit quaternion."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return Quaternion(w=cr * cp * cy + sr * sp * sy, x=sr * cp * cy - cr * sp * sy,
                      y=cr * sp * cy + sr * cp * sy, z=cr * cp * sy - sr * sp * cy)


def euler(q: Any) -> tuple[float, float, float]:
    """Unit quaternion to (yaw, pitch, roll), inverse of :func:`quaternion`."""
    w, x, y, z = q.w, q.x, q.y, q.z
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return yaw, pitch, roll


def _rgba(c: tuple[float, float, float, float]) -> dict[str, float]:
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def _colour(hex_rgb: str) -> Color:
    """A ``#rrggbb`` colour of :mod:`navstress.world.colours` (the pictures' own), opaque."""
    from navstress.world.colours import rgb  # (local: the world package imports numba)

    r, g, b = rgb(hex_rgb)
    return Color(r=r, g=g, b=b, a=1.0)


def terrain_mesh(heights: np.ndarray, cell_m: float, max_cells: int = MESH_MAX_CELLS) -> tuple[np.ndarray, np.ndarray]:
    """The ground as a triangle surface: vertices (n, 3) and counter-clockwise triangles (m, 3) of
    vertex indices. The vertices are nodes of the height grid (node (i, j) at x = j * cell_m,
    y = i * cell_m, its exact height), every k-th row and column with k the smallest step that
    keeps at most ``max_cells`` cells along the longer side (the last row and column always kept);
    between them the surface is linear, so with k > 1 it is the terrain seen at k * cell_m (a
    picture, not the simulated surface). Flat ground is its four corners."""
    from navstress.world.world import terrain_faces  # (local: the world package imports numba)

    h = np.asarray(heights, dtype=np.float64)
    rows, cols = h.shape
    if float(h.max() - h.min()) < 1e-12:
        ri, ci = np.array([0, rows - 1]), np.array([0, cols - 1])
    else:
        k = max(1, math.ceil((max(rows, cols) - 1) / max_cells))
        ri = np.unique(np.append(np.arange(0, rows, k), rows - 1))
        ci = np.unique(np.append(np.arange(0, cols, k), cols - 1))
    yy, xx = np.meshgrid(ri * cell_m, ci * cell_m, indexing="ij")
    verts = np.column_stack([xx.ravel(), yy.ravel(), h[np.ix_(ri, ci)].ravel()])
    return verts, terrain_faces(len(ri), len(ci))  # the triangulation exported meshes have


_COMMAND_CLASS: Any = None


def command_class() -> Any:
    """The protobuf message class of ``/nav/cmd``: ``navstress.VelocityCommand`` with
    ``timestamp`` (``google.protobuf.Timestamp``), ``frame_id`` (the robot's body frame),
    ``linear`` (m/s, forward positive) and ``angular`` (rad/s, counter-clockwise): what the
    navigator commanded. Foxglove has no velocity-command schema, so navstress defines this one;
    it is stored in the trace like every schema, so any MCAP protobuf reader (and Foxglove's Plot
    panel) decodes it."""
    global _COMMAND_CLASS
    if _COMMAND_CLASS is None:
        from google.protobuf import descriptor_pb2, descriptor_pool, message_factory, timestamp_pb2

        pool = descriptor_pool.Default()
        try:
            desc = pool.FindMessageTypeByName("navstress.VelocityCommand")
        except KeyError:
            f = descriptor_pb2.FileDescriptorProto(name="navstress/VelocityCommand.proto", package="navstress",
                                                   syntax="proto3",
                                                   dependency=[timestamp_pb2.DESCRIPTOR.name])
            m = f.message_type.add(name="VelocityCommand")
            fd = descriptor_pb2.FieldDescriptorProto
            m.field.add(name="timestamp", number=1, type=fd.TYPE_MESSAGE, label=fd.LABEL_OPTIONAL,
                        type_name=".google.protobuf.Timestamp")
            m.field.add(name="frame_id", number=2, type=fd.TYPE_STRING, label=fd.LABEL_OPTIONAL)
            m.field.add(name="linear", number=3, type=fd.TYPE_DOUBLE, label=fd.LABEL_OPTIONAL)
            m.field.add(name="angular", number=4, type=fd.TYPE_DOUBLE, label=fd.LABEL_OPTIONAL)
            pool.Add(f)
            desc = pool.FindMessageTypeByName("navstress.VelocityCommand")
        _COMMAND_CLASS = message_factory.GetMessageClass(desc)
    return _COMMAND_CLASS


def mount_frames(robot: RobotSpec) -> list[tuple[str, tuple[float, float, float], tuple[float, float, float]]]:
    """The robot's sensor frames below ``base_link``: (name, xyz, rpy) of each mount, and
    ``lidar`` at the simulation's lidar position when the robot names no ``lidar`` mount; a robot
    that lists its sensors (``RobotSpec.sensors``) adds a frame per sensor, named as the sensor, at
    its mount (a sensor's mount wins over a robot mount of the same name)."""
    out = [(name, m.xyz, m.rpy) for name, m in robot.mounts.items()]
    if "lidar" not in robot.mounts:
        lm = robot.lidar
        out.insert(0, (FRAME_LIDAR, (lm.x_m, lm.y_m, lm.z_m), (0.0, 0.0, 0.0)))
    for s in robot.sensors or ():
        at = next((i for i, f in enumerate(out) if f[0] == s.name), None)
        entry = (s.name, s.mount.xyz, s.mount.rpy)
        if at is None:
            out.append(entry)
        else:
            out[at] = entry
    return out


def sensor_frames(robot: RobotSpec) -> list[tuple[str, str, tuple[float, float, float], tuple[float, float, float]]]:
    """Frames below the sensors' own (parent, child, xyz, rpy): each kind's ``extra["frames"]``
    (a depth camera's optical frame), for a robot that lists its sensors."""
    out = []
    for s in robot.sensors or ():
        frames = kinds()[s.kind].extra.get("frames")
        if callable(frames):
            out.extend(frames(s))
    return out


def sensors_metadata(robot: RobotSpec) -> list[dict[str, Any]]:
    """The sensors of the trace's robot metadata: name, kind, profile, mount (xyz, rpy), in the
    suite's order (a robot that lists its sensors)."""
    return [{"name": s.name, "kind": s.kind, "profile": s.profile,
             "mount": {"xyz": list(s.mount.xyz), "rpy": list(s.mount.rpy)}} for s in robot.sensors or ()]


def default_lidar(sensor: Sensor) -> bool:
    """Whether ``sensor`` is the default lidar: the ``lidar3d`` named ``lidar`` (the default suite's),
    recorded on :data:`TOPIC_LIDAR` with ``record_lidar`` as before sensors were declared; every
    other sensor has its kind's topics under ``/sensors/<name>``."""
    return sensor.kind == "lidar3d" and sensor.name == FRAME_LIDAR


def recorded_sensors(sensors: Sequence[Sensor]) -> list[Sensor]:
    """The sensors of a suite that a trace records through their kind's ``trace`` encoder."""
    return [s for s in sensors if not default_lidar(s) and kinds()[s.kind].trace is not None]


def sensor_topics(sensor: Sensor) -> dict[str, Any]:
    """Every topic a sensor's kind writes for it, with its protobuf class (``extra["topics"]``)."""
    topics = kinds()[sensor.kind].extra.get("topics")
    return dict(topics(sensor)) if callable(topics) else {}


class SensorRecorder:
    """Which readings of a run's sensors go into its trace: every reading of each sensor of
    :func:`recorded_sensors`, at most one per its kind's ``extra["trace_period_s"]`` of simulated
    time (``min_period_s`` raises every period: the live view's). Pure bookkeeping: it reads the
    readings, never changes them."""

    def __init__(self, sensors: Sequence[Sensor], min_period_s: float = 0.0) -> None:
        self.sensors = recorded_sensors(sensors)
        self._period = {s.name: max(float(kinds()[s.kind].extra.get("trace_period_s", 0.0)), min_period_s)
                        for s in self.sensors}
        self._next = {s.name: -math.inf for s in self.sensors}

    def take(self, readings: Mapping[str, Sequence[Any]]) -> list[tuple[Sensor, Any]]:
        """The readings of ``readings`` (by sensor name, each in time order) to record now."""
        out = []
        for s in self.sensors:
            for r in readings.get(s.name, ()):
                if r.t >= self._next[s.name] - 1e-9:
                    out.append((s, r))
                    self._next[s.name] = r.t + self._period[s.name]
        return out


def box_robot(size: tuple[float, float, float], lidar: tuple[float, float, float]) -> RobotSpec:
    """A RobotSpec of a box ``size`` (length, width, height) with its lidar at ``lidar``, the rest
    the default's (built without the checks across fields: only its shape is drawn)."""
    lx, ly, lz = (float(v) for v in lidar)
    return RobotSpec.model_construct(**{**RobotSpec().__dict__, "name": "box", "length_m": float(size[0]),
                                        "width_m": float(size[1]), "body_height_m": float(size[2]),
                                        "mounts": {"lidar": Mount(xyz=(lx, ly, lz))}})


def prism(ring: np.ndarray, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism over the convex counter-clockwise polygon ``ring`` (n, 2) from ``z0`` to
    ``z1``: vertices (2n, 3) and outward-facing triangles (4n - 4, 3)."""
    n = len(ring)
    verts = np.vstack([np.column_stack([ring, np.full(n, z0)]), np.column_stack([ring, np.full(n, z1)])])
    tris = []
    for i in range(n):
        j = (i + 1) % n
        tris += [(i, j, n + j), (i, n + j, n + i)]  # side
    for i in range(1, n - 1):
        tris += [(0, i + 1, i), (n, n + i, n + i + 1)]  # bottom (facing down), top (facing up)
    return verts.astype(np.float64), np.array(tris, dtype=np.int64)


def robot_metadata(robot: RobotSpec) -> dict[str, str]:
    """The trace's ``navstress.robot`` metadata: ``name``, ``digest``, ``description`` (the
    RobotSpec as canonical JSON), and for viewers ``footprint`` (the outline's points in
    ``base_link``, JSON), ``mounts`` (name -> xyz, rpy, JSON) and, for a robot that lists its
    sensors, ``sensors`` (:func:`sensors_metadata`, JSON). A robot with the default suite
    (``sensors`` None) leaves ``sensors`` out of its description and its metadata: its trace is
    byte for byte the one of before sensors were declared."""
    out = {"name": robot.name, "digest": robot.digest, "description": robot.description(),
           "footprint": dumps([[round(float(x), 9), round(float(y), 9)] for x, y in robot.footprint_points()]),
           "mounts": dumps({n: {"xyz": list(xyz), "rpy": list(rpy)} for n, xyz, rpy in mount_frames(robot)},
                           sort_keys=True)}
    if robot.sensors is not None:
        out["sensors"] = dumps(sensors_metadata(robot))
    return out


class TraceMessages:
    """The messages of a run's trace, built from the run's data (one method per kind) and handed
    to :meth:`_put`: :class:`TraceWriter` files them, :class:`navstress.run.live.LivePublisher`
    sends them to Foxglove as the run goes, so a live view and a trace show the same messages."""

    def _put(self, topic: str, msg: Any, log_time: int) -> None:
        raise NotImplementedError

    # -- messages ----------------------------------------------------------------------
    def pose(self, topic: str, t: float, x: float, y: float, z: float, yaw: float, pitch: float, roll: float) -> None:
        if not (math.isfinite(t) and t >= 0.0):  # a navigator's perceived trajectory may hold anything
            return
        msg = PoseInFrame(timestamp=_stamp(t), frame_id=FRAME,
                          pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=quaternion(yaw, pitch, roll)))
        self._put(topic, msg, _ns(t))

    def poses(self, topic: str, rows: np.ndarray) -> None:
        """Many poses at once: ``rows`` (N, 7) = t, x, y, z, yaw, pitch, roll."""
        for r in np.asarray(rows, dtype=np.float64):
            self.pose(topic, *(float(v) for v in r))

    def transforms(self, parent: str, child: str, rows: np.ndarray) -> None:
        """``foxglove.FrameTransform`` ``parent -> child`` at each row (N, 7) = t, x, y, z, yaw,
        pitch, roll (rows with a non-finite value are left out)."""
        for r in np.asarray(rows, dtype=np.float64):
            if not (np.all(np.isfinite(r)) and r[0] >= 0.0):
                continue
            t, x, y, z, yaw, pitch, roll = (float(v) for v in r)
            msg = FrameTransform(timestamp=_stamp(t), parent_frame_id=parent, child_frame_id=child,
                                 translation=Vector3(x=x, y=y, z=z), rotation=quaternion(yaw, pitch, roll))
            self._put(TOPIC_TF, msg, _ns(t))

    def robot(self, robot: RobotSpec | tuple[float, float, float], lidar: tuple[float, float, float] | None = None, *,
              belief: bool) -> None:
        """The robot (a RobotSpec; or, as before robots were data, a box's (length, width, height)
        and its ``lidar`` mount (x, y, z)): its sensor mounts as static transforms ``base_link -> <mount name>`` (each
        mount of the RobotSpec, and ``lidar`` where the simulation's lidar is when the robot names
        no such mount), and one ``/robot/body`` SceneUpdate whose entities are locked to
        ``base_link`` (opaque) and, with ``belief``, to ``perceived/base_link`` (translucent), so
        that the drift between truth and belief shows as two bodies. The body is the footprint
        raised to the body's height (a box footprint: a cube; a circle or a polygon: a prism of
        its outline), and the footprint's outline is drawn on the ground (``footprint`` lines)."""
        if not isinstance(robot, RobotSpec):
            robot = box_robot(robot, lidar if lidar is not None else (0.35, 0.0, 0.75))
        frames = [FRAME_ROBOT] + ([BELIEF + FRAME_ROBOT] if belief else [])
        ents = []
        h = robot.body_height_m
        ring = robot.footprint_points()
        ground = -robot.wheel_radius_m  # base_link is at the axle height
        for frame in frames:
            prefix = frame[: -len(FRAME_ROBOT)]
            for name, xyz, rpy in mount_frames(robot):
                self.transforms(frame, prefix + name, np.array([[0.0, *xyz, rpy[2], rpy[1], rpy[0]]]))
            for parent, child, xyz, rpy in sensor_frames(robot):
                self.transforms(prefix + parent, prefix + child, np.array([[0.0, *xyz, rpy[2], rpy[1], rpy[0]]]))
            alpha = 1.0 if not prefix else 0.35
            colour = Color(r=0.95, g=0.6, b=0.1, a=alpha)
            outline = LinePrimitive(type=LinePrimitive.LINE_STRIP, pose=Pose(orientation=Quaternion(w=1.0)),
                                    thickness=0.02, scale_invariant=False, color=Color(r=0.1, g=0.1, b=0.1, a=alpha),
                                    points=[Point3(x=float(x), y=float(y), z=ground)
                                            for x, y in np.vstack([ring, ring[:1]]).tolist()])
            if robot.footprint.shape == "box":
                body = CubePrimitive(pose=Pose(position=Vector3(), orientation=Quaternion(w=1.0)),
                                     size=Vector3(x=robot.length_m, y=robot.width_m, z=h), color=colour)
                ents.append(SceneEntity(timestamp=_stamp(0.0), frame_id=frame, id=f"{prefix}robot",
                                        frame_locked=True, cubes=[body], lines=[outline]))
            else:
                verts, tris = prism(ring, -h / 2, h / 2)
                body_t = TriangleListPrimitive(pose=Pose(orientation=Quaternion(w=1.0)), color=colour,
                                               points=[Point3(x=x, y=y, z=z) for x, y, z in verts.tolist()],
                                               indices=tris.ravel().tolist())
                ents.append(SceneEntity(timestamp=_stamp(0.0), frame_id=frame, id=f"{prefix}robot",
                                        frame_locked=True, triangles=[body_t], lines=[outline]))
        self._put(TOPIC_ROBOT, SceneUpdate(entities=ents), 0)

    def event(self, t: float, level: str, message: str, name: str = "navstress") -> None:
        msg = Log(timestamp=_stamp(t), level=LEVELS[level], message=cap_message(message), name=name)  # type: ignore[arg-type]
        self._put(TOPIC_EVENTS, msg, _ns(t))

    def grid(self, topic: str, t: float, values: np.ndarray, origin_xy: tuple[float, float], cell_m: float,
             field: str = "elevation") -> None:
        """A 2-D float32 grid (rows along +y) anchored at ``origin_xy`` (the corner of cell [0, 0])."""
        v = np.ascontiguousarray(values, dtype="<f4")
        rows, cols = v.shape
        msg = Grid(timestamp=_stamp(t), frame_id=FRAME,
                   pose=Pose(position=Vector3(x=origin_xy[0], y=origin_xy[1], z=0.0), orientation=Quaternion(w=1.0)),
                   column_count=cols, cell_size=Vector2(x=cell_m, y=cell_m), row_stride=cols * 4, cell_stride=4,
                   fields=[PackedElementField(name=field, offset=0, type=PackedElementField.FLOAT32)],
                   data=v.tobytes())
        self._put(topic, msg, _ns(t))

    def points(self, t: float, pts: np.ndarray, frame: str = FRAME) -> None:
        """A lidar point cloud (N, 3) in ``frame`` (the map frame in traces)."""
        p = np.ascontiguousarray(pts, dtype="<f4")
        msg = PointCloud(timestamp=_stamp(t), frame_id=frame,
                         pose=Pose(position=Vector3(), orientation=Quaternion(w=1.0)), point_stride=12,
                         fields=[PackedElementField(name=n, offset=4 * i, type=PackedElementField.FLOAT32)
                                 for i, n in enumerate("xyz")], data=p.tobytes())
        self._put(TOPIC_LIDAR, msg, _ns(t))

    def reading(self, sensor: Sensor, reading: Any) -> None:
        """One reading of ``sensor`` as its kind's ``trace`` encoder writes it (a kind module
        declares its topics and messages: ``/sensors/<name>...``), logged at the reading's time."""
        encoder = kinds()[sensor.kind].trace
        if encoder is None:
            return
        for topic, msg in encoder(reading, sensor):
            self._put(topic, msg, _ns(reading.t))

    def scene(self, obstacles: list[dict[str, Any]], start: tuple[float, float, float], goal: tuple[float, float],
              ground_z: tuple[float, float]) -> None:
        """Obstacles (dicts with kind, x, y, yaw, size, z and, for a cylinder, ``shape``: what
        ``Obstacle.to_json`` writes) as cubes (boxes and walls, in order) and cylinders (an
        upright ``CylinderPrimitive`` of size (diameter, diameter, height), centred half its height
        above its base, in order); start and goal as spheres; in the colours of the world's
        pictures (per obstacle kind, start, goal)."""
        from navstress.world.colours import GOAL_COLOUR, START_COLOUR, kind_colour  # (local: as terrain_faces)

        kinds = sorted({o["kind"] for o in obstacles})
        colour = {k: _colour(kind_colour(k, kinds)) for k in kinds}

        def pose(o: dict[str, Any]) -> Pose:
            return Pose(position=Vector3(x=o["x"], y=o["y"], z=o["z"] + o["size"][2] / 2),
                        orientation=quaternion(o["yaw"], 0.0, 0.0))

        cubes = [CubePrimitive(pose=pose(o), size=Vector3(x=o["size"][0], y=o["size"][1], z=o["size"][2]),
                               color=colour[o["kind"]])
                 for o in obstacles if o.get("shape", "box") == "box"]
        cylinders = [CylinderPrimitive(pose=pose(o), size=Vector3(x=o["size"][0], y=o["size"][0], z=o["size"][2]),
                                       bottom_scale=1.0, top_scale=1.0, color=colour[o["kind"]])
                     for o in obstacles if o.get("shape", "box") == "cylinder"]
        marks = [SpherePrimitive(pose=Pose(position=Vector3(x=start[0], y=start[1], z=ground_z[0] + 0.5),
                                           orientation=Quaternion(w=1.0)),
                                 size=Vector3(x=1, y=1, z=1), color=_colour(START_COLOUR)),
                 SpherePrimitive(pose=Pose(position=Vector3(x=goal[0], y=goal[1], z=ground_z[1] + 0.5),
                                           orientation=Quaternion(w=1.0)),
                                 size=Vector3(x=1, y=1, z=1), color=_colour(GOAL_COLOUR))]
        ent = SceneEntity(timestamp=_stamp(0.0), frame_id=FRAME, id="world", frame_locked=True,
                          cubes=cubes, spheres=marks, cylinders=cylinders)
        self._put(TOPIC_SCENE, SceneUpdate(entities=[ent]), 0)

    def commands(self, rows: np.ndarray) -> None:
        """The navigator's velocity commands on :data:`TOPIC_CMD`: ``rows`` (N, 3) = t (the
        simulated time it was given), linear m/s, angular rad/s."""
        cls = command_class()
        for t, v, w in np.asarray(rows, dtype=np.float64).reshape(-1, 3).tolist():
            if math.isfinite(t) and t >= 0.0:
                self._put(TOPIC_CMD, cls(timestamp=_stamp(t), frame_id=FRAME_ROBOT, linear=v, angular=w), _ns(t))

    def debug(self, t: float, draw: DebugDraw) -> None:
        """A navigator's drawing (checked by :func:`navstress.nav.api.check_debug`) at ``t`` on
        :data:`TOPIC_DEBUG`: one SceneUpdate with an entity per frame (:data:`DEBUG_ENTITIES`),
        ``navigator/map`` in ``map``, ``navigator/robot`` locked to the belief's
        ``perceived/base_link``; both always sent, so each drawing replaces the last one whole.
        Lines are line strips, points spheres, texts billboards."""
        ents = []
        for frame, eid in DEBUG_ENTITIES.items():
            fid = FRAME if frame == "map" else BELIEF + FRAME_ROBOT
            lines = [LinePrimitive(type=LinePrimitive.LINE_STRIP, pose=Pose(orientation=Quaternion(w=1.0)),
                                   thickness=ln.width_m, scale_invariant=False, color=Color(**_rgba(ln.colour)),
                                   points=[Point3(x=x, y=y, z=z) for x, y, z in ln.points.tolist()])
                     for ln in draw.lines if ln.frame == frame]
            spheres = [SpherePrimitive(pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0)),
                                       size=Vector3(x=p.size_m, y=p.size_m, z=p.size_m),
                                       color=Color(**_rgba(p.colour)))
                       for p in draw.points if p.frame == frame for x, y, z in p.points.tolist()]
            texts = [TextPrimitive(pose=Pose(position=Vector3(x=tx.position[0], y=tx.position[1], z=tx.position[2]),
                                             orientation=Quaternion(w=1.0)),
                                   billboard=True, font_size=tx.size_m, scale_invariant=False,
                                   color=Color(**_rgba(tx.colour)), text=tx.text)
                     for tx in draw.texts if tx.frame == frame]
            ents.append(SceneEntity(timestamp=_stamp(t), frame_id=fid, id=eid, frame_locked=frame == "robot",
                                    lines=lines, spheres=spheres, texts=texts))
        self._put(TOPIC_DEBUG, SceneUpdate(entities=ents), _ns(t))

    def terrain(self, heights: np.ndarray, cell_m: float) -> None:
        """The ground as a 3D surface (:func:`terrain_mesh`), coloured by height, on
        :data:`TOPIC_TERRAIN_MESH` (one ``foxglove.SceneUpdate``, entity ``terrain``), so that
        the robot and the obstacles stand on it in a 3D view."""
        from navstress.world.colours import terrain_colours  # (local: as terrain_faces)

        verts, tris = terrain_mesh(heights, cell_m)
        z = verts[:, 2]
        span = float(z.max() - z.min()) if len(z) else 0.0
        rgb = terrain_colours((z - z.min()) / span if span > 1e-12 else np.full(len(z), 0.25))
        prim = TriangleListPrimitive(
            pose=Pose(orientation=Quaternion(w=1.0)),
            points=[Point3(x=float(x), y=float(y), z=float(zz)) for x, y, zz in verts.tolist()],
            colors=[Color(r=float(r), g=float(g), b=float(b), a=1.0) for r, g, b in rgb.tolist()],
            indices=tris.ravel().tolist())
        ent = SceneEntity(timestamp=_stamp(0.0), frame_id=FRAME, id="terrain", frame_locked=True, triangles=[prim])
        self._put(TOPIC_TERRAIN_MESH, SceneUpdate(entities=[ent]), 0)

    def movers(self, times: np.ndarray, poses: np.ndarray,
               movers: list[tuple[int, str, str, tuple[float, float, float]]]) -> None:
        """The movers at each time: ``poses`` (m, n, 4) x, y, z (body centre), yaw; ``movers`` the
        (id, kind, shape, size) of each (``World.movers``): one SceneUpdate per time, an entity
        ``mover/<id>`` per mover (a cylinder for a disc, else a cube)."""
        p = np.asarray(poses, dtype=np.float64)
        for k, t in enumerate(np.asarray(times, dtype=np.float64).tolist()):
            ents = []
            for i, (mid, kind, shape, size) in enumerate(movers):
                x, y, z, yaw = p[k, i].tolist()
                pose = Pose(position=Vector3(x=x, y=y, z=z), orientation=quaternion(yaw, 0.0, 0.0))
                dims = Vector3(x=size[0], y=size[1], z=size[2])
                prim: dict[str, Any] = ({"cylinders": [CylinderPrimitive(pose=pose, size=dims, bottom_scale=1.0,
                                                                         top_scale=1.0, color=MOVER_COLOUR)]}
                                        if shape == "disc" else {"cubes": [CubePrimitive(pose=pose, size=dims,
                                                                                          color=MOVER_COLOUR)]})
                ents.append(SceneEntity(timestamp=_stamp(t), frame_id=FRAME, id=f"mover/{mid}", frame_locked=False,
                                        metadata=[KeyValuePair(key="kind", value=kind)], **prim))
            self._put(TOPIC_MOVERS, SceneUpdate(entities=ents), _ns(t))


class TraceWriter(TraceMessages):
    """Writes one run's MCAP trace atomically (``path`` appears only when closed successfully)."""

    def __init__(self, path: str | os.PathLike[str], metadata: dict[str, str] | None = None) -> None:
        self.path = Path(path)
        self._tmp = self.path.with_name(f".{self.path.name}.partial")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._f: IO[bytes] = _files.open_nofollow(self._tmp, "wb")  # a link planted there is refused
        self._w = Writer(self._f, compression=CompressionType.ZSTD)
        self._w._writer.add_metadata("navstress.run", {k: str(v) for k, v in (metadata or {}).items()})
        self._pending: list[tuple[int, int, str, Any]] = []  # (log_time, submission order, topic, message)
        self._robot_written = False

    def robot(self, robot: RobotSpec | tuple[float, float, float], lidar: tuple[float, float, float] | None = None, *,
              belief: bool) -> None:
        """As :meth:`TraceMessages.robot`, and the robot's ``navstress.robot`` metadata
        (:func:`robot_metadata`; :func:`read_robot` reads it back)."""
        if not isinstance(robot, RobotSpec):
            robot = box_robot(robot, lidar if lidar is not None else (0.35, 0.0, 0.75))
        if not self._robot_written:
            self._w._writer.add_metadata(ROBOT_METADATA, robot_metadata(robot))
            self._robot_written = True
        super().robot(robot, belief=belief)

    def _put(self, topic: str, msg: Any, log_time: int) -> None:
        """Queue one message; :meth:`close` writes the queue in log-time order."""
        self._pending.append((log_time, len(self._pending), topic, msg))

    # -- lifecycle ---------------------------------------------------------------------
    def close(self) -> Path:
        """Write the queued messages in log-time order, finish the file and move it into place
        atomically; returns the final path."""
        self._pending.sort(key=lambda m: (m[0], m[1]))
        sequence: dict[str, int] = {}
        for log_time, _order, topic, msg in self._pending:
            sequence[topic] = sequence.get(topic, 0) + 1  # per channel, from 1, in file order
            self._w.write_message(topic, msg, log_time=log_time, publish_time=log_time, sequence=sequence[topic])
        self._pending.clear()
        self._w.finish()  # type: ignore[no-untyped-call]
        self._f.flush()
        os.fsync(self._f.fileno())
        self._f.close()
        _files.rename_into_place(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial file (used when the run itself could not be recorded)."""
        self._pending.clear()
        try:
            self._f.close()
        finally:
            self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> "TraceWriter":
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


# -- reading ----------------------------------------------------------------------------
@dataclass(frozen=True)
class TraceEvent:
    t: float
    level: int
    name: str
    message: str


def _messages(path: str | os.PathLike[str], topics: list[str]) -> Iterator[tuple[str, int, Any]]:
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _schema, channel, message, decoded in reader.iter_decoded_messages(topics=topics):
                yield channel.topic, message.log_time, decoded
    except FileNotFoundError:
        raise StoreError(f"trace={str(path)!r} does not exist") from None
    except Exception as err:  # mcap raises several unrelated types on corrupt input
        if isinstance(err, StoreError):
            raise
        raise StoreError(f"trace={str(path)!r} is unreadable: {type(err).__name__}: {err}") from None


def _index_chunks(path: str | os.PathLike[str], topics: Sequence[str], schema: str
                  ) -> dict[str, list[tuple[int, bytes, np.ndarray]]] | None:
    """Where the messages of ``topics`` are, found through the file's MCAP message indexes: per
    topic, for each chunk that holds it, (the chunk's start offset in the file, its decompressed
    records, (n, 2) uint64 (log time, offset of the Message record in those records)); each chunk
    is decompressed once, whatever the number of topics in it. None when the file has no summary
    or index, or a topic's schema is not ``schema`` (the caller reads it the general way then);
    errors as :func:`_messages`."""
    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
            if summary is None or not summary.chunk_indexes:
                return None
            ids = {cid: ch.topic for cid, ch in summary.channels.items() if ch.topic in topics}
            if any(summary.schemas[summary.channels[c].schema_id].name != schema for c in ids
                   if summary.channels[c].schema_id in summary.schemas):
                return None
            out: dict[str, list[tuple[int, bytes, np.ndarray]]] = {t: [] for t in topics}
            for ci in summary.chunk_indexes:
                mine = [(ids[c], ci.message_index_offsets[c]) for c in ids if c in ci.message_index_offsets]
                if not mine:
                    continue
                f.seek(ci.chunk_start_offset + 1 + 8)
                chunk = Chunk.read(ReadDataStream(f))
                if chunk.compression == "zstd":
                    data = zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
                elif chunk.compression == "":
                    data = chunk.data
                else:
                    return None
                for topic, off in mine:
                    # a MessageIndex record: opcode (1), length (8), channel (2), byte length of
                    # the entries (4), then (log time, offset in the chunk) pairs, u64 each
                    f.seek(off)
                    opcode, length = struct.unpack("<BQ", f.read(9))
                    body = f.read(length)
                    if opcode != 0x07 or len(body) != length:
                        return None
                    (n,) = struct.unpack_from("<I", body, 2)
                    if 6 + n > length or n % 16:
                        return None
                    entries = np.frombuffer(body, dtype="<u8", count=n // 8, offset=6).reshape(-1, 2)
                    out[topic].append((ci.chunk_start_offset, data, entries))
    except FileNotFoundError:
        raise StoreError(f"trace={str(path)!r} does not exist") from None
    except Exception as err:  # mcap raises several unrelated types on corrupt input
        raise StoreError(f"trace={str(path)!r} is unreadable: {type(err).__name__}: {err}") from None
    return out


def _indexed(path: str | os.PathLike[str], topic: str, schema: str) -> list[tuple[int, bytes]] | None:
    """(log time, payload) of every message on ``topic``, in log-time order, through the file's
    MCAP message indexes (:func:`_index_chunks`): only the topic's message records are parsed
    (the library's reader parses every record of a chunk). None and errors as
    :func:`_index_chunks`."""
    chunks = _index_chunks(path, [topic], schema)
    if chunks is None:
        return None
    found: list[tuple[int, int, int, bytes]] = []
    for start, data, entries in chunks[topic]:
        for log_time, at in entries.tolist():
            # a Message record: opcode (1), length (8), channel (2), sequence (4), log time (8),
            # publish time (8), then the payload
            if at + 9 > len(data):
                return None
            opcode, length = struct.unpack_from("<BQ", data, at)
            if opcode != 0x05:
                return None
            found.append((log_time, start, at, data[at + 31:at + 9 + length]))
    found.sort(key=lambda m: m[:3])
    return [(m[0], m[3]) for m in found]


def _poses_indexed(path: str | os.PathLike[str], topics: Sequence[str]) -> dict[str, np.ndarray | None] | None:
    """Each of ``topics``'s poses (as :func:`read_poses`) through the message indexes, decoded by a
    compiled loop (:func:`navstress.run.posewire.pose_rows`), the file opened and each chunk
    decompressed once for all of them. None when the file has no usable index; a topic's value is
    None when one of its messages is not one that loop reads (protobuf decodes that topic then)."""
    chunks = _index_chunks(path, topics, PoseInFrame.DESCRIPTOR.full_name)
    if chunks is None:
        return None
    from navstress.run.posewire import pose_rows  # (local: numba, which the trace's writers never need)

    def decoded(parts: list[tuple[int, bytes, np.ndarray]]) -> np.ndarray | None:
        rows, keys = [np.zeros((0, 7))], [np.zeros((0, 3), dtype=np.uint64)]
        for start, data, entries in parts:
            out = np.empty((len(entries), 7), dtype=np.float64)
            # (an offset past int64 wraps negative: pose_rows refuses it like any offset out of the chunk)
            if pose_rows(np.frombuffer(data, dtype=np.uint8), entries[:, 1].astype(np.int64), entries[:, 0].copy(),
                         out) != -1:
                return None
            rows.append(out)
            keys.append(np.column_stack([entries[:, 0], np.full(len(entries), start, dtype=np.uint64), entries[:, 1]]))
        k = np.concatenate(keys)
        # log-time order, ties by place in the file, as the library's reader gives them
        return np.concatenate(rows)[np.lexsort((k[:, 2], k[:, 1], k[:, 0]))]

    return {t: decoded(chunks[t]) for t in topics}


def _poses_protobuf(path: str | os.PathLike[str], topic: str, indexed: bool) -> np.ndarray:
    """:func:`read_poses` decoded message by message with protobuf (found through the message
    indexes when ``indexed``, else by the MCAP library's reader)."""
    rows = []
    for log_time, m in _decoded(path, topic, PoseInFrame, indexed):
        p = m.pose.position
        rows.append((log_time / 1e9, p.x, p.y, p.z, *euler(m.pose.orientation)))
    return np.array(rows, dtype=np.float64).reshape(-1, 7)


def read_poses_of(path: str | os.PathLike[str], topics: Sequence[str], *, indexed: bool = True
                  ) -> dict[str, np.ndarray]:
    """:func:`read_poses` of several topics of one trace, the file read once for all of them
    (what a report does for a failing run: its true and its perceived trajectory)."""
    fast = _poses_indexed(path, topics) if indexed else None
    out: dict[str, np.ndarray] = {}
    for t in topics:
        arr = None if fast is None else fast[t]
        # (no index: straight to the library's reader; a message the loop refused: protobuf decides)
        out[t] = arr if arr is not None else _poses_protobuf(path, t, fast is not None)
    return out


def read_poses(path: str | os.PathLike[str], topic: str = TOPIC_TRUTH, *, indexed: bool = True) -> np.ndarray:
    """(N, 7) float64: t, x, y, z, yaw, pitch, roll, in time order. Read through the file's
    message indexes and decoded by a compiled loop (:func:`_poses_indexed`), else (no index, a
    message that loop does not read, or ``indexed=False``) with the MCAP library's reader and
    protobuf; both give the same bytes."""
    return read_poses_of(path, [topic], indexed=indexed)[topic]


def read_transforms(path: str | os.PathLike[str]) -> dict[tuple[str, str], np.ndarray]:
    """The ``/tf`` frame transforms per (parent, child): (N, 7) rows t, x, y, z, yaw, pitch, roll."""
    out: dict[tuple[str, str], list[list[float]]] = {}
    for _t, lt, m in _messages(path, [TOPIC_TF]):
        p = m.translation
        out.setdefault((m.parent_frame_id, m.child_frame_id), []).append([lt / 1e9, p.x, p.y, p.z, *euler(m.rotation)])
    return {k: np.array(v, dtype=np.float64) for k, v in out.items()}


def read_terrain_mesh(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """The ground surface of a trace: vertices (n, 3) and triangles (m, 3), or None."""
    for _t, _lt, m in _messages(path, [TOPIC_TERRAIN_MESH]):
        tri = m.entities[0].triangles[0]
        verts = np.array([(p.x, p.y, p.z) for p in tri.points], dtype=np.float64).reshape(-1, 3)
        return verts, np.array(tri.indices, dtype=np.int64).reshape(-1, 3)
    return None


def read_commands(path: str | os.PathLike[str]) -> np.ndarray:
    """(N, 3) float64: t, linear, angular of the navigator's commands, in time order."""
    rows = [(lt / 1e9, m.linear, m.angular) for _t, lt, m in _messages(path, [TOPIC_CMD])]
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def read_debug(path: str | os.PathLike[str]) -> list[tuple[float, DebugDraw]]:
    """The navigator's drawings of a trace (:meth:`TraceWriter.debug`), in time order: points of
    one :class:`~navstress.nav.api.DebugPoints` come back as one set per point."""
    out = []
    for _t, lt, m in _messages(path, [TOPIC_DEBUG]):
        lines: list[DebugLine] = []
        points: list[DebugPoints] = []
        texts: list[DebugText] = []
        for e in m.entities:
            frame = next(f for f, eid in DEBUG_ENTITIES.items() if eid == e.id)
            for ln in e.lines:
                c = ln.color
                lines.append(DebugLine(np.array([(p.x, p.y, p.z) for p in ln.points], dtype=np.float64).reshape(-1, 3),
                                       frame, (c.r, c.g, c.b, c.a), ln.thickness))
            for sp in e.spheres:
                c, p = sp.color, sp.pose.position
                points.append(DebugPoints(np.array([[p.x, p.y, p.z]]), frame, (c.r, c.g, c.b, c.a), sp.size.x))
            for tx in e.texts:
                c, p = tx.color, tx.pose.position
                texts.append(DebugText((p.x, p.y, p.z), tx.text, frame, (c.r, c.g, c.b, c.a), tx.font_size))
        out.append((lt / 1e9, DebugDraw(tuple(lines), tuple(points), tuple(texts))))
    return out


def _decoded(path: str | os.PathLike[str], topic: str, cls: Any, indexed: bool = True) -> Iterator[tuple[int, Any]]:
    """(log time, message of protobuf class ``cls``) of every message on ``topic`` in log-time
    order, through the message indexes when the file has them (:func:`_indexed`: a report reads
    thousands of trajectories and hundreds of final maps), else the library's reader."""
    fast = _indexed(path, topic, cls.DESCRIPTOR.full_name) if indexed else None
    if fast is not None:
        return _parsed(path, fast, cls)
    return ((lt, m) for _t, lt, m in _messages(path, [topic]))


def _parsed(path: str | os.PathLike[str], found: list[tuple[int, bytes]], cls: Any) -> Iterator[tuple[int, Any]]:
    """The payloads of :func:`_indexed` parsed, a payload protobuf rejects reported as the
    library's reader reports it (:func:`_messages`: a StoreError naming the file)."""
    for lt, data in found:
        try:
            m = cls.FromString(data)
        except Exception as err:  # protobuf's DecodeError, and whatever else a corrupt payload raises
            raise StoreError(f"trace={str(path)!r} is unreadable: {type(err).__name__}: {err}") from None
        yield lt, m


def read_grids(path: str | os.PathLike[str], topic: str = TOPIC_MAP, *, indexed: bool = True
               ) -> list[tuple[float, np.ndarray, tuple[float, float], float]]:
    """Every grid on ``topic`` in time order: (t, values rows x cols float32, origin xy, cell_m);
    ``indexed``: as :func:`read_poses` (both ways give the same values)."""
    return [(lt / 1e9, _grid_values(m), (m.pose.position.x, m.pose.position.y), m.cell_size.x)
            for lt, m in _decoded(path, topic, Grid, indexed)]


def _grid_values(m: Any) -> np.ndarray:
    return np.frombuffer(m.data, dtype="<f4").reshape(-1, m.column_count).copy()


def read_events(path: str | os.PathLike[str]) -> list[TraceEvent]:
    return [TraceEvent(lt / 1e9, m.level, m.name, m.message) for _t, lt, m in _messages(path, [TOPIC_EVENTS])]


def read_grid(path: str | os.PathLike[str], topic: str = TOPIC_MAP, *, indexed: bool = True
              ) -> tuple[np.ndarray, tuple[float, float], float] | None:
    """The last grid on ``topic``: (values rows x cols float32, origin xy, cell_m), or None;
    ``indexed``: as :func:`read_poses`."""
    last = None
    for _lt, last in _decoded(path, topic, Grid, indexed):
        pass
    if last is None:
        return None
    return _grid_values(last), (last.pose.position.x, last.pose.position.y), last.cell_size.x


def read_movers(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """The movers of a trace: times (m,) and poses (m, n, 4) x, y, z, yaw (entity order, which is
    ``World.movers`` order); (0,) and (0, 0, 4) when it has none."""
    ts, rows = [], []
    for _t, lt, m in _messages(path, [TOPIC_MOVERS]):
        ts.append(lt / 1e9)
        row = []
        for e in m.entities:
            prim = e.cylinders[0] if len(e.cylinders) else e.cubes[0]
            q, pos = prim.pose.orientation, prim.pose.position
            row.append((pos.x, pos.y, pos.z, euler(q)[0]))
        rows.append(row)
    if not ts:
        return np.zeros(0), np.zeros((0, 0, 4))
    return np.array(ts), np.array(rows, dtype=np.float64).reshape(len(ts), -1, 4)


def read_metadata(path: str | os.PathLike[str], name: str = "navstress.run") -> dict[str, str]:
    """The trace's metadata record ``name`` (``navstress.run``: the run's seeds and settings;
    ``navstress.robot``: :func:`robot_metadata`), {} when it has none."""
    with open(path, "rb") as f:
        for md in make_reader(f).iter_metadata():
            if md.name == name:
                return dict(md.metadata)
    return {}


def read_robot(path: str | os.PathLike[str]) -> RobotSpec:
    """The robot a trace was recorded with (its ``navstress.robot`` metadata); the paper's
    ``rmp400`` for a trace written before robots were recorded. A description that is not a
    valid robot is a :class:`~navstress.errors.StoreError` naming the trace."""
    md = read_metadata(path, ROBOT_METADATA)
    if "description" not in md:
        return PROFILES["rmp400"]
    try:
        return RobotSpec.model_validate_json(md["description"])
    except (ValueError, NavstressError) as err:
        msg = " ".join(str(err).split())[:200]
        raise StoreError(f"trace={os.fspath(path)!r} has a robot description that is not valid ({msg}); "
                         "replay it from its campaign's store or record it again") from None
