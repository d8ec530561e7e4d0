"""rmw_zenoh's conventions: how a ROS 2 node speaks on Zenoh (docs/ros2.md names the sources).

Everything here is plain text and bytes, no session: the key expression of a topic's data, the
liveliness tokens that make a node and its endpoints visible to ``ros2 node list`` and
``ros2 topic list``, the QoS text inside them, the attachment every sample carries, the type
names and type hashes. The reference is rmw_zenoh's own source, checked against its newest
files (rolling, 2025; paths under ``rmw_zenoh_cpp/src/detail/``):

* ``liveliness_utils.cpp``: ``TopicInfo`` (the data key: domain, the topic with ONE leading and
  ONE trailing slash stripped, the type, the hash), ``Entity`` (the token's 13 chunks: admin
  space, domain, zid as ``zenoh::Id::to_string()``, node id, entity id, NN/MP/MS/SS/SC, enclave,
  namespace, node, topic, type, hash, QoS; names mangled ``/`` -> ``%``), ``qos_to_keyexpr``.
* ``qos.cpp``: the defaults a QoS text leaves empty (keep last 42, reliable, volatile, infinite
  deadline/lifespan/lease, automatic liveliness); a depth of 0 means the default.
* ``attachment_helpers.cpp``: the attachment is ``zenoh::ext::Serializer`` of int64 sequence
  number, int64 source timestamp, ``std::array<uint8_t, RMW_GID_STORAGE_SIZE>`` (a sequence:
  LEB128 length, then the bytes; the reader refuses any other length). The GID is 16 bytes on
  every distribution, Humble included (rmw_zenoh's Humble port hard-codes 16 where Humble's
  ``rmw/types.h`` says 24: ros2/rmw_zenoh#388).
* ``rmw_publisher_data.cpp``: sequence numbers start at 1; the source timestamp is the wall clock
  (``get_system_time_in_ns``); the GID is XXH3-128 of the entity's token (navstress derives its
  GIDs from the run seed instead: 16 opaque bytes to every receiver, see :class:`Attachment`).

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

__all__ = ["ADMIN_SPACE", "Attachment", "Qos", "TYPE_HASH_NOT_SUPPORTED", "dds_type_name", "demangle",
           "endpoint_token", "gid_size", "mangle", "node_token", "ros_type_name", "strip_slashes", "topic_key",
           "type_hash", "typestore"]

#: The first chunk of every liveliness token.
ADMIN_SPACE = "@ros2_lv"
#: What Humble's rmw_zenoh writes where later distributions write a type hash.
TYPE_HASH_NOT_SUPPORTED = "TypeHashNotSupported"

EntityKind = Literal["NN", "MP", "MS", "SS", "SC"]


#: rosbags' store of each distribution's standard messages (Rolling: rosbags' latest)
STORES = {"humble": "ROS2_HUMBLE", "jazzy": "ROS2_JAZZY", "kilted": "ROS2_KILTED", "rolling": "LATEST"}


@functools.cache
def typestore(distro: str) -> Any:
    """rosbags' typestore of ``distro``'s standard messages (:data:`STORES`; every type navstress
    publishes has the same definition, and so the same hash, in Jazzy, Kilted and Rolling:
    tests/unit/nav/ros2/test_rmw.py)."""
    return fresh_typestore(distro)


def fresh_typestore(distro: str) -> Any:
    """A new typestore of ``distro`` (one navstress may change without touching
    :func:`typestore`'s)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(getattr(Stores, STORES[distro]))


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
    (REP 2011, computed by rosbags) from Jazzy on (``rosidl_stringify_type_hash`` in
    ``rmw_publisher_data.cpp``), :data:`TYPE_HASH_NOT_SUPPORTED` on Humble, which has no type
    hashes: rmw_zenoh's Humble port writes that constant string (ros2/rmw_zenoh#388)."""
    if distro == "humble":
        return TYPE_HASH_NOT_SUPPORTED
    return str(typestore(distro).hash_rihs01(ros_type))


def strip_slashes(name: str) -> str:
    """``name`` without ONE leading and ONE trailing ``/`` (``strip_slashes`` of rmw_zenoh's
    ``liveliness_utils.cpp``; a fully qualified topic name has no more)."""
    start = 1 if name.startswith("/") else 0
    end = len(name) - 1 if len(name) > start and name.endswith("/") else len(name)
    return name[start:end]


def topic_key(domain_id: int, topic: str, ros_type: str, distro: str) -> str:
    """The key expression of a topic's samples: ``<domain>/<topic without its leading slash>/<DDS
    type>/<type hash>`` (``TopicInfo::TopicInfo`` in rmw_zenoh's ``liveliness_utils.cpp``)."""
    return f"{domain_id}/{strip_slashes(topic)}/{dds_type_name(ros_type)}/{type_hash(ros_type, distro)}"


def mangle(name: str) -> str:
    """A ROS name as one chunk of a liveliness token: every ``/`` becomes ``%``
    (``mangle_name`` in rmw_zenoh's ``liveliness_utils.cpp``; the root namespace ``/`` is ``%``;
    an empty name, which rcl never gives, is ``%`` too so that no chunk is empty)."""
    return name.replace("/", "%") if name else "%"


def demangle(chunk: str) -> str:
    """Inverse of :func:`mangle` (``demangle_name``)."""
    return chunk.replace("%", "/")


def gid_size(distro: str) -> int:
    """Bytes of a GID in rmw_zenoh's attachment on ``distro``: 16 on every distribution. Humble's
    ``rmw/types.h`` says RMW_GID_STORAGE_SIZE 24, but rmw_zenoh's Humble port hard-codes 16
    (ros2/rmw_zenoh#388, "Updates to compile against Humble"), and its attachment reader refuses
    a GID of any other length."""
    del distro
    return 16


@dataclass(frozen=True)
class Qos:
    """A QoS profile as rmw_zenoh writes it in a liveliness token (``qos_to_keyexpr`` in
    ``liveliness_utils.cpp``): ``REL:DUR:HIST,DEPTH:DL_S,DL_NS:LS_S,LS_NS:LIV,LEASE_S,LEASE_NS``,
    each policy that differs from rmw_zenoh's default (``qos.cpp``) written as its rmw enum value
    (reliable 1, best effort 2; transient local 1, volatile 2), the others left empty. navstress's
    profiles are keep-last with infinite deadline, lifespan and lease, automatic liveliness."""

    reliability: Literal["reliable", "best_effort"] = "reliable"
    durability: Literal["volatile", "transient_local"] = "volatile"
    depth: int = 10

    #: rmw_zenoh's defaults (``qos.cpp``): reliable, volatile, keep last 42
    DEFAULT_DEPTH = 42

    def keyexpr(self) -> str:
        rel = "" if self.reliability == "reliable" else "2"
        dur = "" if self.durability == "volatile" else "1"
        # a depth of 0 is rmw_zenoh's default (QoS::best_available_qos), which is left empty
        depth = "" if self.depth in (0, self.DEFAULT_DEPTH) else str(self.depth)
        return f"{rel}:{dur}:,{depth}:,:,:,,"

    @classmethod
    def from_keyexpr(cls, text: str) -> Qos:
        """The profile in a token's QoS chunk (``keyexpr_to_qos``); ValueError when it is not one
        or holds a policy navstress's profiles cannot express (keep all, a deadline, ...)."""
        parts = text.split(":")
        if len(parts) != 6 or [p.count(",") for p in parts] != [0, 0, 1, 1, 1, 2]:
            raise ValueError(f"{text!r} is not an rmw_zenoh QoS text such as '::,10:,:,:,,'")
        hist, depth = parts[2].split(",")
        if parts[0] not in ("", "1", "2") or parts[1] not in ("", "1", "2") or hist not in ("", "1") \
                or parts[3:] != [",", ",", ",,"] or not (depth == "" or depth.isdigit()):
            raise ValueError(f"QoS {text!r} is not a keep-last profile without deadline, lifespan or lease")
        return cls("best_effort" if parts[0] == "2" else "reliable",
                   "transient_local" if parts[1] == "1" else "volatile",
                   int(depth) if depth and int(depth) else cls.DEFAULT_DEPTH)


def node_token(domain_id: int, zid: str, node_id: int, namespace: str, node: str) -> str:
    """A node's liveliness token (``NN``): ``Entity::Entity`` in ``liveliness_utils.cpp``, the
    node id twice, the enclave (rcl's default ``/``) as ``%``; ``zid`` is the session's id as
    ``str(session.info.zid())`` prints it, the same text as zenoh-cpp's ``Id::to_string()``."""
    return f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{node_id}/NN/%/{mangle(namespace)}/{mangle(node)}"


def endpoint_token(domain_id: int, zid: str, node_id: int, entity_id: int, kind: EntityKind, *,
                   namespace: str, node: str, topic: str, ros_type: str, distro: str, qos: Qos) -> str:
    """An endpoint's liveliness token: a publisher (``MP``), subscription (``MS``), service
    server (``SS``) or client (``SC``) of ``node``, with its topic, type, hash and QoS."""
    return (f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{entity_id}/{kind}/%/{mangle(namespace)}/{mangle(node)}/"
            f"{mangle(topic)}/{dds_type_name(ros_type)}/{type_hash(ros_type, distro)}/{qos.keyexpr()}")


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to every sample, request and reply (``attachment_helpers.cpp``):
    the sequence number, the source timestamp (ns) and the source GID (:func:`gid_size` bytes),
    in Zenoh's serialisation (two little-endian int64, then the GID as a sequence: its length as a
    LEB128 varint, one byte for any GID, then its bytes)."""

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
