"""run_mission tells the navigator's reset the robot with its resolved suite (never None), before
any fault changes what the navigator believes."""

from __future__ import annotations

from typing import Any

import pytest

from navstress.nav.api import Command, Status
from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.run.mission import run_mission
from navstress.sim.config import SimConfig
from navstress.sim.suite import suite
from tests.support.world_fixtures import small_world


class _Spy:
    def __init__(self) -> None:
        self.robots: list[RobotSpec] = []
        self.readings: set[str] = set()

    def reset(self, mission: object, robot: RobotSpec, *, seed: int) -> None:
        self.robots.append(robot)

    def step(self, obs: Any) -> object:
        self.readings |= set(obs.readings)
        return Status("arrived") if obs.t > 0.3 else Command(0.0, 0.0)

    def close(self) -> None:
        pass


@pytest.mark.parametrize("sensors", [None, [{"name": "front_laser", "kind": "lidar2d", "profile": "ust10"}],
                                     [{"name": "a", "kind": "lidar2d", "profile": "tim571"},
                                      {"name": "b", "kind": "lidar3d", "profile": "vlp16", "rate_hz": 5.0}]])
def test_reset_gets_the_robot_with_its_resolved_suite(sensors: list[dict[str, Any]] | None) -> None:
    robot = profile("jackal") if sensors is None else with_sensors(profile("jackal"), sensors=sensors)
    spy = _Spy()
    run_mission(small_world(bumpy=False), spy, run_seed=1, robot=robot, timeout_s=1.0,  # type: ignore[arg-type]
                sim_config=SimConfig())
    (told,) = spy.robots
    assert told.sensors is not None and told.sensors == suite(robot, SimConfig())
    assert [s.name for s in told.sensors] == (["lidar"] if sensors is None else [s["name"] for s in sensors])
    assert told.model_copy(update={"sensors": robot.sensors}) == robot
    assert spy.readings >= {s.name for s in told.sensors} | {"odom", "imu"}
