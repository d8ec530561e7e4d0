"""reference-2d-v1 end to end in the real simulation: a Jackal with one UST-10LX-class scanner
(LaserScans cast by the simulation), outcomes as the framework classifies them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.registry import make_navigator
from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.run.mission import RunResult, run_mission
from navstress.world import Obstacle, World, WorldSpec, generate, parse_spec
from navstress.world.world import Mission

LASER = [{"name": "front_laser", "kind": "lidar2d", "profile": "ust10"}]
JACKAL = with_sensors(profile("jackal"), sensors=LASER)


def wall(x0: float, y0: float, x1: float, y1: float) -> Obstacle:
    return Obstacle("building", 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0, (x1 - x0, y1 - y0, 1.0), 0.0)


def flat(size: float, obstacles: tuple[Obstacle, ...], start: tuple[float, float, float],
         goal: tuple[float, float], tolerance: float = 1.0) -> World:
    return World.flat(WorldSpec(size_m=(size, size)), obstacles=obstacles, mission=Mission(start, goal, tolerance))


class Recorder:
    """reference-2d-v1, recording its commands."""

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        self.inner = make_navigator("reference-2d-v1", config)
        self.commands: list[tuple[float, float]] = []

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.inner.reset(mission, robot, seed=seed)

    def step(self, obs: Observation) -> Command | Status:
        out = self.inner.step(obs)
        if isinstance(out, Command):
            self.commands.append((out.v, out.omega))
        return out

    def close(self) -> None:
        self.inner.close()


def run(world: World, robot: RobotSpec = JACKAL, seed: int = 1, timeout: float = 60.0) -> tuple[RunResult, Recorder]:
    nav = Recorder()
    return run_mission(world, nav, run_seed=seed, robot=robot, timeout_s=timeout), nav


def outcome(r: RunResult) -> str:
    return r.classification.outcome.value


@pytest.mark.parametrize("seed", [3, 4])
def test_a_jackal_reaches_the_goal_among_trees(seed: int) -> None:
    w = generate(parse_spec({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 6}}}), seed, robot=JACKAL)
    assert len(w.obstacles) > 5
    r, _ = run(w, seed=seed, timeout=90.0)
    assert outcome(r) == "success", r.classification.reason
    assert r.facts.collisions == 0


def test_an_enclosed_goal_is_fail_error() -> None:
    walls = (wall(10.0, 6.0, 16.0, 6.3), wall(10.0, 11.7, 16.0, 12.0), wall(10.0, 6.0, 10.3, 12.0),
             wall(15.7, 6.0, 16.0, 12.0))
    r, _ = run(flat(20.0, walls, (3.0, 9.0, 0.0), (13.0, 9.0)), timeout=90.0)
    assert outcome(r) == "fail-error", r.classification.reason
    assert r.classification.reason.endswith("after 6 recoveries") and r.facts.collisions == 0


def test_an_ackermann_robot_moves_without_turning_in_place() -> None:
    car = with_sensors(profile("f1tenth"), sensors=LASER)
    w = flat(24.0, (wall(9.0, 3.0, 9.6, 6.5),), (3.0, 5.0, 0.0), (18.0, 5.0))
    r, nav = run(w, robot=car, timeout=40.0)
    c = np.array(nav.commands)
    assert car.max_steer_rad is not None
    kappa = math.tan(car.max_steer_rad) / car.wheelbase_m
    assert (np.abs(c[:, 1]) <= np.abs(c[:, 0]) * kappa + 1e-9).all()
    assert outcome(r) == "success", r.classification.reason


def test_the_same_seed_gives_the_same_run() -> None:
    w = generate(parse_spec({"size_m": [24, 24], "obstacles": {"obstruction": {"tree": 6}}}), 5, robot=JACKAL)
    (a, na), (b, nb), (c, nc) = (run(w, seed=s, timeout=15.0) for s in (7, 7, 8))
    assert na.commands == nb.commands and a.facts == b.facts
    assert na.commands != nc.commands
