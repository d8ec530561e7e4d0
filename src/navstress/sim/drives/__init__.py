"""Drive types: one module each (:mod:`.skid_steer`, :mod:`.differential`, :mod:`.ackermann`).

Each module turns a :class:`~navstress.robot.RobotSpec` into a :class:`DriveModel`: its wheel
table (positions, radius, which wheels are driven, steered or passive, and the passive casters),
its derived figures (the effective-track multiplier of the firmware and the odometry, the motor
torque, servo gain and armature when the spec leaves them None, the time step it needs) and its
odometry. :mod:`navstress.sim.model` writes the MJCF from the table; the compiled loop
(:mod:`navstress.sim._step`) runs one firmware and one odometry for every drive, driven by the
table's arrays (at most :data:`MAX_WHEELS` wheels); only the Ackermann steering has a branch of its
own there. docs/simulation.md ("Drive types") explains the models, their calibration and validation.

    >>> from navstress.robot import profile
    >>> [w.name for w in drive_model(profile("rmp400")).wheels]
    ['front_left', 'rear_left', 'front_right', 'rear_right']
    >>> drive_model(profile("turtlebot4")).casters
    ((0.125, 0.0),)
"""

from __future__ import annotations

from dataclasses import replace

from navstress.robot import RobotSpec
from navstress.sim.drives import ackermann, differential, skid_steer
from navstress.sim.drives.common import (ACKERMANN, ARMATURE_SHARE, CASTER_LOAD_SHARE, DIFFERENTIAL,
                                         EXACT_CONTACTS_BELOW_M, GRAVITY, KV_RATE, MAX_WHEELS, SKID_STEER,
                                         TORQUE_MU, WHEEL_MASS_FRACTION, DriveModel, Wheel, gyro_gains,
                                         motor_figures)

__all__ = ["ACKERMANN", "ARMATURE_SHARE", "CASTER_LOAD_SHARE", "DIFFERENTIAL", "EXACT_CONTACTS_BELOW_M", "GRAVITY",
           "KV_RATE", "MAX_WHEELS", "SKID_STEER", "TORQUE_MU", "WHEEL_MASS_FRACTION", "DriveModel", "Wheel",
           "ackermann", "differential", "drive_model", "gyro_gains", "motor_figures", "skid_steer"]


def drive_model(robot: RobotSpec) -> DriveModel:
    """The drive model of ``robot`` (by ``robot.drive``)."""
    if robot.drive == "skid-steer":
        dm = skid_steer.model(robot)
    elif robot.drive == "differential":
        dm = differential.model(robot)
    else:
        dm = ackermann.model(robot)
    # the skid-steer calibration table holds for the exact contacts: a derived multiplier needs them
    exact = (robot.wheel_radius_m < EXACT_CONTACTS_BELOW_M or any(w.steered for w in dm.wheels)
             or (robot.drive == "skid-steer" and robot.track_multiplier is None))
    return replace(dm, exact_contacts=exact) if exact else dm
