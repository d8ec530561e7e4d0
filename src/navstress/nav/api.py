"""The navigator contract: what a navigation stack under test receives and returns.

DESIGN invariant 1: a navigator sees no ground truth. It gets a :class:`NavMission`, the
:class:`~navstress.robot.RobotSpec` it *believes* in, and each control cycle an
:class:`Observation` made only of sensor readings; it answers a :class:`Command`
(velocities) or a :class:`Status` (arrived, or error with a message).

This module imports nothing from ``navstress.sim`` or ``navstress.world``.

    >>> class Stop:
    ...     def reset(self, mission, robot, *, seed): pass
    ...     def step(self, obs): return Command(0.0, 0.0)
    ...     def close(self): pass
    >>> isinstance(Stop(), Navigator)
    True
"""

from __future__ import annotations

import math
import signal
from dataclasses import dataclass, field
from collections.abc import Mapping
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

from navstress.robot import RobotSpec
from navstress.sensors.kinds.depth import DepthImage
from navstress.sensors.kinds.imu import Imu
from navstress.sensors.kinds.lidar2d import LaserScan
from navstress.sensors.kinds.lidar3d import LidarScan
from navstress.sensors.kinds.odometry import Odometry
from navstress.sensors.kinds.pose import PoseReading

__all__ = [
    "Command", "DebugDraw", "DepthImage", "LaserScan", "DebugLine", "DebugPoints", "DebugText", "Imu", "InvalidAnswer", "LidarScan",
    "NavMission", "Navigator", "Observation", "Odometry", "PoseReading", "PriorMap", "Status", "check_answer",
    "check_debug",
    "raised_by_navigator",
]


@dataclass(frozen=True)
class NavMission:
    """What the navigator is asked to do. Coordinates are in the pose sensor's frame (map frame)."""

    start: tuple[float, float, float]  # x, y, yaw as given to the robot's operator
    goal: tuple[float, float]
    goal_tolerance_m: float = 2.0
    #: The mission area, a geofence the robot's centre must stay inside: ``(xmin, ymin, xmax,
    #: ymax)`` in the map frame; None when no area is given. Leaving it ends the run as the
    #: stack's own failure (Fail-Error, "left the mission area").
    bounds: tuple[float, float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class Observation:
    """Everything a navigator gets at one control cycle. Sensor fields are the latest readings
    taken since the previous cycle; ``None`` when that sensor produced nothing new."""

    t: float
    odom: Odometry
    imu: Imu
    pose: PoseReading | None = None
    #: the 3-D lidars' scans (every ``lidar3d`` sensor's, in the order taken): where navigators
    #: written before sensors were declared read them
    scans: tuple[LidarScan, ...] = field(default_factory=tuple)
    #: every reading since the previous cycle by sensor name (the robot's ``sensors``, see
    #: docs/sensors.md): a tuple each, in the order taken; a sensor with no new reading is absent.
    #: The built-in sensors are here too: ``odom`` and ``imu`` (the latest), ``pose`` (when new).
    readings: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)

    def latest(self, name: str) -> Any:
        """The newest reading of sensor ``name`` since the previous cycle, or None."""
        r = self.readings.get(name)
        return r[-1] if r else None


@dataclass(frozen=True)
class Command:
    """Body velocities: linear ``v`` (m/s, forward positive) and angular ``omega`` (rad/s, CCW)."""

    v: float
    omega: float


@dataclass(frozen=True)
class Status:
    """The navigator's own verdict: it has arrived, or it gives up with an error message."""

    kind: Literal["arrived", "error"]
    message: str = ""
    #: True when the error is not the stack's own verdict but a failure around it (its process
    #: died, hung, or spoke garbage): the run is then Fail-Other, not Fail-Error.
    infrastructure: bool = False


@dataclass(frozen=True, eq=False)
class PriorMap:
    """A prior map of the world's static obstacles, for a navigator whose USER asked for one (as
    a ROS 2 user runs Nav2's ``map_server`` with a map file): handed over only through the
    optional hook ``prior_map(provider)`` (see :class:`Navigator`), never otherwise; the default
    is no map. ``occupied``: (rows, cols) bool, True where an obstacle may touch the cell; row
    ``i``, column ``j`` is the square of side ``cell_m`` whose lower-left corner is
    ``origin_xy + (j, i) * cell_m`` in the map frame (rows along +y). Terrain relief and movers
    are not in it."""

    occupied: np.ndarray
    origin_xy: tuple[float, float]
    cell_m: float


@runtime_checkable
class Navigator(Protocol):
    """The contract every navigation stack under test implements (in-process).

    ``reset`` is called once per run before the first ``step``; the robot it gets names its
    sensors (``robot.sensors``: name, kind, mount, parameters; never None there); all randomness inside the
    navigator must come from ``seed``. ``step`` is called at the navigator's control rate on
    simulated time. ``close`` releases resources; it is always called, even after an error.

    Optional hooks the run loop uses when present (docs/plugins.md): ``control_rate_hz``,
    ``perceived_trajectory()``, ``final_map()`` (also read once per simulated second when the run
    records the navigator's view), ``debug()`` (a :class:`DebugDraw` of the last step, or None;
    read after every step when the run records the navigator's view) and ``want_debug(on)``
    (told before ``reset`` whether ``debug()`` will be read, so its work can be skipped),
    ``prior_map(provider)`` (called once before ``reset``; ``provider(cell_m)`` returns the
    world's :class:`PriorMap` at that cell size, for a navigator configured to be given one:
    ground truth a user chose to give, as a prior map is in a real deployment).
    """

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None: ...

    def step(self, obs: Observation) -> Command | Status: ...

    def close(self) -> None: ...


STATUS_KINDS = ("arrived", "error")


class InvalidAnswer(ValueError):
    """A navigator's answer to ``step`` that is not a valid Command or Status (says why)."""


def _real(obj: str, name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InvalidAnswer(f"{obj}.{name}={value!r:.80} is a {type(value).__name__}, not a number")
    f = float(value)
    if not math.isfinite(f):
        raise InvalidAnswer(f"{obj}.{name}={value!r} is not finite")
    return f


def check_answer(out: object) -> Command | Status:
    """``out`` checked as an answer to ``step``: a Command with finite numbers, or a Status
    whose ``kind`` is ``"arrived"`` or ``"error"`` and whose ``message`` is a string.

    The one validation of answers: the run loop applies it to in-process navigators, the line
    protocol to decoded replies, the conformance checker to both, so that one bad answer gets
    the same classification and reason whichever way it came. :class:`InvalidAnswer` says
    what is wrong.

        >>> check_answer(Status("exploded"))  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        navstress.nav.api.InvalidAnswer: Status.kind='exploded' is not 'arrived' or 'error'
    """
    if isinstance(out, Command):
        return Command(_real("Command", "v", out.v), _real("Command", "omega", out.omega))
    if isinstance(out, Status):
        if not isinstance(out.kind, str) or out.kind not in STATUS_KINDS:
            raise InvalidAnswer(f"Status.kind={out.kind!r:.80} is not 'arrived' or 'error'")
        if not isinstance(out.message, str):
            raise InvalidAnswer(f"Status.message={out.message!r:.80} is a {type(out.message).__name__}, "
                                "not a string")
        if not isinstance(out.infrastructure, bool):
            raise InvalidAnswer(f"Status.infrastructure={out.infrastructure!r:.80} is not a bool")
        return out
    raise InvalidAnswer(f"step returned {type(out).__name__} ({out!r:.80}), not a Command or Status")


def raised_by_navigator(err: BaseException) -> bool:
    """Whether ``err``, raised out of a navigator's method, is the navigator's failure (to be
    classified) rather than a request to stop navstress itself.

    Every ``Exception``, ``SystemExit`` (``sys.exit`` in a plug-in) and ``GeneratorExit`` is the
    navigator's. ``KeyboardInterrupt`` is the user's Ctrl-C, except in a process that ignores
    SIGINT (the run and check workers do): there only the navigator can have raised it."""
    if isinstance(err, (Exception, SystemExit, GeneratorExit)):
        return True
    if isinstance(err, KeyboardInterrupt):
        return signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    return False


# ----------------------------------------------------------------------------- debug drawing
#: The frames a navigator draws in: ``"map"`` (the map frame, where its own pose estimate puts
#: things) and ``"robot"`` (its believed body frame: drawn on the belief's ``perceived/base_link``).
DEBUG_FRAMES = ("map", "robot")
#: Most points (over all lines and point sets) and texts one drawing may hold.
MAX_DEBUG_POINTS = 20_000
MAX_DEBUG_TEXTS = 50
#: Most characters of one debug text.
MAX_DEBUG_TEXT_CHARS = 200

Rgba = tuple[float, float, float, float]


@dataclass(frozen=True, eq=False)
class DebugLine:
    """A polyline: ``points`` (N >= 2, 3) in ``frame`` (:data:`DEBUG_FRAMES`), ``colour`` RGBA in
    [0, 1], ``width_m`` its width in meters."""

    points: np.ndarray
    frame: str = "map"
    colour: Rgba = (1.0, 1.0, 1.0, 1.0)
    width_m: float = 0.05


@dataclass(frozen=True, eq=False)
class DebugPoints:
    """Points (N >= 1, 3) in ``frame``, drawn as dots of ``size_m``."""

    points: np.ndarray
    frame: str = "map"
    colour: Rgba = (1.0, 1.0, 1.0, 1.0)
    size_m: float = 0.15


@dataclass(frozen=True)
class DebugText:
    """A label at ``position`` (x, y, z) in ``frame``, ``size_m`` high."""

    position: tuple[float, float, float]
    text: str
    frame: str = "robot"
    colour: Rgba = (1.0, 1.0, 1.0, 1.0)
    size_m: float = 0.4


@dataclass(frozen=True, eq=False)
class DebugDraw:
    """What a navigator shows of its reasoning at one step (optional hook ``debug()``, see
    :class:`Navigator`): lines, points and texts. Recorded in the trace when the run records the
    navigator's view, never read by the simulation: it cannot change a run."""

    lines: tuple[DebugLine, ...] = ()
    points: tuple[DebugPoints, ...] = ()
    texts: tuple[DebugText, ...] = ()


def _frame(obj: str, value: object) -> str:
    if not isinstance(value, str) or value not in DEBUG_FRAMES:
        raise InvalidAnswer(f"{obj}.frame={value!r:.80} is not one of {', '.join(map(repr, DEBUG_FRAMES))}")
    return value


def _colour(obj: str, value: object) -> Rgba:
    if not isinstance(value, (tuple, list, np.ndarray)):
        raise InvalidAnswer(f"{obj}.colour={value!r:.80} is not 4 numbers (r, g, b, a)")
    c = tuple(_real(obj, "colour", v) for v in value)
    if len(c) != 4 or not all(0.0 <= v <= 1.0 for v in c):
        raise InvalidAnswer(f"{obj}.colour={value!r:.80} is not 4 numbers (r, g, b, a) in [0, 1]")
    return (c[0], c[1], c[2], c[3])


def _positive(obj: str, name: str, value: object) -> float:
    f = _real(obj, name, value)
    if not 0.0 < f <= 100.0:
        raise InvalidAnswer(f"{obj}.{name}={value!r:.80} is not in (0, 100] meters")
    return f


def _points(obj: str, value: object, least: int) -> np.ndarray:
    try:
        p = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidAnswer(f"{obj}.points is not an array of numbers") from None
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < least:
        raise InvalidAnswer(f"{obj}.points has shape {p.shape}, not (N, 3) with N >= {least}")
    if not np.isfinite(p).all():
        raise InvalidAnswer(f"{obj}.points holds a value that is not finite")
    return p


def check_debug(draw: object) -> DebugDraw:
    """``draw`` checked as a navigator's debug drawing, copied (a navigator may reuse its arrays):
    lines of (N >= 2, 3) finite points, point sets of (N >= 1, 3), texts of at most
    :data:`MAX_DEBUG_TEXT_CHARS` characters, frames from :data:`DEBUG_FRAMES`, RGBA colours in
    [0, 1], sizes in (0, 100] m, at most :data:`MAX_DEBUG_POINTS` points and
    :data:`MAX_DEBUG_TEXTS` texts in all. :class:`InvalidAnswer` says what is wrong.

        >>> check_debug(DebugDraw(lines=(DebugLine(np.zeros((1, 3))),)))  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        navstress.nav.api.InvalidAnswer: lines[0].points has shape (1, 3), not (N, 3) with N >= 2
    """
    if not isinstance(draw, DebugDraw):
        raise InvalidAnswer(f"debug returned {type(draw).__name__} ({draw!r:.80}), not a DebugDraw or None")
    out_l, out_p, out_t = [], [], []
    for kind, items in (("lines", draw.lines), ("points", draw.points), ("texts", draw.texts)):
        if not isinstance(items, (tuple, list)):
            raise InvalidAnswer(f"DebugDraw.{kind} is a {type(items).__name__}, not a tuple")
        for i, item in enumerate(items):
            obj = f"{kind}[{i}]"
            if kind == "lines" and isinstance(item, DebugLine):
                out_l.append(DebugLine(_points(obj, item.points, 2), _frame(obj, item.frame),
                                       _colour(obj, item.colour), _positive(obj, "width_m", item.width_m)))
            elif kind == "points" and isinstance(item, DebugPoints):
                out_p.append(DebugPoints(_points(obj, item.points, 1), _frame(obj, item.frame),
                                         _colour(obj, item.colour), _positive(obj, "size_m", item.size_m)))
            elif kind == "texts" and isinstance(item, DebugText):
                if not isinstance(item.text, str):
                    raise InvalidAnswer(f"{obj}.text is a {type(item.text).__name__}, not a string")
                if len(item.text) > MAX_DEBUG_TEXT_CHARS:
                    raise InvalidAnswer(f"{obj}.text has {len(item.text):,} characters, more than "
                                        f"{MAX_DEBUG_TEXT_CHARS}")
                try:
                    pos = np.array(item.position, dtype=np.float64)
                except (TypeError, ValueError):
                    pos = np.zeros(0)
                if pos.shape != (3,) or not np.isfinite(pos).all():
                    raise InvalidAnswer(f"{obj}.position={item.position!r:.80} is not 3 finite numbers (x, y, z)")
                out_t.append(DebugText((float(pos[0]), float(pos[1]), float(pos[2])), item.text,
                                       _frame(obj, item.frame), _colour(obj, item.colour),
                                       _positive(obj, "size_m", item.size_m)))
            else:
                want = {"lines": "DebugLine", "points": "DebugPoints", "texts": "DebugText"}[kind]
                raise InvalidAnswer(f"{obj} is a {type(item).__name__}, not a {want}")
    n = sum(len(x.points) for x in out_l) + sum(len(x.points) for x in out_p)
    if n > MAX_DEBUG_POINTS:
        raise InvalidAnswer(f"the drawing has {n:,} points, more than {MAX_DEBUG_POINTS:,}")
    if len(out_t) > MAX_DEBUG_TEXTS:
        raise InvalidAnswer(f"the drawing has {len(out_t)} texts, more than {MAX_DEBUG_TEXTS}")
    return DebugDraw(tuple(out_l), tuple(out_p), tuple(out_t))
