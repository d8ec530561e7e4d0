"""A lifecycle stack, as Nav2 is: the test stack with ``--lifecycle`` serves
``/test_stack/get_state`` (through zenoh-ros2-sdk, which computes the service's keys and hash
itself) and drops goals while it is inactive, as Nav2's BT navigator rejects them; it becomes
active once a /tf has come (as a Nav2 costmap activates once ``map -> base_link`` exists), or
never. navstress waits for it (``wait_active``) publishing /clock and /tf of t = 0, then sends the
goal (docs/ros2.md, Connecting a real Nav2)."""

from __future__ import annotations

import sys
from typing import Any

import pytest

import navstress
from navstress.nav.ros2 import ros2_from_config
from tests.support.ros2_runs import ROBOT, STACK, gone, world

pytestmark = pytest.mark.slow


def _run(*args: str, **over: Any) -> tuple[Any, Any]:
    cfg = {"launch": {"command": [sys.executable, STACK, *args]}, "reply_budget_s": 5.0, **over}
    nav = ros2_from_config(config=cfg)
    r = navstress.run_mission(world(), nav, seed=3, timeout_s=30.0, robot=ROBOT)
    assert len(nav.started_pids) == 2 and all(gone(p) for p in nav.started_pids)
    return r, nav


def test_the_goal_waits_for_the_lifecycle_node_to_be_active() -> None:
    r, _ = _run("--lifecycle", "tf")  # wait_active: auto (the default) finds /test_stack
    assert r.classification.outcome.label == "Success", r.classification.reason
    notes = [e[2] for e in r.events if "ros2 lockstep" in e[2]]
    assert len(notes) == 1 and "goal sent once /test_stack active" in notes[0]


def test_without_the_wait_the_goal_is_dropped() -> None:
    """The same stack with ``wait_active: none``: the goal goes out before the stack is active
    and is dropped; the robot never moves (the wait above is what made that run succeed)."""
    r, _ = _run("--lifecycle", "tf", wait_active="none")
    assert r.classification.outcome.label == "Fail-TimeOut", r.classification.reason
    assert r.path_length_m < 0.01


def test_a_stack_that_never_becomes_active_is_fail_other_saying_its_state() -> None:
    r, nav = _run("--lifecycle", "never", startup_timeout_s=3.0)
    assert r.classification.outcome.label == "Fail-Other"
    reason = r.classification.reason
    assert "/test_stack did not become active" in reason and "'inactive'" in reason and "\n" not in reason
    assert len(nav.overhead_s) == 0  # no cycle ran: the goal was never sent


def test_a_named_node_that_never_answers() -> None:
    r, _ = _run(wait_active=["/nobody"], startup_timeout_s=2.0)
    assert r.classification.outcome.label == "Fail-Other"
    assert "nothing answered /nobody/get_state" in r.classification.reason


def test_a_stack_without_lifecycle_services_is_not_waited_for() -> None:
    r, _ = _run()  # auto, and the plain test stack serves no get_state
    assert r.classification.outcome.label == "Success", r.classification.reason
    assert not any("goal sent once" in e[2] for e in r.events)
