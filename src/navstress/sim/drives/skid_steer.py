"""Skid steer: ``wheels_per_side`` (1..4) driven wheels on each side, fixed (the RMP 400, Husky and
Jackal classes).

**Wheels.** Per side, evenly spaced from x = +wheelbase/2 (front) to -wheelbase/2 (rear) at
y = +-track/2; names ``front_left, rear_left, front_right, rear_right`` for two per side (the
RMP 400's MJCF, unchanged), ``left``/``right`` for one, ``front``, ``mid_...``, ``rear`` otherwise.

**Firmware.** A twist (v, w): each side's wheels turn at ``(v -+ (m w + PI(w - gyro)) track/2) / r``,
with ``m`` the effective-track multiplier (a skid steer turns slower than its wheel speed
difference says, because the wheels slide sideways), the yaw-rate PI on the gyro when the base has
one, the base's acceleration limits, and each wheel holding its integrated angle.

**Odometry.** Wheel encoders: each side's travel is the mean of its wheels'; the heading change is
(right - left) / (m track), or the gyro's when ``odom_heading: gyro``.

**Calibration.** ``track_multiplier`` None: :func:`derived_multiplier` (docs/simulation.md,
"Drive types": Coulomb friction with equal loads says 1 + <x^2>/(track/2)^2 for wheels at x along
a side; this simulator's contacts resist the turn more than that, nearly linearly in
wheelbase/track, and the derived value is the simulator's own, measured over a family of
geometries: :data:`MEASURED`).
"""

from __future__ import annotations

from navstress.robot import RobotSpec
from navstress.sim.drives.common import SKID_STEER, DriveModel, Wheel, gyro_gains, motor_figures

#: Wheel names per side by wheels_per_side (front first).
NAMES: dict[int, tuple[str, ...]] = {1: ("",), 2: ("front", "rear"), 3: ("front", "mid", "rear"),
                                     4: ("front", "mid_front", "mid_rear", "rear")}
#: What this simulator's skid steer turns with: the effective-track multiplier measured in closed
#: loop, turning in place and at half speed at half the top turn rate, for wheelbase/track = 0.5,
#: 1.0, 1.5, by time step (s) and wheels per side (``benchmarks/skid_calibration.py`` on the
#: husky (10 ms) and jackal (5 ms) profiles; docs/simulation.md, "Drive types"). Open-loop runs at
#: 17 and 40 kg gave the same figures: the friction is Coulomb's, independent of the load.
MEASURED: dict[float, dict[int, tuple[float, float, float]]] = {
    0.01: {2: (1.828, 3.091, 4.068), 3: (1.664, 2.876, 4.167), 4: (1.655, 2.729, 3.911)},
    0.005: {2: (1.665, 2.535, 3.312), 3: (1.604, 2.392, 3.25), 4: (1.574, 2.335, 3.121)},
}
MEASURED_RATIOS = (0.5, 1.0, 1.5)
#: The time step a skid steer needs (s): 10 ms with wheels of SMALL_WHEEL_M radius or more, 5 ms
#: with smaller ones (docs/simulation.md, "Drive types": the friction rewrite uses the slip of the
#: step before; a small wheel's slip changes faster, and a Jackal-class base then rocks in a hard
#: turn at 10 ms: pitch swing 2.1 deg, 0.3 deg at 5 ms, 0.1 deg at 2.5 ms).
TIMESTEP_S = 0.01
SMALL_WHEEL_M = 0.15
SMALL_TIMESTEP_S = 0.005


def wheel_x(robot: RobotSpec) -> tuple[float, ...]:
    """The wheels' x along a side, front first."""
    n, wb = robot.wheels_per_side, robot.wheelbase_m
    if n == 1:
        return (0.0,)
    if n == 2:  # the RMP 400's arithmetic (its MJCF is unchanged)
        return (1 * wb / 2, -1 * wb / 2)
    return tuple(wb / 2 - i * wb / (n - 1) for i in range(n))


def coulomb_multiplier(robot: RobotSpec) -> float:
    """Coulomb friction's effective-track multiplier turning in place: 1 + <x^2> / (track/2)^2 (with
    two wheels a side at x = +-wheelbase/2: 1 + (wheelbase/track)^2)."""
    xs = wheel_x(robot)
    b = robot.track_m / 2
    return 1.0 + sum(x * x for x in xs) / len(xs) / (b * b)


def timestep(robot: RobotSpec) -> float:
    """The time step this skid steer needs (:data:`SMALL_WHEEL_M`)."""
    return TIMESTEP_S if robot.wheel_radius_m >= SMALL_WHEEL_M else SMALL_TIMESTEP_S


def derived_multiplier(robot: RobotSpec) -> float:
    """``track_multiplier`` of a spec that leaves it None: what this simulator's skid steer turns
    with at the robot's time step, interpolated in :data:`MEASURED` (piecewise linear in
    wheelbase / track through (0, 1) and the measured points, the last slope beyond them; 1 with
    one wheel a side)."""
    n = robot.wheels_per_side
    if n == 1:
        return 1.0
    rho = robot.wheelbase_m / robot.track_m
    xs = (0.0,) + MEASURED_RATIOS
    ys = (1.0,) + MEASURED[timestep(robot)][n]
    for i in range(1, len(xs)):
        if rho <= xs[i] or i == len(xs) - 1:
            return ys[i - 1] + (ys[i] - ys[i - 1]) * (rho - xs[i - 1]) / (xs[i] - xs[i - 1])
    raise AssertionError("unreachable")


def model(robot: RobotSpec) -> DriveModel:
    xs = wheel_x(robot)
    n = robot.wheels_per_side
    wheels = []
    for side, sname in ((1, "left"), (-1, "right")):
        for i, x in enumerate(xs):
            name = sname if n == 1 else f"{NAMES[n][i]}_{sname}"
            wheels.append(Wheel(name, x, side * robot.track_m / 2, side))
    torque, kv, arm = motor_figures(robot, 2 * n)
    kp, ki = gyro_gains(robot)
    mult = robot.track_multiplier if robot.track_multiplier is not None else derived_multiplier(robot)
    return DriveModel(kind=SKID_STEER, wheels=tuple(wheels), wheel_radius_m=robot.wheel_radius_m, casters=(),
                      caster_radius_m=0.0, track_multiplier=float(mult), torque_nm=torque, kv=kv,
                      armature_kgm2=arm, hold_gain=robot.wheel_hold_gain, yaw_kp=kp, yaw_ki=ki,
                      odom_gyro=robot.odom_heading == "gyro",
                      timestep_s=timestep(robot))
