"""The validation course (navstress.sim.validation): every shipped profile passes it; a robot the
simulation cannot drive right fails it, one line per failed leg."""

from __future__ import annotations

import dataclasses
import math

import pytest

from navstress.robot import PROFILES, RobotSpec
from navstress.sim import SimConfig
from navstress.sim import validation as V


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_every_profile_passes_the_course(name: str) -> None:
    robot = PROFILES[name]
    check = V.check_robot(robot)
    assert check.passed, check.problems()
    assert check.robot == name and check.digest == robot.digest and not check.problems()
    names = [leg.name for leg in check.legs]
    turns = ["turn-left", "turn-right"] if robot.drive == "ackermann" else ["turn-left", "spin"]
    assert names == ["stand", "cruise", *turns, "rough"]
    for leg in check.legs:
        assert leg.passed and leg.why == ""
        if leg.name not in ("stand", "cruise", "rough"):
            assert leg.odom_heading_ratio is not None
            assert abs(leg.odom_heading_ratio - 1.0) <= V.ODOM_HEADING_TOL[robot.drive]
        if leg.name in ("stand", "cruise"):
            assert leg.pitch_swing_deg <= V.PITCH_SWING_MAX_DEG
    cruise = check.legs[1]
    assert cruise.commanded_v == robot.max_speed_mps
    assert cruise.v_error <= max(V.V_TOL_MPS, V.V_TOL_REL * robot.max_speed_mps)


def test_the_time_step_each_profile_needs() -> None:
    """10 ms unless a skid steer's wheels are small (the Jackal: 5 ms, docs/simulation.md)."""
    steps = {n: V.check_robot(p, quick=True).timestep_s for n, p in PROFILES.items()}
    assert steps == {"rmp400": 0.01, "husky": 0.01, "jackal": 0.005, "turtlebot4": 0.01, "f1tenth": 0.01}


@pytest.mark.parametrize("fault, leg, why", [
    ({"track_multiplier": 1.0}, "spin", "odometry heading"),  # the RMP 400 is calibrated at 3.4
    ({"wheel_torque_nm": 3.0}, "cruise", "speed"),  # 60 N m: too weak for the top speed
])
def test_a_robot_simulated_wrong_fails_with_one_line_per_leg(fault: dict[str, float], leg: str, why: str) -> None:
    robot = RobotSpec(name="faulty", **fault)  # type: ignore[arg-type]
    check = V.check_robot(robot, quick=True)
    assert not check.passed
    lines = check.problems()
    assert lines and all("\n" not in ln and ln.startswith("faulty: leg ") for ln in lines)
    failed = {lg.name: lg for lg in check.legs if not lg.passed}
    assert leg in failed and why in failed[leg].why
    assert len(lines) == len(failed)
    for lg in check.legs:
        assert math.isfinite(lg.v_error) and lg.v_error == abs(lg.measured_v - lg.commanded_v)


def test_the_check_uses_the_physics_of_the_config_given() -> None:
    """A config's time step reaches the course (sensors off there whatever it says)."""
    check = V.check_robot(PROFILES["turtlebot4"], dataclasses.replace(SimConfig(), timestep_s=0.005), quick=True)
    assert check.timestep_s == 0.005 and check.passed, check.problems()
