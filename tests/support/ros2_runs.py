"""What the ROS 2 end-to-end and fault tests share: the test stack's path, the robot (a Jackal
with a UST-10-class scanner 0.3 m up), a small flat world, and whether a process is gone."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from navstress.world import Mission, Obstacle, World, WorldSpec

STACK = str(Path(__file__).resolve().parent / "ros2_stack.py")
ROBOT: dict[str, Any] = {"base": "jackal", "sensors": [
    {"name": "front_laser", "kind": "lidar2d", "profile": "ust10", "mount": {"xyz": [0.12, 0, 0.3], "rpy": [0, 0, 0]}}]}


def world() -> World:
    """16 m, flat, no obstacle; start (3, 3) facing +x, goal (10, 5), 1 m."""
    return World.flat(WorldSpec(size_m=(16.0, 16.0)), mission=Mission((3.0, 3.0, 0.0), (10.0, 5.0), 1.0))


def world_past_a_box() -> World:
    """14 m, flat, a 0.6 m box just off the line from start (3, 3) to goal (11, 3): the scan sees it
    within the test stack's 0.6 m clear radius, so each command depends on the cycle's scan too."""
    box = Obstacle("building", 7.0, 3.3, 0.0, (0.6, 0.6, 1.0), 0.0)
    return World.flat(WorldSpec(size_m=(14.0, 14.0)), obstacles=(box,), mission=Mission((3.0, 3.0, 0.0), (11.0, 3.0), 1.0))


def gone(pid: int) -> bool:
    """Whether no process ``pid`` exists any more (it was stopped and reaped)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False
