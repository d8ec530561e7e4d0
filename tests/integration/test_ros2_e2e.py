"""A ROS 2 stack driven by navstress over Zenoh, end to end: the test stack
(tests/support/ros2_stack.py, written on zenoh-ros2-sdk, an implementation of rmw_zenoh's
conventions that is not navstress's) launched for each run, a router started on 127.0.0.1,
real missions in the real simulator; lockstep with TwistStamped and with Twist, paced; the same
seed twice; a campaign of the stack on 2 workers against 1 (the real CLI), and the gate on it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

import navstress
from navstress.campaign.store import Store
from navstress.nav.ros2 import ros2_from_config
from tests.support.cli_run import cli
from tests.support.ros2_runs import ROBOT, STACK, gone as _gone, world as _world, world_past_a_box

pytestmark = pytest.mark.slow


def _config(*args: str, **over: Any) -> dict[str, Any]:
    # a generous reply budget: a loaded machine must not turn a slow answer into a miss (a miss
    # holds the last command, and the replays below would differ)
    return {"launch": {"command": [sys.executable, STACK, *args]}, "startup_timeout_s": 60.0, "reply_budget_s": 5.0,
            **over}


def _run(cfg: dict[str, Any], trace: Path | None = None, seed: int = 3, world: Any = None) -> tuple[Any, Any]:
    nav = ros2_from_config(config=cfg)
    r = navstress.run_mission(world or _world(), nav, seed=seed, timeout_s=30.0, robot=ROBOT, trace=trace)
    assert len(nav.started_pids) == 2  # the router and the stack ...
    assert all(_gone(p) for p in nav.started_pids)  # ... both stopped with the run
    return r, nav


@pytest.mark.parametrize("args", [(), ("--twist",)], ids=["TwistStamped", "Twist"])
def test_lockstep_drives_the_stack_to_the_goal(args: tuple[str, ...]) -> None:
    r, nav = _run(_config(*args))
    assert r.classification.outcome.label == "Success", r.classification.reason
    assert r.facts.goal_distance_m < 1.0
    # lockstep: (nearly) every cycle answered within its budget; the run says how many were not
    assert nav.misses <= 2, nav.missed_at
    notes = [e for e in r.events if "ros2 lockstep" in e[2]]
    assert len(notes) == 1 and f"{len(nav.overhead_s)} cycles" in notes[0][2]


def test_paced_runs_at_a_multiple_of_the_wall_clock() -> None:
    import time

    t0 = time.monotonic()
    r, nav = _run(_config(mode="paced", real_time_factor=4.0))
    wall = time.monotonic() - t0
    assert r.classification.outcome.label == "Success", r.classification.reason
    # simulated time went no faster than 4x the wall clock (the start-up comes on top)
    assert wall >= r.facts.duration_s / 4.0 if hasattr(r.facts, "duration_s") else wall > 0
    assert nav.misses == 0  # paced never waits for a command


def test_same_seed_same_run_in_lockstep(tmp_path: Path) -> None:
    """The stack is deterministic and answers every cycle: the same seed gives the same trace,
    byte for byte (navstress's own part; the stack's indeterminism is its own, docs/ros2.md). The
    world has a box the scan sees, so each command depends on the cycle's scan as well as its
    clock, /tf and odometry (a stack that handled the scan late now and then ran differently)."""
    a, nav_a = _run(_config(), tmp_path / "a.mcap", seed=5, world=world_past_a_box())
    b, nav_b = _run(_config(), tmp_path / "b.mcap", seed=5, world=world_past_a_box())
    assert nav_a.misses == nav_b.misses == 0
    assert a.classification == b.classification
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def _spec(root: Path) -> Path:
    spec = {
        "name": "ros2-stack", "seed": 4, "robot": "jackal", "sensors": ROBOT["sensors"],
        "world": {"size_m": [16.0, 16.0], "cell_m": 0.4},
        "experiments": [{"name": "open", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "maps_per_config": 2, "runs_per_map": 1,
        "navigators": [{"name": "ros2", "config": _config()}],
        "faults": [None], "timeout_s": 30.0, "goal_tolerance_m": 1.0}
    p = root / "spec.yaml"
    p.write_text(yaml.safe_dump(spec, sort_keys=False))
    return p


def _rows(out: Path) -> list[tuple[Any, ...]]:
    with Store.open(out) as st:
        return [(r.run_id, r.outcome, r.reason, round(r.duration_s, 6), round(r.goal_distance_m, 6),
                 round(r.path_length_m, 6)) for r in st.records()]


def test_a_campaign_of_the_stack_on_two_workers_records_what_one_does(tmp_path: Path) -> None:
    spec = _spec(tmp_path)
    for j in ("1", "2"):
        code, out, err = cli("campaign", "run", str(spec), "-o", str(tmp_path / f"j{j}"), "-j", j, "-q")
        assert code == 0, out + err
    one, two = _rows(tmp_path / "j1"), _rows(tmp_path / "j2")
    assert len(one) == 2 and one == two
    assert all(r[1] == "success" for r in one), one
    # the campaign's store is a store like any other: the CI gate reads it
    code, out, err = cli("gate", str(tmp_path / "j2"), "--min-success", "0.5", "--json")
    assert code in (0, 1), out + err  # a verdict (pass or fail on 2 runs), never a refusal
    import json

    verdict = json.loads(out)
    assert "ros2" in json.dumps(verdict)
