"""The ros2 navigator under bad input and faults: one line before anything starts for a bad
configuration; a classified run (Fail-Other, with the reason), never a traceback or a hang, for a
router that cannot be reached or dies, a stack that never answers, crashes, or publishes garbage
or the wrong type on /cmd_vel; and every process navstress started is gone afterwards."""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

import navstress
from navstress.nav.ros2 import ros2_from_config
from navstress.nav.ros2.router import free_port
from tests.support.cli_run import cli
from tests.support.ros2_runs import ROBOT, STACK, gone as _gone, world as _world

pytestmark = pytest.mark.slow

def _run(cfg: dict[str, Any], *, during: Any = None) -> tuple[Any, Any, float]:
    nav = ros2_from_config(config=cfg)
    if during is not None:
        threading.Thread(target=during, args=(nav,), daemon=True).start()
    t0 = time.monotonic()
    r = navstress.run_mission(_world(), nav, seed=2, timeout_s=20.0, robot=ROBOT)
    wall = time.monotonic() - t0
    assert all(_gone(p) for p in nav.started_pids), nav.started_pids
    return r, nav, wall


def _stack(*args: str, **over: Any) -> dict[str, Any]:
    return {"launch": {"command": [sys.executable, STACK, *args]}, "startup_timeout_s": 60.0,
            "reply_budget_s": 0.2, "silence_s": 2.0, **over}


@pytest.mark.parametrize("mode, reason", [
    ("silent", "the stack stopped answering: no command on /cmd_vel for"),
    ("garbage", "the stack published on /cmd_vel a payload that is not a CDR geometry_msgs/msg/Twist"),
    ("wrongtype", "the stack published on /cmd_vel a sample of type std_msgs/msg/String, not"),
    ("crash", "the ROS 2 stack exited with code 3"),
])
def test_a_faulty_stack_is_a_classified_run(mode: str, reason: str) -> None:
    r, nav, wall = _run(_stack("--mode", mode, *(("--twist",) if mode == "garbage" else ())))
    assert r.classification.outcome.label == "Fail-Other"
    assert reason in r.classification.reason, r.classification.reason
    assert "\n" not in r.classification.reason
    assert wall < 60.0


def test_a_router_that_cannot_be_reached_is_a_classified_run() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    r, _, _ = _run({"router": endpoint})
    assert r.classification.outcome.label == "Fail-Other"
    assert f"no Zenoh router answers at {endpoint}" in r.classification.reason


def test_a_router_that_dies_mid_run_ends_the_run() -> None:
    nav = ros2_from_config(config=_stack(reply_budget_s=5.0))
    step = nav.step
    calls = [0]

    def step_then_kill(obs: Any) -> Any:  # the router is killed after the 5th cycle, whatever the load
        calls[0] += 1
        out = step(obs)
        if calls[0] == 5:
            os.kill(nav.started_pids[0], signal.SIGKILL)
            deadline = time.monotonic() + 10.0
            while nav._router is not None and nav._router.alive and time.monotonic() < deadline:
                time.sleep(0.01)
        return out

    nav.step = step_then_kill  # type: ignore[method-assign]
    t0 = time.monotonic()
    r = navstress.run_mission(_world(), nav, seed=2, timeout_s=20.0, robot=ROBOT)
    assert all(_gone(p) for p in nav.started_pids), nav.started_pids
    assert r.classification.outcome.label == "Fail-Other", r.classification.reason
    assert "the Zenoh router at tcp/127.0.0.1:" in r.classification.reason and "stopped" in r.classification.reason
    assert calls[0] == 6  # the next cycle saw it
    assert time.monotonic() - t0 < 60.0


@pytest.mark.parametrize("config, field", [
    ({"domain_id": 233}, "navigator-config.domain_id"),
    ({"domain_id": [1, 1]}, "navigator-config.domain_id"),
    ({"topics": {"cmd_vel": "/2cmd"}}, "navigator-config.topics.cmd_vel"),
    ({"topics": {"scan": "/scan"}}, "navigator-config.topics.scan"),
    ({"topics": {"odom": "odom"}}, "navigator-config.topics.odom"),
    ({"router": "tcp/127.0.0.1:99999"}, "navigator-config.router"),
    ({"mode": "fast"}, "navigator-config.mode"),
    ({"wait_active": []}, "navigator-config.wait_active"),
    # a stack that cannot be started from here: one line before anything runs, not a run per attempt
    ({"launch": {"command": ["/nonexistent/navstack"]}}, "navigator-config.launch.command"),
    ({"launch": {"command": ["no-such-navstack-program"]}}, "navigator-config.launch.command"),
    ({"launch": {"command": ["bin/navstack"]}}, "navigator-config.launch.command"),  # relative, not there
    ({"launch": {"command": [str(Path(__file__).resolve())]}}, "navigator-config.launch.command"),  # not executable
    ({"launch": {"command": ["python3"], "env": {"PATH": "/nonexistent"}}}, "navigator-config.launch.command"),
    ({"launch": {"command": [sys.executable], "cwd": "/nonexistent"}}, "navigator-config.launch.cwd"),
])
def test_a_bad_configuration_is_one_line_before_anything_runs(tmp_path: Path, config: dict[str, Any],
                                                               field: str) -> None:
    world = tmp_path / "w"
    _world().save(world)
    out = tmp_path / "out"
    code, stdout, stderr = cli("run", str(world), "--navigator", "ros2", "--navigator-config", json.dumps(config),
                               "-o", str(out), "--robot", "jackal")
    assert code == 2, stdout + stderr
    lines = [ln for ln in (stdout + stderr).splitlines() if ln.strip() and "NavigatorNote" not in ln
             and "make_navigator" not in ln]
    assert any(field in ln for ln in lines), lines
    assert not out.exists()


def test_parallel_runs_on_a_shared_router_take_different_domain_ids() -> None:
    """Two runs reset at once on one user router with the pool [7, 8, 9]: each holds its own id
    (a third run, while both hold theirs, gets the third; a pool of one taken id is refused)."""
    from navstress.nav.api import NavMission
    from navstress.nav.ros2.router import start_router
    from navstress.robot.profiles import profile

    router = start_router()
    navs = [ros2_from_config(config={"router": router.endpoint, "domain_id": [7, 8, 9], "startup_timeout_s": 0.5})
            for _ in range(3)]
    mission = NavMission((0.0, 0.0, 0.0), (5.0, 0.0))
    robot = profile("jackal").model_copy(update={"sensors": ()})
    try:
        ts = [threading.Thread(target=n.reset, args=(mission, robot), kwargs={"seed": 1}) for n in navs[:2]]
        for t in ts:
            t.start()
        for t in ts:
            t.join(30.0)
        got = sorted(n.domain_id for n in navs[:2])
        assert len(set(got)) == 2 and set(got) <= {7, 8, 9}, got
        navs[2].reset(mission, robot, seed=1)
        assert {navs[2].domain_id, *got} == {7, 8, 9}
        full = ros2_from_config(config={"router": router.endpoint, "domain_id": [7, 8], "startup_timeout_s": 0.5})
        full.reset(mission, robot, seed=1)
        assert full.failure is not None and "every domain id of the pool [7, 8] is taken" in full.failure
        full.close()
    finally:
        for n in navs:
            n.close()
        router.stop()
