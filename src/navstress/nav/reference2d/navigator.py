"""Reference2dNavigator (``reference-2d-v1``): a reference stack for robots with a 2D scanner,
built the way Nav2's defaults are.

Each ``step``: the pose filter of ``reference-v1`` (:class:`~navstress.nav.reference.pose.PoseEstimator`:
odometry + IMU heading + pose sensor) gives the believed pose; the newest scan of each
``lidar2d`` sensor the robot carries (since the previous cycle) is placed by the pose at the scan's time and its mount,
and raytraced into the :class:`~navstress.nav.reference2d.costmap.Costmap` (clearing, marking,
inflation by the believed footprint); the global planner (A* on the costmap, NavFn-style costs)
replans every ``replan_period_s`` and whenever a cell of its path ahead turns lethal; the local
planner (DWB) samples velocities in the dynamic window of the robot's limits, rolls them out for
``sim_time_s`` and elects the best under its critics (obstacle, path distance, path alignment,
goal distance, speed, oscillation). A differential or skid-steer base first turns in place
toward the path when it lies more than ``rotate_to_path_deg`` off (Nav2's rotation shim); an
ackermann base never turns in place: its samples keep ``|omega| <= |v| tan(max_steer) / wheelbase``.

When no path exists, no rollout is collision-free (once stopped) or the robot makes no progress, the recoveries run in Nav2's order (clear
the costmap beyond ``clear_keep_radius_m``, spin ``spin_rad`` where the drive allows it, back up
``backup_m``, wait ``wait_s``); after ``max_recoveries`` of them without getting
``progress_reset_m`` closer to the goal, the navigator answers ``Status("error", ...)``
(Fail-Error): ``no path to the goal``, ``no collision-free trajectory`` or ``no progress`` (the
progress checker: not ``progress_radius_m`` moved in ``progress_timeout_s``). ``arrived`` within
``arrival_fraction`` x the mission's tolerance. Both are latched.

Only :mod:`navstress.nav`, :mod:`navstress.robot` and :mod:`navstress.sensors` are used
(DESIGN invariant 1). Deterministic given the seed and the observations (``cost_jitter`` > 0
draws from the seed).

    >>> from navstress.nav.api import Navigator
    >>> isinstance(Reference2dNavigator(), Navigator)
    True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navstress.errors import NavigatorError
from navstress.nav.api import Command, DebugDraw, DebugLine, DebugText, LaserScan, NavMission, Observation, Status
from navstress.nav.reference.pose import Pose, PoseEstimator, rotation_matrix, wrap_angle
from navstress.nav.reference2d import kernels as K
from navstress.nav.reference2d.config import Reference2dConfig
from navstress.nav.reference2d.costmap import Costmap
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.sensors.base import rotation_rpy

__all__ = ["NO_PATH", "NO_PROGRESS", "NO_TRAJECTORY", "Reference2dNavigator"]

NO_PATH = "no path to the goal"
NO_TRAJECTORY = "no collision-free trajectory"
NO_PROGRESS = "no progress"


class Reference2dNavigator:
    """``reference-2d-v1`` (module doc). ``config`` defaults to :class:`Reference2dConfig`."""

    name = "reference-2d-v1"

    def __init__(self, config: Reference2dConfig | None = None) -> None:
        self.config: Reference2dConfig = config if config is not None else Reference2dConfig()
        self._ready = False

    @property
    def control_rate_hz(self) -> float:
        return self.config.control_rate_hz

    # ----------------------------------------------------------------- protocol
    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        """Start a run: the robot's lidar2d sensors, an empty costmap, no path."""
        cfg = self.config
        if not all(math.isfinite(v) for v in (*mission.start, *mission.goal)):
            raise NavigatorError(f"mission start/goal must be finite, got {mission.start} -> {mission.goal}")
        if not mission.goal_tolerance_m > 0:
            raise NavigatorError(f"mission goal_tolerance_m={mission.goal_tolerance_m} must be > 0")
        sensors = robot.sensors or ()
        self.scanners = [s.name for s in sensors if s.kind == "lidar2d"]
        if not self.scanners:
            have = ", ".join(f"{s.name} ({s.kind})" for s in sensors) or "none declared"
            raise NavigatorError(f"reference-2d-v1 needs a robot with a lidar2d sensor; this robot's sensors: {have}")
        self.mission, self.robot, self.seed = mission, robot, int(seed)
        self._rng = rng(self.seed, self.name)
        self.costmap = Costmap.covering([mission.start[:2], mission.goal], cfg, robot, mission.bounds)
        self.pom = PoseEstimator(mission.start, cfg.pose_tau_xy_s, cfg.pose_tau_yaw_s, cfg.history_s)
        self.vmax = min(cfg.max_speed_mps, robot.max_speed_mps)
        self.wmax = min(cfg.max_yaw_rate_rps, robot.max_yaw_rate_rps)
        self.acc = min(cfg.max_accel_mps2, robot.max_accel_mps2)
        self.wacc = min(cfg.max_yaw_accel_rps2, robot.max_yaw_accel_rps2)
        self.can_spin = robot.drive != "ackermann"
        if robot.drive == "ackermann":
            assert robot.max_steer_rad is not None
            self.kappa_max = math.tan(robot.max_steer_rad) / robot.wheelbase_m
        else:
            self.kappa_max = math.inf
        self._base_height = robot.wheel_radius_m
        self._tilt_max = math.radians(cfg.max_slope_deg)
        self._beam_cache: dict[tuple[str, int, float, float], tuple[np.ndarray, np.ndarray]] = {}
        self._astar_work = K.AStarWork(self.costmap.cost.shape)
        self.path = np.zeros((0, 2))
        self.togo = np.zeros(0)
        self._planned_at = -math.inf
        self._last_t: float | None = None
        self._cmd = (0.0, 0.0)
        self._latched: Status | None = None
        self._pose: Pose | None = None
        self._recovery: dict[str, Any] | None = None
        self.recoveries = 0  # recovery actions since the last progress
        self.recovery_log: list[tuple[float, str]] = []
        self._recovery_dist = math.inf
        self._progress: tuple[float, float, float] | None = None  # t, x, y where the progress check started
        self._weights = np.array([cfg.obstacle_weight, cfg.path_dist_weight, cfg.path_align_weight,
                                  cfg.goal_dist_weight, cfg.speed_weight, cfg.oscillation_weight, cfg.forward_point_m])
        self._n_steps = max(1, int(round(cfg.sim_time_s / cfg.sim_step_s)))
        self.messages: list[tuple[float, str]] = []
        self._ready = True

    def step(self, obs: Observation) -> Command | Status:
        """One control cycle (module doc)."""
        if not self._ready:
            raise NavigatorError("step() called before reset()")
        if self._latched is not None:
            return self._latched
        cfg = self.config
        pose = self.pom.update(obs.t, obs.odom, obs.imu, obs.pose)
        self._pose = pose
        for name in self.scanners:  # the newest scan of each (Nav2's observation_persistence 0)
            scan = obs.latest(name)
            if isinstance(scan, LaserScan):
                self._integrate(name, scan)
        dt = obs.t - self._last_t if self._last_t is not None else cfg.control_period_s
        self._last_t = obs.t
        gx, gy = self.mission.goal
        dist = math.hypot(pose.x - gx, pose.y - gy)
        if dist <= cfg.arrival_fraction * self.mission.goal_tolerance_m:
            return self._latch(obs.t, Status("arrived"))
        if dist < self._recovery_dist - cfg.progress_reset_m:
            self.recoveries = 0
            self._recovery_dist = math.inf
        if self._recovery is not None:
            cmd = self._recover(obs.t, pose)
            if cmd is not None:
                return self._send(*cmd)
            self._progress = None
        if obs.t - self._planned_at >= cfg.replan_period_s or self._blocked(pose) or len(self.path) == 0:
            self._plan(obs.t, pose)
            if len(self.path) == 0:
                return self._fail_or_recover(obs.t, pose, dist, NO_PATH)
        p = self._progress
        if p is None or math.hypot(pose.x - p[1], pose.y - p[2]) >= cfg.progress_radius_m:
            self._progress = (obs.t, pose.x, pose.y)
        elif obs.t - p[0] > cfg.progress_timeout_s:
            self._progress = None
            return self._fail_or_recover(obs.t, pose, dist, NO_PROGRESS)
        cmd = self._control(pose, max(dt, 1e-6))
        if cmd is None and self._cmd[0] > 0.0:
            # every constant-velocity rollout collides at this speed: brake (DWB would fail here;
            # a slower robot's rollouts are shorter), the recoveries only once stopped
            return self._send(max(0.0, self._cmd[0] - self.acc * max(dt, 1e-6)), 0.0)
        if cmd is None:
            return self._fail_or_recover(obs.t, pose, dist, NO_TRAJECTORY)
        return self._send(*cmd)

    def close(self) -> None:
        """Nothing to release; the costmap and the trajectory stay readable."""

    # ----------------------------------------------------------------- readouts
    def perceived_trajectory(self) -> np.ndarray:
        """(N, 7) float64: t, x, y, z, yaw, pitch, roll, one row per step since reset."""
        if not self._ready:
            raise NavigatorError("reset() must be called first")
        return self.pom.trajectory()

    def debug(self) -> DebugDraw | None:
        """The global path (map frame, at the believed ground) and a text: the recovery under
        way, or the latched status. None before the first step."""
        pose = self._pose
        if not self._ready or pose is None:
            return None
        lines: list[DebugLine] = []
        z = pose.z - self._base_height + 0.05
        if len(self.path) >= 2:
            p = self.path[:: max(1, len(self.path) // 500)]
            lines.append(DebugLine(np.column_stack([p, np.full(len(p), z)]), "map", (0.2, 0.6, 1.0, 0.9), 0.05))
        latched = self._latched
        what = (latched.kind + (f": {latched.message}" if latched.message else "") if latched is not None
                else f"recovery: {self._recovery['kind']}" if self._recovery is not None else "following the path")
        return DebugDraw(lines=tuple(lines), texts=(DebugText((0.0, 0.0, 1.0), what, "robot"),))

    # ----------------------------------------------------------------- perception
    def _beams(self, name: str, scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
        """(indices of the beams used, their unit directions (k, 3) in the sensor's frame)."""
        n = int(scan.ranges.shape[0])
        key = (name, n, float(scan.angle_min), float(scan.angle_increment))
        got = self._beam_cache.get(key)
        if got is None:
            step = 1
            inc = abs(float(scan.angle_increment))
            if inc > 0 and self.config.beam_step_deg > 0:
                step = max(1, int(round(math.radians(self.config.beam_step_deg) / inc)))
            idx = np.arange(0, n, step)
            a = scan.angle_min + scan.angle_increment * idx
            got = (idx, np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))]))
            self._beam_cache[key] = got
        return got

    def _integrate(self, name: str, scan: LaserScan) -> None:
        """Raytrace one scan into the costmap, placed by the believed pose at its time."""
        cfg = self.config
        pose = self.pom.pose_at(scan.t)
        idx, dirs = self._beams(name, scan)
        rot = rotation_matrix(pose.yaw, pose.pitch, pose.roll)
        d = dirs @ (rot @ rotation_rpy(*scan.rpy)).T  # map-frame directions
        o = np.array([pose.x, pose.y, pose.z]) + rot @ np.asarray(scan.mount, np.float64)
        r = scan.ranges[idx].astype(np.float64)
        hit = np.isfinite(r) & (r >= scan.range_min)
        reach = np.where(hit, np.minimum(r, cfg.raytrace_max_range_m), min(scan.range_max, cfg.raytrace_max_range_m))
        ends = o[None, :] + d * reach[:, None]
        ground = pose.z - self._base_height + cfg.ground_tolerance_m
        mark = hit & (r <= cfg.obstacle_max_range_m) & (ends[:, 2] >= ground)
        if abs(pose.pitch) > self._tilt_max or abs(pose.roll) > self._tilt_max:
            mark[:] = False  # the beams may be hitting the ground ahead: clear only
        origins = np.broadcast_to(o[:2], (len(ends), 2))
        self.costmap.integrate(np.ascontiguousarray(origins), np.ascontiguousarray(ends[:, :2]), mark)

    # ----------------------------------------------------------------- global planner
    def _plan(self, t: float, pose: Pose) -> None:
        cfg, cm = self.config, self.costmap
        self._planned_at = t
        ny, nx = cm.cost.shape
        si, sj = cm.cell_of(pose.x, pose.y)
        si, sj = min(max(si, 0), ny - 1), min(max(sj, 0), nx - 1)
        gx, gy = self.mission.goal
        gi = (gy - cm.origin[1]) / cm.cell - 0.5
        gj = (gx - cm.origin[0]) / cm.cell - 0.5
        # the path ends well inside the arrival circle (half its radius), at the goal itself when it is free
        goal_r = 0.5 * cfg.arrival_fraction * self.mission.goal_tolerance_m / cm.cell
        cells = K.astar(cm.cost, si, sj, gi, gj, goal_r, cfg.unknown_cell_cost, cfg.cost_weight, work=self._astar_work,
                        heuristic_weight=cfg.heuristic_weight, escape_r=cm.circumscribed_m / cm.cell)
        if len(cells) == 0:
            self.path, self.togo = np.zeros((0, 2)), np.zeros(0)
            return
        xy = cm.centre(cells)
        xy[0] = (pose.x, pose.y)
        if cm.cost_xy(gx, gy) < K.INSCRIBED or cm.cost_xy(gx, gy) == K.NO_INFORMATION:
            xy = np.vstack([xy, [(gx, gy)]])
        seg = np.hypot(*np.diff(xy, axis=0).T)
        self.path = xy
        self.togo = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])

    def _ahead(self, pose: Pose) -> int:
        """Index of the path point nearest the believed position."""
        return int(np.argmin(np.hypot(self.path[:, 0] - pose.x, self.path[:, 1] - pose.y)))

    def _blocked(self, pose: Pose) -> bool:
        """Whether a cell of the path ahead (beyond the robot's own circumscribed circle) is
        now impassable (INSCRIBED or LETHAL)."""
        if len(self.path) == 0:
            return False
        cm = self.costmap
        k = self._ahead(pose)
        p = self.path[k:]
        far = np.hypot(p[:, 0] - pose.x, p[:, 1] - pose.y) > cm.circumscribed_m
        ij = np.floor((p[far] - np.array(cm.origin)) / cm.cell).astype(np.int64)
        ok = (ij[:, 0] >= 0) & (ij[:, 1] >= 0) & (ij[:, 1] < cm.cost.shape[0]) & (ij[:, 0] < cm.cost.shape[1])
        c = cm.cost[ij[ok, 1], ij[ok, 0]]
        return bool(((c == K.INSCRIBED) | (c == K.LETHAL)).any())

    # ----------------------------------------------------------------- local planner
    def _control(self, pose: Pose, dt: float) -> tuple[float, float] | None:
        """The command of this cycle: rotate toward the path, or the best DWB rollout; None when
        every rollout collides."""
        cfg, cm = self.config, self.costmap
        k = self._ahead(pose)
        along = self.togo[k] - self.togo
        carrot = self.path[min(int(np.searchsorted(-self.togo, -(self.togo[k] - cfg.carrot_m))), len(self.path) - 1)]
        err = wrap_angle(math.atan2(carrot[1] - pose.y, carrot[0] - pose.x) - pose.yaw)
        far_enough = math.hypot(carrot[0] - pose.x, carrot[1] - pose.y) > 0.5 * cm.cell
        pv, pw = self._cmd
        if self.can_spin and far_enough and abs(err) > math.radians(cfg.rotate_to_path_deg) and self._spin_free(pose, err):
            w = math.copysign(min(self.wmax, max(0.4, 1.5 * abs(err))), err)
            return (max(0.0, pv - self.acc * dt) if pv > 0 else 0.0, w)
        look = self.vmax * cfg.sim_time_s + 1.0
        window = (along >= 0) & (along <= look)
        window[k] = True
        path = np.ascontiguousarray(self.path[window])
        togo = np.ascontiguousarray(self.togo[window])
        vs, ws = self._samples(pv, pw, dt)
        scores = K.score_rollouts(cm.cost, cm.grid, (float(pose.x), float(pose.y), float(pose.yaw)), (vs, ws),
                                  cm.footprint, (path, togo), self._weights,
                                  K.Rollouts(int(self._n_steps), float(cfg.sim_time_s / self._n_steps),
                                             float(cfg.unknown_cell_cost), float(self.vmax), float(pw)))
        if cfg.cost_jitter > 0:
            scores = scores + self._rng.uniform(0.0, cfg.cost_jitter, len(scores))
        best = int(np.argmin(scores))
        if not math.isfinite(float(scores[best])):
            return None
        return float(vs[best]), float(ws[best])

    def _samples(self, pv: float, pw: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(v, omega) samples in the dynamic window: reachable from the previous command within
        one cycle at the limited accelerations; forward only; for an ackermann drive sampled by
        curvature within its steering limit (v = 0: no turn)."""
        cfg = self.config
        v_lo, v_hi = max(0.0, pv - self.acc * dt), min(self.vmax, max(0.0, pv) + self.acc * dt)
        w_lo, w_hi = max(-self.wmax, pw - self.wacc * dt), min(self.wmax, pw + self.wacc * dt)
        v = np.linspace(v_lo, v_hi, cfg.vx_samples)
        if self.can_spin:
            w = np.linspace(w_lo, w_hi, cfg.vtheta_samples)
            vv, ww = np.meshgrid(v, w, indexing="ij")
            return np.ascontiguousarray(vv.ravel()), np.ascontiguousarray(ww.ravel())
        kap = np.linspace(-self.kappa_max, self.kappa_max, cfg.vtheta_samples)
        if v_hi > 0.0:
            # standing still makes no progress, and a car cannot turn there: stop only by slowing down
            v = np.linspace(max(v_lo, min(v_hi, 0.05)), v_hi, cfg.vx_samples)
        vv, kk = np.meshgrid(v, kap, indexing="ij")
        ww = np.clip(vv * kk, w_lo, w_hi)
        ww = np.clip(ww, -vv * self.kappa_max, vv * self.kappa_max)  # never sharper than the steering allows
        return np.ascontiguousarray(vv.ravel()), np.ascontiguousarray(ww.ravel())

    def _spin_free(self, pose: Pose, angle: float) -> bool:
        """Whether turning in place by ``angle`` keeps the footprint clear."""
        cm = self.costmap
        for a in np.linspace(0.0, angle, 8):
            if K.footprint_hits(cm.cost, cm.grid, float(pose.x), float(pose.y), float(pose.yaw + a), cm.footprint):
                return False
        return True

    # ----------------------------------------------------------------- recoveries
    def _sequence(self) -> list[str]:
        return ["clear", "spin", "backup", "wait"] if self.can_spin else ["clear", "backup", "wait"]

    def _fail_or_recover(self, t: float, pose: Pose, dist: float, why: str) -> Command | Status:
        if self.recoveries >= self.config.max_recoveries:
            return self._latch(t, Status("error", f"{why} after {self.recoveries} recoveries"))
        seq = self._sequence()
        kind = seq[self.recoveries % len(seq)]
        self.recoveries += 1
        self._recovery_dist = min(self._recovery_dist, dist)
        self.recovery_log.append((t, f"{kind} ({why})"))
        self._recovery = {"kind": kind, "t0": t, "x": pose.x, "y": pose.y, "yaw": pose.yaw, "turned": 0.0}
        cmd = self._recover(t, pose)
        return self._send(*(cmd if cmd is not None else (0.0, 0.0)))

    def _recover(self, t: float, pose: Pose) -> tuple[float, float] | None:
        """The recovery's command this cycle, or None when it is over (then replan at once)."""
        cfg, rec = self.config, self._recovery
        assert rec is not None
        kind, elapsed = rec["kind"], t - rec["t0"]
        done = False
        cmd = (0.0, 0.0)
        if kind == "clear":
            self.costmap.clear_beyond(pose.x, pose.y, cfg.clear_keep_radius_m)
            done = True
        elif kind == "spin":
            rec["turned"] += abs(wrap_angle(pose.yaw - rec["yaw"]))
            rec["yaw"] = pose.yaw
            w = min(self.wmax, 1.0)
            done = (rec["turned"] >= cfg.spin_rad or elapsed > 2.0 * cfg.spin_rad / w + 2.0
                    or not self._spin_free(pose, cfg.spin_rad - rec["turned"]))  # never swing into an obstacle
            cmd = (0.0, w)
        elif kind == "backup":
            moved = math.hypot(pose.x - rec["x"], pose.y - rec["y"])
            cm = self.costmap
            bx = pose.x - cfg.backup_m * math.cos(pose.yaw)
            by = pose.y - cfg.backup_m * math.sin(pose.yaw)
            blocked = K.footprint_hits(cm.cost, cm.grid, float(bx), float(by), float(pose.yaw),
                                       cm.footprint) and moved == 0.0
            done = blocked or moved >= cfg.backup_m or elapsed > 2.0 * cfg.backup_m / cfg.backup_speed_mps + 2.0
            cmd = (-cfg.backup_speed_mps, 0.0)
        else:  # wait
            done = elapsed >= cfg.wait_s
        if done:
            self._recovery = None
            self._planned_at = -math.inf
            return None
        return cmd

    # ----------------------------------------------------------------- internals
    def _send(self, v: float, w: float) -> Command:
        self._cmd = (v, w)
        return Command(v, w)

    def _latch(self, t: float, status: Status) -> Status:
        self._latched = status
        self.messages.append((t, f"{status.kind}: {status.message}" if status.message else status.kind))
        return status
