"""rmw_zenoh's conventions in navstress.nav.ros2.rmw, cross-checked against an implementation
that is not ours: zenoh-ros2-sdk's own key expression, token, QoS, attachment and type-hash
functions, and Zenoh's own serialiser (what rmw_zenoh's ``zenoh::ext::Serializer`` writes).
Where the SDK departs from rmw_zenoh's source (its QoS text writes the default depth), the test
says so and follows rmw_zenoh (``liveliness_utils.cpp`` ``qos_to_keyexpr``, ``qos.cpp``)."""

from __future__ import annotations

import string
import tempfile
from pathlib import Path

import pytest
import zenoh
import zenoh.ext as zx
from hypothesis import given, settings
from hypothesis import strategies as st
from zenoh_ros2_sdk import keyexpr as sdk_ke
from zenoh_ros2_sdk.attachment import Attachment as SdkAttachment
from zenoh_ros2_sdk.entity import EndpointEntity, EntityKind, NodeEntity
from zenoh_ros2_sdk.message_registry import MessageRegistry
from zenoh_ros2_sdk.qos import QosDurability, QosProfile, QosReliability
from zenoh_ros2_sdk.utils import (dds_to_ros_type, get_type_hash, load_dependencies_recursive, mangle_name,
                                  ros2_to_dds_type)

from navstress.nav.ros2 import rmw
from navstress.nav.ros2.node import Endpoint, NodeName, _parse_token
from tests.support.ros2_stack import write_msg_files

#: every type navstress publishes or hears, and a few more of the standard set
TYPES = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/PoseStamped",
         "nav_msgs/msg/Odometry", "nav_msgs/msg/OccupancyGrid", "sensor_msgs/msg/LaserScan",
         "sensor_msgs/msg/PointCloud2", "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo",
         "sensor_msgs/msg/Imu", "tf2_msgs/msg/TFMessage", "rosgraph_msgs/msg/Clock", "std_msgs/msg/String",
         "std_msgs/msg/Empty", "action_msgs/msg/GoalStatusArray")
DISTROS = ("humble", "jazzy", "kilted", "rolling")

_tok = st.text(string.ascii_letters + "_", min_size=1, max_size=1).flatmap(
    lambda first: st.text(string.ascii_letters + string.digits + "_", max_size=8).map(lambda rest: first + rest))
topics = st.lists(_tok, min_size=1, max_size=4).map(lambda ts: "/" + "/".join(ts))
namespaces = st.one_of(st.just("/"), topics)
node_names = _tok
domains = st.integers(0, 232)
zids = st.binary(min_size=16, max_size=16).map(lambda b: b.hex().lstrip("0") or "1")
qoses = st.builds(rmw.Qos, st.sampled_from(["reliable", "best_effort"]),
                  st.sampled_from(["volatile", "transient_local"]), st.integers(1, 10_000))


@pytest.fixture(scope="module")
def sdk_hashes() -> dict[str, str]:
    """The SDK's RIHS01 of each type, from .msg files written from rosbags' definitions."""
    with tempfile.TemporaryDirectory() as d:
        write_msg_files(Path(d), TYPES)
        reg = MessageRegistry(d)
        out = {}
        for t in TYPES:
            path = reg.get_msg_file_path(t)
            assert path is not None
            md = path.read_text()
            out[t] = get_type_hash(t, md, load_dependencies_recursive(t, md, reg))
        return out


@pytest.mark.parametrize("ros_type", TYPES)
def test_type_hash_matches_the_sdk_and_humble_has_none(ros_type: str, sdk_hashes: dict[str, str]) -> None:
    for distro in ("jazzy", "kilted", "rolling"):
        assert rmw.type_hash(ros_type, distro) == sdk_hashes[ros_type]
    assert rmw.type_hash(ros_type, "humble") == "TypeHashNotSupported"


@settings(max_examples=100, deadline=None)
@given(domains, topics, st.sampled_from(TYPES), st.sampled_from(DISTROS))
def test_topic_key_matches_the_sdk(domain: int, topic: str, ros_type: str, distro: str) -> None:
    ours = rmw.topic_key(domain, topic, ros_type, distro)
    assert ours == sdk_ke.topic_keyexpr(domain, topic, ros2_to_dds_type(ros_type), rmw.type_hash(ros_type, distro))
    assert ours.split("/")[0] == str(domain) and "//" not in ours and not ours.startswith("/")
    assert rmw.dds_type_name(ros_type) == ros2_to_dds_type(ros_type)
    assert rmw.ros_type_name(rmw.dds_type_name(ros_type)) == ros_type == dds_to_ros_type(ros2_to_dds_type(ros_type))


@given(st.text(string.ascii_letters + "/_", max_size=12))
def test_strip_slashes_removes_one_slash_each_end_as_rmw_zenoh(name: str) -> None:
    # rmw_zenoh's strip_slashes (liveliness_utils.cpp) on a non-empty string
    if not name:
        return
    start = 1 if name[0] == "/" else 0
    end = len(name) - 1 - (1 if name[-1] == "/" else 0)
    assert rmw.strip_slashes(name) == name[start:end + 1]


@given(st.one_of(st.just("/"), topics))
def test_mangle_matches_the_sdk_and_inverts(name: str) -> None:
    assert rmw.mangle(name) == mangle_name(name)
    assert rmw.demangle(rmw.mangle(name)) == name
    assert "/" not in rmw.mangle(name)


@settings(max_examples=100, deadline=None)
@given(domains, zids, st.integers(0, 50), st.integers(1, 1000), namespaces, node_names, topics,
       st.sampled_from(TYPES), st.sampled_from(DISTROS), qoses, st.sampled_from(["MP", "MS", "SS", "SC"]))
def test_tokens_match_the_sdk_and_parse_back(domain: int, zid: str, nid: int, eid: int, ns: str, name: str,
                                             topic: str, ros_type: str, distro: str, qos: rmw.Qos,
                                             kind: str) -> None:
    node = NodeEntity(domain_id=domain, session_id=zid, node_id=nid, node_name=name, namespace=ns, enclave="%")
    assert rmw.node_token(domain, zid, nid, ns, name) == sdk_ke.node_liveliness_keyexpr(node)
    tok = rmw.endpoint_token(domain, zid, nid, eid, kind, namespace=ns, node=name, topic=topic,  # type: ignore[arg-type]
                             ros_type=ros_type, distro=distro, qos=qos)
    sdk = sdk_ke.endpoint_liveliness_keyexpr(EndpointEntity(
        node=node, entity_id=eid, kind=EntityKind(kind), name=topic, dds_type_name=ros2_to_dds_type(ros_type),
        type_hash=rmw.type_hash(ros_type, distro), qos=qos.keyexpr()))
    assert tok == sdk
    parts = tok.split("/")
    assert len(parts) == 13 and all(parts)  # Entity::make(keyexpr) refuses fewer chunks or an empty one
    assert parts[:6] == ["@ros2_lv", str(domain), zid, str(nid), str(eid), kind]
    assert _parse_token(tok) == Endpoint(kind, name, topic, ros_type, rmw.type_hash(ros_type, distro), ns,
                                         qos.keyexpr())
    assert _parse_token(rmw.node_token(domain, zid, nid, ns, name)) == NodeName(ns, name, zid)


@settings(max_examples=100, deadline=None)
@given(qoses)
def test_qos_text_as_rmw_zenoh_writes_it(qos: rmw.Qos) -> None:
    text = qos.keyexpr()
    parts = text.split(":")
    # REL:DUR:HIST,DEPTH:DL_S,DL_NS:LS_S,LS_NS:LIV,LEASE_S,LEASE_NS, defaults (qos.cpp) left empty
    assert parts[0] == ("" if qos.reliability == "reliable" else "2")
    assert parts[1] == ("" if qos.durability == "volatile" else "1")
    assert parts[2] == ("," if qos.depth == 42 else f",{qos.depth}")
    assert parts[3:] == [",", ",", ",,"]
    assert rmw.Qos.from_keyexpr(text) == qos
    decoded = QosProfile.decode(text)  # the SDK's reader
    assert decoded.reliability == (QosReliability.RELIABLE if qos.reliability == "reliable"
                                   else QosReliability.BEST_EFFORT)
    assert decoded.durability == (QosDurability.VOLATILE if qos.durability == "volatile"
                                  else QosDurability.TRANSIENT_LOCAL)
    if qos.depth != 42:
        # the SDK writes the depth even when it is rmw_zenoh's default 42 and reads an empty depth
        # as 10: it agrees with rmw_zenoh everywhere else
        assert decoded.history_depth == qos.depth
        sdk_default = QosProfile(history_depth=42)
        assert QosProfile(reliability=decoded.reliability, durability=decoded.durability,
                          history_depth=qos.depth).encode(default=sdk_default) == text


def test_qos_depth_zero_is_the_default_and_bad_texts_are_refused() -> None:
    assert rmw.Qos(depth=0).keyexpr() == rmw.Qos(depth=42).keyexpr() == "::,:,:,:,,"
    assert rmw.Qos.from_keyexpr("::,:,:,:,,") == rmw.Qos(depth=42)
    assert rmw.Qos.from_keyexpr("2:1:1,5:,:,:,,") == rmw.Qos("best_effort", "transient_local", 5)
    for bad in ("", "::,:,:,:,", ":::,:,:,:,,", "3::,:,:,:,,", "::2,:,:,:,,", "::,:1,2:,:,,", "::,x:,:,:,,"):
        with pytest.raises(ValueError):
            rmw.Qos.from_keyexpr(bad)


@settings(max_examples=150, deadline=None)
@given(st.integers(-(2 ** 63), 2 ** 63 - 1), st.integers(-(2 ** 63), 2 ** 63 - 1), st.sampled_from(DISTROS),
       st.data())
def test_attachment_is_zenohs_serialisation_and_the_sdks(seq: int, ts: int, distro: str, data: st.DataObject) -> None:
    n = rmw.gid_size(distro)
    gid = data.draw(st.binary(min_size=n, max_size=n))
    ours = rmw.Attachment(seq, ts, gid).to_bytes()
    # rmw_zenoh: Serializer.serialize(int64), (int64), (std::array<uint8_t, N>) = a sequence
    assert ours == zx.z_serialize((zx.Int64(seq), zx.Int64(ts), [zx.UInt8(b) for b in gid])).to_bytes()
    back = zx.z_deserialize(tuple[zx.Int64, zx.Int64, list[zx.UInt8]], zenoh.ZBytes(ours))  # type: ignore[misc]
    assert (int(back[0]), int(back[1]), bytes(int(b) for b in back[2])) == (seq, ts, gid)
    assert rmw.Attachment.from_bytes(ours) == rmw.Attachment(seq, ts, gid)
    if seq >= 0 and ts >= 0:
        assert ours == SdkAttachment(seq, ts, gid).to_bytes()
        sdk = SdkAttachment.from_bytes(ours)
        assert (sdk.sequence_id, sdk.timestamp_ns, sdk.gid) == (seq, ts, gid)


def test_gid_size_and_broken_attachments() -> None:
    # 16 everywhere: Humble's rmw/types.h says 24, rmw_zenoh's Humble port hard-codes 16 (#388)
    assert [rmw.gid_size(d) for d in DISTROS] == [16, 16, 16, 16]
    good = rmw.Attachment(1, 2, bytes(16)).to_bytes()
    for bad in (b"", good[:16], good[:-1], good + b"\0", good[:16] + b"\x80" + bytes(16)):
        with pytest.raises(ValueError):
            rmw.Attachment.from_bytes(bad)


_USED = ["rosgraph_msgs/msg/Clock", "tf2_msgs/msg/TFMessage", "nav_msgs/msg/Odometry", "nav_msgs/msg/OccupancyGrid",
         "sensor_msgs/msg/LaserScan", "sensor_msgs/msg/PointCloud2", "sensor_msgs/msg/Image",
         "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/Imu", "geometry_msgs/msg/PoseStamped",
         "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped", "action_msgs/msg/GoalStatusArray",
         "action_msgs/msg/GoalInfo", "lifecycle_msgs/msg/State", "service_msgs/msg/ServiceEventInfo",
         "unique_identifier_msgs/msg/UUID"]


@pytest.mark.parametrize("distro", ["jazzy", "kilted", "rolling"])
def test_each_distribution_hashes_with_its_own_definitions(distro: str) -> None:
    """Each distribution's hashes come from rosbags' store of that distribution; and every type
    navstress publishes or hears has one definition, so one hash, from Jazzy on (a change in a
    later distribution would show here, and its keys would differ from Jazzy's)."""
    from rosbags.typesys import Stores, get_typestore

    own = get_typestore({"jazzy": Stores.ROS2_JAZZY, "kilted": Stores.ROS2_KILTED, "rolling": Stores.LATEST}[distro])
    for t in _USED:
        assert rmw.type_hash(t, distro) == own.hash_rihs01(t) == rmw.type_hash(t, "jazzy"), t
