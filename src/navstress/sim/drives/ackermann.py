"""Ackermann steering: a car-like base (the F1TENTH class): front wheels on steering hinges
(x = +wheelbase/2), rear wheels fixed (x = -wheelbase/2), at y = +-track/2; rear-wheel drive or
``drive_wheels: all``.

**Firmware.** A twist (v, w) is converted with the bicycle model about the rear axle: the
steering angle ``delta = atan(wheelbase w / v)`` clamped to ``max_steer_rad``, moved at most
``max_steer_rate_rps``; each front wheel steers to its own Ackermann angle (the inner wheel more);
v is the rear axle's speed (the body's forward speed), ramped at the acceleration limit, and each
driven wheel turns at the speed of its contact point for the steering it has now (an electronic
differential). A turn in place is impossible: below :data:`MIN_TURN_SPEED` the wheels steer
toward the commanded turn's side (full lock) but the base does not turn, and a commanded w above
``v tan(max_steer) / wheelbase`` is clipped to that (the base turns on its tightest circle).

**Odometry.** The driven wheels' mean travel (rear: the rear axle's; all: the rear wheels') and the
heading change ``ds tan(delta) / wheelbase`` from the measured steering angle (the bicycle angle
of the two steering hinges), or the gyro's (``odom_heading: gyro``).
"""

from __future__ import annotations

from navstress.robot import RobotSpec
from navstress.sim.drives.common import ACKERMANN, GRAVITY, DriveModel, Wheel, motor_figures

#: Below this speed (m/s) an Ackermann base does not try to turn (the bicycle model has no angle).
MIN_TURN_SPEED = 0.05
TIMESTEP_S = 0.01


def model(robot: RobotSpec) -> DriveModel:
    a, h = robot.wheelbase_m / 2, robot.track_m / 2
    four = robot.drive_wheels == "all"
    wheels = (Wheel("front_left", a, h, 1, four, True), Wheel("rear_left", -a, h, 1),
              Wheel("front_right", a, -h, -1, four, True), Wheel("rear_right", -a, -h, -1))
    torque, kv, arm = motor_figures(robot, 4 if four else 2)
    assert robot.max_steer_rad is not None and robot.max_steer_rate_rps is not None
    # steering servo: stiff enough to hold the wheel against its scrub torque (~ m g r / 4 per rad)
    kp = 40.0 * robot.mass_kg * GRAVITY * robot.wheel_radius_m / 4
    return DriveModel(kind=ACKERMANN, wheels=wheels, wheel_radius_m=robot.wheel_radius_m, casters=(),
                      caster_radius_m=0.0, track_multiplier=1.0, torque_nm=torque, kv=kv, armature_kgm2=arm,
                      hold_gain=robot.wheel_hold_gain, yaw_kp=0.0, yaw_ki=0.0,
                      odom_gyro=robot.odom_heading == "gyro", timestep_s=TIMESTEP_S,
                      max_steer_rad=robot.max_steer_rad, max_steer_rate_rps=robot.max_steer_rate_rps,
                      steer_kp=kp, steer_kv=kp / 20.0)
