"""What the sensor kinds' encoders share: trace topics and frames, Foxglove timestamps and point
clouds, ROS 2 headers and point clouds.

A kind's ``trace`` encoder turns one reading into Foxglove protobuf messages (topic, message); its
``ros2`` converters turn those messages (by Foxglove schema name) into ROS 2 messages of the
``rosbags`` typestore the export hands them (``types``: ``typestore.types``). Both are looked up by
kind, never named, in :mod:`navstress.run.trace` and :mod:`navstress.run.ros2`, so a new kind's
encoders live in its own module. A kind module may also declare, in ``KIND.extra``:

- ``topics``: ``topics(sensor) -> {topic: protobuf class}``, every topic its ``trace`` writes for
  that sensor (the live view advertises them before the run);
- ``trace_period_s``: the fewest simulated seconds between two recorded readings of one sensor
  (0 or absent: every reading; docs/traces.md has each kind's figures);
- ``frames``: ``frames(sensor) -> [(parent, child, xyz, rpy), ...]``, frames below the sensor's own
  (a camera's optical frame).

Imports of protobuf and numpy classes are local: importing the sensors package stays cheap.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Where a sensor named N (other than the default lidar) publishes: ``/sensors/N`` and below.
PREFIX = "/sensors/"
#: A camera's optical frame (z forward, x right, y down): ``<name>_optical``, below its frame.
OPTICAL_SUFFIX = "_optical"
#: The optical frame's rotation in the sensor frame (roll, pitch, yaw): x_opt = -y, y_opt = -z, z_opt = x.
OPTICAL_RPY = (-math.pi / 2, 0.0, -math.pi / 2)


def topic(name: str, suffix: str = "") -> str:
    """``/sensors/<name>`` (and ``/<suffix>`` when given)."""
    return PREFIX + name + (f"/{suffix}" if suffix else "")


def sensor_of_topic(t: str) -> str | None:
    """The sensor name of a topic under :data:`PREFIX`, else None."""
    if not t.startswith(PREFIX):
        return None
    name = t[len(PREFIX):].split("/", 1)[0]
    return name or None


def ns(t: float) -> int:
    """Simulated seconds as integer nanoseconds (the trace's log times)."""
    return int(round(t * 1e9))


def stamp(t: float) -> Any:
    """A ``google.protobuf.Timestamp`` of simulated time ``t``."""
    from google.protobuf.timestamp_pb2 import Timestamp

    n = ns(t)
    return Timestamp(seconds=n // 1_000_000_000, nanos=n % 1_000_000_000)


def identity_pose() -> Any:
    """A ``foxglove.Pose`` at the frame's origin, unrotated."""
    from foxglove_schemas_protobuf.Pose_pb2 import Pose
    from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
    from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

    return Pose(position=Vector3(), orientation=Quaternion(w=1.0))


def point_cloud(t: float, frame: str, pts: np.ndarray) -> Any:
    """A ``foxglove.PointCloud`` of (N, 3) points in ``frame``: x, y, z float32, 12 bytes a point
    (as the trace's ``/lidar``)."""
    from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
    from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud

    p = np.ascontiguousarray(np.asarray(pts).reshape(-1, 3), dtype="<f4")
    return PointCloud(timestamp=stamp(t), frame_id=frame, pose=identity_pose(), point_stride=12,
                      fields=[PackedElementField(name=n, offset=4 * i, type=PackedElementField.FLOAT32)
                              for i, n in enumerate("xyz")], data=p.tobytes())


def cloud_points(m: Any) -> np.ndarray:
    """The (N, 3) float32 points of a ``foxglove.PointCloud`` written by :func:`point_cloud`."""
    return np.frombuffer(m.data, dtype="<f4").reshape(-1, 3)


# -- ROS 2 (rosbags' typestore: ``types`` is ``typestore.types``) -------------------------------
def ros_header(types: Any, m: Any) -> Any:
    """The ``std_msgs/Header`` of a Foxglove message (its ``timestamp`` and ``frame_id``)."""
    return types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=m.timestamp.seconds, nanosec=m.timestamp.nanos),
        frame_id=m.frame_id)


def ros_cloud(types: Any, header: Any, xyz: np.ndarray) -> Any:
    """A ``sensor_msgs/PointCloud2`` of (N, 3) points: x, y, z float32."""
    pts = np.ascontiguousarray(np.asarray(xyz).reshape(-1, 3), dtype="<f4")
    field = types["sensor_msgs/msg/PointField"]
    return types["sensor_msgs/msg/PointCloud2"](
        header=header, height=1, width=len(pts),
        fields=[field(name=n, offset=4 * i, datatype=field.FLOAT32, count=1) for i, n in enumerate("xyz")],
        is_bigendian=False, point_step=12, row_step=12 * len(pts), data=np.frombuffer(pts.tobytes(), np.uint8),
        is_dense=True)
