"""reference-2d-v1 in a synthetic closed loop (exact LaserScans of analytic layouts, the robot
moved by its commands: tests/support/laser_synth.py): it reaches goals among obstacles, stops
with Fail-Error when the goal is enclosed, never turns an ackermann base in place, and the same
seed gives the same commands."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstress.errors import NavigatorError, SpecError
from navstress.nav.api import NavMission, Status
from navstress.nav.reference2d import NO_PATH, Reference2dConfig, Reference2dNavigator
from navstress.nav.reference2d.navigator import NO_PROGRESS, NO_TRAJECTORY
from navstress.nav.registry import make_navigator, validate_config
from navstress.robot import profile
from tests.support.laser_synth import Layout, drive, f1tenth, jackal

TREES = Layout(circles=[(4.0, 0.2, 0.3), (7.0, -0.5, 0.4), (9.0, 1.0, 0.3), (5.5, -1.5, 0.3)])


@pytest.mark.parametrize("layout", [
    TREES,
    Layout(segments=[(-1.0, 1.2, 13.0, 1.2), (-1.0, -1.2, 13.0, -1.2)]),  # a corridor 2.4 m wide
    Layout(segments=[(6.0, -5.0, 6.0, -0.5), (6.0, 0.5, 6.0, 5.0)]),  # a wall with a 1 m gap
    Layout(segments=[(6.0, -1.5, 6.0, 1.5)]),  # a wall across the straight line: around it
], ids=["trees", "corridor", "gap", "wall"])
def test_jackal_reaches_the_goal_without_touching_anything(layout: Layout) -> None:
    robot = jackal()
    out = drive(Reference2dNavigator(), layout, robot, (0.0, 0.0, 0.0), (12.0, 0.0), timeout_s=80.0)
    assert out.status == Status("arrived"), out.status
    assert math.hypot(out.poses[-1, 0] - 12.0, out.poses[-1, 1]) <= 0.25 + 0.1
    assert out.min_clearance > robot.width_m / 2  # never closer than the half width


def test_a_gap_narrower_than_the_footprint_is_not_taken() -> None:
    # the only way: through a 0.3 m gap in a closed room, narrower than the Jackal (0.43 m wide)
    room = Layout().box(4.0, -3.0, 8.0, 1.0, gap=(5.85, 6.15))
    out = drive(Reference2dNavigator(), room, jackal(), (6.0, -5.0, math.pi / 2), (6.5, -1.0), timeout_s=120.0)
    assert out.status is not None and out.status.kind == "error"
    assert out.status.message.startswith((NO_PATH, NO_PROGRESS, NO_TRAJECTORY))
    assert out.min_clearance > 0.2
    wider = Layout().box(4.0, -3.0, 8.0, 1.0, gap=(5.4, 6.6))
    assert drive(Reference2dNavigator(), wider, jackal(), (6.0, -5.0, math.pi / 2), (6.5, -1.0),
                 timeout_s=120.0).status == Status("arrived")


def test_an_enclosed_goal_is_fail_error_after_the_recoveries() -> None:
    nav = Reference2dNavigator()
    out = drive(nav, Layout().box(8.0, -2.0, 12.0, 2.0), jackal(), (0.0, 0.0, 0.0), (10.0, 0.0), timeout_s=120.0)
    assert out.status is not None and out.status.kind == "error"
    assert out.status.message.endswith(f"after {nav.config.max_recoveries} recoveries")
    assert out.status.message.startswith((NO_PATH, NO_PROGRESS, NO_TRAJECTORY))
    kinds = [what.split()[0] for _, what in nav.recovery_log]
    assert kinds == ["clear", "spin", "backup", "wait", "clear", "spin"]
    assert out.status == nav.step(None)  # type: ignore[arg-type]  # latched


def test_an_ackermann_base_never_turns_in_place() -> None:
    robot = f1tenth()
    out = drive(Reference2dNavigator(), TREES, robot, (0.0, 0.0, 0.0), (12.0, 0.0), timeout_s=60.0)
    assert out.status == Status("arrived")
    c = np.array(out.commands)
    assert robot.max_steer_rad is not None
    kappa = math.tan(robot.max_steer_rad) / robot.wheelbase_m
    assert (np.abs(c[:, 1]) <= np.abs(c[:, 0]) * kappa + 1e-9).all()
    # a goal behind it: it drives a loop, never a turn on the spot
    out = drive(Reference2dNavigator(), Layout(), robot, (0.0, 0.0, 0.0), (-6.0, 0.0), timeout_s=60.0)
    c = np.array(out.commands)
    assert out.status == Status("arrived")
    assert (np.abs(c[:, 1]) <= np.abs(c[:, 0]) * kappa + 1e-9).all()


def test_a_skid_steer_base_turns_in_place_toward_a_goal_behind_it() -> None:
    out = drive(Reference2dNavigator(), Layout(), jackal(), (0.0, 0.0, 0.0), (-6.0, 0.0), timeout_s=60.0)
    c = np.array(out.commands)
    assert out.status == Status("arrived")
    assert np.abs(c[:5, 0]).max() < 0.05 and np.abs(c[:5, 1]).min() > 0.3


@pytest.mark.parametrize("config", [{}, {"cost_jitter": 0.5}])
def test_same_seed_same_commands(config: dict[str, float]) -> None:
    runs = [drive(make_navigator("reference-2d-v1", config), TREES, jackal(), (0.0, 0.0, 0.0), (12.0, 0.0),
                  seed=s, timeout_s=40.0) for s in (3, 3, 4)]
    assert runs[0].commands == runs[1].commands
    if config:
        assert runs[0].commands != runs[2].commands  # the jitter is drawn from the seed


def test_speeds_and_turns_within_the_limits() -> None:
    robot = jackal()
    nav = Reference2dNavigator(Reference2dConfig(max_speed_mps=3.0, max_yaw_rate_rps=9.0))
    out = drive(nav, TREES, robot, (0.0, 0.0, 0.0), (12.0, 0.0), timeout_s=60.0)
    c = np.array(out.commands)
    assert np.abs(c[:, 0]).max() <= robot.max_speed_mps + 1e-9
    assert np.abs(c[:, 1]).max() <= robot.max_yaw_rate_rps + 1e-9
    dv = np.abs(np.diff(c[:, 0]))
    assert dv.max() <= robot.max_accel_mps2 * 0.1 + 1e-6  # the dynamic window


def test_a_robot_without_a_2d_scanner_is_refused() -> None:
    with pytest.raises(NavigatorError, match=r"needs a robot with a lidar2d sensor; this robot's sensors: none"):
        Reference2dNavigator().reset(NavMission((0, 0, 0), (5, 0)), profile("jackal"), seed=0)
    lidar3d = profile("jackal").model_copy(update={"sensors": ()})
    with pytest.raises(NavigatorError, match=r"lidar2d"):
        Reference2dNavigator().reset(NavMission((0, 0, 0), (5, 0)), lidar3d, seed=0)


def test_config_is_validated_with_one_line_errors() -> None:
    with pytest.raises(SpecError, match=r"vx_samples=1 is invalid"):
        validate_config("reference-2d-v1", {"vx_samples": 1})
    with pytest.raises(SpecError, match=r"raytrace_max_range_m=1.0 is invalid: expected a range >= obstacle_max_range_m"):
        validate_config("reference-2d-v1", {"raytrace_max_range_m": 1.0})
    assert make_navigator("reference-2d-v1", {"cell_m": 0.05}).config.cell_m == 0.05  # type: ignore[attr-defined]
