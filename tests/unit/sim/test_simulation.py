"""Simulation behaviour: driving, turning, slopes, collisions, events, determinism, errors.

Tolerances (flat ground, after the 1-2 s ramp-up): speed within 3 % of the command; yaw rate
within 10 % of the command for 0.1 <= |omega| <= 1 rad/s; odometry distance within 2 % and
odometry yaw rate within 20 % of the truth (skid-steer odometry is poor in combined motion).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstress.errors import SimulationError, SpecError
from navstress.nav.api import Command, Observation
from navstress.robot import RobotSpec
from navstress.sim import SimConfig, Simulation
from navstress.world.world import Obstacle

from tests.support.sim_worlds import bumpy, flat, ramp

NOLIDAR = SimConfig(lidar_enabled=False)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_rest_is_stable() -> None:
    """At rest on flat ground the chassis moves less than 1 mm over 10 s."""
    sim = Simulation(flat(), config=NOLIDAR, seed=0, start=(20.0, 20.0, 0.3))
    sim.advance(0.5)
    p0 = sim.data.xpos[sim.rm.chassis_body].copy()
    sim.advance(10.0)
    assert np.abs(sim.data.xpos[sim.rm.chassis_body] - p0).max() < 1e-3


def test_drives_straight_and_odometry_matches() -> None:
    sim = Simulation(flat(), config=NOLIDAR, seed=0, start=(5.0, 20.0, 0.0))
    sim.command(Command(1.0, 0.0))
    sim.advance(2.0)
    p0, o0 = sim.observer.poses[-1].copy(), sim.observe().odom
    sim.advance(4.0)
    p1, o1 = sim.observer.poses[-1], sim.observe().odom
    true_d = math.hypot(p1[1] - p0[1], p1[2] - p0[2])
    assert true_d / 4.0 == pytest.approx(1.0, rel=0.03)
    assert abs(_wrap(p1[4] - p0[4])) < 0.01
    assert math.hypot(o1.x - o0.x, o1.y - o0.y) == pytest.approx(true_d, rel=0.02)


@pytest.mark.parametrize("v,omega", [(0.0, 0.5), (0.0, 1.0), (0.8, 0.5), (1.2, 0.3), (0.5, -0.8), (0.6, 0.1)])
def test_turn_rate_is_tracked(v: float, omega: float) -> None:
    sim = Simulation(flat(), config=NOLIDAR, seed=0, start=(20.0, 20.0, 0.0))
    sim.command(Command(v, omega))
    sim.advance(2.0)
    p0, o0 = sim.observer.poses[-1].copy(), sim.observe().odom
    yaw_true = yaw_odom = 0.0
    for _ in range(10):  # integrate in short pieces so that wrapping cannot hide turns
        prev_p, prev_o = sim.observer.poses[-1].copy(), sim.observe().odom
        sim.advance(0.3)
        yaw_true += _wrap(sim.observer.poses[-1][4] - prev_p[4])
        o = sim.observe().odom
        yaw_odom += _wrap(o.yaw - prev_o.yaw)
    assert p0 is not None and o0 is not None
    assert yaw_true / 3.0 == pytest.approx(omega, rel=0.10)
    assert yaw_odom == pytest.approx(yaw_true, rel=0.20)


def test_commands_are_clamped_to_robot_limits() -> None:
    sim = Simulation(flat(), config=NOLIDAR, seed=0, start=(5.0, 20.0, 0.0))
    sim.command(Command(5.0, 0.0))
    sim.advance(3.0)
    assert float(np.linalg.norm(sim.data.qvel[:2])) == pytest.approx(sim.robot.max_speed_mps, rel=0.03)


def test_climbs_a_moderate_slope_but_stalls_on_a_steep_one_and_odometry_drifts() -> None:
    def drive(deg: float) -> tuple[float, float]:
        sim = Simulation(ramp(deg), config=NOLIDAR, seed=0, start=(8.0, 20.0, 0.0))
        sim.command(Command(1.0, 0.0))
        sim.advance(8.0)
        p = sim.observer.poses[-1]
        return float(p[1]) - 8.0, sim.observe().odom.x

    up_d, up_odom = drive(15.0)
    assert up_d * 1 / math.cos(math.radians(15)) > 5.0  # it climbs: ~7 m along the surface
    steep_d, steep_odom = drive(45.0)  # steeper than atan(friction) = 38.7 deg
    assert steep_d < 3.0  # reached the foot of the ramp (2 m) and got stuck there
    assert steep_odom - steep_d > 2.0  # wheels spun: odometry believes it went on


def test_stops_against_a_box_with_one_collision_event() -> None:
    box = Obstacle("building", 14.0, 20.0, 0.0, (2.0, 4.0, 3.0))
    sim = Simulation(flat(obstacles=(box,)), config=NOLIDAR, seed=0, start=(6.0, 20.0, 0.0))
    sim.command(Command(1.2, 0.0))  # top speed into the face at x = 13
    max_x = 0.0
    for _ in range(100):
        sim.advance(0.1)
        max_x = max(max_x, float(sim.data.xpos[sim.rm.chassis_body][0]))
    front = max_x + sim.robot.length_m / 2
    assert front < 13.0 + 0.03  # no tunnelling: at most a few cm of soft-contact penetration
    assert front > 12.9  # and it really reached the box
    ev = sim.observer.collisions
    r, gap = sim.robot, 13.0 - 6.0 - sim.robot.length_m / 2
    t_hit = 0.05 + r.max_speed_mps / r.max_accel_mps2 + (gap - r.max_speed_mps**2 / (2 * r.max_accel_mps2)) / r.max_speed_mps
    assert len(ev) == 1 and ev[0].obstacle == 0 and ev[0].t == pytest.approx(t_hit, abs=0.15)
    assert sim.observer.contact_starts >= 1


def test_leaving_the_map_stops_the_run() -> None:
    sim = Simulation(flat(20.0), config=NOLIDAR, seed=0, start=(15.0, 10.0, 0.0))
    sim.command(Command(1.2, 0.0))
    sim.advance(10.0)
    ev = sim.stopped
    assert ev is not None and ev.kind == "left_map" and "left the map" in ev.reason
    t = sim.t
    sim.advance(1.0)
    assert sim.t == t and t < 6.0


def test_tips_over_on_an_extreme_side_slope() -> None:
    sim = Simulation(ramp(55.0, x0=10.0), config=NOLIDAR, seed=0, start=(12.0, 20.0, math.pi / 2))
    sim.advance(5.0)
    ev = sim.stopped
    assert ev is not None and ev.kind == "flipped"


def _run(seed: int, cfg: SimConfig) -> tuple[np.ndarray, list[Observation]]:
    box = Obstacle("tree", 12.0, 21.0, 0.0, (1.0, 1.0, 5.0))
    sim = Simulation(flat(obstacles=(box,)), config=cfg, seed=seed, start=(6.0, 20.0, 0.0))
    obs = []
    for k in range(30):
        sim.command(Command(1.0, 0.4 * math.sin(k / 5)))
        sim.advance(0.1)
        obs.append(sim.observe())
    return sim.observer.poses.copy(), obs


def _flat_obs(obs: list[Observation]) -> np.ndarray:
    rows = []
    for o in obs:
        p = o.pose
        rows.append([o.t, o.odom.x, o.odom.y, o.odom.yaw, o.odom.t, o.imu.yaw, o.imu.t, *o.imu.rates,
                     *((p.x, p.y, p.yaw, p.t) if p else (np.nan,) * 4),
                     sum(float(s.points.astype(np.float64).sum()) for s in o.scans), len(o.scans)])
    return np.array(rows)


def test_same_seed_is_bit_identical_and_other_seeds_differ() -> None:
    cfg = SimConfig()  # noise, jitter and lidar on
    pa, oa = _run(3, cfg)
    pb, ob = _run(3, cfg)
    assert np.array_equal(pa, pb)
    assert np.array_equal(_flat_obs(oa), _flat_obs(ob), equal_nan=True)
    pc, oc = _run(4, cfg)
    assert not np.array_equal(_flat_obs(oa), _flat_obs(oc), equal_nan=True)
    assert not np.array_equal(pa, pc)  # latency jitter changes the true trajectory too


def test_without_noise_and_jitter_seeds_do_not_matter() -> None:
    cfg = SimConfig(lidar_enabled=False, noise=False, jitter=False)
    pa, oa = _run(3, cfg)
    pb, ob = _run(4, cfg)
    assert np.array_equal(pa, pb)
    assert np.array_equal(_flat_obs(oa), _flat_obs(ob), equal_nan=True)


def test_sensor_rates_latency_and_observation_contents() -> None:
    cfg = SimConfig(lidar_enabled=False, jitter=False, command_latency_s=0.2)
    sim = Simulation(flat(), config=cfg, seed=0, start=(20.0, 20.0, 0.0))
    sim.observe()
    sim.command(Command(1.0, 0.0))
    sim.advance(0.19)
    assert np.all(np.abs(sim.data.ctrl) < 1e-6)  # not yet applied
    sim.advance(0.02)
    assert np.all(sim.data.ctrl > 0.01)
    poses = 0
    for _ in range(20):
        sim.advance(0.1)
        poses += sim.observe().pose is not None
    assert poses == 20  # 10 Hz pose sensor, one per 0.1 s
    o = sim.observe()
    assert o.pose is None and o.scans == () and o.odom.t <= o.t and o.imu.t <= o.t
    assert len(sim.observer.poses) == 23  # 10 Hz observer from t = 0 to 2.21 s


def test_lidar_scans_come_at_their_rate_in_the_sensor_frame() -> None:
    box = Obstacle("building", 30.0, 20.0, 0.0, (2.0, 10.0, 8.0))
    sim = Simulation(flat(obstacles=(box,)), config=SimConfig(jitter=False), seed=0, start=(20.0, 20.0, 0.0))
    sim.observe()
    sim.advance(1.0)
    scans = sim.observe().scans
    assert len(scans) == 10
    pts = scans[-1].points
    # the wall faces the robot at x = 29 in the world: 29 - 20 - 0.35 (mount) ahead of the sensor
    ahead = pts[(np.abs(pts[:, 1]) < 0.5) & (pts[:, 2] > 0.0)]
    assert ahead.size and np.median(ahead[:, 0]) == pytest.approx(29.0 - 20.0 - 0.35, abs=0.1)


def test_unstable_physics_raises_simulation_error() -> None:
    cfg = SimConfig(lidar_enabled=False, timestep_s=0.02)
    robot = RobotSpec(wheel_torque_nm=1e7, wheel_kv=1e7)
    sim = Simulation(flat(), robot, config=cfg, seed=0, start=(20.0, 20.0, 0.0))
    sim.command(Command(1.2, 1.0))
    with pytest.raises(SimulationError, match=r"physics became unstable at t=.*"):
        sim.advance(3.0)


def test_bad_inputs() -> None:
    sim = Simulation(flat(), config=NOLIDAR, seed=0, start=(20.0, 20.0, 0.0))
    with pytest.raises(SpecError, match=r"dt=-1.0 is invalid"):
        sim.advance(-1.0)
    with pytest.raises(SpecError, match=r"command="):
        sim.command(Command(float("nan"), 0.0))
    with pytest.raises(SpecError, match=r"sim.timestep_s=0.5 is invalid"):
        SimConfig(timestep_s=0.5)
    with pytest.raises(SpecError, match=r"seed=-1 is invalid"):
        Simulation(flat(), config=NOLIDAR, seed=-1)


def test_stable_on_bumpy_terrain_at_rest_and_driving() -> None:
    """0.3 m bumps every 3 m: no instability while driving and turning; parked on a bump's
    32-degree flank the robot creeps less than 5 mm/s (soft-contact friction creep)."""
    sim = Simulation(bumpy(), config=NOLIDAR, seed=0, start=(10.0, 10.0, 0.5))
    sim.advance(3.0)
    p0 = sim.data.qpos[:3].copy()
    sim.advance(5.0)
    assert np.abs(sim.data.qpos[:3] - p0).max() < 0.025
    for k in range(100):
        sim.command(Command(1.2, 0.8 * math.sin(k / 10)))
        sim.advance(0.1)
    assert sim.stopped is None and math.hypot(*(sim.data.qpos[:2] - p0[:2])) > 5.0


@pytest.mark.parametrize("omega", [0.6, 1.0])
def test_turn_on_the_spot_on_a_slope_drifts_like_coulomb_friction(omega: float) -> None:
    """Turning on the spot on a 12-degree plane: the robot turns as commanded (within 10 %) and
    drifts downhill at a Coulomb speed. Every wheel slides with the rotational slip s_i (from the
    wheel spins and the yaw rate); a small drift v changes each wheel's friction by
    mu N_i v sin^2(phi_i) / |s_i| against it, and over a full turn sin^2 averages to 1/2, so
    v_C = 2 tan(theta) / (mu mean(1/|s_i|)) (first order in v/|s|, wheel loads taken equal).
    Measured: v = 0.83 v_C (omega 0.6) and 0.88 v_C (omega 1.0); the bound is 0.5-1.5 v_C. Fails
    with 20 N m motors (drift 1.9 v_C, no turn) or without the yaw-rate loop (turn 25 % short)."""
    theta = math.radians(12.0)
    cfg = SimConfig(lidar_enabled=False, noise=False, jitter=False)
    sim = Simulation(ramp(12.0, x0=5.0), config=cfg, seed=0, start=(20.0, 20.0, 0.0))
    d, rm, radius = sim.data, sim.rm, sim.robot.wheel_radius_m
    offsets = sim.model.body_pos[rm.wheel_bodies]  # wheel centres in the chassis frame
    sim.advance(1.0)
    sim.command(Command(0.0, omega))
    sim.advance(1.5)  # spin-up
    period = 2 * math.pi / omega  # one whole turn: the slip directions average over all headings
    p0, yaw_prev = d.qpos[:2].copy(), sim.observer.poses[-1][4]
    turned, inv_slip = 0.0, []
    for _ in range(int(round(period / 0.05))):
        sim.advance(0.05)
        yaw = sim.observer.poses[-1][4]
        turned += _wrap(yaw - yaw_prev)
        yaw_prev = yaw
        w = d.qvel[5]  # body-frame yaw rate
        s_roll = -w * offsets[:, 1] - radius * d.qvel[rm.wheel_dofs]
        s_lat = w * offsets[:, 0]
        inv_slip.append(1.0 / np.hypot(s_roll, s_lat))
    drift = (d.qpos[:2] - p0) / period
    v_c = 2 * math.tan(theta) / (cfg.friction * float(np.mean(inv_slip)))
    assert turned / period == pytest.approx(omega, rel=0.10)
    assert 0.5 * v_c < math.hypot(*drift) < 1.5 * v_c
    assert -drift[0] > 0.9 * math.hypot(*drift)  # downhill (the plane rises along +x)
