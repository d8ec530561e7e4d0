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

from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from navstress.robot import RobotSpec

__all__ = [
    "Command", "Imu", "LidarScan", "NavMission", "Navigator", "Observation", "Odometry",
    "PoseReading", "Status",
]


@dataclass(frozen=True)
class NavMission:
    """What the navigator is asked to do. Coordinates are in the pose sensor's frame (map frame)."""

    start: tuple[float, float, float]  # x, y, yaw as given to the robot's operator
    goal: tuple[float, float]
    goal_tolerance_m: float = 2.0


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
