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
from navstress.sim import _step as K
from navstress.sim.model import OBSTACLE_BIT, PARK_Z_M, ObstaclePool, RobotModel, build_model
from navstress.sim.observer import CollisionEvent, Observer, StopEvent
from navstress.world.world import World

_SENSORS = ("odom", "imu", "pose", "lidar", "observer")  # the order of the _step sensor rows
_JITTER_BATCH = 64  # rate-jitter uniforms drawn at a time from each sensor's timing generator
_SAMPLES = 64  # raw sensor samples buffered in the compiled loop between flushes
_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                 mujoco.mjtWarning.mjWARN_BADQACC)


class Simulation:
    """Physics, sensors and observer of one run.

    ``seed`` is the run seed: sensor noise, sensor rate jitter and command latency jitter each
    draw from their own generator derived from it (``navstress.seeding.rng(seed, "sim", ...)``).
    ``start`` overrides the mission start (x, y, yaw).

    The steps run in one compiled loop (``navstress.sim._step.run_steps``) that returns to Python
    only for lidar scans, commands, collisions, stop events and to flush its sensor samples.
    """

    def __init__(self, world: World, robot: RobotSpec = RobotSpec(), config: SimConfig = SimConfig(), *,
                 seed: int, start: tuple[float, float, float] | None = None) -> None:
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise SpecError("seed", seed, "an integer >= 0")
        K.check_layout()
        self.world, self.robot, self.config, self.seed = world, robot, config, seed
        # a pool never needs more slots than the world has obstacles (with n <= K obstacles the slots
        # fill the same way, lowest free first, and none is ever missing); an obstacle-free world has
        # no slot bodies at all: every empty slot is a mocap body that costs kinematics and
        # broadphase time in every step (about 20 % of the step)
        pool_size = min(config.obstacle_pool, len(world.obstacles))
        self.rm: RobotModel = build_model(world, robot, config, start, obstacle_pool=pool_size)
        self.model = self.rm.model
        self.data = mujoco.MjData(self.model)
        cfg, m, d, rm = config, self.model, self.data, self.rm
        self._dt = cfg.timestep_s
        self._pool: ObstaclePool | None = None
        if pool_size > 0:
            self._pool = ObstaclePool(rm, world, robot, config.obstacle_margin_m)
            self._pool.update(d)
        # wheel-ground contacts come from _step.sphere_terrain_contacts, not MuJoCo's hfield collision
        wgeoms = np.flatnonzero(rm.wheel_of_geom >= 0)[np.argsort(rm.wheel_of_geom[rm.wheel_of_geom >= 0])]
        tmpl = K.contact_template(m, d, wgeoms, 0) if cfg.analytic_wheel_contacts else np.zeros(K.CON_SIZE // 8)
        # the contacts are rewritten (and added) after mj_fwdPosition, which computes constraint
        # islands from the contacts; the robot is one kinematic tree: one island, none needed
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
        if cfg.analytic_wheel_contacts:
            m.geom_contype[wgeoms] = 0
            m.geom_conaffinity[wgeoms] = 0
        terrain = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
        hsz = m.hfield_size[0]
        nrow, ncol = int(m.hfield_nrow[0]), int(m.hfield_ncol[0])
        hf = m.geom_pos[terrain][2] + hsz[2] * m.hfield_data.astype(np.float64).reshape(nrow, ncol)
        grid = np.array([m.geom_pos[terrain][0] - hsz[0], m.geom_pos[terrain][1] - hsz[1], 2 * hsz[0] / (ncol - 1),
                         2 * hsz[1] / (nrow - 1), robot.wheel_radius_m])
        self._wheel_args = (wgeoms.astype(np.int64) if cfg.analytic_wheel_contacts else np.zeros(0, np.int64),
                            terrain, hf, grid, tmpl, np.zeros((4, 7)))
        mujoco.mj_forward(m, d)
        self._timing = [rng(seed, "sim", "timing", n) for n in _SENSORS]
        self._latency_gen = rng(seed, "sim", "latency")
        self._queue: list[tuple[int, Command]] = []
        # sensors: IMU and pose noise (ImuSensor/PoseSensor arithmetic, compiled in _step._fire) come
        # from standard normals pre-drawn in batches from each sensor's generator, consumed in order
        self._noise_gen = (rng(seed, "sim", "noise", "imu"), rng(seed, "sim", "noise", "pose"))
        self._noise = np.zeros((2, K.NOISE_BATCH))
        self._lidar: Lidar | None = None
        self._lidar_gen = rng(seed, "sim", "noise", "lidar")
        rates = [cfg.odom_rate_hz, cfg.imu_rate_hz, cfg.pose_rate_hz, 0.0, cfg.observer_rate_hz]
        self._next = np.zeros(K.NSENSORS, np.int64)
        if cfg.lidar_enabled:
            self._lidar = Lidar(build_scene(world), cfg.lidar)
            rates[K.SCAN] = float(cfg.lidar.rate_hz)
        else:
            self._next[K.SCAN] = np.iinfo(np.int64).max  # never due
        self._period = np.array([1.0 / r if r > 0 else 1.0 for r in rates])
        self._jit = np.zeros((K.NSENSORS, _JITTER_BATCH))
        self._jit_idx = np.full(K.NSENSORS, _JITTER_BATCH, np.int64)  # drawn on first use
        self._samples = np.zeros((K.NSENSORS, _SAMPLES, 7))
        self._nsamp = np.zeros(K.NSENSORS, np.int64)
        self.observer = Observer(cfg.collision_debounce_s)
        self._contact_buf = np.zeros(64, np.int64)
        self._contact_prev = np.zeros(64, np.int64)
        self._last_touch = np.full(max(1, len(world.obstacles)), -np.inf)  # per obstacle, for the debounce
        self._event_buf = np.zeros((128, 4))
        # compiled-loop state: ints, floats (drive firmware + constants), fixed argument tuple
        r = robot
        self._I = np.zeros(K.NI, np.int64)
        self._I[K.I_JITTER] = int(cfg.jitter)
        self._I[K.I_CMDK] = K.NO_CMD
        self._I[K.I_NOISE] = int(cfg.noise)
        self._I[K.I_NIMU] = self._I[K.I_NPOSE] = K.NOISE_BATCH  # drawn on first use
        F = self._F = np.zeros(K.NF)
        F[K.F_REF:K.F_REF + 4] = d.qpos[rm.wheel_qpos]
        F[K.F_DT], F[K.F_DV], F[K.F_DW] = self._dt, r.max_accel_mps2 * self._dt, r.max_yaw_accel_rps2 * self._dt
        F[K.F_SKID], F[K.F_KP], F[K.F_KI] = cfg.skid_factor, cfg.yaw_kp, cfg.yaw_ki
        F[K.F_HALFTRACK], F[K.F_RADIUS], F[K.F_HOLD] = r.track_m / 2, r.wheel_radius_m, cfg.wheel_hold_gain
        F[K.F_MU], F[K.F_FLOOR], F[K.F_EPS] = cfg.friction, cfg.friction_floor, cfg.slip_eps_mps
        F[K.F_MAXSPEED], (F[K.F_SX], F[K.F_SY]) = cfg.max_speed_mps, rm.map_size
        F[K.F_MARGIN], F[K.F_COSFLIP], F[K.F_RATEJIT] = cfg.map_margin_m, math.cos(cfg.flip_threshold_rad), \
            cfg.rate_jitter
        F[K.F_DEBOUNCE] = cfg.collision_debounce_s
        F[K.F_OA:K.F_OA + 4] = d.qpos[rm.wheel_qpos]
        F[K.F_OR], F[K.F_OTRACK] = r.wheel_radius_m, r.track_m * cfg.skid_factor
        F[K.F_IATT], F[K.F_IRATE], F[K.F_IDRIFT] = cfg.imu_att_std_rad, cfg.imu_rate_std_rps, cfg.imu_yaw_drift_rps
        F[K.F_PPOS], F[K.F_PATT] = cfg.pose_pos_std_m, cfg.pose_att_std_rad
        warn = d.warning.number
        bad = np.array([int(w) for w in _BAD_WARNINGS], np.int64)
        self._I[K.I_WARN0] = int(sum(int(warn[w]) for w in bad))
        pool = self._pool
        if pool is not None:
            pargs: tuple[object, ...] = (pool.centre, pool.half, pool.quat, pool.reach, pool._dist,
                                         pool.slot_obstacle, rm.slot_geoms, pool.mocap, pool.bvh)
        else:
            e2, e1, ei = np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
            pargs = (e2, e2, np.zeros((0, 4)), e1, e1.copy(), ei, ei, ei, ei)
        self._args_a = (m._address, d._address, K.ncon_address(d), K.contact_field_address(d))
        self._args_b = (
            self._I, F, d.qpos, d.qvel, d.ctrl, d.xpos, d.xmat, warn, bad,
            np.array([rm.chassis_body, rm.bumper_geom, *rm.wheel_bodies], np.int64), rm.wheel_qpos, rm.wheel_dofs,
            rm.wheel_of_geom, rm.obstacle_of_geom, self._contact_buf, self._contact_prev, self._last_touch,
            self._event_buf,
            max(1, int(round(0.1 / self._dt))) if pool is not None else 0, *pargs,
            d.mocap_pos, d.mocap_quat, m.geom_size, m.geom_rbound, m.geom_aabb, m.bvh_aabb, m.geom_contype,
            OBSTACLE_BIT, PARK_Z_M, self._next, self._period, self._jit, self._jit_idx, self._samples,
            self._nsamp, self._noise, *self._wheel_args)
        # readings since the last observe()
        self._scans: list[LidarScan] = []
        self._mount = (robot.lidar.x_m, robot.lidar.y_m, robot.lidar.z_m)
        self._mount_v = np.array(self._mount)
        self._pose: PoseReading | None = None
        self._odom = Odometry(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self._imu: Imu | None = None
        self._run(0)

    # ---- public API -------------------------------------------------------------------
    @property
    def _k(self) -> int:
        return int(self._I[K.I_K])

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
        k = int(self._I[K.I_K]) + max(0, int(round(delay / self._dt)))
        pending = int(self._I[K.I_CMDK])
        if self._queue:  # commands never overtake each other
            k = max(k, self._queue[-1][0])
        elif pending != K.NO_CMD:
            k = max(k, pending)
        self._queue.append((k, cmd))

    def advance(self, dt: float) -> None:
        """Step physics for ``dt`` seconds (rounded to whole steps), firing sensors as due.

        Returns early, without stepping, once the run is :attr:`stopped`.
        Raises SimulationError when the physics becomes unstable.
        """
        if not (math.isfinite(dt) and dt >= 0):
            raise SpecError("dt", dt, "a finite duration >= 0 s")
        self._run(int(self._I[K.I_K]) + int(round(dt / self._dt)))

    def observe(self) -> Observation:
        """Sensor readings since the previous call: all scans, the latest pose (or None),
        the latest odometry and IMU readings."""
        assert self._imu is not None
        obs = Observation(t=int(self._I[K.I_K]) * self._dt, odom=self._odom, imu=self._imu, pose=self._pose, scans=tuple(self._scans))
        self._scans = []
        self._pose = None
        return obs

    # ---- internals --------------------------------------------------------------------
    def _warnings(self) -> int:
        return sum(int(self.data.warning[w].number) for w in _BAD_WARNINGS)

    def _run(self, k_end: int) -> None:
        """Step until step ``k_end`` (or a stop), handling what the compiled loop hands back."""
        r, I, q, F = self.robot, self._I, self._queue, self._F
        a, b, run_steps, ob = self._args_a, self._args_b, K.run_steps, self.observer
        vmax, wmax = r.max_speed_mps, r.max_yaw_rate_rps
        while True:
            # the compiled loop applies one pending command at the start of its step; it stops at
            # the next queued one (a later command for the same step replaces the pending one)
            if q and (I[K.I_CMDK] == K.NO_CMD or q[0][0] <= I[K.I_CMDK]):
                while True:
                    kc, c = q.pop(0)
                    I[K.I_CMDK] = kc
                    F[K.F_CMDV] = min(max(c.v, -vmax), vmax)
                    F[K.F_CMDW] = min(max(c.omega, -wmax), wmax)
                    if not (q and q[0][0] <= kc):
                        break
            stopped = ob.stop is not None
            st = run_steps(*a, int(I[K.I_K]) if stopped else (min(k_end, q[0][0]) if q else k_end), *b)
            if st == K.DONE:
                if stopped or int(I[K.I_K]) >= k_end:
                    break
                continue
            if st & K.UNSTABLE:
                self._flush()
                self._unstable()
            if st & (K.LEFT_MAP | K.FLIPPED):
                self._flush()  # collisions of this step first
                self._events(st)
            if st & K.FLUSH:
                self._flush()
                for s in range(K.NSENSORS):
                    if self._jit_idx[s] >= _JITTER_BATCH:
                        self._jit[s] = self._timing[s].random(_JITTER_BATCH)
                        self._jit_idx[s] = 0
                if self.config.noise:
                    for row, idx in ((K.IMU_NOISE, K.I_NIMU), (K.POSE_NOISE, K.I_NPOSE)):
                        if I[idx] >= K.NOISE_BATCH:  # used up exactly (a multiple of 7 and 6)
                            self._noise[row] = self._noise_gen[row].standard_normal(K.NOISE_BATCH)
                            I[idx] = 0
            if st & K.LIDAR:
                self._scan()
        self._flush()

    def _events(self, st: int) -> None:
        t, x, y = self.t, float(self.data.qpos[0]), float(self.data.qpos[1])
        ob = self.observer
        if st & K.LEFT_MAP:
            ob.stopped(StopEvent(t, x, y, "left_map", f"robot left the map at ({x:.2f}, {y:.2f})"))
        if st & K.FLIPPED:
            up_z = float(self._F[K.F_UPZ])
            ob.stopped(StopEvent(t, x, y, "flipped", f"robot tipped over (up-vector z={up_z:.2f})"))

    def _flush(self) -> None:
        """Turn the raw samples of the compiled loop into readings, in order."""
        n, smp = self._nsamp.tolist(), self._samples
        if n[K.ODOM]:  # the rows are the readings (_step._fire): the last one counts
            o = smp[K.ODOM, n[K.ODOM] - 1].tolist()
            self._odom = Odometry(o[0], o[1], o[2], o[3], o[4], o[5])
        if n[K.IMU]:
            i = smp[K.IMU, n[K.IMU] - 1].tolist()
            self._imu = Imu(i[0], i[1], i[2], i[3], (i[4], i[5], i[6]))
        if n[K.POSE]:
            self._pose = PoseReading(*smp[K.POSE, n[K.POSE] - 1].tolist())
        if n[K.OBSERVER]:
            self.observer.record_poses(smp[K.OBSERVER, : n[K.OBSERVER]])
        self._nsamp[:] = 0
        I, ob = self._I, self.observer
        ne = int(I[K.I_NEVENT])
        if ne or I[K.I_STARTS]:
            ob.collisions.extend(CollisionEvent(float(e[0]), float(e[1]), float(e[2]), int(e[3]))
                                 for e in self._event_buf[:ne])
            ob.contact_starts += int(I[K.I_STARTS])
            I[K.I_NEVENT] = I[K.I_STARTS] = 0
        if I[K.I_TOUCHING] or ob._touching:
            ob._touching = set(self._contact_prev[: int(I[K.I_TOUCHING])].tolist())

    def _scan(self) -> None:
        assert self._lidar is not None
        pts = self._lidar.scan_body(self.data.qpos, self._mount_v, self._lidar_gen if self.config.noise else None)
        self._scans.append(LidarScan(int(self._I[K.I_K]) * self._dt, pts, self._mount))

    def _unstable(self) -> None:
        d = self.data
        if not np.all(np.isfinite(d.qpos)) or not np.all(np.isfinite(d.qvel)):
            why = "NaN in the state"
        elif self._warnings() != int(self._I[K.I_WARN0]):
            why = "MuJoCo reported a bad position/velocity/acceleration (it would reset the state)"
        else:
            why = f"body speed {float(np.abs(d.qvel[:3]).sum()):.1f} m/s above {self.config.max_speed_mps} m/s"
        raise SimulationError(f"physics became unstable at t={self.t:.3f} s: {why}")
