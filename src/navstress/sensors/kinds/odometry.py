"""``odometry``: wheel odometry, integrated in the compiled step from the wheel encoders (or the
gyro heading, ``robot.odom_heading``). Built in: every robot has one, named ``odom``, its rate in
``sim.odom_rate_hz``. Reading: :class:`Odometry`."""

from __future__ import annotations

from dataclasses import dataclass

from navstress.sensors.base import SensorKind, SensorParams


@dataclass(frozen=True)
class Odometry:
    """Wheel odometry integrated from wheel rotation, in the odometry frame (starts at 0, 0, 0)."""

    t: float
    x: float
    y: float
    yaw: float
    v: float  # linear speed estimate, m/s
    omega: float  # yaw rate estimate, rad/s


KIND = SensorKind(name="odometry", params=SensorParams, profiles={"builtin": {"rate_hz": 50.0}},
                  default_profile="builtin", reading=Odometry, caster="builtin",
                  summary="wheel odometry (built in: `odom`, configured in sim:)")
