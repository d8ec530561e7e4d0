"""navstress's node in the ROS graph, seen by an implementation that is not ours: a real router
(navstress.nav.ros2.router.start_router, 127.0.0.1), navstress Nodes with publishers and
subscriptions, and zenoh-ros2-sdk's discovery (what its ``zenoh-ros2 topic list -t`` / ``topic info -v``
print; run in a process of its own) listing the topics with their types, nodes and QoS; the
node list (``ros2 node list``) from the NN tokens; a late subscriber of a transient-local topic
gets the cached sample with an attachment rmw_zenoh's reader accepts. Every process is stopped."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh
import zenoh.ext as zx

from navstress.nav.ros2 import rmw
from navstress.nav.ros2.node import Node, session_config
from navstress.nav.ros2.router import Router, start_router

PUBS = {"/clock": "rosgraph_msgs/msg/Clock", "/odom": "nav_msgs/msg/Odometry", "/scan": "sensor_msgs/msg/LaserScan",
        "/tf": "tf2_msgs/msg/TFMessage", "/robot/map": "nav_msgs/msg/OccupancyGrid"}
SUBS = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")


@pytest.fixture(scope="module")
def router() -> Iterator[Router]:
    r = start_router()
    try:
        yield r
    finally:
        r.stop()
        assert r.proc.poll() is not None, "the router outlived its test"


#: the SDK's discovery (what its ``zenoh-ros2 topic list -t`` / ``topic info -v`` print) in a
#: process of its own; its session is given a second to join the router and meet the peers the
#: router introduces before the one-shot liveliness queries (run at once, as the CLI does, a query
#: can go out while the fresh session's links are still being set up and come back partial)
SDK_DISCOVERY = """
import json, sys, time
from zenoh_ros2_sdk.discovery import get_topic_info, get_topic_names_and_types
from zenoh_ros2_sdk.session import ZenohSession
port, domain, want, topics = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
sess = ZenohSession.get_instance("127.0.0.1", port)


def row(e):
    return {k: getattr(e, k) for k in ("node_name", "node_namespace", "topic_type", "type_hash", "qos")}


try:
    time.sleep(1.0)
    kw = dict(domain_id=domain, router_ip="127.0.0.1", router_port=port, timeout=1.0)
    deadline = time.monotonic() + 20.0
    while True:  # a one-shot query may still come back partial (a loaded machine): ask again, as a user would
        out = {"list": get_topic_names_and_types(**kw), "info": {}}
        for t in topics:
            info = get_topic_info(t, verbose=True, **kw)
            out["info"][t] = None if info is None else {
                "pubs": [row(e) for e in info.publishers], "subs": [row(e) for e in info.subscribers]}
        if (len(out["list"]) >= want and all(out["info"].values())) or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    print(json.dumps(out))
finally:
    sess.session.close()
"""


def _sdk(router: Router, domain: int, want: int, *topics: str) -> dict[str, Any]:
    """The SDK's topic list with types and the verbose info of ``topics`` (loopback only)."""
    port = router.endpoint.rsplit(":", 1)[1]
    env = dict(os.environ, ZENOH_CONFIG_OVERRIDE='listen/endpoints=["tcp/127.0.0.1:0"];'
               'scouting/multicast/enabled=false')
    proc = subprocess.run([sys.executable, "-c", SDK_DISCOVERY, port, str(domain), str(want), *topics], capture_output=True,
                          text=True, timeout=60, env=env, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return dict(json.loads(proc.stdout.strip().splitlines()[-1]))


@pytest.mark.parametrize("distro", ["jazzy", "humble"])
def test_the_sdk_lists_navstress_topics_types_and_nodes(router: Router, distro: str) -> None:
    domain = 11 if distro == "jazzy" else 12
    node = Node(router=router.endpoint, domain_id=domain, distro=distro, namespace="/", name="navstress", seed=3)
    other = Node(router=router.endpoint, domain_id=domain, distro=distro, namespace="/sim", name="watcher", seed=4)
    stray = Node(router=router.endpoint, domain_id=domain + 100, distro=distro, namespace="/", name="elsewhere",
                 seed=5)
    try:
        for topic, typ in PUBS.items():
            node.publisher(topic, typ, rmw.Qos(durability="transient_local", depth=1) if topic.endswith("map")
                           else rmw.Qos(reliability="best_effort", depth=5) if topic == "/scan" else rmw.Qos())
        node.subscription("/cmd_vel", SUBS, lambda s: None)
        stray.publisher("/stray", "std_msgs/msg/String", rmw.Qos())
        # the node list (ros2 node list) and the topic graph, as another node sees them
        assert other.wait_for(lambda g: len({(e.kind, e.topic, e.ros_type) for e in g}) >= len(PUBS) + 2, 10.0)
        names = {n.fqn for n in other.nodes()}
        assert names == {"/navstress", "/sim/watcher"}, names  # not the node of another domain
        mine = {(e.kind, e.topic, e.ros_type, e.type_hash, e.qos) for e in other.graph()}
        for topic, typ in PUBS.items():
            q = [x for x in mine if x[:3] == ("MP", topic, typ)]
            assert len(q) == 1 and q[0][3] == rmw.type_hash(typ, distro)
        assert {x[2] for x in mine if x[:2] == ("MS", "/cmd_vel")} == set(SUBS)

        # the SDK's ros2 topic list -t: every topic with its type(s), nothing of the other domain
        seen = _sdk(router, domain, len(PUBS) + 1, "/robot/map", "/cmd_vel")
        listed = {name: sorted(types) for name, types in seen["list"]}
        assert listed == {**{t: [typ] for t, typ in PUBS.items()}, "/cmd_vel": sorted(SUBS)}, listed

        # ros2 topic info -v: the node, its namespace, the hash and the QoS text per endpoint
        (pub,) = seen["info"]["/robot/map"]["pubs"]
        assert (pub["node_name"], pub["node_namespace"], pub["topic_type"], pub["type_hash"], pub["qos"]) == \
            ("navstress", "/", "nav_msgs/msg/OccupancyGrid", rmw.type_hash("nav_msgs/msg/OccupancyGrid", distro),
             ":1:,1:,:,:,,")
        subs = seen["info"]["/cmd_vel"]["subs"]
        assert sorted((s["node_name"], s["topic_type"]) for s in subs) == [("navstress", t) for t in SUBS]
        # gone when closed: rmw_zenoh's graph drops undeclared tokens
        node.close()
        assert other.wait_for(lambda g: not any(e.node == "navstress" for e in g), 10.0)
        assert {n.fqn for n in other.nodes()} == {"/sim/watcher"}
    finally:
        for n in (node, other, stray):
            n.close()


@pytest.mark.parametrize("distro", ["jazzy", "humble"])
def test_late_subscriber_gets_transient_local_sample_with_rmw_attachment(router: Router, distro: str) -> None:
    """A transient-local publisher is an advanced publisher with a cache (PublisherData::make): a
    subscriber that joins after the sample was published gets it (as rmw_zenoh's transient-local
    subscription, an advanced subscriber with history and late-publisher detection, does), with
    an attachment of sequence 1, a wall-clock timestamp and a 16-byte GID (Humble too)."""
    domain = 21 if distro == "jazzy" else 22
    node = Node(router=router.endpoint, domain_id=domain, distro=distro, namespace="/", name="navstress", seed=9)
    typ = "std_msgs/msg/String"
    got: list[zenoh.Sample] = []
    session = None
    try:
        pub = node.publisher("/latched", typ, rmw.Qos(durability="transient_local", depth=1))
        msg = node.store.types[typ](data="hello")
        before = time.time_ns()
        pub.publish(msg, 0)
        after = time.time_ns()
        time.sleep(0.2)
        session = zenoh.open(session_config(router.endpoint))
        sub = zx.declare_advanced_subscriber(
            session, rmw.topic_key(domain, "/latched", typ, distro), got.append,
            history=zx.HistoryConfig(detect_late_publishers=True, max_samples=1))
        deadline = time.monotonic() + 10.0
        while not got and time.monotonic() < deadline:
            time.sleep(0.02)
        assert got, "the late subscriber did not get the cached sample"
        s = got[0]
        assert node.store.deserialize_cdr(s.payload.to_bytes(), typ).data == "hello"
        assert s.attachment is not None
        att = rmw.Attachment.from_bytes(s.attachment.to_bytes())
        seq, ts, gid = zx.z_deserialize(tuple[zx.Int64, zx.Int64, list[zx.UInt8]], s.attachment)  # type: ignore[misc]
        assert (int(seq), int(ts), bytes(int(b) for b in gid)) == (att.sequence, att.timestamp_ns, att.gid)
        assert att.sequence == 1 and before <= att.timestamp_ns <= after
        assert len(att.gid) == 16 and att.gid == node.gid(1)  # Humble too (ros2/rmw_zenoh#388)
        sub.undeclare()
    finally:
        node.close()
        if session is not None:
            session.close()  # type: ignore[no-untyped-call]


@pytest.mark.parametrize("reliability", ["reliable", "best_effort"])
def test_transient_local_subscription_hears_what_was_published_before(router: Router, reliability: str) -> None:
    """A navstress transient-local subscription (SubscriptionData::init's advanced subscriber)
    gets the last ``depth`` samples a transient-local publisher cached before it joined."""
    domain = 31 if reliability == "reliable" else 32
    qos = rmw.Qos(reliability, "transient_local", 2)  # type: ignore[arg-type]
    pub_node = Node(router=router.endpoint, domain_id=domain, distro="jazzy", namespace="/", name="pub", seed=1)
    sub_node = Node(router=router.endpoint, domain_id=domain, distro="jazzy", namespace="/", name="sub", seed=2)
    typ = "std_msgs/msg/String"
    heard: list[str] = []
    try:
        pub = pub_node.publisher("/status", typ, qos)
        for text in ("one", "two", "three"):
            pub.publish(pub_node.store.types[typ](data=text))
        time.sleep(0.2)
        sub_node.subscription("/status", (typ,), lambda s: heard.append(s.message.data), qos)
        deadline = time.monotonic() + 10.0
        while len(heard) < 2 and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.2)
        assert heard == ["two", "three"]  # the cache keeps depth (2) samples
        pub.publish(pub_node.store.types[typ](data="four"))
        deadline = time.monotonic() + 10.0
        while len(heard) < 3 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert heard == ["two", "three", "four"]
    finally:
        sub_node.close()
        pub_node.close()


def test_router_process_is_gone_after_stop() -> None:
    r = start_router()
    assert r.alive and r.endpoint.startswith("tcp/127.0.0.1:")
    r.stop()
    assert r.proc.poll() is not None and not r.alive
    r.stop()  # idempotent
