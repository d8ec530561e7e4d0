"""ReferenceNavigator (``reference-v1``): the paper's POM + DTM + P3D stack, rebuilt.

Each ``step``: POM fuses the cycle's odometry, IMU and pose readings; DTM integrates every new
scan with the pose estimate at the scan's time and marks the ground under the robot as known
(the robot stands on it; the lidar cannot see there); then either the initial scan manoeuvre
(turn on the spot, then drive a few meters straight) or P3D's arc election runs. Status
``arrived`` when the perceived position is within ``arrival_fraction`` (0.5) x the mission's goal tolerance (aiming well inside it);
``Status("error", "no arc elected")`` when no arc is electable. Both are latched: later steps
repeat them.

Only :mod:`navstress.nav.api` and :mod:`navstress.robot` are used (DESIGN invariant 1).
Deterministic given the seed and the observations; with the default ``cost_jitter=0`` the seed is
not even used.

    >>> from navstress.nav.api import Navigator
    >>> isinstance(ReferenceNavigator(), Navigator)
    True
"""

from __future__ import annotations

import math

import numpy as np

from navstress.errors import NavigatorError
from navstress.nav.api import Command, DebugDraw, DebugLine, DebugText, NavMission, Observation, Status
from navstress.nav.reference.config import ReferenceConfig
from navstress.nav.reference.planner import (_MAX_FP_CELLS, ArcEvaluation, ArcPlanner, _map_footprint_cells,
                                             footprint_half_extents, node_cost)
from navstress.nav.reference.pose import Pose, PoseEstimator, wrap_angle
from navstress.nav.reference.terrain_map import TerrainMap, step_threshold
from navstress.robot import RobotSpec
from navstress.seeding import rng

__all__ = ["NO_ARC", "ReferenceNavigator"]

NO_ARC = "no arc elected"


#: How far inside the mission area (``NavMission.bounds``) the planner keeps the robot's
#: centre: room for the error of its own pose estimate.
GEOFENCE_MARGIN_M = 0.5


class ReferenceNavigator:
    """The reference navigation stack under test (module doc). ``config`` defaults to
    :class:`ReferenceConfig`; the footprint comes from the RobotSpec given to :meth:`reset`."""

    name = "reference-v1"

    def __init__(self, config: ReferenceConfig | None = None) -> None:
        self.config: ReferenceConfig = config if config is not None else ReferenceConfig()
        self._ready = False

    # ----------------------------------------------------------------- protocol
    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        """Start a run: fresh pose filter, empty map, scan manoeuvre pending."""
        cfg = self.config
        if not all(math.isfinite(v) for v in (*mission.start, *mission.goal)):
            raise NavigatorError(f"mission start/goal must be finite, got {mission.start} -> {mission.goal}")
        if not mission.goal_tolerance_m > 0:
            raise NavigatorError(f"mission goal_tolerance_m={mission.goal_tolerance_m} must be > 0")
        self.mission = mission
        self.robot = robot
        self.seed = int(seed)
        self._rng = rng(self.seed, self.name)
        self.planner = ArcPlanner(cfg, robot)
        cfg = self.planner.config  # with the thresholds it leaves to the robot set (config.for_robot)
        assert cfg.obstacle_height_m is not None
        self.pom = PoseEstimator(mission.start, cfg.pose_tau_xy_s, cfg.pose_tau_yaw_s, cfg.history_s)
        step = step_threshold(cfg.obstacle_height_m, cfg.max_slope_deg, cfg.cell_m)
        self.terrain = TerrainMap.covering([mission.start[:2], mission.goal], cfg.map_margin_m, cfg.cell_m,
                                           step, cfg.max_range_m, cfg.obstacle_subcells)
        self._base_height = cfg.base_height_m if cfg.base_height_m is not None else robot.wheel_radius_m
        self.phase = "scan_turn" if cfg.scan_turn_deg > 0 else ("scan_align" if cfg.scan_forward_m > 0 else "navigate")
        self._turned = 0.0
        self._driven = 0.0
        self._prev_odom: tuple[float, float, float] | None = None
        self._last_t: float | None = None
        self._last_cmd = (0.0, 0.0)
        self._latched: Status | None = None
        self.last_evaluation: ArcEvaluation | None = None
        self.last_elected: int = -1
        self._last_pose: Pose | None = None
        self._evaluated_at: Pose | None = None  # the pose the last arc fan was evaluated from
        self._spin_latch = 0
        self.messages: list[tuple[float, str]] = []
        self._fp_buf = np.empty((2, _MAX_FP_CELLS), dtype=np.int64)  # rows i, columns j
        self._ready = True

    def step(self, obs: Observation) -> Command | Status:
        """One control cycle (module doc)."""
        if not self._ready:
            raise NavigatorError("step() called before reset()")
        if self._latched is not None:
            return self._latched
        pose = self.pom.update(obs.t, obs.odom, obs.imu, obs.pose)
        self._last_pose = pose
        for scan in obs.scans:
            self.terrain.integrate(scan.points, scan.mount, self.pom.pose_at(scan.t))
        self._mark_under_robot(pose)
        self._progress_manoeuvre(obs)
        dt = obs.t - self._last_t if self._last_t is not None else self.config.control_period_s
        self._last_t = obs.t
        gx, gy = self.mission.goal
        if math.hypot(pose.x - gx, pose.y - gy) <= self.config.arrival_fraction * self.mission.goal_tolerance_m:
            return self._latch(obs.t, Status("arrived"))
        if self.phase == "scan_turn":
            v, w = 0.0, min(self.config.scan_yaw_rate_rps, self.robot.max_yaw_rate_rps)
        elif self.phase == "scan_align":
            w = min(self.config.scan_yaw_rate_rps, self.robot.max_yaw_rate_rps)
            v, w = 0.0, math.copysign(w, self._goal_bearing_error())
        elif self.phase == "scan_forward":
            v, w = min(self.config.scan_speed_mps, self.planner.max_speed), 0.0
        else:
            self._on_cycle(obs.t, pose)
            # once turning on the spot, keep the direction until a forward arc is elected (no dithering)
            bearing = self._target_bearing(pose)
            spin = self._spin_latch if self._spin_latch != 0 else (1 if bearing >= 0 else -1)
            ev = self.planner.evaluate(self.terrain, pose.x, pose.y, pose.yaw, spin)
            goal = self._geofence(ev, pose, self._goal_terms(ev, pose))
            jitter = self._rng.uniform(0.0, self.config.cost_jitter, len(goal)) if self.config.cost_jitter > 0 else None
            idx = -1
            if abs(bearing) <= math.radians(self.config.spin_min_bearing_deg):
                # the target is within the forward fan's reach: a turn on the spot makes no progress
                idx = self.planner.elect(ev, np.where(ev.is_spin, np.inf, goal), jitter)
            if idx < 0:
                idx = self.planner.elect(ev, goal, jitter)
            self.last_evaluation, self.last_elected, self._evaluated_at = ev, idx, pose
            if idx < 0:
                return self._latch(obs.t, Status("error", NO_ARC))
            self._spin_latch = ev.spin_dir if bool(ev.is_spin[idx]) else 0
            v, w = self.planner.command(ev, idx)
        return self._limit(v, w, max(dt, 1e-6))

    def close(self) -> None:
        """Nothing to release (no threads, no files); the map and trajectory stay readable."""

    # ----------------------------------------------------------------- readouts
    def final_map(self) -> tuple[np.ndarray, tuple[float, float], float]:
        """(elevation float32 rows x cols with NaN = unknown, origin xy of cell [0, 0]'s corner, cell_m)."""
        self._require_reset()
        return self.terrain.elevation(), self.terrain.origin, self.terrain.cell_m

    def perceived_trajectory(self) -> np.ndarray:
        """(N, 7) float64: t, x, y, z, yaw, pitch, roll, one row per step since reset."""
        self._require_reset()
        return self.pom.trajectory()

    def debug(self) -> DebugDraw | None:
        """The last step's reasoning, drawn (read by the run when it records the navigator's view):
        the arc fan in the map frame just above the ground under the robot (its believed height
        less the base height): electable arcs green, refused ones red, the elected one thick
        yellow; over the robot a text with the phase, or the elected arc and its cost (or
        ``no arc elected``). None before the first step."""
        pose = self._last_pose
        if not self._ready or pose is None:
            return None
        texts: list[DebugText] = []
        ev, idx = self.last_evaluation, self.last_elected
        lines: list[DebugLine] = []
        if ev is not None and self._evaluated_at is pose:  # a fan evaluated at this step
            z = pose.z - self._base_height + 0.1
            ok = np.isfinite(ev.terrain_cost) & (ev.terrain_cost <= self.config.election_threshold)
            for a in range(len(ev.nodes)):
                if bool(ev.is_spin[a]) or a == idx:
                    continue  # a turn on the spot has no path to draw (the text says it); the elected arc last
                pts = self._arc_points(ev, a, pose, z)
                lines.append(DebugLine(pts, "map", (0.35, 0.8, 0.35, 0.7) if ok[a] else (0.9, 0.25, 0.2, 0.7), 0.04))
            if idx >= 0 and not bool(ev.is_spin[idx]):
                pts = self._arc_points(ev, idx, pose, z + 0.02)
                lines.append(DebugLine(pts, "map", (1.0, 0.85, 0.1, 1.0), 0.12))
            what = (NO_ARC if idx < 0 else f"turn in place, cost {float(ev.terrain_cost[idx]):.1f}" if ev.is_spin[idx]
                    else f"arc {idx}, cost {float(ev.terrain_cost[idx]):.1f}")
            texts.append(DebugText((0.0, 0.0, 1.2), f"{what} ({int(ok.sum())}/{len(ok)} electable)", "robot"))
        else:
            latched = self._latched
            what = (latched.kind + (f": {latched.message}" if latched.message else "") if latched is not None
                    else self.phase.replace("_", " "))
            texts.append(DebugText((0.0, 0.0, 1.2), what, "robot"))
        return DebugDraw(lines=tuple(lines), texts=tuple(texts))

    @staticmethod
    def _arc_points(ev: ArcEvaluation, a: int, pose: Pose, z: float) -> np.ndarray:
        """Arc ``a`` as a polyline from the believed position through its nodes, at height ``z``."""
        xy = np.vstack([[pose.x, pose.y], ev.nodes[a, :, :2]])
        return np.column_stack([xy, np.full(len(xy), z)])

    # ----------------------------------------------------------------- hooks (the global navigator overrides)
    def _on_cycle(self, t: float, pose: Pose) -> None:
        """Called once per navigation cycle before the arc election."""

    def _goal_terms(self, ev: ArcEvaluation, pose: Pose) -> np.ndarray:
        """goal_weight x the smallest straight-line distance from an arc's nodes to the goal
        (its end's unless the arc passes the goal; turn in place: from the current position, plus
        its penalty)."""
        gx, gy = self.mission.goal
        d = np.hypot(ev.nodes[:, :, 0] - gx, ev.nodes[:, :, 1] - gy).min(axis=1)
        d = np.where(ev.is_spin, math.hypot(pose.x - gx, pose.y - gy) + self.config.turn_in_place_penalty_m, d)
        return self.config.goal_weight * d

    def _geofence(self, ev: ArcEvaluation, pose: Pose, goal: np.ndarray) -> np.ndarray:
        """``goal`` with an infinite cost for every arc that would take the robot out of the
        mission area (``NavMission.bounds`` less :data:`GEOFENCE_MARGIN_M` for pose error), or
        further out when it already is (an arc back inside stays electable). Unchanged when the
        mission gives no area or no arc reaches its edge."""
        b = self.mission.bounds
        if b is None:
            return goal
        m = GEOFENCE_MARGIN_M
        x, y = ev.nodes[:, :, 0], ev.nodes[:, :, 1]
        out = np.maximum.reduce([b[0] + m - x, x - (b[2] - m), b[1] + m - y, y - (b[3] - m)]).max(axis=1)
        now = max(b[0] + m - pose.x, pose.x - (b[2] - m), b[1] + m - pose.y, pose.y - (b[3] - m), 0.0)
        leaving = out > now + 1e-9
        if not leaving.any():
            return goal
        fenced: np.ndarray = np.where(leaving, np.inf, goal)
        return fenced

    def _target_bearing(self, pose: Pose) -> float:
        """Signed angle from the heading to the goal (radians, CCW positive): the side a turn on
        the spot turns to, and whether it may be elected at all (``spin_min_bearing_deg``)."""
        gx, gy = self.mission.goal
        return wrap_angle(math.atan2(gy - pose.y, gx - pose.x) - pose.yaw)

    # ----------------------------------------------------------------- internals
    def _require_reset(self) -> None:
        if not self._ready:
            raise NavigatorError("reset() must be called first")

    def _latch(self, t: float, status: Status) -> Status:
        self._latched = status
        self.messages.append((t, f"{status.kind}: {status.message}" if status.message else status.kind))
        return status

    def _mark_under_robot(self, pose: Pose) -> None:
        t = self.terrain
        buf = self._fp_buf
        hl, hw = footprint_half_extents(self.robot)
        n = _map_footprint_cells(t.constants, t.stats, pose.x, pose.y, pose.yaw, hl, hw, buf)
        if n > 0:  # the buffer's first n entries (footprint_cells without its copies)
            t.fill_unknown(buf[0, :n], buf[1, :n], (pose.x, pose.y), self.config.fill_radius_m,
                           pose.z - self._base_height)

    def _progress_manoeuvre(self, obs: Observation) -> None:
        """Advance the scan manoeuvre: the turn is measured on the perceived (gyro-fused) heading,
        then the robot turns on toward the goal (within 10 deg) before driving straight, so the
        forward part heads toward the goal, never toward the map edge behind the start."""
        od = obs.odom
        yaw = self.pom.yaw
        if self._prev_odom is not None and self.phase != "navigate":
            px, py, pyaw = self._prev_odom
            if self.phase == "scan_turn":
                self._turned += abs(wrap_angle(yaw - pyaw))
                if self._turned >= math.radians(self.config.scan_turn_deg):
                    self.phase = "scan_align" if self.config.scan_forward_m > 0 else "navigate"
            if self.phase == "scan_align" and abs(self._goal_bearing_error()) < math.radians(10.0):
                self.phase = "scan_forward"
            elif self.phase == "scan_forward":
                self._driven += math.hypot(od.x - px, od.y - py)
                if self._driven >= self.config.scan_forward_m or self._blocked_ahead():
                    self.phase = "navigate"
        self._prev_odom = (od.x, od.y, yaw)

    def _goal_bearing_error(self) -> float:
        p = self.pom.current
        gx, gy = self.mission.goal
        return wrap_angle(math.atan2(gy - p.y, gx - p.x) - p.yaw)

    def _blocked_ahead(self) -> bool:
        """Known obstacle (or too steep) under the footprint 0.5 m ahead; unknown cells allowed."""
        p = self.pom.current
        ev_x, ev_y = p.x + 0.5 * math.cos(p.yaw), p.y + 0.5 * math.sin(p.yaw)
        return not math.isfinite(node_cost(self.planner, self.terrain, ev_x, ev_y, p.yaw, unknown_cost=0.0))

    def _limit(self, v: float, w: float, dt: float) -> Command:
        """Acceleration limits of the believed robot."""
        lv, lw = self._last_cmd
        dv = self.robot.max_accel_mps2 * dt
        dw = self.robot.max_yaw_accel_rps2 * dt
        v = min(max(v, lv - dv), lv + dv)
        w = min(max(w, lw - dw), lw + dw)
        self._last_cmd = (v, w)
        return Command(float(v), float(w))
