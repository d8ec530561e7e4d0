"""A ROS 2 node over Zenoh, as rmw_zenoh makes one: a Zenoh peer session connected to the
router, a node liveliness token, and publishers and subscriptions whose key expressions, tokens,
attachments and CDR payloads follow :mod:`navstress.nav.ros2.rmw`.

A subscription callback runs on Zenoh's threads: it decodes the sample and hands it over; the
navigator's thread waits on a condition. ``graph()`` is the ROS graph as the liveliness tokens
show it (what ``ros2 topic list -t`` would print on the stack's side).
"""

from __future__ import annotations

import contextlib
import hashlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import zenoh
import zenoh.ext

from navstress.nav.ros2 import rmw

__all__ = ["Endpoint", "Node", "NodeName", "Publisher", "Sample", "session_config"]

#: rmw_zenoh's heartbeat period for a reliable transient-local publisher's sample miss detection
#: (``SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD`` 500 ms, ``rmw_publisher_data.cpp``), in seconds
SAMPLE_MISS_DETECTION_HEARTBEAT_S = 0.5


def session_config(router: str) -> zenoh.Config:
    """rmw_zenoh's session configuration (its ``config/DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5``,
    the "ROS setting" entries), bound to loopback: a peer that connects to ``router`` (retrying
    without end), listens on 127.0.0.1 only (for the stack's direct connection), multicast scouting
    off, gossip sent to the router only and peers met through it auto-connected (the one of greater
    zid connects), every sample timestamped (the advanced publisher's cache needs it), queries
    answered within 60 s."""
    conf = zenoh.Config()
    for key, value in (
            ("mode", '"peer"'),
            ("connect/endpoints", f'["{router}"]'),
            ("connect/timeout_ms", "{router: -1, peer: -1, client: 0}"),
            ("listen/endpoints", '["tcp/127.0.0.1:0"]'),
            ("scouting/multicast/enabled", "false"),
            ("scouting/gossip/enabled", "true"),
            ("scouting/gossip/multihop", "false"),
            ("scouting/gossip/target", '{router: ["router", "peer"], peer: ["router"]}'),
            ("scouting/gossip/autoconnect", '{router: [], peer: ["router", "peer"]}'),
            ("scouting/gossip/autoconnect_strategy", '{peer: {to_router: "always", to_peer: "greater-zid"}}'),
            ("timestamping/enabled", "{router: true, peer: true, client: true}"),
            ("queries_default_timeout", "60000")):  # routing/peer/mode: Zenoh's default, peer_to_peer
        conf.insert_json5(key, value)
    return conf


@dataclass(frozen=True)
class Sample:
    """A received sample: the topic's type (from its key), its decoded message (None when the
    payload did not decode, with ``error`` saying why) and its attachment (None when absent)."""

    ros_type: str | None
    message: Any
    attachment: rmw.Attachment | None
    error: str | None = None


@dataclass(frozen=True)
class Endpoint:
    """One endpoint of the ROS graph, from its liveliness token (``Entity::make(keyexpr)``)."""

    kind: str  # MP, MS, SS, SC
    node: str
    topic: str
    ros_type: str
    type_hash: str
    namespace: str = "/"
    qos: str = ""


@dataclass(frozen=True)
class NodeName:
    """A node of the ROS graph, from its ``NN`` token (what ``ros2 node list`` prints:
    :attr:`fqn`)."""

    namespace: str
    name: str
    zid: str

    @property
    def fqn(self) -> str:
        return f"{self.namespace.rstrip('/')}/{self.name}"


class Publisher:
    """A ROS 2 publisher as ``PublisherData::make`` declares one (``rmw_publisher_data.cpp``):
    congestion control DROP, Zenoh reliability from the QoS; transient local: an advanced publisher
    with a cache of ``depth`` samples, publisher detection and, when reliable, sample miss
    detection by a sporadic heartbeat of 500 ms. ``publish`` serialises to CDR and attaches
    (sequence number from 1, the wall clock in ns, the GID)."""

    def __init__(self, node: Node, topic: str, ros_type: str, qos: rmw.Qos, entity_id: int) -> None:
        self.topic, self.ros_type, self.qos = topic, ros_type, qos
        self._store = node.store
        self.key = rmw.topic_key(node.domain_id, topic, ros_type, node.distro)
        self.gid = node.gid(entity_id)
        self._seq = 0
        s = node.session
        reliability = zenoh.Reliability.RELIABLE if qos.reliability == "reliable" else \
            zenoh.Reliability.BEST_EFFORT
        if qos.durability == "transient_local":
            miss = zenoh.ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=SAMPLE_MISS_DETECTION_HEARTBEAT_S) \
                if qos.reliability == "reliable" else None
            self._pub: Any = zenoh.ext.declare_advanced_publisher(
                s, self.key, cache=zenoh.ext.CacheConfig(max_samples=qos.depth or rmw.Qos.DEFAULT_DEPTH),
                publisher_detection=True, sample_miss_detection=miss,
                congestion_control=zenoh.CongestionControl.DROP, reliability=reliability)
        else:
            self._pub = s.declare_publisher(self.key, congestion_control=zenoh.CongestionControl.DROP,
                                            reliability=reliability)
        self._token = s.liveliness().declare_token(rmw.endpoint_token(
            node.domain_id, node.zid, node.node_id, entity_id, "MP", namespace=node.namespace, node=node.name,
            topic=topic, ros_type=ros_type, distro=node.distro, qos=qos))

    def matched(self) -> bool:
        """Whether a subscriber's declaration has reached this publisher (its samples are routed
        to someone now); True when Zenoh cannot tell (an advanced publisher)."""
        return bool(getattr(self._pub, "matching_status", True))

    def publish(self, message: Any, stamp_ns: int | None = None) -> None:
        """Publish ``message``. Its simulated stamp (``stamp_ns``) is in its header where it has one;
        the attachment's source timestamp is the wall clock, as rmw_zenoh's
        (``get_system_time_in_ns``): a receiver's ``message_info.source_timestamp``."""
        del stamp_ns  # kept for callers that pass it; rmw_zenoh never puts simulated time here
        self._seq += 1
        data = bytes(self._store.serialize_cdr(message, self.ros_type))
        att = rmw.Attachment(self._seq, time.time_ns(), self.gid).to_bytes()
        self._pub.put(data, encoding=zenoh.Encoding("application/cdr"), attachment=att)

    def close(self) -> None:
        for x in (self._token, self._pub):
            with contextlib.suppress(Exception):
                x.undeclare()


class Node:
    """A node named ``name`` in ``namespace`` on ``domain_id``, joined to the router at ``router``.

    ``seed`` makes the GIDs (:func:`rmw.gid_size` bytes each, from the run seed and the entity id;
    rmw_zenoh hashes the entity's token, whose zid differs every run): two runs with the same seed
    give their endpoints the same GIDs. Node id 0, entity ids from 1, as rmw_zenoh's context
    counts them."""

    def __init__(self, *, router: str, domain_id: int, distro: str, namespace: str, name: str, seed: int) -> None:
        self.domain_id, self.distro, self.namespace, self.name = domain_id, distro, namespace, name
        self.store = rmw.typestore(distro)
        self._seed = int(seed)
        self._lock = threading.Lock()
        self._graph: dict[str, Endpoint | NodeName | None] = {}
        self._graph_changed = threading.Condition(self._lock)
        self._closers: list[Any] = []
        self.session = zenoh.open(session_config(router))
        self.zid = str(self.session.info.zid())
        self.node_id = 0
        self._next_entity = 1
        lv = self.session.liveliness()
        self._closers.append(lv.declare_token(rmw.node_token(domain_id, self.zid, self.node_id, namespace, name)))
        self._closers.append(lv.declare_subscriber(f"{rmw.ADMIN_SPACE}/{domain_id}/**", self._on_token, history=True))

    # ------------------------------------------------------------------ entities
    def gid(self, entity_id: int) -> bytes:
        """16 bytes from the seed and the entity id (:func:`rmw.gid_size`, Humble included)."""
        return hashlib.blake2b(f"navstress-gid/{self._seed}/{entity_id}".encode(),
                               digest_size=rmw.gid_size(self.distro)).digest()

    def _entity(self) -> int:
        self._next_entity += 1
        return self._next_entity - 1

    def publisher(self, topic: str, ros_type: str, qos: rmw.Qos) -> Publisher:
        pub = Publisher(self, topic, ros_type, qos, self._entity())
        self._closers.append(pub)
        return pub

    def subscription(self, topic: str, ros_types: tuple[str, ...], callback: Callable[[Sample], None],
                     qos: rmw.Qos = rmw.Qos()) -> None:
        """Hear ``topic`` whatever type it is published with: ``callback`` gets each sample, decoded
        when its type is one of ``ros_types`` (a subscription token is declared for each of them),
        or with ``error`` set (another type, a payload that is not CDR of its type). A transient-local
        ``qos`` also hears what publishers sent before it joined (their caches)."""
        store = self.store
        wanted = {rmw.dds_type_name(t): t for t in ros_types}
        base = f"{self.domain_id}/{rmw.strip_slashes(topic)}"
        nbase = len(base.split("/"))

        def on_sample(s: zenoh.Sample) -> None:
            parts = str(s.key_expr).split("/")
            dds = parts[nbase] if len(parts) == nbase + 2 else ""
            att = None
            if s.attachment is not None:
                with contextlib.suppress(ValueError):
                    att = rmw.Attachment.from_bytes(s.attachment.to_bytes())
            ros = wanted.get(dds)
            if ros is None:
                try:
                    other: str | None = rmw.ros_type_name(dds)
                except ValueError:
                    other = None
                callback(Sample(other, None, att, f"a sample of type {other or dds or '?'}, not "
                                f"{' or '.join(ros_types)}"))
                return
            try:
                msg = store.deserialize_cdr(s.payload.to_bytes(), ros)
            except Exception as e:  # a payload that is not CDR of its type: the stack's fault, reported
                callback(Sample(ros, None, att, f"a payload that is not a CDR {ros} ({type(e).__name__}: {e})"))
                return
            callback(Sample(ros, msg, att))

        key = f"{base}/*/*"
        if qos.durability == "transient_local":
            # as SubscriptionData::init (rmw_subscription_data.cpp): an advanced subscriber that
            # detects late publishers and asks their caches for ``depth`` samples, recovers missed
            # samples by the publisher's heartbeat when reliable, and can be detected
            recovery = zenoh.ext.RecoveryConfig(periodic_queries=None, heartbeat=True) \
                if qos.reliability == "reliable" else None
            self._closers.append(zenoh.ext.declare_advanced_subscriber(
                self.session, key, on_sample, subscriber_detection=True, recovery=recovery,
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True,
                                                max_samples=qos.depth or rmw.Qos.DEFAULT_DEPTH)))
        else:
            self._closers.append(self.session.declare_subscriber(key, on_sample))
        # the tokens after the subscriber, as SubscriptionData::init: a stack that sees them can
        # publish at once without a sample lost
        lv = self.session.liveliness()
        for t in ros_types:
            self._closers.append(lv.declare_token(rmw.endpoint_token(
                self.domain_id, self.zid, self.node_id, self._entity(), "MS", namespace=self.namespace,
                node=self.name, topic=topic, ros_type=t, distro=self.distro, qos=qos)))

    # ------------------------------------------------------------------ the graph
    def _on_token(self, s: zenoh.Sample) -> None:
        key = str(s.key_expr)
        ep = _parse_token(key)
        with self._lock:
            if s.kind == zenoh.SampleKind.DELETE:
                self._graph.pop(key, None)
            else:
                self._graph[key] = ep
            self._graph_changed.notify_all()

    def graph(self) -> list[Endpoint]:
        """The endpoints other nodes (and this one) have declared, as their tokens show them."""
        with self._lock:
            return [e for e in self._graph.values() if isinstance(e, Endpoint)]

    def nodes(self) -> list[NodeName]:
        """The nodes of the graph (``ros2 node list``), this one included."""
        with self._lock:
            return [e for e in self._graph.values() if isinstance(e, NodeName)]

    def wait_for(self, pred: Callable[[list[Endpoint]], bool], timeout_s: float) -> bool:
        """Wait (wall clock) until ``pred(graph)`` holds; whether it did."""
        with self._lock:
            return self._graph_changed.wait_for(
                lambda: pred([e for e in self._graph.values() if isinstance(e, Endpoint)]), timeout_s)

    def close(self) -> None:
        for x in reversed(self._closers):
            with contextlib.suppress(Exception):
                x.close() if isinstance(x, Publisher) else x.undeclare()
        self._closers.clear()
        with contextlib.suppress(Exception):
            self.session.close()  # type: ignore[no-untyped-call]


def _parse_token(key: str) -> Endpoint | NodeName | None:
    """A liveliness token as rmw_zenoh's ``Entity::make(keyexpr)`` reads it: None for one it would
    refuse (too few chunks, an empty chunk, another admin space or entity kind)."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != rmw.ADMIN_SPACE or not all(parts):
        return None
    if parts[5] == "NN":
        return NodeName(rmw.demangle(parts[7]), rmw.demangle(parts[8]), parts[2])
    if parts[5] not in ("MP", "MS", "SS", "SC") or len(parts) < 13:
        return None
    try:
        ros_type = rmw.ros_type_name(rmw.demangle(parts[10]))
    except ValueError:
        ros_type = rmw.demangle(parts[10])
    return Endpoint(parts[5], rmw.demangle(parts[8]), rmw.demangle(parts[9]), ros_type,
                    rmw.demangle(parts[11]), rmw.demangle(parts[7]), parts[12])
