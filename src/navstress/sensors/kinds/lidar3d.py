"""``lidar3d``: a spinning multi-channel lidar. Channels evenly spaced in elevation from
``min_elevation_deg`` to ``max_elevation_deg`` (as the three profiles' units are); azimuth step
``a`` points at ``2*pi*a/azimuth_steps`` counter-clockwise from the sensor's +x. Returns closer
than ``min_range_m`` or farther than ``max_range_m`` are dropped; each range gets N(0,
``range_noise_std_m``) noise along its ray; each return is lost with ``dropout_prob``.

Reading: :class:`LidarScan`, the hit points in the sensor frame (rays without a return omitted).

Profiles (sources in docs/sensors.md): ``hdl32`` (the paper's unit and the default: byte-identical
to navstress before sensors were declared), ``vlp16``, ``os1_64``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from navstress.errors import SpecError
from navstress.sensors import encode
from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import array, f32, num, pose_fields, text, vec3


class Lidar3dParams(SensorParams):
    """A spinning lidar's figures (defaults: the paper's Velodyne HDL-32E-class unit)."""

    channels: int = Field(32, ge=1, le=1024)
    min_elevation_deg: float = Field(-30.67, ge=-89.0, le=89.0)
    max_elevation_deg: float = Field(10.67, ge=-89.0, le=89.0)
    azimuth_steps: int = Field(360, ge=1, le=100_000)
    rate_hz: float = Field(10.0, gt=0)
    max_range_m: float = Field(70.0, gt=0)
    min_range_m: float = Field(0.3, ge=0)
    range_noise_std_m: float = Field(0.02, ge=0)
    dropout_prob: float = Field(0.0, ge=0, lt=1, description="chance that a return is lost")

    @model_validator(mode="after")
    def _check(self) -> "Lidar3dParams":
        if self.max_elevation_deg < self.min_elevation_deg or (
                self.channels > 1 and self.max_elevation_deg == self.min_elevation_deg):
            raise SpecError("max_elevation_deg", self.max_elevation_deg,
                            f"greater than min_elevation_deg={self.min_elevation_deg}", "swap the two values")
        if self.max_range_m <= self.min_range_m:
            raise SpecError("max_range_m", self.max_range_m, f"a distance > min_range_m={self.min_range_m}")
        return self


@dataclass(frozen=True, eq=False)
class LidarScan:
    """One full lidar revolution.

    ``points``: (N, 3) float32 hit points in the *sensor* frame (x forward, y left, z up),
    rays without a return omitted. ``t``: simulated time the scan was taken. ``mount``:
    sensor position (x, y, z) in the robot frame. The navigator places the scan in its map
    with its own pose estimate at time ``t``: the true pose is never given. ``sensor``: the
    name of the lidar that took it; ``rpy``: its mount's roll, pitch, yaw.
    """

    t: float
    points: np.ndarray
    mount: tuple[float, float, float]
    sensor: str = "lidar"
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


def beams(p: Lidar3dParams) -> tuple[np.ndarray, np.ndarray]:
    """(elevations, azimuths) in radians: channels ascending, azimuths from +x counter-clockwise."""
    el = np.radians(np.linspace(p.min_elevation_deg, p.max_elevation_deg, p.channels))
    az = 2.0 * np.pi * np.arange(p.azimuth_steps) / p.azimuth_steps
    return el, az


PROFILES: dict[str, dict[str, object]] = {
    # Velodyne HDL-32E: 32 channels +10.67 to -30.67 deg (1.33 deg apart), 70 m, 10 Hz, +-2 cm
    "hdl32": {},
    # Velodyne VLP-16 (Puck): 16 channels +-15 deg (2 deg apart), 100 m, 0.2 deg at 10 Hz, +-3 cm
    "vlp16": {"channels": 16, "min_elevation_deg": -15.0, "max_elevation_deg": 15.0, "azimuth_steps": 1800,
              "rate_hz": 10.0, "max_range_m": 100.0, "min_range_m": 0.5, "range_noise_std_m": 0.015},
    # Ouster OS1-64 (uniform beam spacing): 64 channels over 45 deg (+-22.5), 1024 columns at 10 Hz,
    # 120 m, minimum range 0.3 m, precision about 1.5 cm at short range
    "os1_64": {"channels": 64, "min_elevation_deg": -22.5, "max_elevation_deg": 22.5, "azimuth_steps": 1024,
               "rate_hz": 10.0, "max_range_m": 120.0, "min_range_m": 0.3, "range_noise_std_m": 0.015},
}

#: Fewest simulated seconds between two recorded scans of one lidar (as the default lidar's
#: ``/lidar`` with ``record_lidar``: a 32 x 360 scan is up to 138 kB, a VLP-16's 346 kB).
TRACE_PERIOD_S = 1.0


def trace_topics(sensor: Any) -> dict[str, Any]:
    """The trace topic of a lidar named N (not the default ``lidar``, which keeps ``/lidar``):
    ``/sensors/N``, ``foxglove.PointCloud``."""
    from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud

    return {encode.topic(sensor.name): PointCloud}


def trace(r: LidarScan, sensor: Any) -> list[tuple[str, Any]]:
    """A scan as a ``foxglove.PointCloud`` (x, y, z float32) on ``/sensors/<name>`` in the
    sensor's frame."""
    return [(encode.topic(sensor.name), encode.point_cloud(r.t, sensor.name, r.points))]


def ros2_cloud(types: Any, topic: str, m: Any, sensor: Any) -> list[tuple[str, Any]]:
    """``foxglove.PointCloud`` -> ``sensor_msgs/PointCloud2`` (x, y, z float32) on the same topic."""
    return [(topic, encode.ros_cloud(types, encode.ros_header(types, m), encode.cloud_points(m)))]

def to_wire(r: LidarScan) -> dict[str, Any]:
    """A cloud for the line protocol (version 2): ``points`` a base64 (N, 3) float32 array, sensor frame."""
    return {**pose_fields(r), "points": f32(np.asarray(r.points).reshape(-1, 3))}


def from_wire(d: dict[str, Any]) -> LidarScan:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return LidarScan(t=num(d, "t"), points=array(d, "points", ndim=2, last=3), mount=vec3(d, "mount"),
                     sensor=text(d, "sensor"), rpy=vec3(d, "rpy"))


KIND = SensorKind(name="lidar3d", params=Lidar3dParams, profiles=PROFILES, default_profile="hdl32",
                  reading=LidarScan, caster="columns", summary="spinning multi-channel lidar (point cloud)",
                  beams=beams, trace=trace, ros2={"foxglove.PointCloud": ros2_cloud},
                  extra={"topics": trace_topics, "trace_period_s": TRACE_PERIOD_S},
                  to_wire=to_wire, from_wire=from_wire)
