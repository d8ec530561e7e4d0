"""``lidar2d``: a planar scanning range finder. ``beams`` rays in the sensor's x-y plane over a
field of view ``fov_deg`` centred on the sensor's +x (the first beam at ``-fov/2``, the last at
``+fov/2``; a 360-degree scanner's beams ``360/beams`` apart from -180 degrees). The beams leave
the mount pose: on a slope, or when the body pitches, they hit the ground as a real scanner's do.
Ranges outside [``min_range_m``, ``max_range_m``] are no return (``inf``); each range gets
N(0, ``range_noise_std_m``) noise; each return is lost with ``dropout_prob``.

Reading: :class:`LaserScan` (the ranges, as ``sensor_msgs/LaserScan`` has them).

Profiles (sources in docs/sensors.md): ``ust10`` (Hokuyo UST-10LX class, the default), ``tim571``
(SICK TiM571 class), ``rplidar_a2`` (Slamtec RPLIDAR A2 class, 360 degrees).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from navstress.errors import SpecError
from navstress.sensors import encode
from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import array, f32, num, pose_fields, text, vec3


class Lidar2dParams(SensorParams):
    """A planar scanner's figures (defaults: Hokuyo UST-10LX class)."""

    fov_deg: float = Field(270.0, gt=0, le=360.0, description="field of view, centred on +x")
    beams: int = Field(1081, ge=1, le=100_000, description="rays per scan")
    rate_hz: float = Field(40.0, gt=0)
    min_range_m: float = Field(0.06, ge=0)
    max_range_m: float = Field(10.0, gt=0)
    range_noise_std_m: float = Field(0.02, ge=0)
    dropout_prob: float = Field(0.0, ge=0, lt=1, description="chance that a return is lost")

    @model_validator(mode="after")
    def _check(self) -> "Lidar2dParams":
        if self.max_range_m <= self.min_range_m:
            raise SpecError("max_range_m", self.max_range_m, f"a distance > min_range_m={self.min_range_m}")
        if self.beams == 1 and self.fov_deg < 360.0:
            pass  # one beam straight ahead
        return self

    @property
    def angle_min(self) -> float:
        """Angle of the first beam (rad)."""
        if self.fov_deg >= 360.0:
            return -math.pi
        return -math.radians(self.fov_deg) / 2 if self.beams > 1 else 0.0

    @property
    def angle_increment(self) -> float:
        """Angle between beams (rad)."""
        if self.fov_deg >= 360.0:
            return 2 * math.pi / self.beams
        return math.radians(self.fov_deg) / (self.beams - 1) if self.beams > 1 else 0.0


@dataclass(frozen=True, eq=False)
class LaserScan:
    """One sweep of a planar scanner, as ``sensor_msgs/LaserScan`` has it.

    ``ranges``: (beams,) float32 meters, ``inf`` where there is no return; beam ``i`` points at
    ``angle_min + i * angle_increment`` in the sensor's x-y plane (counter-clockwise from +x).
    ``t``: simulated time of the sweep; ``mount`` and ``rpy``: the sensor's pose in ``base_link``;
    ``sensor``: its name."""

    t: float
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    mount: tuple[float, float, float]
    rpy: tuple[float, float, float]
    sensor: str

    @property
    def angles(self) -> np.ndarray:
        """Each beam's angle (rad), (beams,)."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.shape[0])

    def points(self) -> np.ndarray:
        """The returns as (N, 3) float32 points in the sensor frame (no-return beams left out)."""
        a = self.angles
        ok = np.isfinite(self.ranges)
        r = self.ranges[ok].astype(np.float64)
        return np.stack([r * np.cos(a[ok]), r * np.sin(a[ok]), np.zeros_like(r)], axis=1).astype(np.float32)


def beams(p: Lidar2dParams) -> tuple[np.ndarray, np.ndarray]:
    """(elevations, azimuths) in radians: one elevation (0), the beams' angles."""
    return np.zeros(1), p.angle_min + p.angle_increment * np.arange(p.beams)


PROFILES: dict[str, dict[str, object]] = {
    # Hokuyo UST-10LX: 270 deg, 0.25 deg steps (1081 beams), 0.06-10 m, 40 Hz (25 ms), +-40 mm
    "ust10": {},
    # SICK TiM571: 270 deg, 0.33 deg steps (811 beams), 0.05-25 m, 15 Hz, statistical error 20 mm
    "tim571": {"fov_deg": 270.0, "beams": 811, "rate_hz": 15.0, "min_range_m": 0.05, "max_range_m": 25.0,
               "range_noise_std_m": 0.02},
    # Slamtec RPLIDAR A2M8: 360 deg, 0.9 deg at 10 Hz (400 beams), 0.15-12 m, about 1 % of range
    "rplidar_a2": {"fov_deg": 360.0, "beams": 400, "rate_hz": 10.0, "min_range_m": 0.15, "max_range_m": 12.0,
                   "range_noise_std_m": 0.03},
}

def trace_topics(sensor: Any) -> dict[str, Any]:
    """The trace topic of a scanner named N: ``/sensors/N``, ``foxglove.LaserScan``."""
    from foxglove_schemas_protobuf.LaserScan_pb2 import LaserScan as FoxgloveScan

    return {encode.topic(sensor.name): FoxgloveScan}


def trace(r: LaserScan, sensor: Any) -> list[tuple[str, Any]]:
    """A scan as a ``foxglove.LaserScan`` on ``/sensors/<name>`` in the sensor's frame: beam ``i``
    at ``start_angle + i * (end_angle - start_angle) / (beams - 1)``, the ranges as they are
    (``inf``: no return, as REP 117 has it)."""
    (t, cls), = trace_topics(sensor).items()
    n = int(r.ranges.shape[0])
    return [(t, cls(timestamp=encode.stamp(r.t), frame_id=sensor.name, pose=encode.identity_pose(),
                    start_angle=r.angle_min, end_angle=r.angle_min + r.angle_increment * max(n - 1, 0),
                    ranges=np.asarray(r.ranges, dtype=np.float64).tolist()))]


def ros2_scan(types: Any, topic: str, m: Any, sensor: Any) -> list[tuple[str, Any]]:
    """``foxglove.LaserScan`` -> ``sensor_msgs/LaserScan`` on the same topic (range limits and
    scan time from the sensor's parameters when known; float32 ranges, no intensities)."""
    n = len(m.ranges)
    p = Lidar2dParams.model_validate(sensor.params) if sensor is not None else None
    return [(topic, types["sensor_msgs/msg/LaserScan"](
        header=encode.ros_header(types, m), angle_min=m.start_angle, angle_max=m.end_angle,
        angle_increment=(m.end_angle - m.start_angle) / (n - 1) if n > 1 else 0.0, time_increment=0.0,
        scan_time=1.0 / p.rate_hz if p is not None else 0.0, range_min=p.min_range_m if p is not None else 0.0,
        range_max=p.max_range_m if p is not None else math.inf, ranges=np.asarray(m.ranges, dtype=np.float32),
        intensities=np.zeros(0, np.float32)))]

def to_wire(r: LaserScan) -> dict[str, Any]:
    """A scan for the line protocol (version 2): ``ranges`` a base64 float32 array (``inf``: no return)."""
    return {**pose_fields(r), "ranges": f32(r.ranges), "angle_min": float(r.angle_min),
            "angle_increment": float(r.angle_increment), "range_min": float(r.range_min),
            "range_max": float(r.range_max)}


def from_wire(d: dict[str, Any]) -> LaserScan:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return LaserScan(t=num(d, "t"), ranges=array(d, "ranges", ndim=1), angle_min=num(d, "angle_min"),
                     angle_increment=num(d, "angle_increment"), range_min=num(d, "range_min"),
                     range_max=num(d, "range_max", finite=False), mount=vec3(d, "mount"), rpy=vec3(d, "rpy"),
                     sensor=text(d, "sensor"))


KIND = SensorKind(name="lidar2d", params=Lidar2dParams, profiles=PROFILES, default_profile="ust10",
                  reading=LaserScan, caster="columns", summary="planar scanning range finder (LaserScan)",
                  beams=beams, trace=trace, ros2={"foxglove.LaserScan": ros2_scan},
                  extra={"topics": trace_topics, "trace_period_s": 0.0},
                  to_wire=to_wire, from_wire=from_wire)
