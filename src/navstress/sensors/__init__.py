"""Sensors as declared parts: the kinds (one module each under :mod:`navstress.sensors.kinds`),
their profiles and readings, and :class:`Sensor`, a sensor as the robot carries it (name, kind,
mount, parameters). The simulation casts the rays a kind declares; the trace, the line protocol
and the ROS 2 export encode its reading. docs/sensors.md has the kinds, the profiles' sources and
the checklist of a new kind.

    >>> from navstress.sensors import sensor_from_mapping, Mount
    >>> s = sensor_from_mapping({"name": "front_laser", "kind": "lidar2d", "profile": "ust10"},
    ...                         where="sensors[0]", mounts={"lidar": Mount(xyz=(0.1, 0, 0.3))})
    >>> s.params["beams"], s.mount.xyz
    (1081, (0.1, 0.0, 0.3))
    >>> sensor_from_mapping({"name": "x", "kind": "lidar2"}, where="sensors[0]", mounts={})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: sensors[0].kind='lidar2' is invalid: expected a sensor kind: depth, lidar2d, lidar3d; did you mean lidar2d?
"""

from __future__ import annotations

from navstress.sensors.base import MAX_RAY_SENSORS, RESERVED_NAMES, Mount, SensorKind, SensorParams, rotation_rpy
from navstress.sensors.registry import Sensor, check_rates, default_suite, kind, kinds, sensor_from_mapping, suite_from_list, user_kinds

__all__ = ["MAX_RAY_SENSORS", "RESERVED_NAMES", "Mount", "Sensor", "SensorKind", "SensorParams", "check_rates", "default_suite",
           "kind", "kinds", "rotation_rpy", "sensor_from_mapping", "suite_from_list", "user_kinds"]
