"""Conformance checker: passes the examples, fails each deliberately broken navigator on the
right check and only there."""

from __future__ import annotations

import math
import random
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.check import (
    CHECK_NAMES,
    CheckReport,
    check_navigator,
    flat_ground_scan,
    report_text,
    synthetic_observations,
)
from navstress.robot import RobotSpec
from navstress.seeding import rng

FAST = {"n_steps": 8, "azimuth_steps": 36}


class GoodNav:
    """Seeded noise on a go-to-goal command: deterministic per seed, differs across seeds."""

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        self.g: np.random.Generator | None = None

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.g = rng(seed, "good")

    def step(self, obs: Observation) -> Command | Status:
        assert self.g is not None
        return Command(0.5 + 0.01 * float(self.g.random()), 0.0)

    def close(self) -> None:
        self.g = None


class UnseededNav(GoodNav):
    def step(self, obs: Observation) -> Command | Status:
        return Command(random.random(), 0.0)  # global, unseeded: forbidden


class SlowNav(GoodNav):
    def step(self, obs: Observation) -> Command | Status:
        time.sleep(0.03)
        return super().step(obs)


class EmptyScanCrash(GoodNav):
    def step(self, obs: Observation) -> Command | Status:
        if not obs.scans or len(obs.scans[0].points) == 0:
            raise IndexError("no points in scan")
        return super().step(obs)


class NanNav(GoodNav):
    def step(self, obs: Observation) -> Command | Status:
        return Command(float("nan"), 0.0)


class WrongReturn(GoodNav):
    def step(self, obs: Observation) -> Any:
        return (0.5, 0.0)


class BadStatus(GoodNav):
    def step(self, obs: Observation) -> Command | Status:
        return Status("done", "")  # type: ignore[arg-type]


class CloseTwiceCrash(GoodNav):
    def close(self) -> None:
        if self.g is None and getattr(self, "_closed", False):
            raise RuntimeError("already closed")
        self._closed = True
        self.g = None


class LeakyReset(GoodNav):
    """Keeps state across reset: the second run differs from the first."""

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        super().__init__(config)
        self.calls = 0

    def step(self, obs: Observation) -> Command | Status:
        self.calls += 1
        return Command(0.1 * self.calls, 0.0)


def failed(report: CheckReport) -> set[str]:
    return {r.name for r in report.results if not r.passed}


def test_example_navigators_pass(example_package: Path) -> None:
    for name in ("straightline-v1", "straightline-stdio-v1"):
        report = check_navigator(name, n_steps=10)
        assert report.passed, str(report)
        assert [r.name for r in report.results] == list(CHECK_NAMES)


def test_seeded_navigator_passes_and_other_seed_differs() -> None:
    report = check_navigator(GoodNav, **FAST)
    assert report.passed, str(report)
    assert "another seed gives different answers" in report.result("deterministic").detail


@pytest.mark.parametrize(("cls", "fails", "detail"), [
    (UnseededNav, {"deterministic", "resets-cleanly"}, "different answers: step 0: Command"),
    (SlowNav, {"within-budget"}, "over budget"),
    (EmptyScanCrash, {"empty-scan"}, "raised IndexError: no points in scan (at test_nav_check.py:"),
    (NanNav, {"valid-types", "empty-scan"}, "step 0: Command.v=nan is not finite"),
    (WrongReturn, {"valid-types", "empty-scan"}, "step 0: step returned tuple"),
    (BadStatus, {"valid-types", "empty-scan"}, "Status.kind='done' is not 'arrived' or 'error'"),
    (CloseTwiceCrash, {"close-idempotent"}, "raised RuntimeError: already closed"),
    (LeakyReset, {"resets-cleanly"}, "second reset, same seed, different answers: step 0"),
])
def test_broken_navigators_fail_exactly_their_check(cls: type, fails: set[str], detail: str) -> None:
    report = check_navigator(cls, step_budget_s=0.02, **FAST)
    assert not report.passed
    assert failed(report) == fails, str(report)
    assert any(detail in report.result(n).detail for n in fails), str(report)
    text = report_text(report)
    assert "FAIL (" in text and all(n in text for n in CHECK_NAMES)


def test_slow_navigator_timing_is_measured() -> None:
    report = check_navigator(SlowNav, step_budget_s=0.02, **FAST)
    timing = report.timing()
    assert timing["n"] > 0 and timing["median"] >= 0.03 and timing["max"] >= timing["median"]
    assert check_navigator(SlowNav, step_budget_s=1.0, **FAST).passed


def test_unbuildable_navigator() -> None:
    def factory(*, config: Mapping[str, Any]) -> GoodNav:
        raise ValueError("missing model file")

    report = check_navigator(factory, **FAST)
    assert report.result("builds").detail.startswith("raised NavigatorError")
    assert "missing model file" in report.result("builds").detail
    assert all(r.detail.startswith("not run") for r in report.results[1:])
    assert not report.passed


def test_unversioned_name_is_noted(example_package: Path) -> None:
    report = check_navigator("straightline", **FAST)
    assert report.navigator == "straightline-v1"
    assert report.notes and "using the latest" in report.notes[0]


def test_reference_navigator_passes() -> None:
    report = check_navigator("reference-v1", n_steps=10, azimuth_steps=90)
    assert report.passed, str(report)


def test_flat_ground_scan_matches_brute_force_ray_plane_intersection() -> None:
    robot = RobotSpec()
    scan = flat_ground_scan(robot, 1.0, azimuth_steps=12)
    h = robot.wheel_radius_m + robot.lidar.z_m
    expected = []
    for e in np.linspace(-30.7, 10.7, 32):
        for k in range(12):
            a = 2 * math.pi * k / 12
            d = np.array([math.cos(math.radians(e)) * math.cos(a),
                          math.cos(math.radians(e)) * math.sin(a), math.sin(math.radians(e))])
            if d[2] >= 0:
                continue
            t = h / -d[2]  # ray length to the plane z = -h
            if t <= 70.0:
                expected.append(t * d)
    exp = np.array(expected)
    got = scan.points.astype(np.float64)
    assert got.shape == exp.shape
    order_g = np.lexsort(np.round(got, 4).T)
    order_e = np.lexsort(np.round(exp, 4).T)
    np.testing.assert_allclose(got[order_g], exp[order_e], atol=1e-4)
    assert scan.mount == (robot.lidar.x_m, robot.lidar.y_m, robot.lidar.z_m)


def test_synthetic_observations_are_a_plausible_drive() -> None:
    obs = synthetic_observations(RobotSpec(), 6, azimuth_steps=8)
    assert [o.t for o in obs] == pytest.approx([0.1 * k for k in range(1, 7)])
    assert [o.pose is not None for o in obs] == [False, True] * 3
    assert all(o.odom.x == pytest.approx(0.5 * o.t) for o in obs)
    assert all(len(o.scans) == 1 and o.scans[0].t < o.t for o in obs)
