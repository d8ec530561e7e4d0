"""What every drive module shares: the wheel table (:class:`Wheel`, :class:`DriveModel`), the drive
codes and the figures derived from the mass (:mod:`navstress.sim.drives` re-exports them)."""

from __future__ import annotations

from dataclasses import dataclass

from navstress.robot import RobotSpec

#: The most wheels a robot may have (skid steer: 4 per side).
MAX_WHEELS = 8
#: Drive codes of the compiled loop (``PARAMS.drive``).
SKID_STEER, DIFFERENTIAL, ACKERMANN = 0, 1, 2
#: Wheel mass, each, as a fraction of the robot's mass (the chassis carries the rest).
WHEEL_MASS_FRACTION = 0.05
#: The motor figures derived from the mass (spec fields None), as the RMP 400's calibrated ones
#: scale: torque = TORQUE_MU * m g r / n_driven (the traction limit of dry dirt, 1.05x: 60.06 N m
#: on the RMP 400, which has 60); servo gain kv = KV_RATE * m r^2 / n_driven (1/s: the wheel
#: servo's bandwidth; 100 N m s on the RMP 400); armature = ARMATURE_SHARE * m r^2 / n_driven
#: (0.1 kg m^2 on the RMP 400).
TORQUE_MU = 0.84
KV_RATE = 51.8
ARMATURE_SHARE = 0.0518
GRAVITY = 9.81
#: Wheels smaller than this (m), every steered wheel, and every skid steer whose multiplier is
#: derived (``skid_steer.MEASURED`` was measured with them) get the exact sphere-terrain contacts
#: (``_step.sphere_terrain_contacts``) instead of MuJoCo's sphere-hfield collision, which places
#: a small sphere's contacts off its lowest point on the heightfield's cells (0.4 m): a steered wheel
#: then cannot turn (the off-centre lateral force holds it) and a small base rocks on flat ground.
EXACT_CONTACTS_BELOW_M = 0.2
#: A differential base's chassis centre of mass lies this fraction of the way from the wheel axle
#: to its casters' mean position, so that the casters carry load and the base does not rock on
#: its axle.
CASTER_LOAD_SHARE = 0.3


@dataclass(frozen=True)
class Wheel:
    """One wheel: its name (MJCF ``wheel_<name>``), centre (x, y) in base_link at axle height, the
    side (+1 left, -1 right), whether a motor drives it and whether it steers."""

    name: str
    x: float
    y: float
    side: int
    driven: bool = True
    steered: bool = False


@dataclass(frozen=True)
class DriveModel:
    """What the simulation needs of a drive type (see the module docstring)."""

    kind: int  # SKID_STEER, DIFFERENTIAL, ACKERMANN
    wheels: tuple[Wheel, ...]
    wheel_radius_m: float
    casters: tuple[tuple[float, float], ...]  # passive frictionless spheres (x, y)
    caster_radius_m: float
    track_multiplier: float  # effective track / track (firmware feed-forward and odometry)
    torque_nm: float  # per driven wheel
    kv: float  # velocity-servo gain, N m per rad/s
    armature_kgm2: float
    hold_gain: float
    yaw_kp: float  # 0, 0: no gyro loop
    yaw_ki: float
    odom_gyro: bool  # odometry heading from the gyro instead of the wheels
    timestep_s: float  # the largest time step this base is simulated right with
    max_steer_rad: float = 0.0  # ackermann
    max_steer_rate_rps: float = 0.0
    steer_kp: float = 0.0  # steering position servo, N m per rad
    steer_kv: float = 0.0  # its damping, N m per rad/s
    exact_contacts: bool = False  # wheel contacts from _step.sphere_terrain_contacts (EXACT_CONTACTS_BELOW_M)
    com_x_m: float = 0.0  # the chassis centre of mass, x in base_link

    @property
    def driven(self) -> tuple[Wheel, ...]:
        return tuple(w for w in self.wheels if w.driven)


def motor_figures(robot: RobotSpec, n_driven: int) -> tuple[float, float, float]:
    """(torque N m, kv N m s, armature kg m^2) per driven wheel: the spec's, or derived from the
    mass and wheel radius (:data:`TORQUE_MU`, :data:`KV_RATE`, :data:`ARMATURE_SHARE`)."""
    m, r = robot.mass_kg, robot.wheel_radius_m
    torque = robot.wheel_torque_nm
    if torque is None:
        torque = TORQUE_MU * m * GRAVITY * r / n_driven
    kv = robot.wheel_kv
    if kv is None:
        kv = KV_RATE * m * r * r / n_driven
    arm = robot.wheel_armature_kgm2
    if arm is None:
        arm = ARMATURE_SHARE * m * r * r / n_driven
    return float(torque), float(kv), float(arm)


def gyro_gains(robot: RobotSpec) -> tuple[float, float]:
    """The yaw-rate PI gains; (0, 0) without a gyro."""
    return (robot.yaw_kp, robot.yaw_ki) if robot.gyro else (0.0, 0.0)


