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
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from navstress.robot import RobotSpec

__all__ = [
    "Command", "Imu", "InvalidAnswer", "LidarScan", "NavMission", "Navigator", "Observation",
    "Odometry", "PoseReading", "Status", "check_answer", "raised_by_navigator",
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
class LidarScan:
    """One full lidar revolution.

    ``points``: (N, 3) float32 hit points in the *sensor* frame (x forward, y left, z up),
    rays without a return omitted. ``t``: simulated time the scan was taken. ``mount``:
    sensor position (x, y, z) in the robot frame. The navigator places the scan in its map
    with its own pose estimate at time ``t``: the true pose is never given.
    """

    t: float
    points: np.ndarray
    mount: tuple[float, float, float]


@dataclass(frozen=True)
class Odometry:
    """Wheel odometry integrated from wheel rotation, in the odometry frame (starts at 0, 0, 0)."""

    t: float
    x: float
    y: float
    yaw: float
    v: float  # linear speed estimate, m/s
    omega: float  # yaw rate estimate, rad/s


@dataclass(frozen=True)
class PoseReading:
    """The pose sensor (the paper's "Pose"): noisy position and attitude in the map frame."""

    t: float
    x: float
    y: float
    z: float
    yaw: float
    pitch: float
    roll: float


@dataclass(frozen=True)
class Imu:
    """Attitude (roll, pitch; yaw drifts) and body angular rates."""

    t: float
    roll: float
    pitch: float
    yaw: float
    rates: tuple[float, float, float]  # body-frame angular velocity, rad/s


@dataclass(frozen=True, eq=False)
class Observation:
    """Everything a navigator gets at one control cycle. Sensor fields are the latest readings
    taken since the previous cycle; ``None`` when that sensor produced nothing new."""

    t: float
    odom: Odometry
    imu: Imu
    pose: PoseReading | None = None
    scans: tuple[LidarScan, ...] = field(default_factory=tuple)


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


@runtime_checkable
class Navigator(Protocol):
    """The contract every navigation stack under test implements (in-process).

    ``reset`` is called once per run before the first ``step``; all randomness inside the
    navigator must come from ``seed``. ``step`` is called at the navigator's control rate on
    simulated time. ``close`` releases resources; it is always called, even after an error.
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
