"""``odometry``: wheel odometry, integrated in the compiled step from the wheel encoders (or the
gyro heading, ``robot.odom_heading``). Built in: every robot has one, named ``odom``, its rate in
``sim.odom_rate_hz``. Reading: :class:`Odometry`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import num


@dataclass(frozen=True)
class Odometry:
    """Wheel odometry integrated from wheel rotation, in the odometry frame (starts at 0, 0, 0)."""

    t: float
    x: float
    y: float
    yaw: float
    v: float  # linear speed estimate, m/s
    omega: float  # yaw rate estimate, rad/s


FIELDS = ("t", "x", "y", "yaw", "v", "omega")


def to_wire(r: Odometry) -> dict[str, Any]:
    """Odometry for the line protocol (as version 1's ``odom``)."""
    return {k: float(getattr(r, k)) for k in FIELDS}


def from_wire(d: dict[str, Any]) -> Odometry:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return Odometry(*(num(d, k) for k in FIELDS))


KIND = SensorKind(name="odometry", params=SensorParams, profiles={"builtin": {"rate_hz": 50.0}},
                  default_profile="builtin", reading=Odometry, caster="builtin",
                  summary="wheel odometry (built in: `odom`, configured in sim:)",
                  to_wire=to_wire, from_wire=from_wire)
