"""The compiled step loop and what it relies on (MuJoCo's ABI: test_mjabi.py): the obstacle pool, compiled collision bookkeeping, batched sensors, analytic wheel contacts."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from navstress.errors import SpecError
from navstress.nav.api import Command
from navstress.robot import RobotSpec
from navstress.sim import SimConfig, Simulation
from navstress.sim import _step as K
from navstress.sim.model import ObstaclePool, build_model
from navstress.sim.observer import Observer
from navstress.seeding import rng
from tests.oracles.sensors import ImuSensor, PoseSensor, WheelOdometry
from navstress.world.world import Obstacle

from tests.support.sim_worlds import bumpy, flat, rough

NOLIDAR = SimConfig(lidar_enabled=False)


def _pool_world(seed: int, n: int) -> tuple[list[Obstacle], np.ndarray]:
    g = np.random.default_rng(seed)
    obs = [Obstacle("tree", float(x), float(y), float(yaw), (float(a), float(b), 4.0), 0.0)
           for x, y, yaw, a, b in zip(g.uniform(1, 39, n), g.uniform(1, 39, n), g.uniform(-3, 3, n),
                                      g.uniform(0.3, 3.0, n), g.uniform(0.3, 3.0, n))]
    return obs, g.uniform(2, 38, (6, 2))


def _box_gap(o: Obstacle, x: float, y: float) -> float:
    """Distance from (x, y) to a box's footprint: the point in the box's frame, outside its sides."""
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    lx, ly = c * (x - o.x) + s * (y - o.y), -s * (x - o.x) + c * (y - o.y)
    return math.hypot(max(abs(lx) - o.size[0] / 2, 0.0), max(abs(ly) - o.size[1] / 2, 0.0))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(0, 120), margin=st.floats(0.0, 3.0))
def test_pool_holds_exactly_the_obstacles_near_the_robot(seed: int, n: int, margin: float) -> None:
    """Brute force: after each update the filled slots hold exactly the obstacles whose footprint
    is within reach (robot reach + margin from the robot's centre), each with its pose and size;
    empty slots collide with nothing; an obstacle keeps its slot (cylinders and long walls:
    test_shapes.py)."""
    obs, spots = _pool_world(seed, n)
    w = flat(obstacles=tuple(obs))
    r = RobotSpec()
    rm = build_model(w, r, start=(20.0, 20.0, 0.0), obstacle_pool=64)
    m, d = rm.model, mujoco.MjData(rm.model)
    pool = ObstaclePool(rm, w, r, margin)
    robot_reach = math.hypot(r.length_m, r.width_m) / 2
    prev: dict[int, int] = {}
    for x, y in spots:
        d.qpos[0:2] = (x, y)
        pool.update(d)
        want = {k for k, o in enumerate(obs) if _box_gap(o, x, y) <= robot_reach + margin}
        slots = {int(o): s for s, o in enumerate(pool.slot_obstacle) if o >= 0}
        assert set(slots) == want and pool.overflows == 0
        for k, s in slots.items():
            g, b = rm.slot_geoms[s], m.body_mocapid[rm.slot_bodies[s]]
            o = obs[k]
            assert rm.obstacle_of_geom[g] == k and m.geom_contype[g] != 0
            np.testing.assert_allclose(d.mocap_pos[b], (o.x, o.y, o.z + o.size[2] / 2))
            np.testing.assert_allclose(m.geom_size[g], np.array(o.size) / 2)
            assert abs(d.mocap_quat[b][3] - math.sin(o.yaw / 2)) < 1e-12
            if k in prev:
                assert prev[k] == s  # stayed in its slot
        for s in range(64):
            if pool.slot_obstacle[s] < 0:
                assert m.geom_contype[rm.slot_geoms[s]] == 0 and rm.obstacle_of_geom[rm.slot_geoms[s]] == -1
        prev = slots


def test_pool_overflow_keeps_the_nearest() -> None:
    obs = [Obstacle("tree", 20.0 + 0.3 * k, 20.0, 0.0, (0.2, 0.2, 2.0)) for k in range(10)]
    w = flat(obstacles=tuple(obs))
    rm = build_model(w, start=(5.0, 5.0, 0.0), obstacle_pool=4)
    d = mujoco.MjData(rm.model)
    pool = ObstaclePool(rm, w, RobotSpec(), 1.5)
    d.qpos[0:2] = (19.0, 20.0)
    pool.update(d)
    assert sorted(pool.slot_obstacle.tolist()) == [0, 1, 2, 3] and pool.overflows == 1


def test_pool_and_static_obstacles_give_the_same_run() -> None:
    """Driving through a cluster of trees with the pool or with every obstacle static in MuJoCo:
    the same collision events and the same trajectory (to solver round-off)."""
    obs, _ = _pool_world(7, 60)
    obs += [Obstacle("tree", 12.0 + 2.0 * k, 20.5 - 0.3 * k, 0.2 * k, (0.8, 0.8, 5.0)) for k in range(6)]
    runs = []
    for pool in (0, 32):
        cfg = SimConfig(lidar_enabled=False, obstacle_pool=pool, noise=False, jitter=False)
        sim = Simulation(flat(obstacles=tuple(obs)), config=cfg, seed=0, start=(5.0, 20.0, 0.0))
        for k in range(120):
            sim.command(Command(1.2, 0.3 * math.sin(k / 15)))
            sim.advance(0.1)
        runs.append((sim.observer.poses.copy(), [(e.t, e.obstacle) for e in sim.observer.collisions]))
    (pa, ea), (pb, eb) = runs
    assert ea and ea == eb
    assert np.abs(pa - pb).max() < 1e-3


def test_pool_has_no_more_slots_than_obstacles_and_empty_slots_change_nothing() -> None:
    """A world with n < K obstacles gets n slots (none: no slot bodies); the run is bit-identical to
    one where far-away extra obstacles make the pool K slots (K - n of them always empty)."""
    near = [Obstacle("tree", 12.0 + 2.0 * k, 20.5 - 0.3 * k, 0.2 * k, (0.8, 0.8, 5.0)) for k in range(6)]
    far = [Obstacle("tree", 38.0, 2.0 + 1.2 * k, 0.0, (0.3, 0.3, 3.0)) for k in range(30)]
    runs = []
    for obs in (near, near + far):
        sim = Simulation(flat(obstacles=tuple(obs)), config=NOLIDAR, seed=2, start=(5.0, 20.0, 0.0))
        assert len(sim.rm.slot_geoms) == min(len(obs), NOLIDAR.obstacle_pool)
        for k in range(100):
            sim.command(Command(1.0, 0.0))
            sim.advance(0.1)
        runs.append((sim.observer.poses.copy(), [(e.t, e.obstacle) for e in sim.observer.collisions],
                     sim.observer.contact_starts))
    (pa, ea, sa), (pb, eb, sb) = runs
    assert ea and ea == eb and sa == sb and np.array_equal(pa, pb)
    assert len(Simulation(flat(), config=NOLIDAR, seed=0).rm.slot_geoms) == 0


def test_bad_pool_size() -> None:
    with pytest.raises(SpecError, match=r"sim.obstacle_pool=-1 is invalid"):
        SimConfig(obstacle_pool=-1)


@settings(max_examples=30, deadline=None)
@given(seq=st.lists(st.sets(st.integers(0, 4), max_size=3), min_size=1, max_size=40),
       dt=st.sampled_from([0.01, 0.13, 0.3]))
def test_compiled_contact_events_equal_the_observer(seq: list[set[int]], dt: float) -> None:
    """The compiled loop's collision bookkeeping equals Observer.contacts (the reference) fed the
    same touching set after every step: same events, same contact starts."""
    ref = Observer(0.5)
    state = K.new_state()
    I = state[0]
    prev, cur = np.zeros(8, np.int64), np.zeros(8, np.int64)
    last = np.full(5, -np.inf)
    events = np.zeros((64, 4))
    for k, s_ in enumerate(seq):
        t, x, y = k * dt, 0.1 * k, -0.2 * k
        ref.contacts(t, x, y, set(s_))
        cur[: len(s_)] = sorted(s_)
        assert K.contact_events(I, K.CollisionArrays(cur, prev, last, events), len(s_), t, x, y, 0.5)
    got = [(float(e[0]), float(e[1]), float(e[2]), int(e[3])) for e in events[: I["nevent"]]]
    assert got == [(e.t, e.x, e.y, e.obstacle) for e in ref.collisions]
    assert I["starts"] == ref.contact_starts
    assert set(prev[: I["touching"]].tolist()) == ref._touching


def test_compiled_odometry_and_batched_imu_equal_the_reference() -> None:
    g = np.random.default_rng(3)
    angles = np.cumsum(g.normal(0, 0.1, (12, 4)), axis=0)
    t = np.arange(1, 13) * 0.02
    od = WheelOdometry(0.26, 1.8, np.zeros(4), 0.0)
    S = K.new_state()[0]
    P = np.zeros(1, K.PARAMS)[0]
    P["odom_radius"], P["odom_track"] = 0.26, 1.8
    # four wheels FL, RL, FR, RR at qpos 7..10 (the chassis' free joint first), left, left, right, right
    P["n_wheels"], P["wheel_qpos"][:4], P["odom_side"][:4] = 4, [7, 8, 9, 10], [1, 1, 2, 2]
    P["odom_inv_l"] = P["odom_inv_r"] = 0.5
    qpos = np.zeros(11)
    qpos[3] = 1.0
    for k in range(12):
        ref = od.update(angles[k], float(t[k]))
        qpos[7:11] = angles[k]
        K.odom_update(S, P, qpos, float(t[k]))
        got = (S["odom_x"], S["odom_y"], S["odom_yaw"], S["odom_v"], S["odom_w"])
        np.testing.assert_allclose(got, (ref.x, ref.y, ref.yaw, ref.v, ref.omega), rtol=1e-12, atol=1e-12)
    rows = np.column_stack([t, g.normal(0, 1, (12, 6))])
    for noise in (True, False):
        ia = ImuSensor(np.random.default_rng(5), 0.002, 0.005, 0.01, noise, 0.0)
        ib = ImuSensor(np.random.default_rng(5), 0.002, 0.005, 0.01, noise, 0.0)
        for r in rows:
            la = ia.read(float(r[0]), float(r[1]), float(r[2]), float(r[3]), r[4:7])
        lb = ib.read_many(rows)
        assert la == lb and ia.bias == ib.bias


@pytest.mark.parametrize("imu_hz", [50.0, 300.0])
def test_compiled_imu_and_pose_noise_equal_the_reference_sensors(imu_hz: float) -> None:
    """The noisy IMU and pose readings of a run equal ImuSensor.read_many / PoseSensor.read on the
    run's noise generators, fed the noise-free readings of the same run (noise changes no physics)
    at the samples' times (no rate jitter: IMU every 1/imu_hz s, pose every 0.1 s, from t = 0).
    300 Hz uses up the pre-drawn noise rows and fills the sample buffers several times."""
    obs = {}
    for noise in (False, True):
        cfg = SimConfig(lidar_enabled=False, jitter=False, noise=noise, imu_rate_hz=imu_hz)
        sim = Simulation(bumpy(), config=cfg, seed=11, start=(10.0, 10.0, 0.3))
        obs[noise] = []
        for k in range(40):
            sim.command(Command(1.0, 0.4 * math.sin(k / 6)))
            sim.advance(0.1 if k % 5 else 0.83)
            obs[noise].append(sim.observe())
    cfg = SimConfig()
    imu = ImuSensor(rng(11, "sim", "noise", "imu"), cfg.imu_att_std_rad, cfg.imu_rate_std_rps,
                    cfg.imu_yaw_drift_rps, True, 0.0)
    pose = PoseSensor(rng(11, "sim", "noise", "pose"), cfg.pose_pos_std_m, cfg.pose_att_std_rad, True)
    every = max(1, int(round(1.0 / imu_hz / 0.01)))  # (300 Hz: every 10 ms step)
    k_imu = k_pose = 0
    for clean, noisy in zip(obs[False], obs[True]):
        c = clean.imu
        ks = list(range(k_imu, int(round(c.t / 0.01)) + 1, every))
        rows = np.zeros((len(ks), 7))
        rows[:, 0] = np.array(ks) * 0.01
        rows[-1, 1:] = (c.yaw, c.pitch, c.roll, *c.rates)
        assert rows[-1, 0] == c.t
        assert imu.read_many(rows) == noisy.imu
        k_imu = ks[-1] + every
        p = clean.pose
        assert p is not None and noisy.pose is not None
        while k_pose * 0.01 < p.t:  # earlier pose samples of the period: their draws
            pose.read(k_pose * 0.01, np.zeros(3), 0.0, 0.0, 0.0)
            k_pose += 10
        assert pose.read(p.t, np.array([p.x, p.y, p.z]), p.yaw, p.pitch, p.roll) == noisy.pose
        k_pose += 10
    assert obs[True][-1].imu != obs[False][-1].imu


@settings(max_examples=8, deadline=None)
@given(cuts=st.sets(st.integers(1, 9), min_size=1, max_size=4), seed=st.integers(0, 1000),
       doubled=st.integers(0, 29))
def test_advance_in_pieces_gives_the_same_run(cuts: set[int], seed: int, doubled: int) -> None:
    """Commands (with latency jitter) and readings do not depend on how a control period is cut
    into ``advance`` calls: 0.1 s at once or cut after the steps in ``cuts`` gives the same
    trajectory and readings; two commands in one period: the later one wins from its step on."""
    runs = []
    ends = [0, *sorted(cuts), 10]
    for pieces in ([10], [b - a for a, b in zip(ends, ends[1:])]):
        sim = Simulation(bumpy(), config=SimConfig(lidar_enabled=False), seed=seed, start=(10.0, 10.0, 0.3))
        out = []
        for k in range(30):
            sim.command(Command(1.0, 0.5 * math.sin(k / 4)))
            if k == doubled:
                sim.command(Command(-0.5, 0.0))
            for n in pieces:
                sim.advance(n * 0.01)
            o = sim.observe()
            out.append((o.t, o.odom, o.imu))
        runs.append((sim.t, out, sim.observer.poses.copy(), sim.data.qpos.copy()))
    (ta, oa, pa, qa), (tb, ob, pb, qb) = runs
    assert ta == tb and np.array_equal(pa, pb) and np.array_equal(qa, qb)
    assert [x[1:] for x in oa] == [x[1:] for x in ob]


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**31))
@example(seed=15965788)  # a centre behind a steep neighbouring face's plane (was 0.67 m deep instead of 0.17)
def test_sphere_terrain_contacts_find_the_surface_distance(seed: int) -> None:
    """Brute force: the deepest analytic contact is the sphere radius minus the distance from the
    centre to the triangulated surface, sampled densely with Terrain.height_at (within 3 mm)."""
    w = rough(seed, size=12.0, amp=0.3)
    rm = build_model(w, start=(6.0, 6.0, 0.0))
    m = rm.model
    tg = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
    hs = m.hfield_size[0]
    nr, nc = int(m.hfield_nrow[0]), int(m.hfield_ncol[0])
    hf = m.geom_pos[tg][2] + hs[2] * m.hfield_data.astype(np.float64).reshape(nr, nc)
    x0, y0, dx, dy = m.geom_pos[tg][0] - hs[0], m.geom_pos[tg][1] - hs[1], 2 * hs[0] / (nc - 1), 2 * hs[1] / (nr - 1)
    g = np.random.default_rng(seed)
    out = np.zeros((4, 7))
    r = 0.265
    for _ in range(5):
        cx, cy = g.uniform(2.0, 10.0, 2)
        cz = w.terrain.height_at(cx, cy) + r - g.uniform(0.0, 0.08)
        n = K.sphere_terrain_contacts(K.Sphere(cx, cy, cz, r), hf, K.HFieldGrid(x0, y0, dx, dy), out)
        xs = np.arange(cx - r, cx + r, 0.003)
        ys = np.arange(cy - r, cy + r, 0.003)
        X, Y = np.meshgrid(xs, ys)
        Z = np.vectorize(w.terrain.height_at)(X, Y)
        dist = np.sqrt((X - cx) ** 2 + (Y - cy) ** 2 + (Z - cz) ** 2).min()
        if dist >= r:
            assert n == 0 or out[:n, 0].min() > -0.003
            continue
        assert n >= 1
        assert -out[:n, 0].min() == pytest.approx(r - dist, abs=3e-3)
        normals = out[:n, 4:7]
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9)
        assert np.all(normals[:, 2] > 0.0)  # from the ground up to the wheel


def test_analytic_wheel_contacts_rest_and_drive() -> None:
    cfg = SimConfig(lidar_enabled=False, analytic_wheel_contacts=True)
    sim = Simulation(flat(), config=cfg, seed=0, start=(10.0, 20.0, 0.0))
    sim.advance(1.0)
    p0 = sim.data.qpos[:3].copy()
    sim.advance(5.0)
    assert np.abs(sim.data.qpos[:3] - p0).max() < 1e-3
    assert sim.data.qpos[2] == pytest.approx(RobotSpec().wheel_radius_m, abs=2e-3)
    sim.command(Command(1.0, 0.0))
    sim.advance(6.0)
    assert sim.data.qpos[0] - p0[0] == pytest.approx(5.0 + 1.0 - 0.5 - 0.05, abs=0.5)


def test_params_need_every_field_and_state_only_known_ones() -> None:
    """The loop's constants are named: new_params refuses a missing or unknown field (a constant
    added to PARAMS must be given by Simulation), new_state an unknown one."""
    full = {n: 0 for n in K.PARAMS.names}
    assert K.new_params(**full).dtype == K.PARAMS
    for name in K.PARAMS.names:
        with pytest.raises(TypeError, match=name):
            K.new_params(**{n: v for n, v in full.items() if n != name})
    with pytest.raises(TypeError, match="not_a_field"):
        K.new_params(**full, not_a_field=1)
    with pytest.raises(TypeError, match="not_a_field"):
        K.new_state(not_a_field=1)
    s = K.new_state(k=3, ref=np.arange(8.0))
    assert s[0]["k"] == 3 and list(s[0]["ref"]) == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0] and s[0]["cmd_v"] == 0.0


def test_loop_arrays_flatten_the_groups_in_order() -> None:
    """run_steps regroups the flat arrays by the groups' field counts: loop_arrays gives them in
    GROUPS order and refuses groups out of order."""
    sim = Simulation(flat(), config=NOLIDAR, seed=0)
    groups = [cls(*(np.zeros(1) for _ in cls._fields)) for cls in K.GROUPS]
    flat_ = K.loop_arrays(*groups)  # type: ignore[arg-type]
    assert len(flat_) == sum(len(c._fields) for c in K.GROUPS)
    assert all(a is b for a, b in zip(flat_, (x for g in groups for x in g)))
    with pytest.raises(TypeError, match="expected MjArrays"):
        K.loop_arrays(*groups[1:], groups[0])  # type: ignore[arg-type]
    assert len(sim._arrays) == len(flat_) and sim._arrays[0] is sim.data.qpos
