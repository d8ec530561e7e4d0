"""Differential drive: two driven wheels on one axle (x = 0, y = +-track/2) and passive casters
(the TurtleBot class).

**Wheels.** ``left`` and ``right``, driven; the casters (``caster_positions``) are frictionless
spheres of ``caster_radius_m`` (default: half the wheel radius) fixed to the chassis, touching the
ground: they carry load and slide in every direction, as a free-swivelling caster does (its
rolling resistance and swivel lag are not modelled).

**Firmware.** A twist (v, w): wheel speeds ``(v -+ w track/2) / r`` (multiplier 1: the wheels do
not slide sideways), the yaw-rate PI on the gyro when the base has one, the acceleration limits.

**Odometry.** Wheel encoders, heading (right - left) / track, or the gyro's (``odom_heading: gyro``,
as the Create 3 base fuses its IMU).
"""

from __future__ import annotations

from navstress.robot import RobotSpec
from navstress.sim.drives.common import CASTER_LOAD_SHARE, DIFFERENTIAL, DriveModel, Wheel, gyro_gains, motor_figures

TIMESTEP_S = 0.01


def model(robot: RobotSpec) -> DriveModel:
    h = robot.track_m / 2
    wheels = (Wheel("left", 0.0, h, 1), Wheel("right", 0.0, -h, -1))
    torque, kv, arm = motor_figures(robot, 2)
    kp, ki = gyro_gains(robot)
    mult = robot.track_multiplier if robot.track_multiplier is not None else 1.0
    cr = robot.caster_radius_m if robot.caster_radius_m is not None else robot.wheel_radius_m / 2
    return DriveModel(kind=DIFFERENTIAL, wheels=wheels, wheel_radius_m=robot.wheel_radius_m,
                      casters=tuple((float(x), float(y)) for x, y in robot.caster_positions), caster_radius_m=cr,
                      track_multiplier=float(mult), torque_nm=torque, kv=kv, armature_kgm2=arm,
                      hold_gain=robot.wheel_hold_gain, yaw_kp=kp, yaw_ki=ki,
                      odom_gyro=robot.odom_heading == "gyro", timestep_s=TIMESTEP_S,
                      com_x_m=CASTER_LOAD_SHARE * sum(x for x, _ in robot.caster_positions) / len(robot.caster_positions))
