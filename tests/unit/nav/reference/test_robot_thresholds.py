"""The reference stack's obstacle and roughness thresholds follow the believed robot
(``config.for_robot``): the RMP 400 keeps the paper's 0.3 m / 0.2 m exactly; a small base gets
what its wheels and belly clear; a value the configuration sets is kept. And the reason, end to
end: on a map of 8 % trees a Jackal (lidar 0.3 m above the ground) drove into trees with the RMP
400's fixed 0.3 m, and does not with its own thresholds."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.reference.config import (OBSTACLE_HEIGHT_MAX_M, ROUGHNESS_MAX_M, THRESHOLD_MIN_M, GlobalConfig,
                                            ReferenceConfig, for_robot)
from navstress.nav.reference.navigator import ReferenceNavigator
from navstress.robot import PROFILES, RobotSpec
from navstress.run.mission import run_mission
from navstress.seeding import derive_seed
from navstress.world.generate import generate
from navstress.world.spec import parse_spec


def test_the_rmp400_keeps_the_papers_thresholds_exactly() -> None:
    for cls in (ReferenceConfig, GlobalConfig):
        c = for_robot(cls(), RobotSpec())
        assert (c.obstacle_height_m, c.max_roughness_m) == (0.3, 0.2)
        assert type(c) is cls


@settings(max_examples=60, deadline=None)
@given(r=st.floats(0.02, 0.5), clear=st.floats(0.0, 0.4), given_h=st.one_of(st.none(), st.floats(0.05, 1.0)))
def test_thresholds_follow_what_the_robot_clears(r: float, clear: float, given_h: float | None) -> None:
    robot = RobotSpec(wheel_radius_m=r, ground_clearance_m=clear, mounts={})
    c = for_robot(ReferenceConfig(obstacle_height_m=given_h), robot)
    want = min(OBSTACLE_HEIGHT_MAX_M, max(THRESHOLD_MIN_M, r + clear))
    assert c.obstacle_height_m == (given_h if given_h is not None else want)
    assert c.max_roughness_m == min(ROUGHNESS_MAX_M, max(THRESHOLD_MIN_M, r + clear))


def test_every_profile_gets_thresholds_at_most_the_rmp400s() -> None:
    for robot in PROFILES.values():
        c = for_robot(ReferenceConfig(), robot)
        assert c.obstacle_height_m is not None and c.max_roughness_m is not None
        assert THRESHOLD_MIN_M <= c.obstacle_height_m <= OBSTACLE_HEIGHT_MAX_M
        assert THRESHOLD_MIN_M <= c.max_roughness_m <= ROUGHNESS_MAX_M


def test_a_jackal_sees_the_trees_with_its_own_thresholds() -> None:
    world = generate(parse_spec({"size_m": [40.0, 40.0], "cell_m": 0.4, "obstacles": {"obstruction": {"tree": 8.0}}}),
                     2403830265523439843)
    seeds = [derive_seed(0, "run", i) for i in (0, 2)]

    def outcomes(config: ReferenceConfig) -> list[str]:
        return [run_mission(world, ReferenceNavigator(config), run_seed=s, robot="jackal",
                            timeout_s=90).classification.outcome.value for s in seeds]

    assert outcomes(ReferenceConfig()) == ["success", "success"]
    # the RMP 400's fixed thresholds on the Jackal: it drives into trees (why they follow the robot)
    assert outcomes(ReferenceConfig(obstacle_height_m=0.3, max_roughness_m=0.2)) == ["fail-collision"] * 2
