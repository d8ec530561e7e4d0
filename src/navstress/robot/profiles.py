"""The named robot profiles: the figures of the real bases they stand for (sources in docs/robots.md).

``rmp400`` is the paper's robot and the default (``RobotSpec()``); its firmware constants were
calibrated in this simulator (docs/simulation.md). The other profiles leave the firmware figures
that follow from the geometry and the mass (``track_multiplier``, the motors) to the drive model,
unless the real base's own firmware publishes them.

    >>> sorted(PROFILES)
    ['f1tenth', 'husky', 'jackal', 'rmp400', 'turtlebot4']
    >>> profile("jackal").mass_kg
    17.0
    >>> profile("jackall")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: robot='jackall' is invalid: expected a robot profile (one of f1tenth, husky, jackal, rmp400, turtlebot4) or a robot file (.yaml, .yml, .json); did you mean jackal?
"""

from __future__ import annotations

import difflib
import math

from navstress.errors import SpecError
from navstress.robot.spec import Footprint, Mount, RobotSpec

#: name -> the profile's RobotSpec.
PROFILES: dict[str, RobotSpec] = {
    # the paper's Segway RMP 400 (Mana): today's defaults, byte-identical behaviour
    "rmp400": RobotSpec(),
    # Clearpath Husky A200: 990 x 670 x 390 mm, 50 kg, 1.0 m/s, skid steer; wheels, track and body
    # from husky_description (husky.urdf.xacro), the scanner at the LMS1xx's focal point on the top plate
    "husky": RobotSpec(
        name="husky", drive="skid-steer", length_m=0.99, width_m=0.67, body_height_m=0.2475,
        ground_clearance_m=0.1323, mass_kg=50.0, wheel_radius_m=0.1651, wheel_width_m=0.1143,
        wheelbase_m=0.512, track_m=0.5708, wheels_per_side=2, wheel_torque_nm=None, wheel_kv=None,
        wheel_armature_kgm2=None, track_multiplier=None, max_speed_mps=1.0, max_yaw_rate_rps=2.0,
        max_accel_mps2=3.0, max_yaw_accel_rps2=6.0,
        mounts={"lidar": Mount(xyz=(0.337, 0.0, 0.275))}),
    # Clearpath Jackal: 508 x 430 x 250 mm, 17 kg, 2.0 m/s, skid steer, 2D scanner ~0.3 m up; wheels,
    # track and chassis from jackal_description (jackal.urdf.xacro)
    "jackal": RobotSpec(
        name="jackal", drive="skid-steer", length_m=0.508, width_m=0.43, body_height_m=0.184,
        ground_clearance_m=0.0635, mass_kg=17.0, wheel_radius_m=0.098, wheel_width_m=0.04,
        wheelbase_m=0.262, track_m=0.37559, wheels_per_side=2, wheel_torque_nm=None, wheel_kv=None,
        wheel_armature_kgm2=None, track_multiplier=None, max_speed_mps=2.0, max_yaw_rate_rps=4.0,
        max_accel_mps2=2.0, max_yaw_accel_rps2=6.0,
        mounts={"lidar": Mount(xyz=(0.12, 0.0, 0.21))}),
    # TurtleBot 4 (iRobot Create 3 base): 342 mm round, 3.9 kg, 0.31 m/s, two wheels + caster; wheels,
    # caster, clearance and the RPLIDAR's position from irobot_create_description and turtlebot4_description
    "turtlebot4": RobotSpec(
        name="turtlebot4", drive="differential", length_m=0.342, width_m=0.342,
        footprint=Footprint(shape="circle", radius_m=0.171), body_height_m=0.15,
        ground_clearance_m=0.0045, mass_kg=3.9, wheel_radius_m=0.03575, wheel_width_m=0.015,
        wheelbase_m=0.0, track_m=0.233, wheels_per_side=1, caster_positions=((0.125, 0.0),),
        caster_radius_m=0.015, wheel_torque_nm=None, wheel_kv=None, wheel_armature_kgm2=None,
        track_multiplier=None, odom_heading="gyro", max_speed_mps=0.31, max_yaw_rate_rps=1.9,
        max_accel_mps2=0.9, max_yaw_accel_rps2=3.0,
        mounts={"lidar": Mount(xyz=(-0.04, 0.0, 0.16))}),
    # F1TENTH (a 1/10 car, the F1TENTH gym's vehicle parameters): ackermann, rear-wheel drive
    "f1tenth": RobotSpec(
        name="f1tenth", drive="ackermann", length_m=0.58, width_m=0.31, body_height_m=0.12,
        ground_clearance_m=0.03, mass_kg=3.74, wheel_radius_m=0.05, wheel_width_m=0.04,
        wheelbase_m=0.3302, track_m=0.24, wheels_per_side=1, max_steer_rad=0.4189,
        max_steer_rate_rps=3.2, drive_wheels="rear", wheel_torque_nm=None, wheel_kv=None,
        wheel_armature_kgm2=None, track_multiplier=None, gyro=False, max_speed_mps=3.0,
        max_yaw_rate_rps=math.pi, max_accel_mps2=3.0, max_yaw_accel_rps2=10.0,
        mounts={"lidar": Mount(xyz=(0.27, 0.0, 0.1))}),
}


def profile(name: str) -> RobotSpec:
    """The profile ``name``; SpecError with a "did you mean" for an unknown one."""
    if name in PROFILES:
        return PROFILES[name]
    close = difflib.get_close_matches(str(name), list(PROFILES), n=1, cutoff=0.5)
    raise SpecError("robot", name, "a robot profile (one of " + ", ".join(sorted(PROFILES))
                    + ") or a robot file (.yaml, .yml, .json)", f"did you mean {close[0]}?" if close else None)
