"""StraightLineNavigator: drive straight at the goal using the pose sensor (naive on purpose).

Pose estimate: the latest pose-sensor reading, propagated by the odometry increments since it
(before the first reading: the mission start). Heading error -> turn rate (proportional, capped);
speed falls with the heading error and near the goal. ``Status("arrived")`` once the estimate is
within half the mission's goal tolerance (the estimate is noisy). It never looks at the lidar: obstacles are not its business.
Deterministic; the seed is not needed.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstress.errors import SpecError
from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.external import ExternalNavigator
from navstress.robot import RobotSpec

DEFAULTS: dict[str, float | None] = {
    "max_speed_mps": None,  # None: the RobotSpec's max speed
    "heading_gain": 1.5,  # rad/s of turn per rad of heading error
    "slowdown_radius_m": 2.0,  # speed ramps down linearly inside this distance to the goal
}


def _wrap(a: float) -> float:
    return math.remainder(a, math.tau)


class StraightLineNavigator:
    """A naive go-to-goal controller (module doc); ``config`` keys: see ``DEFAULTS``."""

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        cfg = dict(config or {})
        for key in cfg:
            if key not in DEFAULTS:
                raise SpecError(f"navigator-config.{key}", cfg[key],
                                f"one of {', '.join(DEFAULTS)}")
        self.params = {**DEFAULTS, **cfg}
        self._mission: NavMission | None = None

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self._mission = mission
        self._robot = robot
        self._fix = mission.start  # last pose fix in the map frame (x, y, yaw)
        self._odom_at_fix: tuple[float, float, float] | None = None

    def _estimate(self, obs: Observation) -> tuple[float, float, float]:
        o = obs.odom
        if obs.pose is not None:
            self._fix = (obs.pose.x, obs.pose.y, obs.pose.yaw)
            self._odom_at_fix = (o.x, o.y, o.yaw)
        if self._odom_at_fix is None:
            self._odom_at_fix = (o.x, o.y, o.yaw)
        fx, fy, fyaw = self._fix
        ox, oy, oyaw = self._odom_at_fix
        rot = fyaw - oyaw  # odometry frame -> map frame
        dx, dy = o.x - ox, o.y - oy
        c, s = math.cos(rot), math.sin(rot)
        return fx + c * dx - s * dy, fy + s * dx + c * dy, _wrap(fyaw + (o.yaw - oyaw))

    def step(self, obs: Observation) -> Command | Status:
        if self._mission is None:
            return Status("error", "step before reset")
        x, y, yaw = self._estimate(obs)
        gx, gy = self._mission.goal
        dist = math.hypot(gx - x, gy - y)
        if dist <= 0.5 * self._mission.goal_tolerance_m:  # aim well inside: the estimate is noisy
            return Status("arrived", f"{dist:.2f} m from the goal")
        err = _wrap(math.atan2(gy - y, gx - x) - yaw)
        robot = self._robot
        vmax = min(float(self.params["max_speed_mps"] or robot.max_speed_mps), robot.max_speed_mps)
        omega = max(-robot.max_yaw_rate_rps,
                    min(robot.max_yaw_rate_rps, float(self.params["heading_gain"]) * err))
        ramp = min(1.0, dist / float(self.params["slowdown_radius_m"]))
        v = vmax * max(0.0, math.cos(err)) ** 2 * ramp
        return Command(v, omega)

    def close(self) -> None:
        self._mission = None


STDIO_SCRIPT = Path(__file__).with_name("stdio_nav.py")


def stdio_navigator(*, config: Mapping[str, Any] | None = None) -> ExternalNavigator:
    """``straightline-stdio-v1``: :data:`STDIO_SCRIPT` run out of process.

    ``step_budget_s``/``reset_budget_s`` go to the adapter, the other keys to the script.
    """
    import json

    cfg = dict(config or {})
    budgets = {k: cfg.pop(k) for k in ("step_budget_s", "reset_budget_s") if k in cfg}
    return ExternalNavigator([sys.executable, str(STDIO_SCRIPT), json.dumps(cfg)], **budgets)
