"""A client of Nav2's ``navigate_to_pose`` action over Zenoh, as rmw_zenoh carries actions.

A ROS 2 action is three services and two topics under ``<action>/_action/`` (rcl_action):
``send_goal`` (``<Action>_SendGoal``), ``get_result`` (``<Action>_GetResult``), ``cancel_goal``
(``action_msgs/srv/CancelGoal``), ``status`` (``action_msgs/msg/GoalStatusArray``) and
``feedback`` (``<Action>_FeedbackMessage``); the services go as :mod:`navstress.nav.ros2.service`
carries any service.

Nav2's ``NavigateToPose`` differs by distribution: Humble's result is ``std_msgs/Empty``, Jazzy's
(and later) carries ``error_code`` and ``error_msg``.
"""

from __future__ import annotations

import contextlib
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from navstress.nav.api import Status
from navstress.nav.ros2 import rmw, service
from navstress.nav.ros2.service import (ServiceClient, register, register as _register, register_service,
                                        service_key, service_type_hash)

__all__ = ["ACTION_TYPE", "ActionClient", "GOAL_STATUS", "action_verdict", "Outcome", "register_action_types",
           "service_type_hash"]

ACTION_TYPE = "nav2_msgs/action/NavigateToPose"

#: action_msgs/msg/GoalStatus's constants
GOAL_STATUS = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED",
               6: "ABORTED"}

_GOAL = "geometry_msgs/PoseStamped pose\nstring behavior_tree\n"
_RESULT = {
    "humble": "std_msgs/Empty result\n",
    "jazzy": ("uint16 NONE=0\nuint16 UNKNOWN=9000\nuint16 FAILED_TO_LOAD_BEHAVIOR_TREE=9001\n"
              "uint16 TF_ERROR=9002\nuint16 TIMEOUT=9003\nuint16 error_code\nstring error_msg\n"),
}
_FEEDBACK = {
    "humble": ("geometry_msgs/PoseStamped current_pose\nbuiltin_interfaces/Duration navigation_time\n"
               "builtin_interfaces/Duration estimated_time_remaining\nint16 number_of_recoveries\n"
               "float32 distance_remaining\n"),
}
_FEEDBACK["jazzy"] = _FEEDBACK["humble"]


def _defs(action: str, distro: str) -> dict[str, str]:
    """Message definitions of ``action``'s generated types (rosidl's action expansion)."""
    d = "humble" if distro == "humble" else "jazzy"
    a = action
    uuid = "unique_identifier_msgs/UUID goal_id\n"
    return {
        f"{a}_Goal": _GOAL, f"{a}_Result": _RESULT[d], f"{a}_Feedback": _FEEDBACK[d],
        f"{a}_SendGoal_Request": uuid + f"@{a}_Goal goal\n",
        f"{a}_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
        f"{a}_GetResult_Request": uuid,
        f"{a}_GetResult_Response": f"int8 status\n@{a}_Result result\n",
        f"{a}_FeedbackMessage": uuid + f"@{a}_Feedback feedback\n",
    }


#: action_msgs/srv/CancelGoal (rcl_interfaces' action_msgs)
_CANCEL = {
    "action_msgs/srv/CancelGoal_Request": "action_msgs/GoalInfo goal_info\n",
    "action_msgs/srv/CancelGoal_Response": ("int8 ERROR_NONE=0\nint8 ERROR_REJECTED=1\nint8 ERROR_UNKNOWN_GOAL_ID=2\n"
                                            "int8 ERROR_GOAL_TERMINATED=3\nint8 return_code\n"
                                            "action_msgs/GoalStatus[] goals_canceling\n"),
}


def register_action_types(distro: str, action: str = ACTION_TYPE) -> Any:
    """Register ``action``'s types (and its services' types) in ``distro``'s typestore; the store."""
    store = rmw.typestore(distro)
    with service._LOCK:
        register(store, _CANCEL)
        register(store, _defs(action, distro))
        for srv in (f"{action}_SendGoal", f"{action}_GetResult", "action_msgs/srv/CancelGoal"):
            register_service(store, srv)
    return store


@dataclass(frozen=True)
class Outcome:
    """The goal's end: its status name (SUCCEEDED, ABORTED, CANCELED, REJECTED) and the result's
    message (with its error code where the distribution has one)."""

    status: str
    message: str


def action_verdict(o: Outcome | None, action_name: str) -> Status | None:
    """The run's verdict from the goal's outcome: SUCCEEDED -> arrived; ABORTED, CANCELED or
    REJECTED -> the stack's own error (Fail-Error) with the result's message; an answer navstress
    cannot read -> a failure around the stack (Fail-Other); None while the goal runs."""
    if o is None:
        return None
    if o.status == "SUCCEEDED":
        return Status("arrived")
    if o.status in ("ABORTED", "CANCELED", "REJECTED"):
        return Status("error", f"{action_name} {o.status.lower()}: {o.message}")
    return Status("error", f"{action_name}: {o.message}", infrastructure=True)


class ActionClient:
    """A ``navigate_to_pose`` client of ``node``: ``server_seen()`` (the send_goal server's
    token), ``send(goal)`` (send_goal, then get_result in the background), ``outcome()`` (None
    while the goal runs), ``cancel()``, ``close()``."""

    def __init__(self, node: Any, action_name: str, *, action_type: str = ACTION_TYPE) -> None:
        self.node, self.name, self.type = node, action_name, action_type
        register_action_types(node.distro, action_type)
        base = f"/{action_name.strip('/')}/_action"
        self.services = {"send_goal": (f"{base}/send_goal", f"{action_type}_SendGoal"),
                         "get_result": (f"{base}/get_result", f"{action_type}_GetResult"),
                         "cancel_goal": (f"{base}/cancel_goal", "action_msgs/srv/CancelGoal")}
        self._lock = threading.Lock()
        self._outcome: Outcome | None = None
        self._goal_id: bytes | None = None
        self.status: str | None = None  # the latest status of our goal on the status topic
        self.feedback = 0  # feedback messages heard for our goal
        self._clients = {what: ServiceClient(node, service, srv) for what, (service, srv) in self.services.items()}
        node.subscription(f"{base}/status", ("action_msgs/msg/GoalStatusArray",), self._on_status,
                          rmw.Qos("reliable", "transient_local", 1))
        node.subscription(f"{base}/feedback", (f"{action_type}_FeedbackMessage",), self._on_feedback)

    # ------------------------------------------------------------------ graph
    def server_seen(self, graph: list[Any] | None = None) -> bool:
        """Whether a server of the action's send_goal service has its token up (in ``graph``, as
        ``Node.wait_for`` hands it over: never call ``node.graph()`` inside that wait)."""
        service = self.services["send_goal"][0]
        return any(e.kind == "SS" and e.topic == service for e in (self.node.graph() if graph is None else graph))

    # ------------------------------------------------------------------ requests
    def _query(self, what: str, request: Any, timeout_s: float, on_reply: Any) -> None:
        self._clients[what].call_async(request, timeout_s, on_reply)

    def _uuid(self) -> Any:
        T = self.node.store.types
        return T["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(self._goal_id or bytes(16), dtype="uint8").copy())

    def send(self, pose_stamped: Any, goal_id: bytes, timeout_s: float) -> Outcome | None:
        """send_goal (waits up to ``timeout_s`` for the answer); when accepted, get_result is asked
        in the background. An Outcome at once when the goal was rejected or nothing answered."""
        T = self.node.store.types
        a = self.type
        self._goal_id = bytes(goal_id)
        req = T[f"{a}_SendGoal_Request"](goal_id=self._uuid(),
                                         goal=T[f"{a}_Goal"](pose=pose_stamped, behavior_tree=""))
        done = threading.Event()
        box: list[Any] = []

        def on_send(msg: Any, err: str | None) -> None:
            box.append((msg, err))
            done.set()

        self._query("send_goal", req, timeout_s, on_send)
        if not done.wait(timeout_s):
            return self._set(Outcome("NO_ANSWER", f"the {self.name} action server did not answer send_goal "
                                                  f"within {timeout_s:g} s"))
        msg, err = box[0]
        if err is not None:
            return self._set(Outcome("BAD_REPLY", err))
        if not msg.accepted:
            return self._set(Outcome("REJECTED", f"the {self.name} action server rejected the goal"))
        self._query("get_result", T[f"{a}_GetResult_Request"](goal_id=self._uuid()), 86400.0, self._on_result)
        return None

    def _on_result(self, msg: Any, err: str | None) -> None:
        if err is not None:
            self._set(Outcome("BAD_REPLY", err))
            return
        status = GOAL_STATUS.get(int(msg.status), f"status {int(msg.status)}")
        r = msg.result
        if hasattr(r, "error_msg"):
            detail = f"{r.error_msg or 'no message'} (error_code {int(r.error_code)})"
        else:
            detail = "no message (this distribution's NavigateToPose result carries none)"
        self._set(Outcome(status, detail))

    def _set(self, o: Outcome) -> Outcome:
        with self._lock:
            if self._outcome is None:
                self._outcome = o
            return self._outcome

    def outcome(self) -> Outcome | None:
        with self._lock:
            return self._outcome

    def cancel(self, timeout_s: float = 1.0) -> None:
        """Ask the server to cancel our goal (best effort, e.g. when the run ends first)."""
        if self._goal_id is None or self.outcome() is not None:
            return
        T = self.node.store.types
        info = T["action_msgs/msg/GoalInfo"](goal_id=self._uuid(),
                                            stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0))
        done = threading.Event()
        with contextlib.suppress(Exception):
            self._query("cancel_goal", T["action_msgs/srv/CancelGoal_Request"](goal_info=info), timeout_s,
                        lambda m, e: done.set())
            done.wait(timeout_s)

    # ------------------------------------------------------------------ topics
    def _on_status(self, s: Any) -> None:
        if s.message is None or self._goal_id is None:
            return
        for st in s.message.status_list:
            if bytes(st.goal_info.goal_id.uuid) == self._goal_id:
                self.status = GOAL_STATUS.get(int(st.status), str(int(st.status)))

    def _on_feedback(self, s: Any) -> None:
        if s.message is not None and self._goal_id is not None and bytes(s.message.goal_id.uuid) == self._goal_id:
            self.feedback += 1

    def close(self) -> None:
        for c in self._clients.values():
            c.close()
