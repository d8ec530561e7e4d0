"""rmw_zenoh's conventions: how a ROS 2 node speaks on Zenoh (docs/ros2.md names the sources).

Everything here is plain text and bytes, no session: the key expression of a topic's data, the
liveliness tokens that make a node and its endpoints visible to ``ros2 node list`` and
``ros2 topic list``, the QoS text inside them, the attachment every sample carries, the type
names and type hashes. The reference is rmw_zenoh's own source (``docs/design.md``,
``src/detail/liveliness_utils.cpp``, ``attachment_helpers.cpp``, ``qos.cpp``).

    >>> topic_key(0, "/cmd_vel", "geometry_msgs/msg/Twist", "jazzy")
    '0/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a'
    >>> topic_key(0, "/cmd_vel", "geometry_msgs/msg/Twist", "humble")
    '0/cmd_vel/geometry_msgs::msg::dds_::Twist_/TypeHashNotSupported'
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass
from typing import Any, Literal

__all__ = ["ADMIN_SPACE", "Attachment", "Qos", "TYPE_HASH_NOT_SUPPORTED", "dds_type_name", "endpoint_token",
           "mangle", "node_token", "ros_type_name", "topic_key", "type_hash", "typestore"]

#: The first chunk of every liveliness token.
ADMIN_SPACE = "@ros2_lv"
#: What Humble's rmw_zenoh writes where later distributions write a type hash.
TYPE_HASH_NOT_SUPPORTED = "TypeHashNotSupported"

EntityKind = Literal["NN", "MP", "MS", "SS", "SC"]


@functools.cache
def typestore(distro: str) -> Any:
    """rosbags' typestore of ``distro``'s standard messages (Kilted and Rolling have Jazzy's
    definitions of every type navstress uses)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE if distro == "humble" else Stores.ROS2_JAZZY)


def dds_type_name(ros_type: str) -> str:
    """``geometry_msgs/msg/Twist`` -> ``geometry_msgs::msg::dds_::Twist_`` (the name rmw_zenoh
    puts in key expressions, as the DDS RMWs name their types)."""
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_type_name(dds: str) -> str:
    """Inverse of :func:`dds_type_name`; ValueError for anything else."""
    parts = dds.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        raise ValueError(f"{dds!r} is not a DDS type name such as 'std_msgs::msg::dds_::String_'")
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


@functools.cache
def type_hash(ros_type: str, distro: str) -> str:
    """The type hash in ``distro``'s key expressions: ``RIHS01_<sha256>`` of the type description
    (REP 2011, computed by rosbags) from Jazzy on, :data:`TYPE_HASH_NOT_SUPPORTED` on Humble."""
    if distro == "humble":
        return TYPE_HASH_NOT_SUPPORTED
    return str(typestore(distro).hash_rihs01(ros_type))


def topic_key(domain_id: int, topic: str, ros_type: str, distro: str) -> str:
    """The key expression of a topic's samples: ``<domain>/<topic without its leading slash>/<DDS
    type>/<type hash>``."""
    return f"{domain_id}/{topic.strip('/')}/{dds_type_name(ros_type)}/{type_hash(ros_type, distro)}"


def mangle(name: str) -> str:
    """A ROS name as one chunk of a liveliness token: every ``/`` becomes ``%`` (an empty name,
    or the root namespace, is ``%``)."""
    return name.replace("/", "%") if name else "%"


@dataclass(frozen=True)
class Qos:
    """A QoS profile as rmw_zenoh writes it in a liveliness token (``qos_to_keyexpr``): each policy
    that differs from rmw_zenoh's default is written, the others left empty."""

    reliability: Literal["reliable", "best_effort"] = "reliable"
    durability: Literal["volatile", "transient_local"] = "volatile"
    depth: int = 10

    #: rmw_zenoh's defaults (``qos.cpp``): reliable, volatile, keep last 42
    DEFAULT_DEPTH = 42

    def keyexpr(self) -> str:
        rel = "" if self.reliability == "reliable" else "2"
        dur = "" if self.durability == "volatile" else "1"
        depth = "" if self.depth == self.DEFAULT_DEPTH else str(self.depth)
        return f"{rel}:{dur}:,{depth}:,:,:,,"


def node_token(domain_id: int, zid: str, node_id: int, namespace: str, node: str) -> str:
    """A node's liveliness token (``NN``)."""
    return f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{node_id}/NN/%/{mangle(namespace)}/{mangle(node)}"


def endpoint_token(domain_id: int, zid: str, node_id: int, entity_id: int, kind: EntityKind, *,
                   namespace: str, node: str, topic: str, ros_type: str, distro: str, qos: Qos) -> str:
    """An endpoint's liveliness token: a publisher (``MP``), subscription (``MS``), service
    server (``SS``) or client (``SC``) of ``node``, with its topic, type, hash and QoS."""
    return (f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{entity_id}/{kind}/%/{mangle(namespace)}/{mangle(node)}/"
            f"{mangle(topic)}/{dds_type_name(ros_type)}/{type_hash(ros_type, distro)}/{qos.keyexpr()}")


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to every sample, request and reply: the sequence number, the source
    timestamp (ns) and the source GID (16 bytes), in Zenoh's serialisation (two little-endian
    int64, then the GID as a sequence: its length as a LEB128 varint, then its bytes)."""

    sequence: int
    timestamp_ns: int
    gid: bytes

    def to_bytes(self) -> bytes:
        if len(self.gid) > 127:
            raise ValueError("a GID longer than 127 bytes")
        return struct.pack("<qqB", self.sequence, self.timestamp_ns, len(self.gid)) + self.gid

    @classmethod
    def from_bytes(cls, data: bytes) -> Attachment:
        """ValueError for bytes that are not an attachment."""
        if len(data) < 17:
            raise ValueError(f"an attachment of {len(data)} bytes, fewer than 17")
        seq, ts, n = struct.unpack_from("<qqB", data)
        if n > 127 or len(data) != 17 + n:
            raise ValueError(f"an attachment of {len(data)} bytes whose GID says {n}")
        return cls(seq, ts, bytes(data[17:]))
