"""``imu``: attitude and body rates with noise and a drifting yaw bias, computed in the compiled
step. Built in: every robot has one, named ``imu``, its figures in ``sim:`` (``imu_rate_hz``,
``imu_att_std_rad``, ``imu_rate_std_rps``, ``imu_yaw_drift_rps``). Reading: :class:`Imu`."""

from __future__ import annotations

from dataclasses import dataclass

from navstress.sensors.base import SensorKind, SensorParams


@dataclass(frozen=True)
class Imu:
    """Attitude (roll, pitch; yaw drifts) and body angular rates."""

    t: float
    roll: float
    pitch: float
    yaw: float
    rates: tuple[float, float, float]  # body-frame angular velocity, rad/s


KIND = SensorKind(name="imu", params=SensorParams, profiles={"builtin": {"rate_hz": 50.0}},
                  default_profile="builtin", reading=Imu, caster="builtin",
                  summary="attitude and body rates (built in: `imu`, configured in sim:)")
