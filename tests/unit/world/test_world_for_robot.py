"""Worlds sized to the robot: the start and goal free discs follow the robot's half diagonal
(when the spec sets no radius), the traversability its half width; the RMP 400's worlds are
those of before; a robot that does not fit the free discs is refused in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec
from navstress.world import generate, parse_spec
from navstress.world.generate import check_robot_fits, free_radius_for, sized_to_robot

SPEC = {"size_m": [40, 40], "ground": {"subdivisions": 3, "deformation": 0.6},
        "obstacles": {"obstruction": {"tree": 3}}}


def test_the_rmp400s_world_is_the_world_of_before(tmp_path: Path) -> None:
    spec = parse_spec(SPEC)
    generate(spec, 7).save(tmp_path / "a")
    generate(spec, 7, robot=PROFILES["rmp400"]).save(tmp_path / "b")
    for f in ("world.json", "terrain.npz"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


@pytest.mark.parametrize("name", sorted(set(PROFILES) - {"rmp400"}))
def test_a_smaller_robot_gets_smaller_free_areas_and_its_own_traversability(name: str) -> None:
    robot = PROFILES[name]
    spec = parse_spec(SPEC)
    big, small = generate(spec, 7), generate(spec, 7, robot=robot)
    assert small.mission.free_radius_m == pytest.approx(5.0 - PROFILES["rmp400"].half_diagonal_m
                                                        + robot.half_diagonal_m)
    assert small.mission.free_radius_m < big.mission.free_radius_m
    fa_small, fa_big = small.descriptors["free_areas"], big.descriptors["free_areas"]
    assert fa_small != fa_big
    assert small.descriptors["traversability"]["robot"] == name
    assert small.descriptors["traversability"]["half_width_m"] == pytest.approx(robot.width_m / 2)
    assert big.descriptors["traversability"]["half_width_m"] == pytest.approx(0.335)


def test_a_radius_the_spec_sets_is_kept() -> None:
    spec = parse_spec({**SPEC, "mission": {"free_radius_m": 3.0}})
    for robot in PROFILES.values():
        assert sized_to_robot(spec, robot).mission.free_radius_m == 3.0


@pytest.mark.parametrize("radius", [0.2, 0.5, 0.6])
def test_a_robot_that_does_not_fit_the_free_discs_is_refused(radius: float) -> None:
    spec = parse_spec({**SPEC, "mission": {"free_radius_m": radius}})
    for robot in PROFILES.values():
        if robot.half_diagonal_m <= radius:
            assert sized_to_robot(spec, robot).mission.free_radius_m == radius
            continue
        with pytest.raises(SpecError) as err:
            generate(spec, 1, robot=robot)
        msg = str(err.value)
        assert "\n" not in msg and msg.startswith(f"robot={robot.name!r}") and "free_radius_m" in msg
        with pytest.raises(SpecError, match=r"^--robot="):
            check_robot_fits(radius, robot, "--robot")


def test_no_free_discs_ask_nothing() -> None:
    check_robot_fits(0.0, RobotSpec(length_m=5.0, width_m=3.0))


def test_a_large_robot_whose_discs_leave_the_map_is_refused_naming_the_robot() -> None:
    big = RobotSpec(name="big", length_m=4.0, width_m=3.0)  # half diagonal 2.5 m: discs of 6.84 m, inset 5 m
    assert free_radius_for(big) > 5.0
    with pytest.raises(SpecError) as err:
        generate(parse_spec(SPEC), 1, robot=big)
    assert str(err.value).startswith("robot='big'") and "\n" not in str(err.value)
