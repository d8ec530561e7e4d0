"""A small ROS 2 navigation stack written on zenoh-ros2-sdk (an implementation of rmw_zenoh's
conventions that is not navstress's): the test stack of docs/ros2.md.

It subscribes to ``/clock``, ``/odom``, ``/tf``, ``/scan`` and ``/goal_pose``, and
publishes a command on ``/cmd_vel`` for each control cycle (a ``TwistStamped`` stamped with the cycle's ``/clock``, or a
``Twist`` with ``--twist``): a go-to-goal controller that turns away from returns closer than
``--clear`` meters ahead. It reads the router from ``NAVSTRESS_ZENOH_ROUTER`` (``tcp/HOST:PORT``)
and the domain from ``ROS_DOMAIN_ID``, as a stack launched by navstress gets them.

    python tests/support/ros2_stack.py [--twist] [--speed 0.8] [--mode silent|garbage|wrongtype|crash]
                                       [--lifecycle tf|never]

``--mode`` makes the faulty stacks of the fault tests: ``silent`` never publishes a command,
``garbage`` publishes bytes that are not CDR on the Twist key, ``wrongtype`` publishes
``std_msgs/String`` on ``/cmd_vel``, ``crash`` exits after its first command.
``--lifecycle tf|never`` makes it a lifecycle node as Nav2's BT navigator is: it serves
``/test_stack/get_state`` (``inactive`` or ``active``) and drops goals while inactive; ``tf``
activates it at its first ``/tf`` (a Nav2 costmap activates once ``map -> base_link`` exists).

The SDK would fetch message definitions from the network; here they are written from rosbags'
typestore into a temporary directory first (:func:`write_msg_files`).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import queue
import sys
import tempfile
import threading
import time
from pathlib import Path

TYPES = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/PoseStamped",
         "nav_msgs/msg/Odometry", "sensor_msgs/msg/LaserScan", "tf2_msgs/msg/TFMessage", "std_msgs/msg/String",
         "rosgraph_msgs/msg/Clock", "lifecycle_msgs/msg/State")


def _field_text(t: tuple) -> str:
    kind, spec = t
    name = getattr(kind, "name", str(kind))
    if name == "BASE":
        base = spec[0]
        return "string" if base == "string" else base
    if name == "NAME":
        return spec.replace("/msg/", "/")
    if name == "SEQUENCE":
        return _field_text(spec[0]) + "[]"
    if name == "ARRAY":
        return _field_text(spec[0]) + f"[{spec[1]}]"
    raise ValueError(f"unknown field {t!r}")


def write_msg_files(root: Path, types: tuple[str, ...] = TYPES) -> Path:
    """``<root>/<pkg>/msg/<Name>.msg`` for ``types`` and every type they use."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    todo, done = list(types), set()
    while todo:
        t = todo.pop()
        if t in done:
            continue
        done.add(t)
        consts, fields = ts.fielddefs[t]
        lines = [f"{ct} {cn}={cv}" for cn, ct, cv in consts]
        for fname, ftype in fields:
            lines.append(f"{_field_text(ftype)} {fname}")
            k, spec = ftype
            inner = spec[0] if getattr(k, "name", "") in ("SEQUENCE", "ARRAY") else (k, spec)
            if getattr(inner[0], "name", "") == "NAME":
                todo.append(inner[1])
        pkg, _, name = t.split("/")
        p = root / pkg / "msg" / f"{name}.msg"
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("\n".join(lines) + "\n")
    return root


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--twist", action="store_true", help="publish Twist, not TwistStamped")
    ap.add_argument("--speed", type=float, default=0.8)
    ap.add_argument("--clear", type=float, default=0.6)
    ap.add_argument("--mode", default="normal", choices=("normal", "silent", "garbage", "wrongtype", "crash"))
    ap.add_argument("--lifecycle", default=None, choices=("tf", "never"),
                    help="a lifecycle node as Nav2's BT navigator is: inactive, dropping goals, until "
                         "'tf': a /tf has come (a costmap's activation), or 'never'")
    args = ap.parse_args()
    router = os.environ["NAVSTRESS_ZENOH_ROUTER"]
    host, port = router.split("/", 1)[1].rsplit(":", 1)
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    msgdir = write_msg_files(Path(tempfile.mkdtemp(prefix="ros2-stack-msgs-")))

    import zenoh
    from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber, get_message_class
    from zenoh_ros2_sdk.message_registry import get_registry

    get_registry(str(msgdir))  # the registry reads these, never the network
    common = dict(router_ip=host, router_port=int(port), domain_id=domain, node_name="test_stack")
    lock = threading.Lock()
    state: dict = {"active": False, "goal": None, "map_odom": (0.0, 0.0, 0.0), "front": math.inf, "sent": 0}
    out_type = "geometry_msgs/msg/Twist" if args.twist else "geometry_msgs/msg/TwistStamped"
    if args.mode == "wrongtype":
        pub = ROS2Publisher(topic="/cmd_vel", msg_type="std_msgs/msg/String", **common)
    else:
        pub = ROS2Publisher(topic="/cmd_vel", msg_type=out_type, **common)

    # navstress publishes, each control cycle of time t: /clock at t, one /tf stamped t (odom ->
    # base_link, and map -> odom once the pose sensor has spoken), the sensors, and the odometry
    # (stamped at its reading, at most t). Zenoh may hand different subscriptions' samples over in
    # any order, so the stack gathers a cycle's clock, /tf and odometry (the first clock at or
    # after the odometry's stamp) and computes the cycle's command once all three are in: the
    # same inputs give the same command, whatever the order they came in (lockstep replays).
    clocks: dict = {}  # clock ns -> the clock message
    tfs: dict = {}  # stamp ns -> map -> odom in that /tf (or None)
    odoms: list = []

    def _ns(t) -> int:
        return t.sec * 1_000_000_000 + t.nanosec

    def ready() -> tuple | None:
        while odoms and clocks:
            s_odom = _ns(odoms[0].header.stamp)
            at = min((c for c in clocks if c >= s_odom), default=None)
            if at is None:
                return None
            if at not in tfs:
                return None
            for c in [c for c in clocks if c < at]:
                clocks.pop(c)
            for c in [c for c in tfs if c < at]:
                tfs.pop(c)
            mo = tfs.pop(at)
            if mo is not None:
                state["map_odom"] = mo
            return clocks.pop(at), odoms.pop(0)
        return None

    def on_clock(m) -> None:
        with lock:
            clocks[_ns(m.clock)] = m.clock
            p = ready()
        if p is not None:
            guarded(*p)

    def on_odom(m) -> None:
        with lock:
            odoms.append(m)
            p = ready()
        if p is not None:
            guarded(*p)

    def on_tf(m) -> None:
        if args.lifecycle == "tf" and not state["active"]:
            state["active"] = True
            print("test stack active", flush=True)
        mo = None
        stamp = None
        for tr in m.transforms:
            stamp = _ns(tr.header.stamp)
            if tr.header.frame_id == "map" and tr.child_frame_id == "odom":
                mo = (tr.transform.translation.x, tr.transform.translation.y, _yaw(tr.transform.rotation))
        if stamp is None:
            return
        with lock:
            tfs[stamp] = mo
            p = ready()
        if p is not None:
            guarded(*p)

    def on_goal(m) -> None:
        if args.lifecycle and not state["active"]:  # Nav2: "Action server is inactive. Rejecting the goal."
            print("test stack inactive: goal dropped", flush=True)
            return
        with lock:
            state["goal"] = (m.pose.position.x, m.pose.position.y)

    def on_scan(m) -> None:
        n = len(m.ranges)
        front = math.inf
        for i in range(n):
            a = m.angle_min + i * m.angle_increment
            if abs(a) < 0.5 and m.ranges[i] < front:
                front = float(m.ranges[i])
        with lock:
            state["front"] = front

    def guarded(clock, m) -> None:
        try:
            control(clock, m)
        except Exception:  # shown on stderr (the SDK would swallow it), which navstress reports
            import traceback

            traceback.print_exc()

    def control(clock, m) -> None:
        with lock:
            goal, (mx, my, myaw), front = state["goal"], state["map_odom"], state["front"]
        if args.mode == "silent":
            return
        if args.mode == "garbage":
            pub.pub.put(b"\x01\x02not cdr", attachment=pub._create_attachment(0, 0))
            return
        if args.mode == "wrongtype":
            pub.publish(data="forward")
            return
        ox, oy, oyaw = m.pose.pose.position.x, m.pose.pose.position.y, _yaw(m.pose.pose.orientation)
        c, s = math.cos(myaw), math.sin(myaw)
        x, y, yaw = mx + c * ox - s * oy, my + s * ox + c * oy, myaw + oyaw
        v = w = 0.0
        if goal is not None:
            d = math.hypot(goal[0] - x, goal[1] - y)
            err = math.atan2(goal[1] - y, goal[0] - x) - yaw
            err = math.atan2(math.sin(err), math.cos(err))
            w = max(-1.5, min(1.5, 2.0 * err))
            v = min(args.speed, d) * max(0.0, math.cos(err))
            if d < 0.2:  # there: hold still (navstress's sign of arrival by topic)
                v = w = 0.0
            if front < args.clear:
                v, w = 0.0, 1.0
        lin = dict(x=v, y=0.0, z=0.0)
        ang = dict(x=0.0, y=0.0, z=w)
        from zenoh_ros2_sdk import get_message_class

        V = get_message_class("geometry_msgs/msg/Vector3")
        T = get_message_class("geometry_msgs/msg/Twist")
        tw = T(linear=V(**lin), angular=V(**ang))
        if args.twist:
            pub.publish(linear=tw.linear, angular=tw.angular)
        else:
            # stamped with the node's clock (the simulated /clock, as use_sim_time gives a ROS node)
            H = get_message_class("std_msgs/msg/Header")
            pub.publish(header=H(stamp=clock, frame_id="base_link"), twist=tw)
        state["sent"] += 1
        if args.mode == "crash" and state["sent"] >= 3:
            os._exit(3)

    if args.lifecycle:
        # (before the goal's subscription, as a lifecycle node has it from its construction)
        # rclcpp_lifecycle's get_state service, served by the SDK (which computes the service's
        # type hash itself): State 2 'inactive' until active, then 3 'active'
        from zenoh_ros2_sdk import ROS2ServiceServer

        srv = msgdir / "lifecycle_msgs" / "srv" / "GetState.srv"  # (the SDK would fetch it from the network)
        srv.parent.mkdir(parents=True, exist_ok=True)
        srv.write_text("---\nlifecycle_msgs/State current_state\n")

        def get_state(_req):
            S = get_message_class("lifecycle_msgs/msg/State")
            R = keep_srv.response_msg_class
            return R(current_state=S(id=3, label="active") if state["active"] else S(id=2, label="inactive"))

        keep_srv = ROS2ServiceServer(  # noqa: F841 (kept alive with the process)
            service_name="/test_stack/get_state", srv_type="lifecycle_msgs/srv/GetState", callback=get_state,
            request_definition="uint8 structure_needs_at_least_one_member\n",
            response_definition="lifecycle_msgs/State current_state\n", router_ip=host, router_port=int(port),
            domain_id=domain, node_name="test_stack")
    inbox: queue.SimpleQueue = queue.SimpleQueue()

    class Subscriber(ROS2Subscriber):  # type: ignore[misc]
        """The SDK's subscriber with two changes. Its samples are queued by Zenoh's network thread
        (a direct callback) and handled on one thread in that order (``pump``): with the SDK's
        own (zenoh-python's default indirect callback, a Python thread per subscription) the scan
        or the goal could be handled after a cycle's /tf now and then, and the same inputs gave
        another run. Its liveliness tokens are declared after the subscriber itself, as rmw_zenoh
        does (SubscriptionData::init declares the token last): the SDK declares them first, and a
        peer that waits for the token of /goal_pose (navstress) may publish the goal before the
        router routes it here."""

        later = True

        def _declare_liveliness_tokens(self) -> None:
            if not self.later:
                super()._declare_liveliness_tokens()

        def in_order(self) -> None:
            self.sub.undeclare()
            self.sub = self.session_mgr.session.declare_subscriber(
                self.keyexpr, zenoh.handlers.Callback(lambda sample: inbox.put((self, sample)), indirect=False))

    def pump() -> None:
        while True:
            sub, sample = inbox.get()
            sub._process_sample(sample)  # (the SDK's: decodes, calls the callback, logs what raises)

    subs = [Subscriber(topic="/clock", msg_type="rosgraph_msgs/msg/Clock", callback=on_clock, **common),
            Subscriber(topic="/tf", msg_type="tf2_msgs/msg/TFMessage", callback=on_tf, **common),
            Subscriber(topic="/scan", msg_type="sensor_msgs/msg/LaserScan", callback=on_scan, **common),
            Subscriber(topic="/odom", msg_type="nav_msgs/msg/Odometry", callback=on_odom, **common),
            Subscriber(topic="/goal_pose", msg_type="geometry_msgs/msg/PoseStamped", callback=on_goal, **common)]
    # rosbags compiles a type's CDR code at its first message (0.1 s and more on a loaded machine):
    # done before navstress hears of the stack, so that the first cycle's reply is not late
    store = pub.session_mgr.store
    if args.mode == "normal":
        V, T = get_message_class("geometry_msgs/msg/Vector3"), get_message_class("geometry_msgs/msg/Twist")
        tw = T(linear=V(x=0.0, y=0.0, z=0.0), angular=V(x=0.0, y=0.0, z=0.0))
        fields = dict(linear=tw.linear, angular=tw.angular) if args.twist else dict(
            header=get_message_class("std_msgs/msg/Header")(
                stamp=get_message_class("builtin_interfaces/msg/Time")(sec=0, nanosec=0), frame_id="base_link"),
            twist=tw)
        store.serialize_cdr(pub.msg_class(**fields), out_type)
    for s in subs:
        with contextlib.suppress(Exception):  # (the bytes are no message: only the code is wanted)
            store.deserialize_cdr(b"\x00\x01\x00\x00", s.msg_type)
        s.in_order()
    threading.Thread(target=pump, name="stack-inbox", daemon=True).start()
    for s in subs:  # every subscription routed before any is announced; /goal_pose (what navstress waits for) last
        s.later = False
        s._declare_liveliness_tokens()
    print("test stack up", flush=True)
    try:
        while True:
            time.sleep(3600)
    finally:
        for s in subs:
            s.close()
        pub.close()


if __name__ == "__main__":
    sys.exit(main())
