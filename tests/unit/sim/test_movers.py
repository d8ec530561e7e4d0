"""The movers' controllers (navstress.sim.movers): limits, static obstacles, determinism, and each
behaviour against a robot that drives a scripted straight line (pure kinematics, no MuJoCo)."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from navstress.sim import movers as M
from navstress.sim.movers import (HARD_STOPS, P_AMAX, P_RADIUS, P_VMAX, PH_COMMITTED, PH_DONE, PH_PARKED, PHASE,
                                  VX, VY, X, Y, initial_state, make_plan, poses, step)
from navstress.world import World, WorldSpec, generate, parse_spec
from navstress.world.world import Mover, Obstacle

#: A world with every behaviour: 8 crossing and 4 patrolling pedestrians, 6 intercepting walkers,
#: 2 still-then-move children, 1 vehicle, among trees and buildings.
EVERY: dict[str, Any] = {
    "size_m": [60, 60], "obstacles": {"obstruction": {"tree": 4, "building": 6}},
    "movers": {
        "types": {"patroller": {"shape": "disc", "length_m": 0.5, "width_m": 0.5, "height_m": 1.8,
                                "speed_min_m_s": 0.5, "speed_max_m_s": 1.5},
                  "walker": {"shape": "disc", "length_m": 0.5, "width_m": 0.5, "height_m": 1.8,
                             "speed_min_m_s": 0.5, "speed_max_m_s": 1.5, "variability": 0.2},
                  "child": {"shape": "disc", "length_m": 0.4, "width_m": 0.4, "height_m": 1.2,
                            "speed_min_m_s": 1.0, "speed_max_m_s": 2.0}},
        "count": {"pedestrian": 8, "patroller": 4, "walker": 6, "child": 2, "vehicle": 1},
        "behaviour": {"pedestrian": {"pause_max_s": 2.0}, "patroller": {"kind": "patrol"},
                      "walker": {"kind": "intercept", "reaction_s": 0.3, "engage_m": 40},
                      "child": {"kind": "still-then-move", "trigger_m": 15},
                      "vehicle": {"kind": "intercept", "ttc_s": 0.5}},
    },
}


def robot_line(k: int, dt: float, start: tuple[float, float] = (5.0, 5.0), heading: float = math.pi / 4,
               speed: float = 1.0) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """The scripted robot: a straight line at constant speed; its true pose and velocity at step k."""
    c, s = math.cos(heading), math.sin(heading)
    return (start[0] + c * speed * k * dt, start[1] + s * speed * k * dt, heading), (c * speed, s * speed)


def simulate(world: World, run_seed: int, steps: int, dt: float = 0.1, **line: Any) -> np.ndarray:
    """(steps + 1, n, N_STATE) states of ``world``'s movers against the scripted robot."""
    plan = make_plan(world)
    state = initial_state(plan)
    gen = np.random.default_rng(run_seed)
    out = [state.copy()]
    for k in range(steps):
        pose, vel = robot_line(k, dt, **line)
        step(plan, state, dt, pose, vel, gen)
        out.append(state.copy())
    return np.array(out)


def box_disc_distance(o: Obstacle, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    px, py = cx - o.x, cy - o.y
    lx, ly = c * px + s * py, -s * px + c * py
    out: np.ndarray = np.hypot(np.maximum(np.abs(lx) - o.size[0] / 2, 0.0), np.maximum(np.abs(ly) - o.size[1] / 2, 0.0))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_limits_obstacles_and_the_map_edge_are_respected(seed: int) -> None:
    world = generate(parse_spec(EVERY), seed)
    plan = make_plan(world)
    dt = 0.1
    hist = simulate(world, seed, 1200, dt)
    r, vmax, amax = plan.params[:, P_RADIUS], plan.params[:, P_VMAX], plan.params[:, P_AMAX]
    speed = np.hypot(hist[:, :, VX], hist[:, :, VY])
    assert (speed <= vmax * (1 + 1e-9)).all()
    dv = np.hypot(np.diff(hist[:, :, VX], axis=0), np.diff(hist[:, :, VY], axis=0))
    assert (dv <= amax * dt * (1 + 1e-9)).all()
    assert (hist[-1, :, HARD_STOPS] == 0).all()
    xs, ys = hist[:, :, X], hist[:, :, Y]
    sx, sy = world.size_m
    assert ((xs >= r) & (xs <= sx - r) & (ys >= r) & (ys <= sy - r)).all()
    for o in world.obstacles:
        assert (box_disc_distance(o, xs, ys) >= r - 1e-9).all(), o
    travelled = np.hypot(np.diff(xs, axis=0), np.diff(ys, axis=0)).sum(axis=0)
    assert (travelled[[m.behaviour in ("crossing", "patrol") for m in world.movers]] > 5).all()  # they do move


def test_movers_keep_apart() -> None:
    """Two pedestrians walking head-on along one line, and a crowd on a small map: no two discs meet."""
    a = Mover(id=0, kind="p", shape="disc", size=(0.5, 0.5, 1.8), start=(5.0, 10.0, 0.0), speed_m_s=1.2,
              speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="crossing", waypoints=((25.0, 10.0),))
    b = Mover(id=1, kind="p", shape="disc", size=(0.5, 0.5, 1.8), start=(25.0, 10.0, math.pi), speed_m_s=1.2,
              speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="crossing", waypoints=((5.0, 10.0),))
    head_on = simulate(World.flat(WorldSpec(size_m=(30.0, 20.0)), movers=(a, b)), 0, 600)
    gap = np.hypot(head_on[:, 0, X] - head_on[:, 1, X], head_on[:, 0, Y] - head_on[:, 1, Y])
    assert gap.min() >= 0.5
    crowd = generate(parse_spec({"size_m": [30, 30], "movers": {"count": {"pedestrian": 25}}}), 4)
    hist = simulate(crowd, 4, 1000)
    r = make_plan(crowd).params[:, P_RADIUS]
    d = np.hypot(hist[:, :, None, X] - hist[:, None, :, X], hist[:, :, None, Y] - hist[:, None, :, Y])
    d = d - r[None, :, None] - r[None, None, :]
    d[:, np.arange(len(r)), np.arange(len(r))] = np.inf
    assert d.min() >= 0.0


def test_same_seeds_same_trace_and_the_run_seed_matters() -> None:
    world = generate(parse_spec(EVERY), 7)
    a, b, c = simulate(world, 11, 600), simulate(world, 11, 600), simulate(world, 12, 600)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)  # pauses and reaction times are the run seed's


def _hits(kind: str, seeds: range, **behaviour: Any) -> int:
    """In how many seeds one pedestrian of ``kind`` touches the footprint (1.14 x 0.67 m) of a robot
    driving a straight line at 1 m/s for 50 s across an empty 60 m map."""
    n = 0
    for seed in seeds:
        spec = parse_spec({"size_m": [60, 60], "mission": {"start": [5, 30, 0], "goal": [55, 30]},
                           "movers": {"count": {"pedestrian": 1},
                                      "behaviour": {"pedestrian": {"kind": kind, **behaviour}}}})
        hist = simulate(generate(spec, seed), seed, 500, start=(5.0, 30.0), heading=0.0)
        rx = 5.0 + 0.1 * np.arange(len(hist))
        ex = np.maximum(np.abs(hist[:, 0, X] - rx) - 0.57, 0.0)
        ey = np.maximum(np.abs(hist[:, 0, Y] - 30.0) - 0.335, 0.0)
        n += bool((np.hypot(ex, ey) < 0.25).any())
    return n


def test_an_intercepting_mover_meets_the_robot_far_more_often_than_a_crossing_one() -> None:
    seeds = range(30)
    intercept, crossing = _hits("intercept", seeds, ttc_s=0.5), _hits("crossing", seeds)
    # measured: 30 of 30 against 1 of 30 (seeds 0-29)
    assert intercept >= 24 and crossing <= 6 and intercept - crossing >= 18, (intercept, crossing)


def test_a_larger_lead_is_fairer() -> None:
    """aim: clearance with a lead far beyond the robot's footprint: the mover crosses ahead of it."""
    seeds = range(12)
    assert _hits("intercept", seeds, aim="clearance", clearance_m=6.0, cross_m=1.0) <= 3


def test_still_then_move_stays_still_until_the_trigger() -> None:
    trigger, reaction = 8.0, 0.5
    m = Mover(id=0, kind="child", shape="disc", size=(0.4, 0.4, 1.2), start=(30.0, 24.0, 0.0), speed_m_s=1.5,
              speed_max_m_s=2.0, accel_m_s2=2.0, behaviour="still-then-move",
              params=(("aim", "ttc"), ("cross_m", 3.0), ("reaction_s", reaction), ("trigger_m", trigger), ("ttc_s", 0.0)))
    world = World.flat(WorldSpec(size_m=(60.0, 60.0)), movers=(m,))
    dt = 0.1
    hist = simulate(world, 3, 400, dt, start=(5.0, 30.0), heading=0.0)
    moved = np.flatnonzero(np.hypot(hist[:, 0, X] - 30.0, hist[:, 0, Y] - 24.0) > 0)
    first = int(moved[0])
    robot_x = 5.0 + np.arange(len(hist)) * dt
    dist = np.hypot(robot_x - 30.0, 6.0)
    trig = int(np.flatnonzero(dist[:-1] <= trigger)[0])  # the step whose robot state triggers it
    assert (hist[:first, 0, PHASE] != PH_COMMITTED).all() and (hist[:trig + 1, 0, PHASE] == PH_PARKED).all()
    # it starts one reaction time (x U(0.75, 1.25)) after the trigger
    assert 0.75 * reaction - 2 * dt <= (first - trig) * dt <= 1.25 * reaction + 2 * dt
    assert hist[-1, 0, PHASE] == PH_DONE and hist[-1, 0, Y] > 30.0  # it crossed the robot's line and parked
    assert (poses(hist[-1])[:, :2] == hist[-1, :, X:Y + 1]).all()


def test_a_patrol_loops_and_a_crossing_walks_back() -> None:
    loop = Mover(id=0, kind="p", shape="disc", size=(0.5, 0.5, 1.8), start=(10.0, 10.0, 0.0), speed_m_s=1.0,
                 speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="patrol", waypoints=((20.0, 10.0), (20.0, 20.0)))
    back = Mover(id=1, kind="p", shape="disc", size=(0.5, 0.5, 1.8), start=(5.0, 25.0, 0.0), speed_m_s=1.0,
                 speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="crossing", waypoints=((15.0, 25.0), (15.0, 28.0)))
    hist = simulate(World.flat(WorldSpec(size_m=(30.0, 30.0)), movers=(loop, back)), 0, 1200)
    near = lambda i, p: np.hypot(hist[:, i, X] - p[0], hist[:, i, Y] - p[1]) < 0.1  # noqa: E731
    t_a, t_b = np.flatnonzero(near(0, (20.0, 10.0)))[0], np.flatnonzero(near(0, (20.0, 20.0)))[0]
    t_home = np.flatnonzero(near(0, (10.0, 10.0)) & (np.arange(len(hist)) > t_b))[0]
    assert t_a < t_b < t_home
    t_end = np.flatnonzero(near(1, (15.0, 28.0)))[0]
    assert near(1, (15.0, 25.0))[t_end:].any() and near(1, (5.0, 25.0))[t_end:].any()


def test_an_intercepting_mover_slides_along_or_stops_at_a_wall() -> None:
    """A wall across the map between the mover and the robot's path: the mover never enters it."""
    wall = Obstacle("building", 30.0, 20.0, 0.0, (60.0, 1.0, 3.0))
    m = Mover(id=0, kind="p", shape="disc", size=(0.5, 0.5, 1.8), start=(30.0, 10.0, 0.0), speed_m_s=1.0,
              speed_max_m_s=2.0, accel_m_s2=2.0, behaviour="intercept",
              params=(("aim", "ttc"), ("cross_m", 3.0), ("engage_m", 60.0), ("reaction_s", 0.2), ("ttc_s", 0.0)),
              waypoints=((35.0, 10.0),))
    world = World.flat(WorldSpec(size_m=(60.0, 60.0)), obstacles=(wall,), movers=(m,))
    hist = simulate(world, 0, 600, start=(5.0, 30.0), heading=0.0)
    assert (box_disc_distance(wall, hist[:, 0, X], hist[:, 0, Y]) >= 0.25 - 1e-9).all()
    assert hist[:, 0, Y].max() < 20.0 and hist[-1, 0, HARD_STOPS] == 0
    assert np.ptp(hist[:, 0, X]) > 5.0  # it slid along the wall after the robot


def test_a_bad_time_step_is_refused() -> None:
    world = generate(parse_spec({"size_m": [20, 20], "movers": {"count": {"pedestrian": 1}}}), 0)
    plan = make_plan(world)
    for dt in (0.0, -0.1, math.nan):
        with pytest.raises(ValueError, match="dt="):
            step(plan, initial_state(plan), dt, (0, 0, 0), (0, 0), np.random.default_rng(0))


def test_no_movers_is_a_no_op() -> None:
    plan = make_plan(World.flat(WorldSpec(size_m=(20.0, 20.0))))
    state = initial_state(plan)
    assert state.shape == (0, M.N_STATE)
    step(plan, state, 0.1, (1, 1, 0), (1, 0), np.random.default_rng(0))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**20), dt=st.floats(0.02, 0.25), heading=st.floats(-math.pi, math.pi),
       speed=st.floats(0.0, 2.0), x0=st.floats(5.0, 55.0), y0=st.floats(5.0, 55.0))
# found by hypothesis: mover 16 grazes a box corner nearly tangent to its path at step 260; the
# sampled look-ahead passes, the move does not, and the mover stops short (one hard stop)
@example(seed=65, dt=0.03125, heading=0.25, speed=1.03125, x0=5.0, y0=48.65625)
def test_limits_hold_for_any_time_step_and_robot_line(seed: int, dt: float, heading: float, speed: float, x0: float,
                                                       y0: float) -> None:
    """Speed limit always; the acceleration limit at every step but a hard stop (the module's
    step 5: the one exception, documented), and hard stops rare: at most one per 1,000 mover
    steps in any example (measured: none in 945,000 mover steps of 150 random examples)."""
    world = every_world(21 + seed % 2)
    plan = make_plan(world)
    hist = simulate(world, seed, 300, dt, start=(x0, y0), heading=heading, speed=speed)
    r, vmax, amax = plan.params[:, P_RADIUS], plan.params[:, P_VMAX], plan.params[:, P_AMAX]
    assert (np.hypot(hist[:, :, VX], hist[:, :, VY]) <= vmax * (1 + 1e-9)).all()
    dv = np.hypot(np.diff(hist[:, :, VX], axis=0), np.diff(hist[:, :, VY], axis=0))
    hard = np.diff(hist[:, :, HARD_STOPS], axis=0) > 0
    assert (hard | (dv <= amax * dt * (1 + 1e-9))).all()
    assert hard.sum() <= hard.size / 1000, f"{int(hard.sum())} hard stops in {hard.size} mover steps"
    for o in world.obstacles:
        assert (box_disc_distance(o, hist[:, :, X], hist[:, :, Y]) >= r - 1e-9).all(), o


@functools.cache
def every_world(seed: int) -> World:
    return generate(parse_spec(EVERY), seed)
