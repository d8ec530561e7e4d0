"""navigate_to_pose through the action, end to end through a router (issue 38): the test action
server (tests/support/ros2_action_stack.py) accepts the goal, its controller drives, and the
goal's result is the run's verdict. Plus the action's service type hashes against independent
references."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import navstress
from navstress.nav.ros2 import action, rmw
from navstress.nav.ros2 import ros2_from_config
from navstress.world import Mission, World, WorldSpec

SUPPORT = Path(__file__).resolve().parents[1] / "support"
ROBOT = {"base": "jackal", "sensors": [{"name": "front_laser", "kind": "lidar2d", "profile": "ust10",
                                        "mount": {"xyz": [0.12, 0, 0.3], "rpy": [0, 0, 0]}}]}


def _run(cfg: dict, timeout_s: float = 20.0):
    world = World.flat(WorldSpec(size_m=(20.0, 20.0)), mission=Mission((3.0, 3.0, 0.0), (6.0, 3.0), 1.0))
    nav = ros2_from_config(config={"reply_budget_s": 0.5, "startup_timeout_s": 20.0, **cfg})
    try:
        return navstress.run_mission(world, nav, seed=1, timeout_s=timeout_s, robot=ROBOT), nav
    finally:
        nav.close()


@pytest.mark.parametrize("goal", ["action", "both"])
def test_succeeded_is_arrival(goal: str) -> None:
    r, nav = _run({"goal": goal, "launch": {"command": [sys.executable, str(SUPPORT / "ros2_action_stack.py")]}})
    assert r.classification.outcome.value == "success", (r.classification, r.facts.error, bytes(nav._stderr).decode()[-800:])
    assert nav._proc is None  # the stack's process group was stopped


@pytest.mark.parametrize("message", ["Failed to make progress", "Controller patience exceeded"])
def test_aborted_is_fail_error_with_the_message(message: str) -> None:
    r, nav = _run({"goal": "action", "launch": {"command": [
        sys.executable, str(SUPPORT / "ros2_action_stack.py"), "--outcome", "aborted", "--message", message]}})
    assert r.classification.outcome.value == "fail-error", (r.classification, r.facts.error)
    assert r.facts.error and message in r.facts.error and "aborted" in r.facts.error and "9003" in r.facts.error


def test_a_server_that_never_appears_is_a_classified_failure() -> None:
    # the plain test stack subscribes to /goal_pose but serves no action
    r, nav = _run({"goal": "action", "startup_timeout_s": 3.0,
                   "launch": {"command": [sys.executable, str(SUPPORT / "ros2_stack.py")]}})
    assert r.classification.outcome.value == "fail-other", (r.classification, r.facts.error)
    assert r.facts.error and "navigate_to_pose" in r.facts.error


# independent references: rmw_zenoh's docs/design.md (AddTwoInts) and a third-party ROS 2 client's
# test vectors for example_interfaces/action/Fibonacci; zenoh-ros2-sdk's compute_service_type_hash
REFS = {
    "example_interfaces/srv/AddTwoInts": "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a",
    "example_interfaces/action/Fibonacci_SendGoal":
        "RIHS01_d1a57fb2a4afe8c21e34fb10db206f16ce6729b28531141472df92277c55b557",
    "example_interfaces/action/Fibonacci_GetResult":
        "RIHS01_1b0de0d5d29dc955d92f546706568428632771db13ec84c15ec1c1a59f424a57",
}


@pytest.mark.parametrize("srv", sorted(REFS))
def test_service_type_hash_matches_references(srv: str) -> None:
    st = rmw.typestore("jazzy")
    action._register(st, {"example_interfaces/srv/AddTwoInts_Request": "int64 a\nint64 b\n",
                          "example_interfaces/srv/AddTwoInts_Response": "int64 sum\n",
                          "example_interfaces/action/Fibonacci_Goal": "int32 order\n",
                          "example_interfaces/action/Fibonacci_Result": "int32[] sequence\n",
                          "example_interfaces/action/Fibonacci_Feedback": "int32[] sequence\n"})
    a = "example_interfaces/action/Fibonacci"
    action._register(st, {k: v for k, v in action._defs(a, "jazzy").items()
                          if k.endswith(("_Request", "_Response", "_FeedbackMessage"))})
    assert action.service_type_hash(srv, "jazzy") == REFS[srv]
    assert action.service_type_hash(srv, "humble") == "TypeHashNotSupported"


def test_cancel_goal_hash_matches_the_sdk(tmp_path: Path) -> None:
    sys.path.insert(0, str(SUPPORT))
    from ros2_stack import write_msg_files
    from zenoh_ros2_sdk.utils import compute_service_type_hash

    root = write_msg_files(tmp_path, ("action_msgs/msg/GoalInfo", "action_msgs/msg/GoalStatus"))
    deps = {f"{p.parts[-3]}/msg/{p.stem}": p.read_text() for p in root.rglob("*.msg")}
    sdk = compute_service_type_hash("action_msgs/srv/CancelGoal", "action_msgs/GoalInfo goal_info",
                                    "int8 return_code\naction_msgs/GoalStatus[] goals_canceling", deps)
    action.register_action_types("jazzy")
    assert action.service_type_hash("action_msgs/srv/CancelGoal", "jazzy") == sdk
