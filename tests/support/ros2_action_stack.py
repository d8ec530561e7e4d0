"""A test ``navigate_to_pose`` action server over Zenoh, with the test stack as its controller.

Like Nav2's bt_navigator it accepts the goal through the action (``send_goal``), hands it to the
controller (it republishes the goal on ``/goal_pose`` with zenoh-ros2-sdk's publisher, and runs
``tests/support/ros2_stack.py`` as a child process in its own process group, so navstress stops
both), and answers ``get_result`` when the goal ends:

* ``--outcome succeeded``: once the controller, after moving, holds still (its hold-still near the
  goal) for 3 commands: status SUCCEEDED;
* ``--outcome aborted``: after the controller's 5th command: ABORTED, error_code 9003 (TIMEOUT),
  error_msg ``--message``.

The services are Zenoh queryables on rmw_zenoh's service keys with server (``SS``) liveliness
tokens; replies carry the request's sequence number and client GID (rmw_zenoh's
``rmw_service_data.cpp``); the status topic gets a ``GoalStatusArray`` on accept and at the end.
It reads the router from ``NAVSTRESS_ZENOH_ROUTER`` and the domain from ``ROS_DOMAIN_ID``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import zenoh

HERE = Path(__file__).resolve().parent
ACTION = "nav2_msgs/action/NavigateToPose"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--outcome", default="succeeded", choices=("succeeded", "aborted"))
    ap.add_argument("--message", default="Failed to make progress")
    ap.add_argument("--name", default="/navigate_to_pose")
    args = ap.parse_args()
    router = os.environ["NAVSTRESS_ZENOH_ROUTER"]
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    distro = os.environ.get("NAVSTRESS_TEST_DISTRO", "jazzy")

    from navstress.nav.ros2 import action, rmw

    store = action.register_action_types(distro)
    T = store.types
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{router}"]')
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    zid = str(session.info.zid())
    base = f"/{args.name.strip('/')}/_action"
    lock = threading.Lock()
    state: dict = {"goal_id": None, "pending": [], "cmds": 0, "moved": False, "still": 0, "done": None, "goal_pose": None}
    keep: list = [session.liveliness().declare_token(rmw.node_token(domain, zid, 0, "/", "bt_navigator"))]
    status_key = rmw.topic_key(domain, f"{base}/status", "action_msgs/msg/GoalStatusArray", distro)
    keep.append(session.liveliness().declare_token(rmw.endpoint_token(
        domain, zid, 0, 9, "MP", namespace="/", node="bt_navigator", topic=f"{base}/status",
        ros_type="action_msgs/msg/GoalStatusArray", distro=distro, qos=rmw.Qos("reliable", "transient_local", 1))))
    gid = bytes(range(16))
    seq = [0]

    def publish_status(code: int) -> None:
        gi = state["goal_id"]
        info = T["action_msgs/msg/GoalInfo"](goal_id=gi, stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0))
        arr = T["action_msgs/msg/GoalStatusArray"](status_list=[T["action_msgs/msg/GoalStatus"](
            goal_info=info, status=code)])
        seq[0] += 1
        session.put(status_key, bytes(store.serialize_cdr(arr, "action_msgs/msg/GoalStatusArray")),
                    attachment=rmw.Attachment(seq[0], time.time_ns(), gid).to_bytes())

    def reply(query: zenoh.Query, msg, typ: str) -> None:
        att = rmw.Attachment.from_bytes(query.attachment.to_bytes())
        query.reply(query.key_expr, bytes(store.serialize_cdr(msg, typ)),
                    attachment=rmw.Attachment(att.sequence, time.time_ns(), att.gid).to_bytes())

    from zenoh_ros2_sdk import ROS2Publisher
    from zenoh_ros2_sdk.message_registry import get_registry

    sys.path.insert(0, str(HERE))
    from ros2_stack import write_msg_files

    import tempfile

    get_registry(str(write_msg_files(Path(tempfile.mkdtemp(prefix="ros2-action-msgs-")))))
    host, port = router.split("/", 1)[1].rsplit(":", 1)
    goal_pub = ROS2Publisher(topic="/goal_pose", msg_type="geometry_msgs/msg/PoseStamped", router_ip=host,
                             router_port=int(port), domain_id=domain, node_name="bt_navigator_goal")

    def on_send_goal(query: zenoh.Query) -> None:
        req = store.deserialize_cdr(query.payload.to_bytes(), f"{ACTION}_SendGoal_Request")
        with lock:
            state["goal_id"], state["goal_pose"] = req.goal_id, req.goal.pose
        p = req.goal.pose
        goal_pub.publish(header=p.header, pose=p.pose)
        reply(query, T[f"{ACTION}_SendGoal_Response"](
            accepted=True, stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0)), f"{ACTION}_SendGoal_Response")
        publish_status(2)

    def finish() -> None:
        with lock:
            done, pending = state["done"], list(state["pending"])
            if done is None:
                return
            state["pending"].clear()
        print(f"action server: goal ends with status {done[0]}, {len(pending)} get_result waiting",
              file=sys.stderr, flush=True)
        code, result = done
        for q in pending:
            reply(q, T[f"{ACTION}_GetResult_Response"](status=code, result=result), f"{ACTION}_GetResult_Response")
        publish_status(code)

    def on_get_result(query: zenoh.Query) -> None:
        with lock:
            state["pending"].append(query)
        finish()

    def on_cancel(query: zenoh.Query) -> None:
        reply(query, T["action_msgs/srv/CancelGoal_Response"](return_code=0, goals_canceling=[]),
              "action_msgs/srv/CancelGoal_Response")

    def result(code: int, msg: str):
        R = T[f"{ACTION}_Result"]
        if distro == "humble":
            return R(result=T["std_msgs/msg/Empty"]())
        return R(error_code=code, error_msg=msg)

    def on_cmd(sample: zenoh.Sample) -> None:
        try:
            m = store.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/TwistStamped")
        except Exception as e:
            print(f"action server: unreadable command ({e})", file=sys.stderr, flush=True)
            return
        v, w = m.twist.linear.x, m.twist.angular.z
        if state["cmds"] < 50 and state["goal_pose"] is not None:  # the controller may subscribe late
            goal_pub.publish(header=state["goal_pose"].header, pose=state["goal_pose"].pose)
        with lock:
            if state["goal_id"] is None or state["done"] is not None:
                return
            state["cmds"] += 1
            if abs(v) > 1e-3 or abs(w) > 1e-3:
                state["moved"], state["still"] = True, 0
            elif state["moved"]:
                state["still"] += 1
            if args.outcome == "aborted" and state["cmds"] >= 5:
                state["done"] = (6, result(9003, args.message))
            elif args.outcome == "succeeded" and state["still"] >= 3:
                state["done"] = (4, result(0, ""))
        finish()

    for what, srv, cb in (("send_goal", f"{ACTION}_SendGoal", on_send_goal),
                          ("get_result", f"{ACTION}_GetResult", on_get_result),
                          ("cancel_goal", "action_msgs/srv/CancelGoal", on_cancel)):
        service = f"{base}/{what}"
        keep.append(session.declare_queryable(action.service_key(domain, service, srv, distro), cb))
        keep.append(session.liveliness().declare_token(
            f"{rmw.ADMIN_SPACE}/{domain}/{zid}/0/{len(keep)}/SS/%/%/bt_navigator/{rmw.mangle(service)}/"
            f"{rmw.dds_type_name(srv)}/{action.service_type_hash(srv, distro)}/{rmw.Qos().keyexpr()}"))
    keep.append(session.declare_subscriber(f"{domain}/cmd_vel/geometry_msgs::msg::dds_::TwistStamped_/*", on_cmd))
    child = subprocess.Popen([sys.executable, str(HERE / "ros2_stack.py")], stdin=subprocess.DEVNULL)
    print("test action server up", flush=True)
    try:
        child.wait()
    finally:
        goal_pub.close()
        for k in keep:
            k.undeclare()
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
