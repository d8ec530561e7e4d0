"""The ``ros2`` navigator's configuration (docs/ros2.md): which router, which domain, which ROS 2
distribution, how time advances, which topics and frames, how the stack is started.

Every default is Nav2's (its ``nav2_bringup`` defaults: ``/scan``, ``/odom``, ``/cmd_vel``,
``/goal_pose``, ``map``/``odom``/``base_link``). Checked strictly, like every spec model: a
topic name ROS 2 forbids, a domain id out of range or an unknown key is one line
(:class:`~navstress.errors.SpecError`) before anything starts.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from navstress._models import LIST, SPEC_CONFIG, parse
from navstress.errors import SpecError

__all__ = ["DISTROS", "DOMAIN_ID_MAX", "QosConfig", "Ros2Config", "TopicsConfig", "FramesConfig",
           "check_topic_name", "parse_config"]

#: The ROS 2 distributions whose conventions navstress speaks (docs/ros2.md): Humble has no type
#: hashes (rmw_zenoh writes ``TypeHashNotSupported``), Jazzy and later do (RIHS01); Nav2 sends
#: ``TwistStamped`` on ``/cmd_vel`` from Kilted on.
DISTROS = ("humble", "jazzy", "kilted", "rolling")
#: The largest ROS domain id (REP 2005 / ``ROS_DOMAIN_ID``: 0..232 on every RMW; rmw_zenoh uses it
#: as the first chunk of every key expression).
DOMAIN_ID_MAX = 232

_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_ENDPOINT = re.compile(r"^(tcp|udp|quic|tls)/(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})$")


def check_topic_name(name: str) -> str | None:
    """Why ``name`` is not a fully qualified ROS 2 topic name (``/a/b_c``), or None when it is.

    The rules of ROS 2's ``rcl_validate_topic_name`` and ``rmw_validate_full_topic_name``
    (design article "Topic and Service name mapping"): it starts with ``/``, each token between
    slashes is not empty, starts with a letter or ``_`` (a digit is refused), and holds only
    letters, digits and ``_``; no ``~`` or ``{}`` substitution is left; at most 255 characters.

        >>> check_topic_name("/cmd_vel") is None
        True
        >>> check_topic_name("/2d/scan")
        "token '2d' starts with a digit"
    """
    if not isinstance(name, str) or not name:
        return "it is empty"
    if not name.startswith("/"):
        return "it does not start with '/' (write the fully qualified name, e.g. '/scan')"
    if len(name) > 255:
        return f"it has {len(name)} characters, more than 255"
    if name != "/" and name.endswith("/"):
        return "it ends with '/'"
    for tok in name[1:].split("/"):
        if not tok:
            return "it has an empty token ('//')"
        if tok[0] in "0123456789":
            return f"token {tok!r} starts with a digit"
        if not _TOKEN.match(tok):
            # ASCII only: ROS 2 refuses non-ASCII letters and digits too ('é', '٣')
            bad = next(c for c in tok if not (c.isascii() and (c.isalnum() or c == "_")))
            return f"token {tok!r} holds {bad!r} (only ASCII letters, digits and '_')"
    return None


def _topic(field: str, value: str) -> str:
    why = check_topic_name(value)
    if why is not None:
        raise SpecError(field, value, "a ROS 2 topic name such as '/scan'", why)
    return value


class TopicsConfig(BaseModel):
    """Topic names (Nav2's defaults). ``sensors`` maps a sensor's name to its topic; a sensor not
    named there gets its kind's default (docs/ros2.md: the first ``lidar2d`` on ``/scan``, the
    first ``lidar3d`` on ``/points``, a depth camera on ``/<name>/depth/image_raw`` and
    ``/<name>/depth/camera_info``, the IMU on ``/imu``, other sensors on ``/<name>``)."""

    model_config = SPEC_CONFIG
    clock: str = "/clock"
    tf: str = "/tf"
    tf_static: str = "/tf_static"
    odom: str = "/odom"
    cmd_vel: str = "/cmd_vel"
    goal: str = "/goal_pose"
    map: str = "/map"
    sensors: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _names(self) -> TopicsConfig:
        for f in ("clock", "tf", "tf_static", "odom", "cmd_vel", "goal", "map"):
            _topic(f, getattr(self, f))
        for k, v in self.sensors.items():
            _topic(f"sensors.{k}", v)
        return self


class FramesConfig(BaseModel):
    """Frame ids (REP 105): ``map -> odom -> base_link -> <sensor name>``."""

    model_config = SPEC_CONFIG
    map: str = "map"
    odom: str = "odom"
    base: str = "base_link"

    @model_validator(mode="after")
    def _ids(self) -> FramesConfig:
        for f in ("map", "odom", "base"):
            v = getattr(self, f)
            if not v or v.startswith("/") or not all(_TOKEN.match(t) for t in v.split("/")):
                raise SpecError(f, v, "a frame id such as 'base_link'",
                                "letters, digits, '_' and inner '/' only, no leading '/'")
        if len({self.map, self.odom, self.base}) != 3:
            raise SpecError("map", self.model_dump(), "three different frame ids for map, odom and base")
        return self


class QosConfig(BaseModel):
    """One topic's QoS, as ROS 2 has it (rmw_zenoh maps reliability to Zenoh's congestion control
    and transient local to a publication cache)."""

    model_config = SPEC_CONFIG
    reliability: Literal["reliable", "best_effort"] = "reliable"
    durability: Literal["volatile", "transient_local"] = "volatile"
    depth: int = Field(10, ge=1, le=10_000)


class LaunchConfig(BaseModel):
    """A stack navstress starts for each run (and stops at its end, its whole process group):
    ``command`` (a list, or a line split as a shell would), ``cwd``, ``env`` (added to
    navstress's environment, after ``ROS_DOMAIN_ID``, ``RMW_IMPLEMENTATION`` and the Zenoh
    router's address, docs/ros2.md)."""

    model_config = SPEC_CONFIG
    command: tuple[str, ...] = Field(strict=LIST, min_length=1)
    cwd: str | None = None
    env: dict[str, str] = Field(default_factory=dict)

    @field_validator("command", mode="before")
    @classmethod
    def _split(cls, v: Any) -> Any:
        if isinstance(v, str):
            import shlex  # stdlib, used for this one field

            return shlex.split(v)
        return v


class Ros2Config(BaseModel):
    """The ``ros2`` navigator's configuration (docs/ros2.md has each key)."""

    model_config = SPEC_CONFIG
    #: ``auto``: navstress starts a Zenoh router for each run on 127.0.0.1 (a free port) and
    #: stops it at the run's end; or an endpoint such as ``tcp/127.0.0.1:7447`` to join.
    router: str = "auto"
    #: the ROS domain id, or a pool of them: each run takes a free one of the pool for its
    #: duration (parallel runs on one router never hear each other)
    domain_id: int | list[int] = 0
    distro: Literal["humble", "jazzy", "kilted", "rolling"] = "jazzy"
    #: ``lockstep``: publish the sensors for simulated time t, wait for the stack's command of
    #: that cycle (within ``reply_budget_s``), advance; ``paced``: simulated time advances at
    #: ``real_time_factor`` times the wall clock.
    mode: Literal["lockstep", "paced"] = "lockstep"
    real_time_factor: float = Field(1.0, gt=0.0, le=1000.0)
    control_rate_hz: float = Field(20.0, gt=0.0, le=1000.0)
    #: lockstep: the wall-clock seconds navstress waits for the command of one cycle before it
    #: advances holding the previous command (a miss, counted)
    reply_budget_s: float = Field(1.0, gt=0.0, le=600.0)
    #: a stack that sends no command for this many wall-clock seconds (after its first) has
    #: stopped answering: the run ends, Fail-Other
    silence_s: float = Field(30.0, gt=0.0, le=3600.0)
    #: wall-clock seconds for the stack to appear (its subscriptions to the goal and, when
    #: launched, its process) at the start of a run
    startup_timeout_s: float = Field(60.0, gt=0.0, le=3600.0)
    #: ``twist``, ``twist_stamped`` or ``auto`` (both are heard; Kilted and later's default is
    #: ``twist_stamped``, which lockstep matches by its stamp)
    cmd_vel_type: Literal["auto", "twist", "twist_stamped"] = "auto"
    #: how the goal is given: on the goal topic, through the ``navigate_to_pose`` action, or both
    goal: Literal["topic", "action", "both"] = "topic"
    action_name: str = "/navigate_to_pose"
    #: where ``map -> odom`` comes from: the pose sensor (``pose``) or nobody (``none``: the
    #: stack localises itself, e.g. AMCL)
    map_to_odom: Literal["pose", "none"] = "pose"
    #: ``/map`` (transient local): ``none``, or the world rasterised at ``map_resolution_m``
    map: Literal["none", "world"] = "none"
    map_resolution_m: float = Field(0.05, gt=0.0, le=10.0)
    node_name: str = "navstress"
    namespace: str = "/"
    topics: TopicsConfig = Field(default_factory=TopicsConfig)
    frames: FramesConfig = Field(default_factory=FramesConfig)
    #: per-topic QoS overrides, by topic name
    qos: dict[str, QosConfig] = Field(default_factory=dict)
    launch: LaunchConfig | None = None
    #: what the stack must be before it gets the goal. ``auto``: if the node that takes the goal
    #: (the goal topic's subscriber, the action's server) is a ROS 2 lifecycle node (it serves
    #: ``<node>/get_state``, as Nav2's ``bt_navigator`` does), navstress waits until it says
    #: ``active``; a list of fully qualified node names (``/bt_navigator``) waits for each of
    #: them; ``none`` sends the goal as soon as the stack's goal subscriber or server is there.
    #: While it waits, navstress publishes ``/clock``, ``/tf`` and ``/tf_static`` of t = 0 (a
    #: Nav2 costmap activates only once ``map -> base_link`` exists), within ``startup_timeout_s``.
    wait_active: Literal["auto", "none"] | list[str] = "auto"

    @field_validator("wait_active")
    @classmethod
    def _wait_active(cls, v: str | list[str]) -> str | list[str]:
        if isinstance(v, list):
            if not v:
                raise SpecError("wait_active", v, "'auto', 'none' or a non-empty list of node names such as "
                                "'/bt_navigator'")
            for n in v:
                why = check_topic_name(n)
                if why is not None:
                    raise SpecError("wait_active", n, "a fully qualified ROS 2 node name such as '/bt_navigator'",
                                    why)
        return v

    @field_validator("router")
    @classmethod
    def _router(cls, v: str) -> str:
        if v != "auto":
            m = _ENDPOINT.match(v)
            if m is None or not 0 < int(m.group(3)) < 65536:
                raise SpecError("router", v,
                                "'auto' or a Zenoh endpoint such as 'tcp/127.0.0.1:7447'")
        return v

    @field_validator("domain_id")
    @classmethod
    def _domain(cls, v: int | list[int]) -> int | list[int]:
        ids = (v,) if isinstance(v, int) else v
        if not ids:
            raise SpecError("domain_id", list(ids), "a domain id or a non-empty list of them")
        for i in ids:
            if isinstance(i, bool) or not 0 <= i <= DOMAIN_ID_MAX:
                raise SpecError("domain_id", v, f"an integer in [0, {DOMAIN_ID_MAX}] "
                                "(ROS_DOMAIN_ID's range) or a list of them")
        if len(set(ids)) != len(ids):
            raise SpecError("domain_id", list(ids), "a list without repeats")
        return v

    @field_validator("node_name")
    @classmethod
    def _node(cls, v: str) -> str:
        if not _TOKEN.match(v):
            raise SpecError("node_name", v, "a ROS 2 node name (letters, digits, '_')")
        return v

    @model_validator(mode="after")
    def _rest(self) -> Ros2Config:
        if self.namespace != "/":
            _topic("namespace", self.namespace)
        _topic("action_name", self.action_name)
        for k in self.qos:
            _topic(f"qos.{k}", k)
        return self

    @property
    def domain_pool(self) -> tuple[int, ...]:
        """The domain ids a run may take, in order of preference."""
        return (self.domain_id,) if isinstance(self.domain_id, int) else tuple(self.domain_id)


def parse_config(config: Mapping[str, Any] | None) -> Ros2Config:
    """The configuration from a navigator config mapping; :class:`SpecError` naming the key."""
    if config is not None and not isinstance(config, Mapping):
        raise SpecError("navigator-config", config, "a mapping of the ros2 navigator's keys (docs/ros2.md)")
    return parse(Ros2Config, dict(config or {}), prefix="navigator-config")
