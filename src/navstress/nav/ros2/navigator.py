"""The ``ros2`` navigator: navstress as the simulator of a ROS 2 system, over Zenoh.

For each run: a router (navstress's own on 127.0.0.1, or the user's), a node ``/navstress``
that publishes the clock, the frame tree, the odometry, every sensor and the goal, and hears
``/cmd_vel``; optionally the stack itself, started for the run and stopped at its end.
``reset`` waits for the stack's goal subscriber (or action server); the first ``step`` publishes
the latched topics, waits (``wait_active``) until the stack's lifecycle node that takes the goal
is active, publishing /clock and /tf of t = 0 meanwhile, and sends the goal. Each control cycle
(``step``) publishes the readings of simulated time t, then

* ``lockstep``: waits for the stack's command of that cycle (a ``TwistStamped`` stamped at or
  after t, or any ``Twist`` that arrives after the readings), at most ``reply_budget_s`` of wall
  time; past it the cycle goes on with the last command (a *miss*, counted in
  :attr:`Ros2Navigator.misses`). A stack that answers every cycle in budget gets the same inputs,
  and so (if it is itself deterministic) gives the same run, whatever its speed.
* ``paced``: sleeps until the wall clock reaches ``t / real_time_factor`` since the start, then
  takes the latest command: for stacks that cannot be driven cycle by cycle; not reproducible.

Failures around the stack (a router that cannot be reached or dies, a stack that never appears,
exits, stops answering for ``silence_s``, or publishes garbage on ``/cmd_vel``) end the run with
``Status("error", ..., infrastructure=True)``: Fail-Other, never a hang.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shlex
import signal
import subprocess
import threading
import time
import weakref
from typing import Any

import zenoh

from navstress.errors import NavigatorError
from navstress.nav.api import Command, NavMission, Observation, PriorMap, Status
from navstress.nav.ros2.action import ActionClient, action_verdict
from navstress.nav.ros2.config import Ros2Config
from navstress.nav.ros2.lifecycle import ACTIVE, GetStateClient, lifecycle_nodes
from navstress.nav.ros2.messages import POSE_STAMPED, TWIST, TWIST_STAMPED, Encoder, Twist
from navstress.nav.ros2.node import Node, Publisher, Sample, session_config
from navstress.nav.ros2.router import Router, reachable, start_router
from navstress.robot import RobotSpec

__all__ = ["Ros2Navigator"]

#: how long a domain-id claim waits for the other runs' claims to reach it (wall seconds)
CLAIM_SETTLE_S = 0.3
STDERR_TAIL = 16 * 1024
#: wall seconds between the stack's goal subscription appearing (and matching) and the goal
#: going out, so that the stack's subscriptions are in place (see ``reset``)
SETTLE_S = 0.25


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=2.0)
    except Exception:
        pass
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        proc.wait(timeout=5.0)


class Ros2Navigator:
    """A ROS 2 stack under test, reached over Zenoh (see the module's docstring)."""

    def __init__(self, config: Ros2Config) -> None:
        self.cfg = config
        self.control_rate_hz = float(config.control_rate_hz)
        self.failure: str | None = None
        #: lockstep cycles that went on without the stack's command (budget passed)
        self.misses = 0
        #: the simulated times of the missed cycles
        self.missed_at: list[float] = []
        #: the processes the last reset started (the router, the stack): all stopped by close
        self.started_pids: list[int] = []
        #: navstress's own wall time per cycle (publish + bookkeeping, the wait left out), seconds
        self.overhead_s: list[float] = []
        self.domain_id: int | None = None
        self.router_endpoint: str | None = None
        self._router: Router | None = None
        self._claim_session: Any = None
        self._claim_token: Any = None
        self._claim_sub: Any = None
        self._node: Node | None = None
        self._proc: subprocess.Popen[bytes] | None = None
        self._proc_finalizer: Any = None
        self._stderr = bytearray()
        self._pubs: dict[tuple[str, str], Publisher] = {}
        self._enc: Encoder | None = None
        self._cv = threading.Condition()
        self._cmd: Twist | None = None
        self._count = 0  # commands received
        self._bad: str | None = None
        self._last_cmd_wall: float | None = None
        self._wall0 = 0.0
        self._mission: NavMission | None = None
        self._action: ActionClient | None = None
        self._pose: Any = None
        self._prior_map: PriorMap | str | None = None  # the run loop's map (map: world), or why none
        self._lifecycle: list[str] = []  # the lifecycle nodes that must be active before the goal
        self._begun = False  # the goal sent (at the first cycle)
        self._deadline = 0.0  # startup_timeout_s from the launch, monotonic
        self._goal_id = 0  # the run's seed: the action goal's id

    # ------------------------------------------------------------------ Navigator
    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self._teardown()
        self.failure, self.misses, self.overhead_s, self.missed_at = None, 0, [], []
        self.started_pids = []
        self._cmd, self._count, self._bad, self._last_cmd_wall = None, 0, None, None
        cfg = self.cfg
        self._mission, self._pose = mission, None
        prior = self._prior_map
        if cfg.map == "world" and not isinstance(prior, PriorMap):
            self._fail("map: world, but no map of the world: "
                       + (prior or "the run loop gave none (run it through navstress.run_mission)"))
            return
        if cfg.router == "auto":
            self._router = start_router()
            self.started_pids.append(self._router.proc.pid)
            self.router_endpoint = self._router.endpoint
        else:
            why = reachable(cfg.router)
            if why is not None:
                self._fail(why)
                return
            self.router_endpoint = cfg.router
        pool = cfg.domain_pool
        if len(pool) == 1 or cfg.router == "auto":  # a router of its own: no one else to share with
            self.domain_id = pool[0]
        else:
            claimed = self._claim_domain(pool)
            if claimed is None:
                self._fail(f"every domain id of the pool {list(pool)} is taken on {self.router_endpoint} by other "
                           "navstress runs; give a longer domain_id list or fewer workers")
                return
            self.domain_id = claimed
        node = self._node = Node(router=self.router_endpoint, domain_id=self.domain_id, distro=cfg.distro,
                                 namespace=cfg.namespace, name=cfg.node_name, seed=seed)
        self._enc = Encoder(cfg, tuple(robot.sensors or ()), prior if isinstance(prior, PriorMap) else None)
        types = {"auto": (TWIST, TWIST_STAMPED), "twist": (TWIST,), "twist_stamped": (TWIST_STAMPED,)}[cfg.cmd_vel_type]
        node.subscription(cfg.topics.cmd_vel, types, self._on_cmd, qos=self._enc.qos(cfg.topics.cmd_vel))
        for topic, ros_type in self._enc.publications():
            self._pub(topic, ros_type)
        if cfg.launch is not None:
            self._launch()
        goal_topic = cfg.topics.goal
        deadline = time.monotonic() + cfg.startup_timeout_s
        seen = False
        act = self._action = ActionClient(node, cfg.action_name) if cfg.goal != "topic" else None  # nav/ros2/action.py
        want_topic = cfg.goal != "action"

        def ready(g: list[Any]) -> bool:
            return ((not want_topic or any(e.kind == "MS" and e.topic == goal_topic for e in g))
                    and (act is None or act.server_seen(g)))

        while not seen and time.monotonic() < deadline and self._proc_dead() is None:
            seen = node.wait_for(ready, min(0.2, max(0.0, deadline - time.monotonic())))
        if not seen and self._proc_dead() is None:
            what = (f"no subscriber of {goal_topic}" if want_topic and act is None else
                    f"no server of the {cfg.action_name} action" if not want_topic else
                    f"no subscriber of {goal_topic} and server of the {cfg.action_name} action")
            self._fail(f"{what} appeared on domain {self.domain_id} at "
                       f"{self.router_endpoint} within {cfg.startup_timeout_s:g} s (is the stack running, on "
                       "this router and domain?)")
            return
        dead = self._proc_dead()
        if dead is not None:
            self._fail(dead)
            return
        # the stack's token can come before its subscriber is routable (zenoh-ros2-sdk declares the
        # token first): a goal published then is lost (it is volatile), in 2 runs of 3 with the test
        # stack even once Zenoh reports a match; so wait for the match, then SETTLE_S more
        goal_pub = self._pub(goal_topic, POSE_STAMPED)
        while not goal_pub.matched() and time.monotonic() < deadline and self._proc_dead() is None:
            time.sleep(0.002)
        # a stack declares its endpoints one after another (the goal's may come before the
        # odometry's): the first cycle goes out when the graph has been quiet for SETTLE_S, so
        # that a stack that is still starting up does not miss it (and a replay starts alike)
        last, quiet_since = sorted(map(repr, node.graph())), time.monotonic()
        while time.monotonic() - quiet_since < SETTLE_S and time.monotonic() < deadline:
            time.sleep(0.02)
            now = sorted(map(repr, node.graph()))
            if now != last:
                last, quiet_since = now, time.monotonic()
        self._deadline, self._goal_id, self._begun = deadline, seed, False
        g = node.graph()
        takers = [e for e in g if (want_topic and e.kind == "MS" and e.topic == goal_topic)
                  or (act is not None and e.kind == "SS" and e.topic == act.services["send_goal"][0])]
        wa = cfg.wait_active
        self._lifecycle = (lifecycle_nodes(g, takers) if wa == "auto" else [] if wa == "none" else list(wa))

    def _begin(self, first: list[tuple[str, str, Any, int]]) -> Status | None:
        """The start of the run, at its first cycle (``first``: that cycle's messages): the
        latched topics, then (when the stack's lifecycle nodes must be active first) /clock and
        /tf of t = 0 again and again until they are, then /clock 0 and the goal."""
        cfg, enc, mission = self.cfg, self._enc, self._mission
        assert enc is not None and mission is not None
        for topic, ros_type, msg, stamp in enc.latched():
            self._publish(topic, ros_type, msg, stamp)
        if self._lifecycle:
            st = self._wait_active([m for m in first if m[0] in (cfg.topics.clock, cfg.topics.tf)])
            if st is not None:
                return st
        self._publish(cfg.topics.clock, "rosgraph_msgs/msg/Clock", enc.clock(0.0), 0)
        if cfg.goal != "action":
            self._publish(cfg.topics.goal, POSE_STAMPED, enc.goal(0.0, mission), 0)
        act = self._action
        if act is not None:
            gid = hashlib.blake2b(f"navstress-goal/{self._goal_id}".encode(), digest_size=16).digest()
            early = act.send(enc.goal(0.0, mission), gid, cfg.startup_timeout_s)
            if early is not None and early.status in ("NO_ANSWER", "BAD_REPLY"):
                return self._fail(early.message)
        self._wall0 = time.monotonic()
        self._begun = True
        return None

    def _wait_active(self, warm: list[tuple[str, str, Any, int]]) -> Status | None:
        """Publish ``warm`` (/clock and /tf of t = 0) every 0.1 s of wall time and ask each
        lifecycle node of :attr:`_lifecycle` its state until all say ``active`` (within
        ``startup_timeout_s`` of the launch); the failure if not."""
        assert self._node is not None
        clients = [GetStateClient(self._node, n) for n in self._lifecycle]
        try:
            pending = list(clients)
            while True:
                dead = self._proc_dead() or self._router_dead()
                if dead is not None:
                    return self._fail(dead)
                for m in warm:
                    self._publish(*m)
                for c in list(pending):
                    left = self._deadline - time.monotonic()
                    st = c.state(min(0.5, max(0.05, left)))
                    if st is not None and st[0] == ACTIVE:
                        pending.remove(c)
                if not pending:
                    return None
                if time.monotonic() >= self._deadline:
                    c = pending[0]
                    said = (f"its state is {c.last[1]!r}" if isinstance(c.last, tuple) else
                            c.last if c.last is not None else f"nothing answered {c.fqn}/get_state")
                    return self._fail(f"the lifecycle node {c.fqn} did not become active within "
                                      f"startup_timeout_s {self.cfg.startup_timeout_s:g} s ({said}); navstress "
                                      "sends the goal only to an active stack (wait_active, docs/ros2.md)")
                time.sleep(0.1)
        finally:
            for c in clients:
                c.close()

    def step(self, obs: Observation) -> Command | Status:
        if self.failure is not None:
            return Status("error", self.failure, infrastructure=True)
        if self._node is None or self._enc is None:
            return self._fail("the ros2 navigator was stepped before reset")
        w0 = time.perf_counter()
        cfg, enc = self.cfg, self._enc
        t, n = obs.t, enc_ns(obs.t)
        dead = self._proc_dead() or self._router_dead()
        if dead is not None:
            return self._fail(dead)
        msgs = list(enc.cycle(obs))
        if not self._begun:
            b0 = time.perf_counter()
            st = self._begin(msgs)
            if st is not None:
                return st
            w0 += time.perf_counter() - b0  # the start is not a cycle's overhead
        with self._cv:
            before = self._count
        for topic, ros_type, msg, stamp in msgs:
            self._publish(topic, ros_type, msg, stamp)
        w1 = time.perf_counter()
        if cfg.mode == "lockstep":
            def answered() -> bool:
                c = self._cmd
                if self._bad is not None or c is None:
                    return self._bad is not None
                return (c.stamp_ns >= n) if c.stamp_ns is not None else self._count > before

            with self._cv:
                ok = self._cv.wait_for(answered, cfg.reply_budget_s)
            if not ok:
                self.misses += 1
                self.missed_at.append(t)
        else:
            delay = self._wall0 + t / cfg.real_time_factor - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        w2 = time.perf_counter()
        with self._cv:
            cmd, bad, last = self._cmd, self._bad, self._last_cmd_wall
        if bad is not None:
            return self._fail(f"the stack published on {cfg.topics.cmd_vel} {bad}")
        now = time.monotonic()
        since = last if last is not None else self._wall0
        if now - since > cfg.silence_s:
            what = "no command" if last is None else "no command since its last one"
            return self._fail(f"the stack stopped answering: {what} on {cfg.topics.cmd_vel} for "
                              f"{now - since:.1f} s of wall time (silence_s {cfg.silence_s:g})")
        self.overhead_s.append((w1 - w0) + (time.perf_counter() - w2))
        verdict = action_verdict(self._action.outcome(), cfg.action_name) if self._action is not None else None
        if verdict is not None:
            return verdict
        if cmd is None:
            return Command(0.0, 0.0)
        if self._arrived(obs, cmd):
            return Status("arrived")
        return Command(cmd.v, cmd.omega)

    def run_notes(self) -> list[str]:
        """What the run loop records of this run (events in the trace): the time mode, the cycles
        that went on without the stack's command, and the failure around the stack if any. Wall
        times are left out (a trace holds what the same seeds reproduce); the per-cycle overhead is
        :attr:`overhead_s` and ``benchmarks/bench_ros2.py``."""
        cfg = self.cfg
        mode = (f"lockstep (reply budget {cfg.reply_budget_s:g} s)" if cfg.mode == "lockstep"
                else f"paced at {cfg.real_time_factor:g}x real time")
        n = len(self.overhead_s)
        notes = [f"ros2 {mode}, distro {cfg.distro}, domain {self.domain_id}"
                 + (f", goal sent once {', '.join(self._lifecycle)} active" if self._lifecycle and self._begun else "")
                 + f": {n} cycles"
                 + (f", {self.misses} without the stack's command in budget (first at t={self.missed_at[0]:.2f} s)"
                    if cfg.mode == "lockstep" and self.misses else "")]
        return notes

    def close(self) -> None:
        self._teardown()

    def prior_map(self, provider: Any) -> None:
        """The run loop's optional hook (:class:`navstress.nav.api.Navigator`): with ``map:
        world`` the world's map at ``map_resolution_m`` is taken here, before ``reset``, and
        published on ``/map``: ground truth the user chose to give, as Nav2's ``map_server`` gives
        a map file; with ``map: none`` nothing is asked."""
        self._prior_map = None
        if self.cfg.map != "world":
            return
        try:
            self._prior_map = provider(self.cfg.map_resolution_m)
        except ValueError as e:  # a map too large for its resolution: the run fails, saying so
            self._prior_map = str(e)

    # ------------------------------------------------------------------ internals
    def _arrived(self, obs: Observation, cmd: Twist) -> bool:
        """Arrival when the goal went by topic (which has no verdict): the stack holds still
        (both velocities under 1e-3) while the pose sensor puts the robot within the mission's goal
        tolerance. With the action, its result says it (SUCCEEDED)."""
        if self.cfg.goal == "action" or self._mission is None:
            return False
        if obs.pose is not None:
            self._pose = obs.pose
        p = self._pose
        if p is None or abs(cmd.v) >= 1e-3 or abs(cmd.omega) >= 1e-3:
            return False
        g = self._mission.goal
        return bool((p.x - g[0]) ** 2 + (p.y - g[1]) ** 2 <= self._mission.goal_tolerance_m ** 2)

    def _fail(self, message: str) -> Status:
        self.failure = message
        return Status("error", message, infrastructure=True)

    def _on_cmd(self, s: Sample) -> None:
        with self._cv:
            if s.message is None:
                self._bad = self._bad or (s.error or "an unreadable sample")
            else:
                try:
                    self._cmd = Encoder.twist(s.ros_type or TWIST, s.message)
                except Exception as e:  # a message of the right type with fields we cannot read
                    self._bad = self._bad or f"a command navstress cannot read ({type(e).__name__}: {e})"
                self._count += 1
                self._last_cmd_wall = time.monotonic()
            self._cv.notify_all()

    def _pub(self, topic: str, ros_type: str) -> Publisher:
        key = (topic, ros_type)
        p = self._pubs.get(key)
        if p is None:
            assert self._node is not None and self._enc is not None
            p = self._pubs[key] = self._node.publisher(topic, ros_type, self._enc.qos(topic))
        return p

    def _publish(self, topic: str, ros_type: str, msg: Any, stamp_ns: int) -> None:
        self._pub(topic, ros_type).publish(msg, stamp_ns)

    def _launch(self) -> None:
        cfg = self.cfg
        assert cfg.launch is not None and self.router_endpoint is not None
        env = {**os.environ, "ROS_DOMAIN_ID": str(self.domain_id), "RMW_IMPLEMENTATION": "rmw_zenoh_cpp",
               "ZENOH_CONFIG_OVERRIDE": (f'connect/endpoints=["{self.router_endpoint}"];'
                                         'listen/endpoints=["tcp/127.0.0.1:0"];scouting/multicast/enabled=false'),
               "NAVSTRESS_ZENOH_ROUTER": self.router_endpoint, **cfg.launch.env}
        argv = list(cfg.launch.command)
        try:
            proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, cwd=cfg.launch.cwd, env=env, start_new_session=True)
        except OSError as e:
            raise NavigatorError(f"cannot start the ROS 2 stack {shlex.join(argv)!r}: {e.strerror or e}; "
                                 "fix the navigator config's launch.command") from e
        self._proc = proc
        self.started_pids.append(proc.pid)
        self._proc_finalizer = weakref.finalize(self, _kill_group, proc)
        self._stderr = tail = bytearray()
        stream = proc.stderr
        assert stream is not None

        def drain() -> None:
            with contextlib.suppress(Exception):
                while chunk := os.read(stream.fileno(), 1 << 16):
                    tail.extend(chunk)
                    del tail[: max(0, len(tail) - STDERR_TAIL)]

        threading.Thread(target=drain, name="navstress-ros2-stderr", daemon=True).start()

    def _proc_dead(self) -> str | None:
        p = self._proc
        if p is None or p.poll() is None:
            return None
        lines = [ln for ln in bytes(self._stderr).decode("utf-8", "replace").splitlines() if ln.strip()][-5:]
        return (f"the ROS 2 stack exited with code {p.returncode}; "
                + ("last stderr lines: " + " | ".join(ln[:300] for ln in lines) if lines else "no stderr output"))

    def _router_dead(self) -> str | None:
        r = self._router
        if r is not None and not r.alive:
            return f"the Zenoh router at {r.endpoint} stopped"
        return None

    def _claim_domain(self, pool: tuple[int, ...]) -> int | None:
        """The first domain id of ``pool`` that no other navstress run holds on the shared router,
        held (a liveliness token ``@navstress/domain/<id>/<zid>``) until the run's end. An id with
        a holder is skipped; two runs that claim a free id at once both see both tokens: the one
        with the smaller zid keeps it, the other tries the next id.
        Nothing is written anywhere but on the router."""
        assert self.router_endpoint is not None
        s = self._claim_session = zenoh.open(session_config(self.router_endpoint))
        me = str(s.info.zid())
        lv = s.liveliness()
        # the claims as a liveliness subscriber sees them (its history first): a query sent while
        # the session is still joining the router can find no one
        held: dict[str, bool] = {}
        lock = threading.Lock()

        def on_token(t: Any) -> None:
            with lock:
                held[str(t.key_expr)] = t.kind != zenoh.SampleKind.DELETE

        self._claim_sub = lv.declare_subscriber("@navstress/domain/**", on_token, history=True)
        deadline = time.monotonic() + 5.0
        while not list(s.info.routers_zid()) and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(CLAIM_SETTLE_S)

        def holders(d: int) -> list[str]:
            with lock:
                return sorted(k.rsplit("/", 1)[1] for k, on in held.items()
                              if on and k.startswith(f"@navstress/domain/{d}/"))

        for d in pool:
            if holders(d):  # held by a run under way
                continue
            token = lv.declare_token(f"@navstress/domain/{d}/{me}")
            time.sleep(CLAIM_SETTLE_S)  # let a concurrent claim's token reach us
            now = holders(d)
            if not now or now[0] == me:
                self._claim_token = token
                return d
            token.undeclare()  # type: ignore[no-untyped-call]
        return None

    def _teardown(self) -> None:
        if self._action is not None:
            self._action.cancel()
            self._action.close()
            self._action = None
        if self._claim_session is not None:
            with contextlib.suppress(Exception):
                self._claim_session.close()
            self._claim_session, self._claim_token, self._claim_sub = None, None, None
        if self._proc_finalizer is not None:
            self._proc_finalizer()
            self._proc_finalizer, self._proc = None, None
        if self._node is not None:
            self._node.close()
            self._node = None
        self._pubs.clear()
        if self._router is not None:
            self._router.stop()
            self._router = None


def enc_ns(t: float) -> int:
    """Simulated seconds as integer nanoseconds (the stamps' clock)."""
    return int(round(t * 1e9))
