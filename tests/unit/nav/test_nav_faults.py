"""Faults are wrappers whose effect is observable by the inner navigator."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import NavigatorError
from navstress.nav.api import Command, Imu, LidarScan, NavMission, Observation, Odometry, Status
from navstress.nav.check import check_navigator
from navstress.nav.faults import (
    DelayedScans,
    DroppedScans,
    FaultyNavigator,
    OdometryScale,
    apply_fault,
    get_fault,
    list_faults,
)
from navstress.nav.registry import load_factory, make_navigator, resolve
from navstress.robot import RobotSpec

MISSION = NavMission((0.0, 0.0, 0.0), (10.0, 0.0))
EMPTY = np.zeros((0, 3), dtype=np.float32)


class Spy:
    """Records what it is told and what it observes."""

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        self.config = dict(config or {})
        self.robot: RobotSpec | None = None
        self.seen: list[Observation] = []

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.robot, self.seen = robot, []

    def step(self, obs: Observation) -> Command | Status:
        self.seen.append(obs)
        return Command(0.0, 0.0)

    def close(self) -> None: ...


def obs_at(k: int, x: float = 0.0, y: float = 0.0, yaw: float = 0.0, n_scans: int = 1) -> Observation:
    t = 0.1 * k
    scans = tuple(LidarScan(t + 0.001 * j, EMPTY, (0.0, 0.0, 1.0)) for j in range(n_scans))
    return Observation(t, Odometry(t, x, y, yaw, 1.0, 0.2), Imu(t, 0, 0, yaw, (0, 0, 0)), None, scans)


def build(fault: str) -> FaultyNavigator:
    nav = apply_fault(Spy, fault)(config={})
    assert isinstance(nav, FaultyNavigator) and isinstance(nav.inner, Spy)
    return nav


def test_catalogue() -> None:
    names = [f.name for f in list_faults()]
    assert names == ["small-footprint", "odometry-scale", "dropped-scans", "delayed-scans",
                     "unknown-as-free", "permissive-slope"]
    assert all(f.description and "\n" not in f.description for f in list_faults())
    with pytest.raises(NavigatorError) as err:
        get_fault("dropped-scan")
    assert "unknown fault 'dropped-scan'. Did you mean 'dropped-scans'?" in str(err.value)
    assert "Known faults: small-footprint, odometry-scale" in str(err.value)


def test_small_footprint_is_what_the_navigator_believes() -> None:
    nav = build("small-footprint")
    real = RobotSpec(max_speed_mps=0.8)
    nav.reset(MISSION, real, seed=0)
    told = nav.inner.robot  # type: ignore[attr-defined]
    assert (told.length_m, told.width_m) == (0.84, 0.45)
    assert (real.length_m, real.width_m) == (1.14, 0.67)
    assert told.max_speed_mps == 0.8 and told.mass_kg == real.mass_kg  # the rest is kept


def test_odometry_scale_straight_line() -> None:
    nav = build("odometry-scale")
    nav.reset(MISSION, RobotSpec(), seed=0)
    for k in range(11):
        nav.step(obs_at(k, x=0.3 * k))
    seen = nav.inner.seen  # type: ignore[attr-defined]
    assert [o.odom.x for o in seen] == pytest.approx([1.05 * 0.3 * k for k in range(11)])
    assert all(o.odom.v == pytest.approx(1.05) and o.odom.omega == 0.2 for o in seen)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.5, 0.5), st.floats(-0.1, 0.1), st.floats(-0.5, 0.5)),
                min_size=1, max_size=30),
       st.floats(-3, 3), st.floats(-3, 3))
def test_odometry_scale_increments(steps: list[tuple[float, float, float]], x0: float, y0: float) -> None:
    """Each increment, seen in the previous pose's frame, is scaled by 1.05; yaw is untouched."""
    fault = OdometryScale(1.05)
    fault.on_reset(MISSION, RobotSpec(), 0)
    x, y, yaw = x0, y0, 0.3
    true = [(x, y, yaw)]
    faulty = [fault.on_observation(obs_at(0, x, y, yaw)).odom]
    for fwd, lat, dyaw in steps:
        x += fwd * math.cos(yaw) - lat * math.sin(yaw)
        y += fwd * math.sin(yaw) + lat * math.cos(yaw)
        yaw = math.remainder(yaw + dyaw, math.tau)
        true.append((x, y, yaw))
        faulty.append(fault.on_observation(obs_at(0, x, y, yaw)).odom)
    assert (faulty[0].x, faulty[0].y) == (x0, y0)
    for (tx0, ty0, tyaw0), (tx1, ty1, tyaw1), f0, f1 in zip(true, true[1:], faulty, faulty[1:]):
        assert f1.yaw == pytest.approx(tyaw1, abs=1e-9)
        assert math.hypot(f1.x - f0.x, f1.y - f0.y) == pytest.approx(
            1.05 * math.hypot(tx1 - tx0, ty1 - ty0), abs=1e-9)
        # same direction relative to the heading
        tf = math.atan2(ty1 - ty0, tx1 - tx0) - tyaw0
        ff = math.atan2(f1.y - f0.y, f1.x - f0.x) - f0.yaw
        if math.hypot(tx1 - tx0, ty1 - ty0) > 1e-6:
            assert math.remainder(tf - ff, math.tau) == pytest.approx(0.0, abs=1e-6)


def dropped_times(seed: int, n: int = 400) -> set[float]:
    nav = build("dropped-scans")
    nav.reset(MISSION, RobotSpec(), seed=seed)
    sent: set[float] = set()
    for k in range(n):
        o = obs_at(k, n_scans=3)
        sent |= {s.t for s in o.scans}
        nav.step(o)
    kept = {s.t for o in nav.inner.seen for s in o.scans}  # type: ignore[attr-defined]
    fault = nav.fault
    assert isinstance(fault, DroppedScans) and fault.seen == 3 * n
    assert fault.dropped == len(sent - kept)
    return sent - kept


def test_dropped_scans_fraction_and_seed() -> None:
    a = dropped_times(1)
    # binomial(1200, 0.3): sd = 15.9 scans; 5 sd bounds
    assert abs(len(a) - 360) < 80
    assert dropped_times(1) == a  # same seed, same scans dropped
    b = dropped_times(2)
    assert b != a and abs(len(b) - 360) < 80


def test_dropped_scans_resets_per_run() -> None:
    nav = build("dropped-scans")
    runs = []
    for _ in range(2):
        nav.reset(MISSION, RobotSpec(), seed=9)
        for k in range(50):
            nav.step(obs_at(k))
        runs.append([len(o.scans) for o in nav.inner.seen])  # type: ignore[attr-defined]
    assert runs[0] == runs[1]


def test_delayed_scans_arrive_n_cycles_late_with_their_timestamp() -> None:
    nav = FaultyNavigator(Spy(), DelayedScans(3))
    nav.reset(MISSION, RobotSpec(), seed=0)
    for k in range(10):
        nav.step(obs_at(k))
    seen = nav.inner.seen  # type: ignore[attr-defined]
    assert [len(o.scans) for o in seen[:3]] == [0, 0, 0]
    for k in range(3, 10):
        assert seen[k].t == pytest.approx(0.1 * k)
        assert [s.t for s in seen[k].scans] == pytest.approx([0.1 * (k - 3)])
    assert build("delayed-scans").fault.cycles == 3  # type: ignore[attr-defined]


def test_config_mutants_of_the_reference_stack() -> None:
    ref = load_factory(resolve("reference-v1")[0])
    nav = apply_fault(ref, "unknown-as-free")(config={"max_slope_deg": 20.0})
    assert nav.config.unknown_cell_cost == 0.0 and nav.config.max_slope_deg == 20.0  # type: ignore[attr-defined]
    assert make_navigator("reference-v1").config.unknown_cell_cost == math.inf  # type: ignore[attr-defined]
    slope = make_navigator("reference-v1", fault="permissive-slope")
    assert slope.config.max_slope_deg == 50.0  # type: ignore[attr-defined]
    assert make_navigator("reference-v1", {"max_slope_deg": 30.0},
                          fault="permissive-slope").config.max_slope_deg == 60.0  # type: ignore[attr-defined]
    assert make_navigator("reference-v1", {"max_slope_deg": 60.0},
                          fault="permissive-slope").config.max_slope_deg == 89.0  # type: ignore[attr-defined]
    glob = make_navigator("reference-global-v1", fault="unknown-as-free")
    assert type(glob).__name__ == "GlobalNavigator" and glob.config.unknown_cell_cost == 0.0  # type: ignore[attr-defined]
    both = apply_fault(apply_fault(ref, "unknown-as-free"), "permissive-slope")(config={})
    assert (both.config.unknown_cell_cost, both.config.max_slope_deg) == (0.0, 50.0)  # type: ignore[attr-defined]


def test_config_mutants_refuse_other_navigators(example_package: Path) -> None:
    with pytest.raises(NavigatorError, match=r"fault 'unknown-as-free' mutates the reference "
                       r"stack's configuration and applies only to reference navigators.*not to "
                       r"'straightline-v1'; faults for any navigator: small-footprint, "
                       r"odometry-scale, dropped-scans, delayed-scans"):
        make_navigator("straightline-v1", fault="unknown-as-free")
    with pytest.raises(NavigatorError, match=r"applies only to reference navigators"):
        apply_fault(Spy, "permissive-slope")


@pytest.mark.parametrize("fault", ["small-footprint", "odometry-scale", "dropped-scans",
                                   "delayed-scans"])
def test_faulty_navigators_still_conform(fault: str, example_package: Path) -> None:
    factory = apply_fault(load_factory(resolve("straightline-v1")[0]), fault)
    report = check_navigator(factory, n_steps=12, azimuth_steps=36)
    assert report.passed, str(report)


def test_wrapper_parameters_validated() -> None:
    with pytest.raises(NavigatorError, match=r"fraction=1.5 is invalid"):
        DroppedScans(1.5)
    with pytest.raises(NavigatorError, match=r"cycles=-1 is invalid"):
        DelayedScans(-1)
    with pytest.raises(NavigatorError, match=r"scale=0.0 is invalid"):
        OdometryScale(0.0)
