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
from typing import Any

import mujoco
import numpy as np

from navstress.errors import SimulationError, SpecError
from navstress.nav.api import Command, Imu, LidarScan, Observation, Odometry, PoseReading
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.sim.config import SimConfig
from navstress.sim.drives import MAX_WHEELS, DriveModel, ackermann, drive_model
from navstress.sensors import Sensor
from navstress.sim.lidar import Lidar, build_scene
from navstress.sim.rays import Lidar3dCaster, RayCaster, caster
from navstress.sim.suite import effective_config as effective_config  # (re-exported: its old home)
from navstress.sim.suite import suite
from navstress.sim import _step as step_loop
from navstress.sim import mjabi
from navstress.sim import movers as mover_control
from navstress.sim.model import OBSTACLE_BIT, PARK_Z_M, ObstaclePool, RobotModel, build_model, empty_pool_arrays
from navstress.sim.observer import CollisionEvent, Observer, StopEvent
from navstress.world.world import World

_BUILTIN = ("odom", "imu", "pose", "observer")  # the built-in rows of _step (ODOM ... OBSERVER)
_JITTER_BATCH = 64  # rate-jitter uniforms drawn at a time from each sensor's timing generator
_SAMPLES = 64  # raw sensor samples buffered in the compiled loop between flushes
#: Control period of the movers (s): their controller (:mod:`navstress.sim.movers`) runs every
#: this long from the robot's true state; in between each mover body moves linearly.
MOVER_PERIOD_S = 0.1


def _pad(a: np.ndarray, fill: float) -> np.ndarray:
    """``a`` padded with ``fill`` to :data:`MAX_WHEELS` entries (the loop's wheel arrays)."""
    out = np.full(MAX_WHEELS, fill, dtype=a.dtype)
    out[: a.size] = a
    return out


class Simulation:
    """Physics, sensors and observer of one run.

    ``seed`` is the run seed: sensor noise, sensor rate jitter and command latency jitter each
    draw from their own generator derived from it (``navstress.seeding.rng(seed, "sim", ...)``).
    ``start`` overrides the mission start (x, y, yaw).

    The steps run in one compiled loop (``navstress.sim._step.run_steps``) that returns to Python
    only for lidar scans, commands, collisions, stop events, the movers' controller and to flush
    its sensor samples.

    Movers (``world.movers``): their controller runs every :data:`MOVER_PERIOD_S` from the robot's
    TRUE pose and velocity (they are part of the world; the navigator sees them only through its
    ray sensors), drawing from ``navstress.seeding.rng(seed, "movers")``; :meth:`mover_track` holds
    their poses at every run of it.

    Ray sensors: :attr:`sensors` (:func:`navstress.sim.suite.suite`: the robot's, or its default
    lidar), each cast by a :mod:`navstress.sim.rays` caster on its own schedule row of the compiled
    step, its streams keyed by its name.
    """

    def __init__(self, world: World, robot: RobotSpec = RobotSpec(), config: SimConfig = SimConfig(), *,
                 seed: int, start: tuple[float, float, float] | None = None) -> None:
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise SpecError("seed", seed, "an integer >= 0")
        mjabi.check_layout()
        self.world, self.robot, self.config, self.seed = world, robot, config, seed
        self.drive: DriveModel = drive_model(robot)
        config = effective_config(robot, config)
        self.config = config
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
        exact = cfg.analytic_wheel_contacts or self.drive.exact_contacts
        wgeoms = np.flatnonzero(rm.wheel_of_geom >= 0)[np.argsort(rm.wheel_of_geom[rm.wheel_of_geom >= 0])]
        tmpl = step_loop.contact_template(m, d, wgeoms, 0) if exact else np.zeros(mjabi.CF)
        # the contacts are rewritten (and added) after mj_fwdPosition, which computes constraint
        # islands from the contacts; the robot is one kinematic tree: one island, none needed
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
        if exact:
            m.geom_contype[wgeoms] = 0
            m.geom_conaffinity[wgeoms] = 0
        terrain = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
        hsz = m.hfield_size[0]
        nrow, ncol = int(m.hfield_nrow[0]), int(m.hfield_ncol[0])
        hf = m.geom_pos[terrain][2] + hsz[2] * m.hfield_data.astype(np.float64).reshape(nrow, ncol)
        grid = np.array([m.geom_pos[terrain][0] - hsz[0], m.geom_pos[terrain][1] - hsz[1], 2 * hsz[0] / (ncol - 1),
                         2 * hsz[1] / (nrow - 1)])  # x0, y0, dx, dy of hf
        wheel_arrays = step_loop.WheelContactArrays(
            wgeoms.astype(np.int64) if exact else np.zeros(0, np.int64), hf, tmpl,
            np.zeros((4, 7)))
        mujoco.mj_forward(m, d)
        #: the ray sensors of the run, in schedule-row order
        self.sensors: tuple[Sensor, ...] = suite(robot, config)
        self._scene = scene = build_scene(world) if self.sensors else None
        self._casters: list[RayCaster] = [caster(s, seed, scene) for s in self.sensors] if scene is not None else []
        names = _BUILTIN + tuple(s.name for s in self.sensors)
        self._timing = [rng(seed, "sim", "timing", n) for n in names]
        self._nrows = len(names)
        self._latency_gen = rng(seed, "sim", "latency")
        self._queue: list[tuple[int, Command]] = []
        # sensors: IMU and pose noise (ImuSensor/PoseSensor arithmetic, compiled in _step._fire) come
        # from standard normals pre-drawn in batches from each sensor's generator, consumed in order
        self._noise_gen = (rng(seed, "sim", "noise", "imu"), rng(seed, "sim", "noise", "pose"))
        self._noise = np.zeros((2, step_loop.NOISE_BATCH))
        rates = [cfg.odom_rate_hz, cfg.imu_rate_hz, cfg.pose_rate_hz, cfg.observer_rate_hz]
        rates += [c.rate_hz for c in self._casters] + [0.0] * (step_loop.NROWS - self._nrows)
        next_k = np.zeros(step_loop.NROWS, np.int64)
        next_k[self._nrows:] = np.iinfo(np.int64).max  # rows without a sensor: never due
        n_obst, n_mov = len(world.obstacles), len(world.movers)
        self._init_movers(n_obst)
        self._jitter = np.zeros((step_loop.NROWS, _JITTER_BATCH))
        self._samples = np.zeros((step_loop.NBUILTIN, _SAMPLES, 7))
        self.observer = Observer(cfg.collision_debounce_s)
        self._contact_buf = np.zeros(64, np.int64)
        self._contact_prev = np.zeros(64, np.int64)
        # per obstacle then per mover (contact index n_obst + i), for the debounce
        self._last_touch = np.full(max(1, n_obst + n_mov), -np.inf)
        self._event_buf = np.zeros((128, step_loop.EVENT_COLS))
        # compiled-loop state and constants (named records, see _step.STATE / PARAMS) and arrays
        r = robot
        dm = self.drive
        nw = len(dm.wheels)
        wheel_angles = np.zeros(MAX_WHEELS)
        wheel_angles[:nw] = d.qpos[rm.wheel_qpos]
        q0 = d.qpos
        yaw0 = math.atan2(2.0 * (q0[3] * q0[6] + q0[4] * q0[5]), 1.0 - 2.0 * (q0[5] * q0[5] + q0[6] * q0[6]))
        self._state = step_loop.new_state(cmd_k=step_loop.NO_CMD, ref=wheel_angles, odom_a=wheel_angles,
                                          odom_gyro_yaw=yaw0,
                                          next_k=next_k, mover_k=0 if self._mover_every else step_loop.NO_CMD,
                                          # noise and jitter rows: drawn on first use
                                          n_imu=step_loop.NOISE_BATCH, n_pose=step_loop.NOISE_BATCH,
                                          jitter_idx=_JITTER_BATCH)
        # views of the fields Python reads or writes every cycle (a view reads ~4x faster than a
        # field of the record); the rest through self._state
        st = self._state
        self._sk, self._cmd_k, self._cmd_v, self._cmd_w = st["k"], st["cmd_k"], st["cmd_v"], st["cmd_w"]
        self._touching, self._starts, self._nevent = st["touching"], st["starts"], st["nevent"]
        self._jitter_idx, self._nsamp, self._due = st["jitter_idx"][0], st["nsamples"][0], st["due"][0]
        self._mover_k, self._mover_k0 = st["mover_k"], st["mover_k0"]
        warn = d.warning.number
        bad = [int(w) for w in step_loop.BAD_WARNINGS]
        pool = self._pool
        adr = mjabi.addresses(m, d)
        steer_act, steer_qpos = -np.ones(nw, np.int64), -np.ones(nw, np.int64)
        k_steer = 0
        for i, w in enumerate(dm.wheels):
            if w.steered:
                steer_act[i], steer_qpos[i] = rm.steer_act[k_steer], rm.steer_qpos[k_steer]
                k_steer += 1
        # odometry encoders: every driven wheel (ackermann: the rear wheels)
        odom_side = np.array([(1 if w.side > 0 else 2) if (w.driven and not w.steered) else 0 for w in dm.wheels],
                             np.int64)
        self._params = step_loop.new_params(
            model=adr.model, data=adr.data, ncon_addr=adr.ncon, contact_field=adr.contact_field,
            chassis=rm.chassis_body, bumper=rm.bumper_geom, terrain=terrain,
            n_wheels=nw, wheel_body=_pad(rm.wheel_bodies, -1), wheel_qpos=_pad(rm.wheel_qpos, -1),
            wheel_dof=_pad(rm.wheel_dofs, -1), wheel_x=_pad(np.array([w.x for w in dm.wheels]), 0.0),
            wheel_y=_pad(np.array([w.y for w in dm.wheels]), 0.0), wheel_act=_pad(rm.wheel_act, -1),
            axle_body=_pad(rm.axle_bodies, -1), steer_act=_pad(steer_act, -1), steer_qpos=_pad(steer_qpos, -1),
            odom_side=_pad(odom_side, 0), odom_inv_l=1.0 / max(1, int(np.sum(odom_side == 1))),
            odom_inv_r=1.0 / max(1, int(np.sum(odom_side == 2))), odom_gyro=int(dm.odom_gyro), drive=dm.kind,
            wheelbase=r.wheelbase_m, rear_x=-r.wheelbase_m / 2, max_steer=dm.max_steer_rad,
            steer_step=dm.max_steer_rate_rps * self._dt, min_turn_speed=ackermann.MIN_TURN_SPEED,
            warning_ids=bad,
            period=[1.0 / hz if hz > 0 else 1.0 for hz in rates], n_rays=len(self._casters),
            dt=self._dt, dv=r.max_accel_mps2 * self._dt, dw=r.max_yaw_accel_rps2 * self._dt,
            skid=dm.track_multiplier, kp=dm.yaw_kp, ki=dm.yaw_ki,
            wheel_radius=r.wheel_radius_m, hold=dm.hold_gain,
            mu=cfg.friction, friction_floor=cfg.friction_floor, slip_eps=cfg.slip_eps_mps,
            max_speed=cfg.max_speed_mps, size_x=rm.map_size[0], size_y=rm.map_size[1], margin=cfg.map_margin_m,
            cos_flip=math.cos(cfg.flip_threshold_rad), debounce=cfg.collision_debounce_s,
            odom_radius=r.wheel_radius_m, odom_track=r.track_m * dm.track_multiplier,
            jitter=int(cfg.jitter), rate_jitter=cfg.rate_jitter, noise=int(cfg.noise),
            imu_att=cfg.imu_att_std_rad, imu_rate=cfg.imu_rate_std_rps, imu_drift=cfg.imu_yaw_drift_rps,
            pose_pos=cfg.pose_pos_std_m, pose_att=cfg.pose_att_std_rad,
            warn0=int(sum(int(warn[w]) for w in bad)),
            pool_every=max(1, int(round(0.1 / self._dt))) if pool is not None else 0,
            pool_contype=OBSTACLE_BIT, park_z=PARK_Z_M,
            hfield_x0=grid[0], hfield_y0=grid[1], hfield_dx=grid[2], hfield_dy=grid[3],
            mover_every=self._mover_every, n_obstacles=n_obst)
        self._arrays = step_loop.loop_arrays(
            step_loop.MjArrays(d.qpos, d.qvel, d.ctrl, d.xpos, d.xmat, warn, d.mocap_pos, d.mocap_quat, m.geom_size,
                               m.geom_rbound, m.geom_aabb, m.bvh_aabb, m.geom_contype, m.geom_type),
            step_loop.RobotArrays(rm.wheel_of_geom, rm.obstacle_of_geom),
            pool.arrays if pool is not None else empty_pool_arrays(),
            step_loop.SensorArrays(self._jitter, self._samples, self._noise),
            step_loop.CollisionArrays(self._contact_buf, self._contact_prev, self._last_touch, self._event_buf),
            wheel_arrays, self._mover_arrays)
        # readings since the last observe(): the lidar3d scans, every ray sensor's by name
        self._scans: list[LidarScan] = []
        self._new: dict[str, list[Any]] = {c.name: [] for c in self._casters}
        self._pose: PoseReading | None = None
        self._odom = Odometry(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self._imu: Imu | None = None
        self._run(0)

    # ---- public API -------------------------------------------------------------------
    @property
    def _k(self) -> int:
        return int(self._sk[0])

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
        k = int(self._sk[0]) + max(0, int(round(delay / self._dt)))
        pending = int(self._cmd_k[0])
        if self._queue:  # commands never overtake each other
            k = max(k, self._queue[-1][0])
        elif pending != step_loop.NO_CMD:
            k = max(k, pending)
        self._queue.append((k, cmd))

    def advance(self, dt: float) -> None:
        """Step physics for ``dt`` seconds (rounded to whole steps), firing sensors as due.

        Returns early, without stepping, once the run is :attr:`stopped`.
        Raises SimulationError when the physics becomes unstable.
        """
        if not (math.isfinite(dt) and dt >= 0):
            raise SpecError("dt", dt, "a finite duration >= 0 s")
        self._run(int(self._sk[0]) + int(round(dt / self._dt)))

    def observe(self) -> Observation:
        """Sensor readings since the previous call: every ray sensor's by name (``readings``; the
        lidar3d scans also in ``scans``), the latest pose (or None), the latest odometry and IMU
        readings (in ``readings`` too: ``odom``, ``imu``, and ``pose`` when new)."""
        imu, odom, pose = self._imu, self._odom, self._pose
        assert imu is not None
        readings: dict[str, tuple[Any, ...]] = {"odom": (odom,), "imu": (imu,)}
        if pose is not None:
            readings["pose"] = (pose,)
        new = self._new
        for name, got in new.items():
            if got:
                readings[name] = tuple(got)
                new[name] = []
        obs = Observation(t=int(self._sk[0]) * self._dt, odom=odom, imu=imu, pose=pose, scans=tuple(self._scans),
                          readings=readings)
        self._scans = []
        self._pose = None
        return obs

    @property
    def _lidar(self) -> Lidar | None:
        """The first lidar3d sensor's :class:`Lidar` (None: none)."""
        for c in self._casters:
            if isinstance(c, Lidar3dCaster):
                return c.lidar
        return None

    def mover_track(self) -> tuple[np.ndarray, np.ndarray]:
        """The movers' poses at every run of their controller so far: times (m,) and poses
        (m, n, 4) x, y, z (body centre), yaw (``world.movers`` order); empty without movers."""
        n = len(self.world.movers)
        if not self._mover_t:
            return np.zeros(0), np.zeros((0, n, 4))
        return np.array(self._mover_t), np.stack(self._mover_poses)

    def mover_poses(self) -> np.ndarray:
        """(n, 4) x, y, z (body centre), yaw of every mover body now."""
        mv = self._mover_arrays
        every = self._mover_every
        if not every:
            return np.zeros((0, 4))
        f = (int(self._sk[0]) - int(self._state["mover_k0"][0])) / every
        out: np.ndarray = mv.pose0 + f * (mv.pose1 - mv.pose0)
        d = (mv.pose1[:, 3] - mv.pose0[:, 3] + math.pi) % (2 * math.pi) - math.pi
        out[:, 3] = mv.pose0[:, 3] + f * d
        return out

    # ---- internals --------------------------------------------------------------------
    def _init_movers(self, n_obst: int) -> None:
        """The movers' controller, bodies and contact indices (nothing without movers)."""
        world, rm = self.world, self.rm
        n = len(world.movers)
        self._mover_t: list[float] = []
        self._mover_poses: list[np.ndarray] = []
        if n == 0:
            self._mover_every = 0
            self._mover_arrays = step_loop.empty_mover_arrays()
            return
        self._mover_every = max(1, int(round(MOVER_PERIOD_S / self._dt)))
        self._mover_plan = mover_control.make_plan(world)
        self._mover_state = mover_control.initial_state(self._mover_plan)
        self._mover_rng = rng(self.seed, "movers")
        self._mover_half_h = np.array([mv.size[2] / 2 for mv in world.movers])
        rm.obstacle_of_geom[rm.mover_geoms] = n_obst + np.arange(n)
        pose = np.zeros((n, 4))
        pose[:, :2] = self._mover_state[:, mover_control.X:mover_control.Y + 1]
        ter = world.terrain
        pose[:, 2] = [step_loop.ground_height(ter.heights, float(ter.cell_m), x, y)
                      for x, y in pose[:, :2].tolist()]
        pose[:, 2] += self._mover_half_h
        pose[:, 3] = self._mover_state[:, mover_control.YAW]
        self._mover_arrays = step_loop.MoverArrays(rm.mover_mocap.astype(np.int64), pose, pose.copy(),
                                                   np.zeros((n, 2)))
        # lidar shapes: discs (x, y, r, z bottom, z top) and boxes (LidarScene rows), each after the static ones
        self._disc_movers = np.array([i for i, mv in enumerate(world.movers) if mv.shape == "disc"], np.int64)
        self._box_movers = np.array([i for i, mv in enumerate(world.movers) if mv.shape != "disc"], np.int64)
        self._mover_size = np.array([mv.size for mv in world.movers], np.float64).reshape(n, 3)
        self._scan_discs = np.zeros((len(self._disc_movers), 5))
        self._scan_boxes: np.ndarray | None = None
        if self._casters:  # the scene's boxes and discs, then one row per mover (rewritten per cast)
            assert self._scene is not None
            boxes, discs = self._scene.boxes, self._scene.discs
            nb, nd = boxes.shape[0], discs.shape[0]
            self._scan_boxes = np.zeros((nb + len(self._box_movers), 9))
            self._scan_boxes[:nb] = boxes
            self._scan_discs = np.zeros((nd + len(self._disc_movers), 5))
            self._scan_discs[:nd] = discs

    def _step_movers(self) -> None:
        """Run the movers' controller for the next period from the robot's true state; the bodies
        then move linearly to where it puts them."""
        k, every = int(self._sk[0]), self._mover_every
        q, qv = self.data.qpos, self.data.qvel
        qw, qx, qy, qz = float(q[3]), float(q[4]), float(q[5]), float(q[6])
        yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        mv, st = self._mover_arrays, self._mover_state
        self._mover_t.append(k * self._dt)
        self._mover_poses.append(mv.pose1.copy())  # where the bodies are now
        period = every * self._dt
        mover_control.step(self._mover_plan, st, period, (float(q[0]), float(q[1]), yaw),
                           (float(qv[0]), float(qv[1])), self._mover_rng)
        ter = self.world.terrain
        step_loop.mover_targets(st, self._mover_half_h, ter.heights, float(ter.cell_m), period, mv.pose0, mv.pose1,
                                mv.vel)
        self._mover_k0[0] = k
        self._mover_k[0] = k + every

    def _warnings(self) -> int:
        return sum(int(self.data.warning[w].number) for w in step_loop.BAD_WARNINGS)

    def _run(self, k_end: int) -> None:
        """Step until step ``k_end`` (or a stop), handling what the compiled loop hands back."""
        r, q, sk, cmd_k = self.robot, self._queue, self._sk, self._cmd_k
        state, params, arrays = self._state, self._params, self._arrays
        run_steps, ob = step_loop.run_steps, self.observer  # looked up per call: benchmarks wrap it
        vmax, wmax = r.max_speed_mps, r.max_yaw_rate_rps
        while True:
            # the compiled loop applies one pending command at the start of its step; it stops at
            # the next queued one (a later command for the same step replaces the pending one)
            if q and (cmd_k[0] == step_loop.NO_CMD or q[0][0] <= cmd_k[0]):
                while True:
                    kc, c = q.pop(0)
                    cmd_k[0] = kc
                    self._cmd_v[0] = min(max(c.v, -vmax), vmax)
                    self._cmd_w[0] = min(max(c.omega, -wmax), wmax)
                    if not (q and q[0][0] <= kc):
                        break
            stopped = ob.stop is not None
            st = run_steps(int(sk[0]) if stopped else (min(k_end, q[0][0]) if q else k_end), state, params, *arrays)
            if st == step_loop.DONE:
                if stopped or int(sk[0]) >= k_end:
                    break
                continue
            if st & step_loop.UNSTABLE:
                self._flush()
                self._unstable()
            if st & (step_loop.LEFT_MAP | step_loop.FLIPPED):
                self._flush()  # collisions of this step first
                self._events(st)
            if st & step_loop.FLUSH:
                self._flush()
                for s in range(self._nrows):
                    if self._jitter_idx[s] >= _JITTER_BATCH:
                        self._jitter[s] = self._timing[s].random(_JITTER_BATCH)
                        self._jitter_idx[s] = 0
                if self.config.noise:
                    for row, field in ((step_loop.IMU_NOISE, "n_imu"), (step_loop.POSE_NOISE, "n_pose")):
                        if state[field][0] >= step_loop.NOISE_BATCH:  # used up exactly (a multiple of 7, 6)
                            self._noise[row] = self._noise_gen[row].standard_normal(step_loop.NOISE_BATCH)
                            state[field] = 0
            if st & step_loop.RAYS:
                self._cast()
            if st & step_loop.MOVERS:
                self._step_movers()
        self._flush()

    def _events(self, st: int) -> None:
        t, x, y = self.t, float(self.data.qpos[0]), float(self.data.qpos[1])
        ob = self.observer
        if st & step_loop.LEFT_MAP:
            ob.stopped(StopEvent(t, x, y, "left_map", f"robot left the map at ({x:.2f}, {y:.2f})"))
        if st & step_loop.FLIPPED:
            up_z = float(self._state["up_z"][0])
            ob.stopped(StopEvent(t, x, y, "flipped", f"robot tipped over (up-vector z={up_z:.2f})"))

    def _flush(self) -> None:
        """Turn the raw samples of the compiled loop into readings, in order."""
        n, smp = self._nsamp.tolist(), self._samples
        if n[step_loop.ODOM]:  # the rows are the readings (_step._fire): the last one counts
            o = smp[step_loop.ODOM, n[step_loop.ODOM] - 1].tolist()
            self._odom = Odometry(o[0], o[1], o[2], o[3], o[4], o[5])
        if n[step_loop.IMU]:
            i = smp[step_loop.IMU, n[step_loop.IMU] - 1].tolist()
            self._imu = Imu(i[0], i[1], i[2], i[3], (i[4], i[5], i[6]))
        if n[step_loop.POSE]:
            self._pose = PoseReading(*smp[step_loop.POSE, n[step_loop.POSE] - 1].tolist())
        if n[step_loop.OBSERVER]:
            self.observer.record_poses(smp[step_loop.OBSERVER, : n[step_loop.OBSERVER]])
        self._nsamp[:] = 0
        ob, nevent, starts, touching = self.observer, self._nevent, self._starts, self._touching
        ne = int(nevent[0])
        if ne or starts[0]:
            n_obst = len(self.world.obstacles)
            for e in self._event_buf[:ne].tolist():
                o = int(e[3])
                if o < n_obst:
                    ob.collisions.append(CollisionEvent(e[0], e[1], e[2], o))
                else:
                    ob.collisions.append(CollisionEvent(e[0], e[1], e[2], -1, mover=self.world.movers[o - n_obst].id,
                                                        robot_speed=e[4], mover_speed=e[5], relative_speed=e[6]))
            ob.contact_starts += int(starts[0])
            nevent[0] = starts[0] = 0
        if touching[0] or ob._touching:
            ob._touching = set(self._contact_prev[: int(touching[0])].tolist())

    def _cast(self) -> None:
        """Cast every ray sensor that is due (``STATE.due``), in row order."""
        discs = boxes = None
        if self._mover_every:  # the movers where they are now
            assert self._scan_boxes is not None
            f = (int(self._sk[0]) - int(self._mover_k0[0])) / self._mover_every
            discs, boxes, mv = self._scan_discs, self._scan_boxes, self._mover_arrays
            step_loop.mover_shapes(f, mv.pose0, mv.pose1, self._mover_size, self._disc_movers, self._box_movers, discs,
                                   boxes)
        t, qpos, noisy, due = int(self._sk[0]) * self._dt, self.data.qpos, bool(self.config.noise), self._due
        for i, c in enumerate(self._casters):
            if due[i]:
                due[i] = 0
                reading = c.cast(qpos, t, noisy, discs, boxes)
                self._new[c.name].append(reading)
                if c.kind == "lidar3d":
                    self._scans.append(reading)

    def _unstable(self) -> None:
        d = self.data
        if not np.all(np.isfinite(d.qpos)) or not np.all(np.isfinite(d.qvel)):
            why = "NaN in the state"
        elif self._warnings() != int(self._params["warn0"][0]):
            why = "MuJoCo reported a bad position/velocity/acceleration (it would reset the state)"
        else:
            why = f"body speed {float(np.abs(d.qvel[:3]).sum()):.1f} m/s above {self.config.max_speed_mps} m/s"
        raise SimulationError(f"physics became unstable at t={self.t:.3f} s: {why}")
