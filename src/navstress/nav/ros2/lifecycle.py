"""ROS 2 lifecycle nodes, as navstress waits for them: the ``get_state`` service
(``lifecycle_msgs/srv/GetState``) every lifecycle node serves at ``<node>/get_state``
(rclcpp_lifecycle's ``LifecycleNodeStateServicesManager``), and which nodes of the graph offer it.

Nav2's servers are lifecycle nodes: the lifecycle manager configures and activates them in turn,
and the BT navigator, which takes the goal, rejects goals until it is *active*
(``nav2_simple_commander``'s ``waitUntilNav2Active`` asks ``/bt_navigator/get_state`` until it says
``active`` for the same reason). See docs/ros2.md, "Connecting a real Nav2".
"""

from __future__ import annotations

from typing import Any

from navstress.nav.ros2 import rmw, service
from navstress.nav.ros2.node import Endpoint

__all__ = ["GET_STATE", "GetStateClient", "lifecycle_nodes", "register_lifecycle_types"]

GET_STATE = "lifecycle_msgs/srv/GetState"
#: lifecycle_msgs/msg/State's primary state ``active``
ACTIVE = 3

# lifecycle_msgs/srv/GetState.srv: an empty request (rosidl gives an empty structure its one
# ``uint8 structure_needs_at_least_one_member``, as rosbags' std_msgs/Empty has it) and the state
_DEFS = {
    f"{GET_STATE}_Request": "uint8 structure_needs_at_least_one_member\n",
    f"{GET_STATE}_Response": "lifecycle_msgs/State current_state\n",
}


def register_lifecycle_types(distro: str) -> Any:
    """Register GetState's types (and the service's, for its hash) in ``distro``'s typestore."""
    store = rmw.typestore(distro)
    with service._LOCK:
        service.register(store, _DEFS)
        service.register_service(store, GET_STATE)
    return store


def _fqn(e: Endpoint) -> str:
    return f"{e.namespace.rstrip('/')}/{e.node}"


def lifecycle_nodes(graph: list[Endpoint], takers: list[Endpoint]) -> list[str]:
    """The fully qualified names of the nodes among ``takers``' nodes that serve
    ``<node>/get_state`` of type GetState in ``graph``, sorted."""
    serving = {e.topic for e in graph if e.kind == "SS" and e.ros_type == GET_STATE}
    return sorted({_fqn(e) for e in takers if f"{_fqn(e)}/get_state" in serving})


class GetStateClient:
    """``get_state`` of the lifecycle node ``fqn``: :meth:`state` is its state's label (``active``,
    ``inactive``, ...) or None when it did not answer in time."""

    def __init__(self, node: Any, fqn: str) -> None:
        register_lifecycle_types(node.distro)
        self.fqn = fqn
        self._client = service.ServiceClient(node, f"{fqn}/get_state", GET_STATE)
        self._request = node.store.types[f"{GET_STATE}_Request"](structure_needs_at_least_one_member=0)
        #: the last answer: (id, label), or why it could not be read
        self.last: tuple[int, str] | str | None = None

    def state(self, timeout_s: float) -> tuple[int, str] | None:
        msg, err = self._client.call(self._request, timeout_s)
        if err is not None:
            self.last = err
            return None
        if msg is None:
            return None
        self.last = (int(msg.current_state.id), str(msg.current_state.label))
        return self.last

    def close(self) -> None:
        self._client.close()
