"""``imu``: attitude and body rates with noise and a drifting yaw bias, computed in the compiled
step. Built in: every robot has one, named ``imu``, its figures in ``sim:`` (``imu_rate_hz``,
``imu_att_std_rad``, ``imu_rate_std_rps``, ``imu_yaw_drift_rps``). Reading: :class:`Imu`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from navstress.sensors.base import SensorKind, SensorParams
from navstress.sensors.wirefields import num, vec3


@dataclass(frozen=True)
class Imu:
    """Attitude (roll, pitch; yaw drifts) and body angular rates."""

    t: float
    roll: float
    pitch: float
    yaw: float
    rates: tuple[float, float, float]  # body-frame angular velocity, rad/s


def to_wire(r: Imu) -> dict[str, Any]:
    """The IMU for the line protocol (as version 1's ``imu``)."""
    return {"t": float(r.t), "roll": float(r.roll), "pitch": float(r.pitch), "yaw": float(r.yaw),
            "rates": [float(v) for v in r.rates]}


def from_wire(d: dict[str, Any]) -> Imu:
    """Inverse of :func:`to_wire`; ValueError naming the bad field."""
    return Imu(num(d, "t"), num(d, "roll"), num(d, "pitch"), num(d, "yaw"), vec3(d, "rates"))


KIND = SensorKind(name="imu", params=SensorParams, profiles={"builtin": {"rate_hz": 50.0}},
                  default_profile="builtin", reading=Imu, caster="builtin",
                  summary="attitude and body rates (built in: `imu`, configured in sim:)",
                  to_wire=to_wire, from_wire=from_wire)
