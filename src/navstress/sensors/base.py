"""What every sensor kind shares: the mount, the kind's declaration (:class:`SensorKind`), the
sensor as the robot carries it (:class:`Sensor`), and the checks of a sensor suite.

A sensor kind is one module under ``navstress.sensors.kinds`` that defines ``KIND``, a
:class:`SensorKind`: its parameter model (a spec model: strict, no unknown key), its named
profiles (the real devices' figures; sources in docs/sensors.md), its reading type, and how its
rays are laid out (``caster``) so that the simulation can cast them. Nothing else is edited to add
one (docs/sensors.md, "A new sensor kind").

Frames: a sensor's frame has x forward, y left, z up, placed on ``base_link`` by its mount
(xyz, then roll, pitch, yaw about the fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)).
"""

from __future__ import annotations

import base64
import binascii
import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Literal

import numpy as np
from pydantic import BaseModel, Field

from navstress._models import LIST, SPEC_CONFIG

Vec3 = tuple[float, float, float]

#: Names the simulation's own readings use: no sensor of a suite may take them.
RESERVED_NAMES = ("odom", "imu", "pose", "observer")
NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]{0,31}$")
#: How many ray sensors one robot may carry (the compiled step's schedule rows).
MAX_RAY_SENSORS = 8


class Mount(BaseModel):
    """Where a sensor sits on the robot: position (m) and roll, pitch, yaw (rad) in ``base_link``."""

    model_config = SPEC_CONFIG
    xyz: Vec3 = Field(strict=LIST)
    rpy: Vec3 = Field((0.0, 0.0, 0.0), strict=LIST)

    def rotation(self) -> np.ndarray:
        """base_link-from-sensor rotation, (3, 3): Rz(yaw) Ry(pitch) Rx(roll)."""
        return rotation_rpy(*self.rpy)


def rotation_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll), (3, 3)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


class SensorParams(BaseModel):
    """Parameters every sensor kind has."""

    model_config = SPEC_CONFIG
    rate_hz: float = Field(10.0, gt=0, description="readings per second")


Caster = Literal["columns", "pinhole", "builtin"]


@dataclass(frozen=True)
class SensorKind:
    """A sensor kind's declaration (one per module under ``navstress.sensors.kinds``).

    ``caster`` says how the simulation casts its rays: ``columns`` (vertical fans of rays at
    shared elevations, one fan per azimuth: :meth:`beams` gives the elevations and azimuths),
    ``pinhole`` (a camera: :meth:`rays` gives one direction per pixel), ``builtin`` (odometry, IMU
    and pose: computed in the compiled step, configured in ``sim:``, one of each)."""

    name: str
    params: type[SensorParams]
    profiles: dict[str, dict[str, Any]]
    default_profile: str
    reading: type
    caster: Caster
    summary: str
    #: (elevations_rad, azimuths_rad) of a ``columns`` kind, from its parameters
    beams: Callable[[Any], tuple[np.ndarray, np.ndarray]] | None = None
    #: (H, W, 3) unit directions in the sensor frame of a ``pinhole`` kind, from its parameters
    rays: Callable[[Any], np.ndarray] | None = None
    #: extra per-kind checks of a parameter set (raise SpecError naming ``where.<field>``)
    check: Callable[[Any, str], None] | None = None
    # --- how the rest encodes a reading (filled in by each kind module; None: not recorded there)
    #: line protocol version 2: reading -> JSON-able dict, and back (ValueError on a bad one)
    to_wire: Callable[[Any], dict[str, Any]] | None = None
    from_wire: Callable[[dict[str, Any]], Any] | None = None
    #: trace (Foxglove schemas): ``trace(reading, sensor) -> [(topic, protobuf message), ...]``
    trace: Callable[..., list[tuple[str, Any]]] | None = None
    #: ROS 2 export: converters of this kind's trace messages, by Foxglove schema name
    ros2: dict[str, Callable[..., Any]] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)


def encode_array(a: np.ndarray) -> dict[str, Any]:
    """An array for the line protocol: ``{"dtype", "shape", "data"}``, data the base64 of its
    little-endian bytes (C order)."""
    arr = np.ascontiguousarray(a)
    le = arr.astype(arr.dtype.newbyteorder("<"), copy=False)
    return {"dtype": le.dtype.str, "shape": list(arr.shape), "data": base64.b64encode(le.tobytes()).decode("ascii")}


def decode_array(d: Any, *, dtype: str) -> np.ndarray:
    """The array :func:`encode_array` wrote; ValueError when ``d`` is not one of ``dtype`` ("<f4")."""
    if not isinstance(d, dict) or d.get("dtype") != dtype or not isinstance(d.get("shape"), list) \
            or not isinstance(d.get("data"), str):
        raise ValueError(f"not an encoded {dtype} array: {str(d)[:80]}")
    shape = d["shape"]
    if not all(isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 1 << 24 for n in shape) or len(shape) > 3:
        raise ValueError(f"bad array shape {shape!r:.80}")
    try:
        raw = base64.b64decode(d["data"], validate=True)
    except (binascii.Error, ValueError):
        raise ValueError("array data is not base64") from None
    n = int(np.prod(shape)) if shape else 1
    a = np.frombuffer(raw, dtype=np.dtype(dtype))
    if a.size != n:
        raise ValueError(f"array data holds {a.size} values, its shape {shape} needs {n}")
    return a.reshape(shape)
