"""``small-footprint`` follows the robot: any robot's believed footprint is its own scaled by the
paper's ratios (length 0.84/1.14, width 0.45/0.67), the RMP 400's exactly 0.84 m x 0.45 m; and the
reference planner checks a rectangle that holds the whole believed footprint."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.faults import FaultyNavigator, SmallFootprint, small_footprint
from navstress.nav.reference.planner import ArcPlanner, footprint_half_extents
from navstress.nav.reference.config import ReferenceConfig
from navstress.robot import PROFILES, Footprint, RobotSpec

KX, KY = 0.84 / 1.14, 0.45 / 0.67


def test_the_rmp400_believes_exactly_the_papers_figures() -> None:
    b = small_footprint(RobotSpec())
    assert (b.name, b.length_m, b.width_m) == ("rmp400-small-belief", 0.84, 0.45)
    assert b == RobotSpec().model_copy(update={"name": "rmp400-small-belief", "length_m": 0.84, "width_m": 0.45})


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_every_profile_shrinks_by_the_papers_ratios(name: str) -> None:
    robot = PROFILES[name]
    b = small_footprint(robot)
    assert b.name == f"{name}-small-belief"
    assert b.length_m == pytest.approx(robot.length_m * KX, rel=1e-9)
    assert b.width_m == pytest.approx(robot.width_m * KY, rel=1e-9)
    assert np.allclose(np.ptp(b.footprint_points()[:, 0]), np.ptp(robot.footprint_points()[:, 0]) * KX)
    assert np.allclose(np.ptp(b.footprint_points()[:, 1]), np.ptp(robot.footprint_points()[:, 1]) * KY)
    keep = set(RobotSpec.model_fields) - {"name", "length_m", "width_m", "footprint"}
    assert {k: getattr(b, k) for k in keep} == {k: getattr(robot, k) for k in keep}  # only the footprint changes


@st.composite
def shaped(draw: st.DrawFn) -> RobotSpec:
    shape = draw(st.sampled_from(["box", "circle", "polygon"]))
    if shape == "box":
        return RobotSpec(name="b", length_m=draw(st.floats(0.1, 3)), width_m=draw(st.floats(0.1, 3)))
    if shape == "circle":
        return RobotSpec(name="c", footprint=Footprint(shape="circle", radius_m=draw(st.floats(0.05, 1.5))))
    n = draw(st.integers(3, 10))
    a, b = draw(st.floats(0.1, 1.5)), draw(st.floats(0.1, 1.5))
    off = draw(st.floats(0, 0.5))
    pts = tuple((round(a * math.cos(t), 6), round(b * math.sin(t) * (1 - off * 0.5), 6))
                for t in np.linspace(0, 2 * math.pi, n, endpoint=False) + off)
    return RobotSpec(name="p", footprint=Footprint(shape="polygon", points=pts))


@settings(max_examples=60, deadline=None)
@given(shaped())
def test_any_footprint_is_scaled_point_by_point(robot: RobotSpec) -> None:
    b = small_footprint(robot)
    true, believed = robot.footprint_points(), b.footprint_points()
    if robot.footprint.shape == "box":
        assert b.footprint.shape == "box"
        assert (b.length_m, b.width_m) == pytest.approx((robot.length_m * KX, robot.width_m * KY), rel=1e-12)
    else:
        assert b.footprint.shape == "polygon"
        assert np.allclose(believed, true * [KX, KY], atol=1e-9)
        assert b.length_m == pytest.approx(2 * np.max(np.abs(believed[:, 0])))
    hl, hw = footprint_half_extents(b)
    assert np.all(np.abs(believed[:, 0]) <= hl + 1e-12) and np.all(np.abs(believed[:, 1]) <= hw + 1e-12)


@settings(max_examples=60, deadline=None)
@given(shaped())
def test_the_planner_rectangle_holds_the_whole_footprint(robot: RobotSpec) -> None:
    hl, hw = footprint_half_extents(robot)
    pts = robot.footprint_points(256)
    assert np.all(np.abs(pts[:, 0]) <= hl + 1e-9) and np.all(np.abs(pts[:, 1]) <= hw + 1e-9)
    # and it is the smallest such rectangle: a vertex touches each side
    assert np.isclose(np.max(np.abs(pts[:, 0])), hl, atol=1e-3 * hl) and np.isclose(np.max(np.abs(pts[:, 1])), hw,
                                                                                    atol=1e-3 * hw)
    p = ArcPlanner(ReferenceConfig(footprint_margin_m=0.1), robot)
    assert (p.half_length, p.half_width) == (hl + 0.1, hw + 0.1)


def test_a_box_is_checked_as_before() -> None:
    for robot in PROFILES.values():
        if robot.footprint.shape == "box":
            assert footprint_half_extents(robot) == (0.5 * robot.length_m, 0.5 * robot.width_m)


def test_the_wrapper_tells_the_navigator_the_believed_robot() -> None:
    told: list[RobotSpec] = []

    class Inner:
        def reset(self, mission: object, robot: RobotSpec, *, seed: int) -> None:
            told.append(robot)

    for robot in PROFILES.values():
        FaultyNavigator(Inner(), SmallFootprint()).reset(None, robot, seed=0)  # type: ignore[arg-type]
    assert told == [small_footprint(r) for r in PROFILES.values()]
