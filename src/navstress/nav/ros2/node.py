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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import zenoh
import zenoh.ext

from navstress.nav.ros2 import rmw

__all__ = ["Endpoint", "Node", "Publisher", "Sample", "session_config"]


def session_config(router: str) -> zenoh.Config:
    """rmw_zenoh's session configuration, bound to loopback: a peer that connects to ``router``,
    listens on 127.0.0.1 only (for the stack's direct connection), multicast scouting off."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{router}"]')
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "true")
    conf.insert_json5("timestamping/enabled", '{"router": true, "peer": true, "client": true}')
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
    """One endpoint of the ROS graph, from its liveliness token."""

    kind: str  # MP, MS, SS, SC
    node: str
    topic: str
    ros_type: str
    type_hash: str


def _demangle(chunk: str) -> str:
    return chunk.replace("%", "/")


class Publisher:
    """A ROS 2 publisher: ``publish(message, stamp_ns)`` serialises to CDR and attaches
    (sequence, stamp, GID)."""

    def __init__(self, node: Node, topic: str, ros_type: str, qos: rmw.Qos, entity_id: int) -> None:
        self.topic, self.ros_type, self.qos = topic, ros_type, qos
        self._store = node.store
        self.key = rmw.topic_key(node.domain_id, topic, ros_type, node.distro)
        self.gid = node.gid(entity_id)
        self._seq = 0
        s = node.session
        if qos.durability == "transient_local":
            self._pub: Any = zenoh.ext.declare_advanced_publisher(
                s, self.key, cache=zenoh.ext.CacheConfig(max_samples=qos.depth), publisher_detection=True)
        else:
            self._pub = s.declare_publisher(self.key)
        self._token = s.liveliness().declare_token(rmw.endpoint_token(
            node.domain_id, node.zid, node.node_id, entity_id, "MP", namespace=node.namespace, node=node.name,
            topic=topic, ros_type=ros_type, distro=node.distro, qos=qos))

    def matched(self) -> bool:
        """Whether a subscriber's declaration has reached this publisher (its samples are routed
        to someone now); True when Zenoh cannot tell (an advanced publisher)."""
        return bool(getattr(self._pub, "matching_status", True))

    def publish(self, message: Any, stamp_ns: int) -> None:
        self._seq += 1
        data = bytes(self._store.serialize_cdr(message, self.ros_type))
        att = rmw.Attachment(self._seq, int(stamp_ns), self.gid).to_bytes()
        self._pub.put(data, encoding=zenoh.Encoding("application/cdr"), attachment=att)

    def close(self) -> None:
        for x in (self._token, self._pub):
            with contextlib.suppress(Exception):
                x.undeclare()


class Node:
    """A node named ``name`` in ``namespace`` on ``domain_id``, joined to the router at ``router``.

    ``seed`` makes the GIDs (16 bytes each, from the run seed and the entity id): two runs with the
    same seed put the same bytes on the wire."""

    def __init__(self, *, router: str, domain_id: int, distro: str, namespace: str, name: str, seed: int) -> None:
        self.domain_id, self.distro, self.namespace, self.name = domain_id, distro, namespace, name
        self.store = rmw.typestore(distro)
        self._seed = int(seed)
        self._lock = threading.Lock()
        self._graph: dict[str, Endpoint | None] = {}
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
        return hashlib.blake2b(f"navstress-gid/{self._seed}/{entity_id}".encode(), digest_size=16).digest()

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
        or with ``error`` set (another type, a payload that is not CDR of its type)."""
        store = self.store
        wanted = {rmw.dds_type_name(t): t for t in ros_types}
        lv = self.session.liveliness()
        for t in ros_types:
            self._closers.append(lv.declare_token(rmw.endpoint_token(
                self.domain_id, self.zid, self.node_id, self._entity(), "MS", namespace=self.namespace,
                node=self.name, topic=topic, ros_type=t, distro=self.distro, qos=qos)))
        base = f"{self.domain_id}/{topic.strip('/')}"
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

        self._closers.append(self.session.declare_subscriber(f"{base}/*/*", on_sample))

    # ------------------------------------------------------------------ the graph
    def _on_token(self, s: zenoh.Sample) -> None:
        key = str(s.key_expr)
        parts = key.split("/")
        ep = None
        if len(parts) >= 13 and parts[5] in ("MP", "MS", "SS", "SC"):
            ep = Endpoint(parts[5], _demangle(parts[8]), _demangle(parts[9]), rmw.ros_type_name(parts[10])
                          if parts[10].count("::") == 3 else parts[10], parts[11])
        with self._lock:
            if s.kind == zenoh.SampleKind.DELETE:
                self._graph.pop(key, None)
            else:
                self._graph[key] = ep
            self._graph_changed.notify_all()

    def graph(self) -> list[Endpoint]:
        """The endpoints other nodes (and this one) have declared, as their tokens show them."""
        with self._lock:
            return [e for e in self._graph.values() if e is not None]

    def wait_for(self, pred: Callable[[list[Endpoint]], bool], timeout_s: float) -> bool:
        """Wait (wall clock) until ``pred(graph)`` holds; whether it did."""
        with self._lock:
            return self._graph_changed.wait_for(
                lambda: pred([e for e in self._graph.values() if e is not None]), timeout_s)

    def close(self) -> None:
        for x in reversed(self._closers):
            with contextlib.suppress(Exception):
                x.close() if isinstance(x, Publisher) else x.undeclare()
        self._closers.clear()
        with contextlib.suppress(Exception):
            self.session.close()  # type: ignore[no-untyped-call]
