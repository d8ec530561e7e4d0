"""The observer: ground truth that the navigator never sees.

Real poses at a fixed rate in growable arrays; collision, flipped-over and left-the-map events.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


#: A robot slower than this (m/s, planar, true) when a mover touches it was standing: it was hit.
STATIONARY_MPS = 0.05


@dataclass(frozen=True)
class CollisionEvent:
    """The robot's bumper touched obstacle ``obstacle`` at time ``t`` at robot position (x, y).

    A contact with a mover has ``obstacle`` -1 and ``mover`` its id, with the robot's and the
    mover's planar speeds and the norm of their velocity difference at the step of the contact
    (true values, m/s)."""

    t: float
    x: float
    y: float
    obstacle: int
    mover: int | None = None
    robot_speed: float = 0.0
    mover_speed: float = 0.0
    relative_speed: float = 0.0

    @property
    def robot_hit(self) -> bool:
        """A mover hit the robot while it stood (robot slower than :data:`STATIONARY_MPS`, the
        mover not): the robot did not cause it."""
        return self.mover is not None and self.robot_speed < STATIONARY_MPS <= self.mover_speed


@dataclass(frozen=True)
class StopEvent:
    """The run cannot go on: ``kind`` is "flipped" or "left_map"."""

    t: float
    x: float
    y: float
    kind: str
    reason: str


POSE_FIELDS = ("t", "x", "y", "z", "yaw", "pitch", "roll")


class Observer:
    """Records real poses (t, x, y, z, yaw, pitch, roll) and events.

    Collisions are debounced: contact with an obstacle that was last touched less than
    ``debounce_s`` ago continues the same event; ``contact_starts`` counts every start.
    """

    def __init__(self, debounce_s: float) -> None:
        self._poses = np.zeros((256, 7), np.float64)
        self._n = 0
        self.debounce_s = debounce_s
        self.collisions: list[CollisionEvent] = []
        self.contact_starts = 0
        self.stop: StopEvent | None = None
        self._last_touch: dict[int, float] = {}
        self._touching: set[int] = set()

    def record_pose(self, row: tuple[float, float, float, float, float, float, float]) -> None:
        if self._n == self._poses.shape[0]:
            self._poses = np.concatenate([self._poses, np.zeros_like(self._poses)])
        self._poses[self._n] = row
        self._n += 1

    def record_poses(self, rows: np.ndarray) -> None:
        """Append (n, 7) rows (t, x, y, z, yaw, pitch, roll)."""
        n = rows.shape[0]
        while self._n + n > self._poses.shape[0]:
            self._poses = np.concatenate([self._poses, np.zeros_like(self._poses)])
        self._poses[self._n: self._n + n] = rows
        self._n += n

    @property
    def poses(self) -> np.ndarray:
        """(n, 7) array of (t, x, y, z, yaw, pitch, roll), a read-only view."""
        v = self._poses[: self._n]
        v.flags.writeable = False
        return v

    def contacts(self, t: float, x: float, y: float, obstacles: set[int]) -> None:
        """The set of obstacles the bumper touches after the step at time ``t``."""
        for o in obstacles - self._touching:
            self.contact_starts += 1
            last = self._last_touch.get(o)
            if last is None or t - last > self.debounce_s:
                self.collisions.append(CollisionEvent(t, x, y, o))
        for o in obstacles:
            self._last_touch[o] = t
        self._touching = obstacles

    def stopped(self, ev: StopEvent) -> None:
        if self.stop is None:
            self.stop = ev
