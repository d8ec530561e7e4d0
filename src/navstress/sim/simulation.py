"""Simulation: a World and a RobotSpec in MuJoCo, in lockstep on simulated time.

    >>> from navstress.world.spec import WorldSpec
    >>> from navstress.world.world import World
    >>> from navstress.nav.api import Command
    >>> w = World.flat(WorldSpec(size_m=(20.0, 20.0)))
    >>> sim = Simulation(w, config=SimConfig(lidar_enabled=False), seed=1)
    >>> sim.command(Command(1.0, 0.0)); sim.advance(1.0)
    >>> round(sim.t, 6), sim.observe().odom.x > 0.3
    (1.0, True)

The navigator only ever gets :meth:`observe` (sensor data); :attr:`observer` holds the ground
truth (real poses, collisions, stop events) for the run's classification.
"""

from __future__ import annotations

import math
import mujoco
import numpy as np

from navstress.errors import SimulationError, SpecError
from navstress.nav.api import Command, Imu, LidarScan, Observation, Odometry, PoseReading
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.sim.config import SimConfig
from navstress.sim.lidar import Lidar, build_scene
from navstress.sim.model import ObstaclePool, RobotModel, align_wheel_contacts, build_model, obstacle_contacts
from navstress.sim.observer import Observer, StopEvent
from navstress.sim.sensors import ImuSensor, PoseSensor, WheelOdometry, euler_from_mat
from navstress.world.world import World

_SENSORS = ("odom", "imu", "pose", "lidar", "observer")
_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                 mujoco.mjtWarning.mjWARN_BADQACC)


class Simulation:
    """Physics, sensors and observer of one run.

    ``seed`` is the run seed: sensor noise, sensor rate jitter and command latency jitter each
    draw from their own generator derived from it (``navstress.seeding.rng(seed, "sim", ...)``).
    ``start`` overrides the mission start (x, y, yaw).
    """

    def __init__(self, world: World, robot: RobotSpec = RobotSpec(), config: SimConfig = SimConfig(), *,
                 seed: int, start: tuple[float, float, float] | None = None) -> None:
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise SpecError("seed", seed, "an integer >= 0")
        self.world, self.robot, self.config, self.seed = world, robot, config, seed
        self.rm: RobotModel = build_model(world, robot, config, start, obstacle_pool=config.obstacle_pool)
        self.model = self.rm.model
        self.data = mujoco.MjData(self.model)
        cfg = config
        self._dt = cfg.timestep_s
        self._pool: ObstaclePool | None = None
        self._pool_every = max(1, int(round(0.1 / self._dt)))
        if config.obstacle_pool > 0:
            self._pool = ObstaclePool(self.rm, world, robot, config.obstacle_margin_m)
            self._pool.update(self.data)
        mujoco.mj_forward(self.model, self.data)
        self._k = 0
        self._timing = {n: rng(seed, "sim", "timing", n) for n in _SENSORS}
        self._latency_gen = rng(seed, "sim", "latency")
        # drive state: commanded target, ramped command, yaw-rate integrator
        self._queue: list[tuple[int, Command]] = []
        self._target = (0.0, 0.0)
        self._v = self._w = self._yaw_i = 0.0
        self._half_track = robot.track_m / 2
        self._wheel_ref = [float(self.data.qpos[q]) for q in self.rm.wheel_qpos]
        # sensors
        d = self.data
        self.odometry = WheelOdometry(robot.wheel_radius_m, robot.track_m * cfg.skid_factor,
                                      d.qpos[self.rm.wheel_qpos], 0.0)
        self.pose_sensor = PoseSensor(rng(seed, "sim", "noise", "pose"), cfg.pose_pos_std_m,
                                      cfg.pose_att_std_rad, cfg.noise)
        self.imu_sensor = ImuSensor(rng(seed, "sim", "noise", "imu"), cfg.imu_att_std_rad, cfg.imu_rate_std_rps,
                                    cfg.imu_yaw_drift_rps, cfg.noise, 0.0)
        self._lidar: Lidar | None = None
        self._lidar_gen = rng(seed, "sim", "noise", "lidar")
        rates = {"odom": cfg.odom_rate_hz, "imu": cfg.imu_rate_hz, "pose": cfg.pose_rate_hz,
                 "observer": cfg.observer_rate_hz}
        if cfg.lidar_enabled:
            lcfg = cfg.lidar
            self._lidar = Lidar(build_scene(world), lcfg)
            rates["lidar"] = float(lcfg.rate_hz)
        self._period = {n: 1.0 / r for n, r in rates.items()}
        self._next: dict[str, int] = {n: 0 for n in rates}
        self.observer = Observer(cfg.collision_debounce_s)
        self._contact_buf = np.zeros(64, np.int64)
        self._rot9 = np.zeros(9)
        # readings since the last observe()
        self._scans: list[LidarScan] = []
        self._pose: PoseReading | None = None
        self._odom: Odometry = self.odometry.last
        self._imu: Imu | None = None
        self._warn0 = self._warnings()
        self._fire_due()

    # ---- public API -------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time in seconds (an exact multiple of the time step)."""
        return self._k * self._dt

    @property
    def stopped(self) -> StopEvent | None:
        """Why the run cannot go on (flipped over, left the map), or None."""
        return self.observer.stop

    def command(self, cmd: Command) -> None:
        """Queue a velocity command; it takes effect after the (jittered) command latency."""
        if not (math.isfinite(cmd.v) and math.isfinite(cmd.omega)):
            raise SpecError("command", cmd, "finite v and omega")
        cfg = self.config
        delay = cfg.command_latency_s
        if cfg.jitter and cfg.command_latency_jitter_s > 0:
            delay += cfg.command_latency_jitter_s * float(self._latency_gen.random())
        k = self._k + max(0, int(round(delay / self._dt)))
        if self._queue:
            k = max(k, self._queue[-1][0])  # commands never overtake each other
        self._queue.append((k, cmd))

    def advance(self, dt: float) -> None:
        """Step physics for ``dt`` seconds (rounded to whole steps), firing sensors as due.

        Returns early, without stepping, once the run is :attr:`stopped`.
        Raises SimulationError when the physics becomes unstable.
        """
        if not (math.isfinite(dt) and dt >= 0):
            raise SpecError("dt", dt, "a finite duration >= 0 s")
        n = int(round(dt / self._dt))
        for _ in range(n):
            if self.observer.stop is not None:
                return
            self._step()

    def observe(self) -> Observation:
        """Sensor readings since the previous call: all scans, the latest pose (or None),
        the latest odometry and IMU readings."""
        assert self._imu is not None
        obs = Observation(t=self.t, odom=self._odom, imu=self._imu, pose=self._pose, scans=tuple(self._scans))
        self._scans = []
        self._pose = None
        return obs

    # ---- internals --------------------------------------------------------------------
    def _warnings(self) -> int:
        return sum(int(self.data.warning[w].number) for w in _BAD_WARNINGS)

    def _drive(self) -> None:
        """Robot firmware: clamp, ramp to the acceleration limits, yaw-rate PI, wheel speeds."""
        r, cfg, dt = self.robot, self.config, self._dt
        while self._queue and self._queue[0][0] <= self._k:
            c = self._queue.pop(0)[1]
            self._target = (min(max(c.v, -r.max_speed_mps), r.max_speed_mps),
                            min(max(c.omega, -r.max_yaw_rate_rps), r.max_yaw_rate_rps))
        tv, tw = self._target
        dv, dw = r.max_accel_mps2 * dt, r.max_yaw_accel_rps2 * dt
        self._v += min(max(tv - self._v, -dv), dv)
        self._w += min(max(tw - self._w, -dw), dw)
        gyro = float(self.data.qvel[5])  # free joint: body-frame angular velocity
        err = self._w - gyro
        self._yaw_i = min(max(self._yaw_i + err * dt, -0.5), 0.5)
        dw_cmd = cfg.skid_factor * self._w + cfg.yaw_kp * err + cfg.yaw_ki * self._yaw_i
        rad = r.wheel_radius_m
        left = (self._v - dw_cmd * self._half_track) / rad
        right = (self._v + dw_cmd * self._half_track) / rad
        # wheel-angle hold: each wheel tracks the integral of its speed command (bounded lag),
        # so a stopped robot holds on a slope instead of creeping at torque / kv
        qp, ref, lim, kp = self.data.qpos, self._wheel_ref, 0.5, cfg.wheel_hold_gain
        ctrl = self.data.ctrl
        for i, wq in enumerate(self.rm.wheel_qpos):
            cmd = left if i < 2 else right
            a = float(qp[wq])
            e = ref[i] + cmd * dt - a
            e = min(max(e, -lim), lim)
            ref[i] = a + e
            ctrl[i] = cmd + kp * e

    def _step(self) -> None:
        m, d, rm, cfg = self.model, self.data, self.rm, self.config
        self._drive()
        if self._pool is not None and self._k % self._pool_every == 0:
            self._pool.update(d)
        mujoco.mj_fwdPosition(m, d)
        if d.ncon:
            c = d.contact
            if align_wheel_contacts(c.frame, c.friction, c.pos, c.geom, rm.wheel_of_geom, d.qvel,
                                    d.xmat[rm.chassis_body].reshape(3, 3), d.xpos[rm.chassis_body],
                                    d.xpos[rm.wheel_bodies], rm.wheel_dofs, cfg.friction, cfg.friction_floor,
                                    cfg.slip_eps_mps):
                mujoco.mj_makeConstraint(m, d)
                mujoco.mj_projectConstraint(m, d)
        mujoco.mj_fwdVelocity(m, d)
        mujoco.mj_step2(m, d)
        self._k += 1
        qv = d.qvel
        sp = abs(qv[0]) + abs(qv[1]) + abs(qv[2])
        if not sp < cfg.max_speed_mps or (self._k % 50 == 0 and self._warnings() != self._warn0):
            self._unstable()
        qp = d.qpos
        x, y = float(qp[0]), float(qp[1])
        if d.ncon:
            nk = obstacle_contacts(d.contact.geom, rm.obstacle_of_geom, rm.bumper_geom, self._contact_buf)
            if nk or self.observer._touching:
                self.observer.contacts(self.t, x, y, set(self._contact_buf[:nk].tolist()))
        elif self.observer._touching:
            self.observer.contacts(self.t, x, y, set())
        sx, sy = rm.map_size
        mg = cfg.map_margin_m
        if not (mg <= x <= sx - mg and mg <= y <= sy - mg):
            self.observer.stopped(StopEvent(self.t, x, y, "left_map",
                                            f"robot left the map at ({x:.2f}, {y:.2f})"))
        qw, qx, qy, qz = float(qp[3]), float(qp[4]), float(qp[5]), float(qp[6])
        up_z = 1.0 - 2.0 * (qx * qx + qy * qy) / (qw * qw + qx * qx + qy * qy + qz * qz)
        if up_z < math.cos(cfg.flip_threshold_rad):
            self.observer.stopped(StopEvent(self.t, x, y, "flipped",
                                            f"robot tipped over (up-vector z={up_z:.2f})"))
        if self._k >= self._next_min:
            self._fire_due()

    def _unstable(self) -> None:
        d = self.data
        if not np.all(np.isfinite(d.qpos)) or not np.all(np.isfinite(d.qvel)):
            why = "NaN in the state"
        elif self._warnings() != self._warn0:
            why = "MuJoCo reported a bad position/velocity/acceleration (it would reset the state)"
        else:
            why = f"body speed {float(np.abs(d.qvel[:3]).sum()):.1f} m/s above {self.config.max_speed_mps} m/s"
        raise SimulationError(f"physics became unstable at t={self.t:.3f} s: {why}")

    def _fire_due(self) -> None:
        d, rm, cfg, k, t = self.data, self.rm, self.config, self._k, self.t
        pos = d.qpos[0:3].copy()  # free joint: chassis position and orientation at the new time
        mujoco.mju_quat2Mat(self._rot9, d.qpos[3:7])
        rot = self._rot9.reshape(3, 3)
        yaw, pitch, roll = euler_from_mat(rot)
        for name, nk in self._next.items():
            if nk > k:
                continue
            if name == "odom":
                self._odom = self.odometry.update(d.qpos[rm.wheel_qpos], t)
            elif name == "imu":
                self._imu = self.imu_sensor.read(t, yaw, pitch, roll, d.qvel[3:6])
            elif name == "pose":
                self._pose = self.pose_sensor.read(t, pos, yaw, pitch, roll)
            elif name == "lidar":
                lm = self.robot.lidar
                origin = pos + rot @ np.array([lm.x_m, lm.y_m, lm.z_m])
                srot = rot.copy()
                assert self._lidar is not None
                pts = self._lidar.scan(origin, srot, self._lidar_gen if cfg.noise else None)
                self._scans.append(LidarScan(t, pts, (lm.x_m, lm.y_m, lm.z_m)))
            else:
                self.observer.record_pose((t, float(pos[0]), float(pos[1]), float(pos[2]), yaw, pitch, roll))
            period = self._period[name]
            if cfg.jitter and cfg.rate_jitter > 0 and name != "observer":
                period *= 1.0 + cfg.rate_jitter * (2.0 * float(self._timing[name].random()) - 1.0)
            self._next[name] = k + max(1, int(round(period / self._dt)))
        self._next_min = min(self._next.values())
