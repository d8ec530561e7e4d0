"""Watch a run in Foxglove as it happens: ``navstress run WORLD --live``.

The run's process makes a channel for every topic the run will send (those below and its robot's
sensors'), then starts a Foxglove WebSocket server (``foxglove-sdk``) on ``127.0.0.1`` (port
8765 by default), waits until a client subscribes (at most ``wait_s``) and its subscriptions
settle (none new for :data:`SETTLE_S`: the server takes a request for several channels one at a
time), then runs the mission
paced to the wall clock (``speed`` simulated seconds per real second) and sends, after every
control step, the messages a trace holds (:class:`~navstress.run.trace.TraceMessages`, the same
topics, schemas and protobuf encoding; log times are simulated time):

- at the start, and again whenever a client subscribes (so a panel opened late still sees them):
  ``/world/scene``, ``/world/terrain_mesh``, ``/world/terrain``, ``/robot/body`` and the lidar
  mounts on ``/tf``;
- every step: ``/tf`` and ``/truth/pose`` (the true pose now), ``/tf`` and ``/perceived/pose``
  (the navigator's belief, its ``perceived_trajectory()``'s last row), ``/nav/cmd``,
  ``/world/movers``, the new ``/events``, what the navigator drew (``/nav/debug``) and its map
  (``/nav/map``, once per simulated second);
- ``/lidar``: the default lidar's last scan of the step in the ``lidar`` frame, at most once per
  0.5 simulated seconds;
- every other sensor of the robot (``RobotSpec.sensors``) on its trace topics, as its kind's
  ``trace`` encoder writes them (a 2D scan: ``foxglove.LaserScan`` on ``/sensors/<name>``, drawn in
  its frame by the 3D panel; a depth camera: ``foxglove.RawImage`` on ``/sensors/<name>/depth``
  with its ``foxglove.CameraCalibration``, for the Image panel or projected in the 3D panel), at
  most once per :data:`SENSOR_PERIOD_S` simulated seconds a sensor (and no more often than the
  trace records them: :class:`~navstress.run.trace.SensorRecorder`); their frames are on ``/tf``
  with the mounts;
- at the end: the last events (the outcome) and the final map.

Every channel before the server: foxglove-sdk (0.30.3) sends a client the advertisement of a
channel made while it is connected BEFORE it records that channel as advertised to it, so a client
that subscribes as soon as it learns of a channel (the Foxglove app does, for the topics its panels
show) can be refused ("Unknown channel ID") and never get that topic. The channels of a server's
context when a client connects are advertised and recorded before the server reads the client's
first request: they cannot be refused. (``late_topics`` lists any channel made after the server
started: only for a robot other than the one the publisher was made for.)

What the server logs about its clients (a client that fails the handshake or sends a message the
protocol does not know) reaches standard error only through :class:`ClientLog`: escaped (a client's
bytes never move the cursor or restyle the terminal), each line bounded, at most
:data:`LOG_BURST` lines per :data:`LOG_WINDOW_S` seconds and then one line saying how many more
there were.

A live run is the same run: it records the navigator's view (``--live`` implies
``--navigator-view``) and writes the same trace, byte for byte, as the run without ``--live``
(tested); pacing only sleeps between steps, outside the simulation's clock.
"""

from __future__ import annotations

import logging
import math
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass
from typing import IO, TYPE_CHECKING, Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap_protobuf.schema import build_file_descriptor_set

from navstress._console import one_line
from navstress.robot import RobotSpec
from navstress.run.mission import NavigatorView, RunResult, attr_through_wrappers, execute, true_pose, world_messages
from navstress.run.record import RunRecord, RunTask
from navstress.run.trace import (BELIEF, FRAME, FRAME_LIDAR, FRAME_ROBOT, TOPIC_CMD, TOPIC_DEBUG, TOPIC_EVENTS,
                                 TOPIC_LIDAR, TOPIC_MAP, TOPIC_MOVERS, TOPIC_PERCEIVED, TOPIC_ROBOT, TOPIC_SCENE,
                                 TOPIC_TERRAIN, TOPIC_TERRAIN_MESH, TOPIC_TF, TOPIC_TRUTH, SensorRecorder,
                                 TraceMessages, command_class, sensor_topics)

if TYPE_CHECKING:
    from navstress.sim.simulation import Simulation
    from navstress.world.world import World

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
#: Wall seconds a server stays up after the run's last message when a client is watching.
LINGER_S = 1.0
#: Messages the server queues per client before it drops the oldest (the SDK's default is 1,024,
#: a second of a run at 8x: a viewer on a loaded machine lost whole topics).
BACKLOG = 32_768
#: Most simulated seconds between two lidar clouds sent live.
LIDAR_PERIOD_S = 0.5
#: Fewest simulated seconds between two readings of one sensor sent live (a 40 Hz scanner: 10 a second).
SENSOR_PERIOD_S = 0.1
#: Wall seconds without a new subscription after which a client's subscriptions count as settled
#: and the run starts (:meth:`LivePublisher._settle`), and the longest such wait.
SETTLE_S = 0.2
SETTLE_MAX_S = 2.0


@dataclass(frozen=True)
class LiveSettings:
    """Where to serve and how fast to run (picklable: it travels to the run's worker process)."""

    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT
    speed: float = 1.0  # simulated seconds per wall-clock second
    wait_s: float = 30.0  # longest wait for a client before the run starts anyway


#: The logger the Foxglove SDK's server logs to (about its clients: handshakes, bad messages).
SDK_LOGGER = "foxglove"
#: Most lines about clients printed per :data:`LOG_WINDOW_S` seconds (the others are counted).
LOG_BURST = 3
LOG_WINDOW_S = 10.0
#: Longest line about a client, in characters (what a client sent is cut to fit).
LOG_LINE_CHARS = 200


class ClientLog(logging.Handler):
    """Prints what the Foxglove server logs about its clients on standard error, safely: one line
    per message, ``live: `` and the message with every control character escaped, at most
    :data:`LOG_LINE_CHARS` characters; at most :data:`LOG_BURST` lines per :data:`LOG_WINDOW_S`
    seconds, the rest counted and said in one line (when the next window opens, or at
    :meth:`flush_counts`). Installed on the SDK's logger for the life of a server (:meth:`install`)."""

    def __init__(self, stream: IO[str] | None = None, *, burst: int = LOG_BURST, window_s: float = LOG_WINDOW_S,
                 width: int = LOG_LINE_CHARS) -> None:
        super().__init__(logging.WARNING)
        self._stream = stream
        self.burst, self.window_s, self.width = burst, window_s, width
        self._window0 = -math.inf
        self._shown = 0
        self.suppressed = 0
        self._saved: tuple[bool, int] | None = None

    def install(self) -> "ClientLog":
        """Take the SDK's log lines (they no longer reach Python's last-resort handler raw)."""
        log = logging.getLogger(SDK_LOGGER)
        self._saved = (log.propagate, log.level)
        log.addHandler(self)
        log.propagate = False
        if log.level == logging.NOTSET:
            log.setLevel(logging.WARNING)
        return self

    def uninstall(self) -> None:
        """Give the logger back as it was, after saying how many lines were not shown."""
        self.flush_counts()
        log = logging.getLogger(SDK_LOGGER)
        log.removeHandler(self)
        if self._saved is not None:
            log.propagate, level = self._saved
            log.setLevel(level)
            self._saved = None

    def _write(self, text: str) -> None:
        stream = self._stream if self._stream is not None else sys.stderr
        try:
            stream.write(text + "\n")
            stream.flush()
        except (OSError, ValueError):  # a closed or broken standard error: nothing to tell
            pass

    def _say_suppressed(self) -> None:
        n, self.suppressed = self.suppressed, 0
        if n:
            self._write(f"live: {n} more message(s) about clients not shown (at most {self.burst} lines per "
                        f"{self.window_s:g} s)")

    def flush_counts(self) -> None:
        """Say how many lines were not shown since the last time, if any."""
        self.acquire()
        try:
            self._say_suppressed()
        finally:
            self.release()

    def emit(self, record: logging.LogRecord) -> None:  # called with the handler's lock held
        try:
            text = record.getMessage()
        except Exception:  # a record whose arguments do not format: its raw text
            text = str(record.msg)
        now = time.monotonic()
        if now - self._window0 >= self.window_s:
            self._say_suppressed()
            self._window0, self._shown = now, 0
        if self._shown >= self.burst:
            self.suppressed += 1
            return
        self._shown += 1
        self._write("live: " + one_line(text, self.width - len("live: ")))


class LivePublisher(TraceMessages):
    """A Foxglove WebSocket server for one run (module doc); a :class:`~navstress.run.mission.RunWatcher`."""

    def __init__(self, settings: LiveSettings, robot: RobotSpec | None = None) -> None:
        import foxglove  # local: only live runs need the server

        self.settings = settings
        self._fg = foxglove
        self._ctx = foxglove.Context()
        self._channels: dict[str, Any] = {}
        self._subscribed = threading.Event()
        self._resend = threading.Event()
        self._last_subscribe = 0.0
        #: topics whose channel was made while a client could be connected (:meth:`_channel`)
        self.late_topics: list[str] = []
        self._serving = False
        outer = self

        class Listener(foxglove.ServerListener):  # type: ignore[misc,name-defined]
            def on_subscribe(self, client: Any, channel: Any) -> None:
                outer._last_subscribe = time.monotonic()
                outer._subscribed.set()
                outer._resend.set()

        # every channel of the run made before the server starts (module doc, "Every channel
        # before the server"): a channel made later races its own advertisement
        self._sensors = SensorRecorder((robot.sensors or ()) if robot is not None else (), SENSOR_PERIOD_S)
        self._advertise(self._sensors)
        self._log = ClientLog().install()  # before the server: its first client may be a bad one
        try:
            self._server = foxglove.start_server(name="navstress", host=settings.host, port=settings.port,
                                                 context=self._ctx, server_listener=Listener(),
                                                 message_backlog_size=BACKLOG)
        except BaseException:
            self._log.uninstall()
            raise
        self._serving = True
        self._statics: list[tuple[str, Any, int]] | None = None
        self._collecting = False
        self._events_sent: Counter[tuple[float, str, str]] = Counter()
        self._drawings_sent = 0
        self._maps_sent = 0
        self._next_lidar = 0.0
        self._wall0 = 0.0

    @property
    def port(self) -> int:
        return int(self._server.port)

    def _advertise(self, sensors: SensorRecorder) -> None:
        """A channel for every topic a run sends (:func:`_topics`) and for ``sensors``' topics."""
        for topic, cls in _topics().items():
            self._channel(topic, cls)
        for sensor in sensors.sensors:
            for topic, cls in sensor_topics(sensor).items():
                self._channel(topic, cls)

    def _channel(self, topic: str, cls: Any) -> Any:
        ch = self._channels.get(topic)
        if ch is None:
            if self._serving:  # (only for a robot other than the one the publisher was made for)
                self.late_topics.append(topic)
            fds = build_file_descriptor_set(cls)
            schema = self._fg.Schema(name=cls.DESCRIPTOR.full_name, encoding="protobuf", data=fds.SerializeToString())
            ch = self._channels[topic] = self._fg.Channel(topic, schema=schema, message_encoding="protobuf",
                                                          context=self._ctx)
        return ch

    def _put(self, topic: str, msg: Any, log_time: int) -> None:
        if self._statics is not None and self._collecting:
            self._statics.append((topic, msg, log_time))
        self._channel(topic, type(msg)).log(msg.SerializeToString(), log_time=log_time)

    # -- the run's hooks (navstress.run.mission.RunWatcher) --------------------------------------------
    def start(self, world: World, robot: RobotSpec, sim: Simulation) -> None:
        """Send the world and the robot, wait for a client (at most ``wait_s``) and its
        subscriptions to settle, start the clock. (Every channel was advertised before the
        server started: a client subscribes when it learns of a channel, and a message sent
        before that is lost to it.)"""
        self._sensors = SensorRecorder(robot.sensors or (), SENSOR_PERIOD_S)
        self._advertise(self._sensors)  # nothing new unless ``robot`` is not the publisher's
        self._statics, self._collecting = [], True
        world_messages(self, world)
        self.robot(robot, belief=True)
        self._collecting = False
        if self._subscribed.wait(max(0.0, self.settings.wait_s)):
            self._settle()
        self._wall0 = time.monotonic() - sim.t / self.settings.speed

    def _settle(self) -> None:
        """After a client's first subscription: wait until none came for :data:`SETTLE_S` (at
        most :data:`SETTLE_MAX_S`). The server takes a request for several channels one channel
        at a time; the run starting at the first would send its first steps to only some of them."""
        t_end = time.monotonic() + SETTLE_MAX_S
        while (now := time.monotonic()) < t_end:
            quiet = now - self._last_subscribe
            if quiet >= SETTLE_S:
                return
            time.sleep(min(SETTLE_S - quiet, t_end - now))

    def _resend_statics(self) -> None:
        if self._resend.is_set() and self._statics is not None:
            self._resend.clear()
            for topic, msg, log_time in self._statics:
                self._put(topic, msg, log_time)

    def update(self, sim: Simulation, obs: Any, navigator: Any, commands: list[tuple[float, float, float]],
               events: list[tuple[float, str, str]], view: NavigatorView | None) -> None:
        """After a control step: send what changed (module doc), then sleep until the wall clock
        catches up with the simulated one."""
        self._resend_statics()
        truth = np.array([true_pose(sim)])
        self.poses(TOPIC_TRUTH, truth)
        self.transforms(FRAME, FRAME_ROBOT, truth)
        perceived = attr_through_wrappers(navigator, "perceived_trajectory")
        if callable(perceived):
            try:
                rows = np.asarray(perceived(), dtype=np.float64).reshape(-1, 7)
            except Exception:  # the trace's reader of the hook says what went wrong, at the end
                rows = np.zeros((0, 7))
            if len(rows):
                self.poses(TOPIC_PERCEIVED, rows[-1:])
                self.transforms(FRAME, BELIEF + FRAME_ROBOT, rows[-1:])
        if commands:
            self.commands(np.array(commands[-1:]))
        movers = sim.world.movers
        if movers:
            self.movers(np.array([sim.t]), sim.mover_poses()[None], [(mv.id, mv.kind, mv.shape, mv.size) for mv in movers])
        self._send_new(events, view)
        scans = [s for s in obs.scans if len(s.points) and s.sensor == FRAME_LIDAR]
        if scans and scans[-1].t >= self._next_lidar - 1e-9:
            self._next_lidar = scans[-1].t + LIDAR_PERIOD_S
            self.points(scans[-1].t, scans[-1].points, frame=FRAME_LIDAR)
        for sensor, reading in self._sensors.take(getattr(obs, "readings", {})):
            self.reading(sensor, reading)
        delay = self._wall0 + sim.t / self.settings.speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def _send_new(self, events: list[tuple[float, str, str]], view: NavigatorView | None) -> None:
        for t, level, msg in unsent(events, self._events_sent):
            self.event(t, level, msg)
            self._events_sent[(t, level, msg)] += 1
        if view is not None:
            for t, draw in view.drawings[self._drawings_sent:]:
                self.debug(t, draw)
            self._drawings_sent = len(view.drawings)
            for t, grid, origin, cell in view.maps[self._maps_sent:]:
                self.grid(TOPIC_MAP, t, grid, origin, cell)
            self._maps_sent = len(view.maps)

    def finish(self, result: RunResult, view: NavigatorView | None) -> None:
        """The end: the last events (with the outcome) and the final map."""
        self._send_new(result.events, view)
        if result.final_map is not None:
            grid, origin, cell = result.final_map
            self.grid(TOPIC_MAP, result.duration_s, np.asarray(grid, dtype=np.float32), origin, float(cell))

    def close(self) -> None:
        """Stop the server; a watching client first gets :data:`LINGER_S` to receive the last
        messages (the server sends from its own threads, and stopping drops what is queued)."""
        if self._subscribed.is_set():
            time.sleep(LINGER_S)
        try:
            self._server.stop()
        finally:
            self._log.uninstall()


def unsent(events: list[tuple[float, str, str]], sent: Counter[tuple[float, str, str]]) -> list[tuple[float, str, str]]:
    """``events`` less those already ``sent`` (counted, not by position: at its end a run adds the
    events it found afterwards, collisions for one, and sorts them all by time).

        >>> unsent([(1.0, "warning", "hit"), (2.0, "info", "a"), (3.0, "info", "end")], Counter([(2.0, "info", "a")]))
        [(1.0, 'warning', 'hit'), (3.0, 'info', 'end')]
    """
    left = Counter(sent)
    out = []
    for e in events:
        if left[e] > 0:
            left[e] -= 1
        else:
            out.append(e)
    return out


def _topics() -> dict[str, Any]:
    """Every topic a live run sends, with its protobuf message class."""
    return {TOPIC_TF: FrameTransform, TOPIC_TRUTH: PoseInFrame, TOPIC_PERCEIVED: PoseInFrame,
            TOPIC_EVENTS: Log, TOPIC_SCENE: SceneUpdate, TOPIC_ROBOT: SceneUpdate,
            TOPIC_TERRAIN_MESH: SceneUpdate, TOPIC_MOVERS: SceneUpdate, TOPIC_DEBUG: SceneUpdate,
            TOPIC_TERRAIN: Grid, TOPIC_MAP: Grid, TOPIC_LIDAR: PointCloud, TOPIC_CMD: command_class()}


def execute_live(task: RunTask, settings: LiveSettings) -> RunRecord:
    """:func:`navstress.run.mission.execute` with the run shown live (module doc); the server
    stops when the run ends."""
    if not (math.isfinite(settings.speed) and settings.speed > 0):
        raise ValueError(f"speed={settings.speed!r}: expected a number > 0")
    pub = LivePublisher(settings, task.robot_spec())
    try:
        return execute(task, watch=pub)
    finally:
        pub.close()
