"""Lifecycle nodes (nav/ros2/lifecycle.py): GetState's service type hash against the value rosidl
generates, and which nodes of a graph navstress waits for (issue 38, Nav2's bring-up)."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.ros2 import lifecycle, service
from navstress.nav.ros2.node import Endpoint

# rosidl_generator_c's lifecycle_msgs__srv__GetState__get_type_hash (Kilted), as generated into
# hpmicro/hpm_sdk middleware/microros/kilted/include/lifecycle_msgs/lifecycle_msgs/srv/detail/
# get_state__description.c: bytes 80 0a 0a 5a ... 97 95
GET_STATE_RIHS01 = "RIHS01_800a0a5aae599782b02932de0caf563f6dc4e7e94b794eadde075ba2cbef9795"


@pytest.mark.parametrize("distro", ["jazzy", "kilted", "rolling"])
def test_get_state_type_hash_is_rosidls(distro: str) -> None:
    lifecycle.register_lifecycle_types(distro)
    assert service.service_type_hash(lifecycle.GET_STATE, distro) == GET_STATE_RIHS01


def test_get_state_on_humble_has_no_hash() -> None:
    lifecycle.register_lifecycle_types("humble")
    assert service.service_type_hash(lifecycle.GET_STATE, "humble") == "TypeHashNotSupported"


_NODES = st.sampled_from([("/", "bt_navigator"), ("/", "test_stack"), ("/robot1", "bt_navigator"), ("/", "x")])


def _ep(kind: str, ns_node: tuple[str, str], topic: str, ros_type: str) -> Endpoint:
    ns, node = ns_node
    return Endpoint(kind, node, topic, ros_type, "RIHS01_0", ns)


@settings(max_examples=200, deadline=None)
@given(takers=st.lists(_NODES, max_size=3), servers=st.lists(st.tuples(_NODES, st.booleans(), st.booleans()),
                                                                 max_size=4))
def test_lifecycle_nodes_are_the_takers_that_serve_get_state(
        takers: list[tuple[str, str]], servers: list[tuple[tuple[str, str], bool, bool]]) -> None:
    """A taker's node counts when an SS endpoint ``<its fqn>/get_state`` of type GetState is in
    the graph; another service, another type or another node's get_state does not."""
    def fqn(n: tuple[str, str]) -> str:
        return f"{n[0].rstrip('/')}/{n[1]}"

    t = [_ep("MS", n, "/goal_pose", "geometry_msgs/msg/PoseStamped") for n in takers]
    g = list(t)
    for n, right_name, right_type in servers:
        g.append(_ep("SS", n, f"{fqn(n)}/get_state" if right_name else f"{fqn(n)}/get_parameters",
                     lifecycle.GET_STATE if right_type else "lifecycle_msgs/srv/ChangeState"))
    want = sorted({fqn(n) for n in takers if any(s == n and a and b for s, a, b in servers)})
    assert lifecycle.lifecycle_nodes(g, t) == want
