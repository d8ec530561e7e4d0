"""Movers in the simulation: mocap bodies moved by their controller from the robot's true state,
seen by the lidar at scan time, collision events with the mover's id and speeds (a parked robot
hit, a robot driving into a still mover), and static worlds unchanged to the bit."""

from __future__ import annotations

import hashlib
import math
from typing import Any

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.robot import RobotSpec
from navstress.run.mission import run_mission
from navstress.seeding import rng
from navstress.sim import _raybox
from navstress.sim import movers as M
from navstress.sim._raycast import Ray
from navstress.sim.config import SimConfig
from navstress.sim.lidar import Lidar, build_scene
from navstress.sim.model import MOVER_BIT, OBSTACLE_BIT, build_model
from navstress.sim.simulation import MOVER_PERIOD_S, Simulation
from navstress.world import Obstacle, World, WorldSpec, generate, parse_spec
from navstress.world.world import Mission, Mover

QUIET = SimConfig(noise=False, jitter=False)


def mover(shape: str = "disc", start: tuple[float, float, float] = (4.0, 10.0, 0.0), behaviour: str = "crossing",
          waypoints: tuple[tuple[float, float], ...] = ((16.0, 10.0),), **params: Any) -> Mover:
    size = (0.5, 0.5, 1.8) if shape == "disc" else (2.0, 1.0, 1.5)
    return Mover(id=0, kind="pedestrian", shape=shape, size=size, start=start, speed_m_s=1.0, speed_max_m_s=1.5,
                 accel_m_s2=1.0, behaviour=behaviour, params=tuple(sorted(params.items())), waypoints=waypoints)


def flat(*movers: Mover, size: float = 20.0, obstacles: tuple[Obstacle, ...] = (),
         mission: Mission | None = None) -> World:
    kw: dict[str, Any] = {"mission": mission} if mission is not None else {}
    return World.flat(WorldSpec(size_m=(size, size)), movers=movers, obstacles=obstacles, **kw)


# ---------------------------------------------------------------- static worlds: unchanged


def _digest(world: World, start: tuple[float, float, float] | None, cmds: list[tuple[float, float]], seed: int) -> str:
    sim = Simulation(world, seed=seed, start=start)
    h = hashlib.sha256()
    obs = []
    for v, w in cmds:
        sim.command(Command(v, w))
        sim.advance(0.1)
        obs.append(sim.observe())
    h.update(np.ascontiguousarray(sim.observer.poses).tobytes())
    for e in sim.observer.collisions:
        h.update(repr((e.t, e.x, e.y, e.obstacle)).encode())
    for o in obs:
        h.update(repr((o.t, o.odom, o.imu, o.pose)).encode())
        for s in o.scans:
            h.update(np.ascontiguousarray(s.points).tobytes())
    return h.hexdigest()


def test_static_worlds_keep_their_bytes() -> None:
    """Digests of two static-world runs (noise, jitter, lidar on; a collision in the first) taken
    with the simulation before movers existed: the same to the bit."""
    box = Obstacle("tree", 12.0, 21.0, 0.0, (1.0, 1.0, 5.0))
    one_box = World.flat(WorldSpec(size_m=(40.0, 40.0)), obstacles=(box,))
    assert _digest(one_box, (6.0, 21.0, 0.0), [(1.0, 0.0)] * 80, 3) == \
        "02c2be8d87e3d7a74436f9da78864ad20771b24410c590fb95ad8c63b9511c4a"
    gen = generate(parse_spec({"size_m": [40, 40], "obstacles": {"obstruction": {"tree": 6, "building": 2}}}), 5)
    assert _digest(gen, None, [(1.0, 0.3 * math.sin(k / 7)) for k in range(150)], 4) == \
        "cbbb17cdb3bc389c45d83bf1116cf8fe30324788cf06866c6ee1216e6d400208"


def test_mover_bodies_in_the_model() -> None:
    """One mocap body per mover (a cylinder or a box on the ground, touching only the bumper); a
    world without movers has none and its bumper touches obstacles only."""
    w = flat(mover(), Mover(id=1, kind="car", shape="box", size=(4.5, 1.8, 1.5), start=(10.0, 4.0, 0.5),
                            speed_m_s=3.0, speed_max_m_s=5.0, accel_m_s2=2.0, behaviour="crossing",
                            waypoints=((10.0, 16.0),)))
    rm = build_model(w)
    m = rm.model
    assert m.nmocap == 2 and list(rm.mover_mocap) == [0, 1]
    g0, g1 = rm.mover_geoms
    assert m.geom_type[g0] == mujoco.mjtGeom.mjGEOM_CYLINDER and m.geom_size[g0][:2] == pytest.approx([0.25, 0.9])
    assert m.geom_type[g1] == mujoco.mjtGeom.mjGEOM_BOX and m.geom_size[g1] == pytest.approx([2.25, 0.9, 0.75])
    assert m.geom_contype[g0] == MOVER_BIT and m.geom_conaffinity[g0] == 0
    assert m.geom_conaffinity[rm.bumper_geom] == OBSTACLE_BIT | MOVER_BIT
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert d.xpos[m.geom_bodyid[g1]] == pytest.approx([10.0, 4.0, 0.75], abs=1e-3)
    plain = build_model(flat())
    assert plain.model.nmocap == 0 and plain.model.geom_conaffinity[plain.bumper_geom] == OBSTACLE_BIT


# ---------------------------------------------------------------- stepping


def test_the_bodies_follow_the_controller_from_the_robots_true_state() -> None:
    """At every control period the bodies are where the controller (fed the robot's true pose and
    velocity, its generator seeded from the run seed) puts them, linearly in between."""
    w = generate(parse_spec({"size_m": [40, 40], "obstacles": {"obstruction": {"tree": 2}},
                             "movers": {"count": {"pedestrian": 4, "vehicle": 1},
                                        "behaviour": {"vehicle": {"kind": "intercept"}}}}), 3)
    sim = Simulation(w, config=SimConfig(lidar_enabled=False), seed=9)
    plan = M.make_plan(w)
    state, gen = M.initial_state(plan), rng(9, "movers")
    ids = sim.rm.mover_mocap
    every = round(MOVER_PERIOD_S / sim.config.timestep_s)
    for k in range(60):
        sim.command(Command(1.0, 0.2))
        q, v = sim.data.qpos.copy(), sim.data.qvel.copy()
        yaw = math.atan2(2 * (q[3] * q[6] + q[4] * q[5]), 1 - 2 * (q[5] ** 2 + q[6] ** 2))
        assert sim.mover_poses()[:, :2] == pytest.approx(state[:, :2], abs=1e-12)
        before = state[:, :2].copy()
        M.step(plan, state, MOVER_PERIOD_S, (q[0], q[1], yaw), (v[0], v[1]), gen)
        sim.advance(MOVER_PERIOD_S / 2)  # half way: half way between the two controller poses
        half = sim.data.mocap_pos[ids, :2]
        assert half == pytest.approx(before + (state[:, :2] - before) * (every // 2 - 1) / every, abs=1e-9)
        sim.advance(MOVER_PERIOD_S / 2)
    t, track = sim.mover_track()
    assert len(t) == 60 and t[1] == pytest.approx(MOVER_PERIOD_S) and track.shape == (60, 5, 4)
    assert np.abs(state[:, :2] - M.initial_state(plan)[:, :2]).max() > 2.0  # they did move


def test_same_seeds_same_movers_and_the_run_seed_matters() -> None:
    w = generate(parse_spec({"size_m": [40, 40], "movers": {"count": {"pedestrian": 6},
                                                            "behaviour": {"pedestrian": {"pause_max_s": 3.0}}}}), 1)

    def run(seed: int) -> np.ndarray:
        sim = Simulation(w, config=SimConfig(lidar_enabled=False), seed=seed)
        sim.advance(20.0)
        return sim.mover_track()[1]

    a, b, c = run(4), run(4), run(5)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


# ---------------------------------------------------------------- collisions


@pytest.mark.slow
def test_a_mover_walking_into_a_parked_robot_hit_it() -> None:
    sim = Simulation(flat(mover()), config=QUIET, seed=1, start=(10.0, 10.0, math.pi / 2))
    sim.advance(10.0)
    (ev,) = sim.observer.collisions
    assert ev.mover == 0 and ev.obstacle == -1 and ev.robot_hit
    assert ev.robot_speed < 1e-3 and ev.mover_speed == pytest.approx(1.0) and ev.relative_speed == pytest.approx(1.0)
    # the disc (r 0.25) met the bumper's side (half width 0.335) at x = 10 - 0.585
    x_mover = float(np.interp(ev.t, *(lambda t, p: (t, p[:, 0, 0]))(*sim.mover_track())))
    assert x_mover == pytest.approx(10.0 - 0.335 - 0.25, abs=0.03)
    assert sim.data.qpos[0] > 11.0  # pushed: the robot does not push a mover


def test_a_robot_driving_into_a_still_mover_caused_the_collision() -> None:
    still = mover("box", start=(14.0, 10.0, 0.0), behaviour="still-then-move", waypoints=(), trigger_m=0.0)
    sim = Simulation(flat(still), config=QUIET, seed=1, start=(8.0, 10.0, 0.0))
    sim.command(Command(1.0, 0.0))
    sim.advance(8.0)
    ev = sim.observer.collisions[0]
    assert ev.mover == 0 and not ev.robot_hit
    assert ev.robot_speed == pytest.approx(1.0, abs=0.02) and ev.mover_speed == 0.0
    assert ev.relative_speed == pytest.approx(ev.robot_speed)
    assert ev.x == pytest.approx(14.0 - 1.0 - 0.57, abs=0.03)  # box front at 13, bumper half length 0.57
    assert sim.mover_poses()[0, :2] == pytest.approx([14.0, 10.0])  # it was not pushed


class _Drive:
    """Sends one command whatever it sees."""

    def __init__(self, v: float) -> None:
        self.v = v

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        pass

    def step(self, obs: Observation) -> Command | Status:
        return Command(self.v, 0.0)

    def close(self) -> None:
        pass


def test_the_run_classifies_both_kinds_of_mover_collision() -> None:
    """Fail-Collision either way; a robot that stood and was hit has its own reason."""
    parked = flat(mover(), mission=Mission((10.0, 10.0, math.pi / 2), (10.0, 18.0), 1.0))
    r = run_mission(parked, _Drive(0.0), run_seed=1, timeout_s=15.0)
    assert r.classification.outcome.value == "fail-collision"
    assert r.classification.reason.startswith("hit by a mover while stationary: 1 collision(s) (first at t=5.")
    assert r.facts.collisions == r.facts.collisions_hit == 1
    assert any(e[2].startswith("hit by mover 0 (pedestrian)") and "relative speed 1.00 m/s" in e[2] for e in r.events)
    still = mover("box", start=(14.0, 10.0, 0.0), behaviour="still-then-move", waypoints=(), trigger_m=0.0)
    driven = flat(still, mission=Mission((8.0, 10.0, 0.0), (18.0, 10.0), 1.0))
    r = run_mission(driven, _Drive(1.0), run_seed=1, timeout_s=15.0)
    assert r.classification.outcome.value == "fail-collision"
    assert r.classification.reason.startswith("1 collision(s) (first at t=")
    assert r.facts.collisions_hit == 0
    assert any(e[2].startswith("collision with mover 0 (pedestrian)") for e in r.events)


# ---------------------------------------------------------------- lidar


def _straight_ahead(scan_points: np.ndarray) -> float:
    """Range of the return nearest the sensor's +x axis (azimuth 0, elevation ~0)."""
    p = scan_points.astype(np.float64)
    r = np.linalg.norm(p, axis=1)
    az = np.arctan2(p[:, 1], p[:, 0])
    el = np.arcsin(p[:, 2] / r)
    k = np.flatnonzero((np.abs(az) < math.radians(0.5)) & (np.abs(el) < math.radians(0.7)))
    assert len(k) == 1
    return float(r[k[0]])


@pytest.mark.parametrize("shape", ["disc", "box"])
def test_the_lidar_sees_a_mover_where_it_is_at_scan_time(shape: str) -> None:
    """A mover walking away along the sensor's axis on flat ground: every scan's range straight
    ahead is the distance from the sensor to the mover's near face at the scan's time (the
    controller's positions, linear in between), not where it was at the last control step."""
    m = mover(shape, start=(15.0, 10.0, 0.0), waypoints=((38.0, 10.0),))
    sim = Simulation(flat(m, size=40.0), config=QUIET, seed=2, start=(5.0, 10.0, 0.0))
    half = 0.25 if shape == "disc" else 1.0
    scans = []
    for _ in range(40):
        sim.advance(0.25)
        q = sim.data.qpos
        assert abs(q[1] - 10.0) < 1e-3 and abs(q[6]) < 1e-3  # the robot stands still, facing +x
        scans += [(s, float(q[0])) for s in sim.observe().scans]
    sim.advance(0.2)
    t, track = sim.mover_track()
    for scan, x in scans:
        x_mover = float(np.interp(scan.t, t, track[:, 0, 0]))
        sensor_x = x + sim.robot.lidar.x_m  # (flat ground, level: pitch below 1e-3 rad)
        assert _straight_ahead(scan.points) == pytest.approx(x_mover - half - sensor_x, abs=5e-3), scan.t
    assert len(scans) >= 99 and track[-1, 0, 0] > 22.0  # it did move: 0.1 m between two 10 Hz scans


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-math.pi, math.pi), st.floats(0.3, 30.0),
       st.floats(-math.pi, math.pi), st.floats(0.1, 3.0), st.floats(-1.0, 2.0))
def test_the_disc_pass_is_the_exact_cylinder_on_every_ray(roll: float, pitch: float, yaw: float, dist: float,
                                                          bearing: float, radius: float, zb: float) -> None:
    """Its column culling never drops a hit: the same ranges as every ray tested against the
    cylinder (a tilted sensor included)."""
    lidar = Lidar(build_scene(flat(size=80.0)))
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rot = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                    [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                    [-sp, cp * sr, cp * cr]])
    o = np.array([40.0, 40.0, 1.0])
    disc = np.array([[o[0] + dist * math.cos(bearing), o[1] + dist * math.sin(bearing), radius, zb, zb + 1.8]])
    out = np.full((32, 360), np.inf)
    _raybox.disc_pass(disc, lidar._beams, lidar._params, o, rot, out)  # (max_range 70 m)
    ref = np.full((32, 360), np.inf)
    for k in range(32):
        for a in range(360):
            awx = rot[0, 0] * lidar._cos_az[a] + rot[0, 1] * lidar._sin_az[a]
            awy = rot[1, 0] * lidar._cos_az[a] + rot[1, 1] * lidar._sin_az[a]
            awz = rot[2, 0] * lidar._cos_az[a] + rot[2, 1] * lidar._sin_az[a]
            ce, se = lidar._cos_el[k], lidar._sin_el[k]
            ref[k, a] = _raybox._ray_cylinder(_raybox.Cylinder(*disc[0]),
                                              Ray(*o, ce * awx + se * rot[0, 2], ce * awy + se * rot[1, 2],
                                                  ce * awz + se * rot[2, 2]))
    assert np.array_equal(out, ref)


@settings(max_examples=60)
@given(rows=st.integers(2, 6), cols=st.integers(2, 6), cell=st.sampled_from([0.2, 0.4, 1.0, 2.5]),
       seed=st.integers(0, 2**32 - 1), pts=st.lists(st.tuples(st.floats(-3.0, 20.0), st.floats(-3.0, 20.0)),
                                                    min_size=1, max_size=12))
def test_the_compiled_ground_height_is_terrain_height_at(rows: int, cols: int, cell: float, seed: int,
                                                         pts: list[tuple[float, float]]) -> None:
    """The loop's ``ground_height`` (where a mover body stands) is ``Terrain.height_at`` to the bit,
    inside the map, on cell edges and clamped outside it."""
    from navstress.sim._step import ground_height
    from navstress.world.world import Terrain

    ter = Terrain(np.random.default_rng(seed).normal(0.0, 1.0, (rows, cols)), cell)
    edges = [(j * cell, i * cell) for i in range(rows) for j in range(cols)]
    for x, y in [*pts, *edges]:
        assert ground_height(ter.heights, cell, x, y) == ter.height_at(x, y)
