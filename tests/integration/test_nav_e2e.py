"""End to end: the reference stack in the real MuJoCo simulation with the real lidar.

Small hand-built or generated worlds and short timeouts, so the whole file runs in well under
a minute. Outcomes are checked as the framework classifies them (the real final position).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstress.nav.registry import make_navigator
from navstress.run.mission import RunResult, execute, run_mission
from navstress.run.record import RunTask
from navstress.world import Obstacle, World, WorldSpec, generate, parse_spec
from navstress.world.world import Mission

pytestmark = pytest.mark.slow


def wall(x0: float, y0: float, x1: float, y1: float, h: float = 2.0) -> Obstacle:
    """An axis-aligned box covering [x0, x1] x [y0, y1]."""
    return Obstacle("building", 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0, (x1 - x0, y1 - y0, h), 0.0)


def flat(size: float, obstacles: tuple[Obstacle, ...], start: tuple[float, float, float],
         goal: tuple[float, float]) -> World:
    return World.flat(WorldSpec(size_m=(size, size)), obstacles=obstacles, mission=Mission(start, goal, 3.0))


def run(world: World, nav: str = "reference-v1", *, seed: int = 1, timeout: float = 90.0,
        fault: str | None = None) -> RunResult:
    return run_mission(world, make_navigator(nav, fault=fault), run_seed=seed, timeout_s=timeout)


def outcome(r: RunResult) -> str:
    return r.classification.outcome.value


# ---------------------------------------------------------------- 1. reaches the goal
def test_reaches_the_goal_on_a_flat_empty_world() -> None:
    w = flat(30.0, (), (5.0, 5.0, 0.0), (25.0, 22.0))
    r = run(w, timeout=80.0)
    assert outcome(r) == "success", r.classification.reason
    # it aims well inside the 2 m tolerance, and drives a near-straight path
    assert r.facts.goal_distance_m < 1.5
    assert r.path_length_m < 1.3 * w.mission.straight_distance_m + 4.0
    assert r.facts.collisions == 0


@pytest.mark.parametrize("seed", [3, 4])
def test_reaches_the_goal_among_sparse_trees(seed: int) -> None:
    w = generate(parse_spec({"size_m": [36, 36], "obstacles": {"obstruction": {"tree": 3}}}), seed)
    assert len(w.obstacles) > 10
    r = run(w, seed=seed, timeout=110.0)
    assert outcome(r) == "success", r.classification.reason
    assert r.facts.collisions == 0


# ---------------------------------------------------------------- 2. no arc elected
def test_dead_end_corridor_gives_no_arc_elected() -> None:
    # a 2 m wide corridor closed at x = 16; the goal lies beyond its end. The real robot can turn
    # on the spot there (half diagonal 0.66 m) but the planner cannot (the cells along the walls
    # are obstacles), the curved arcs hit the side walls and the straight one the end wall.
    walls = (wall(2.0, 9.0, 16.0, 9.4), wall(2.0, 11.4, 16.0, 11.8), wall(16.0, 9.0, 16.4, 11.8),
             wall(1.6, 9.0, 2.0, 11.8))
    w = flat(30.0, walls, (5.0, 10.4, 0.0), (25.0, 10.4))
    r = run(w, timeout=60.0)
    assert outcome(r) == "fail-error", r.classification.reason
    assert "no arc elected" in r.classification.reason
    assert r.facts.collisions == 0 and r.duration_s < 55.0
    assert r.truth[-1, 1] < 16.0 - 0.57  # it stopped in front of the end wall


# ---------------------------------------------------------------- 3. footprint fault
def gap_world(gap: float) -> World:
    """A wall across the whole map at x = 15 with one gap of ``gap`` meters centred at y = 15; the
    goal 4 m behind it, so the gap is the only short way (around the wall ends: ~30 m)."""
    lo, hi = 15.0 - gap / 2, 15.0 + gap / 2
    return flat(30.0, (wall(14.8, 0.0, 15.2, lo), wall(14.8, hi, 15.2, 30.0)), (6.0, 15.0, 0.0), (19.0, 15.0))


# 0.7 m: the real body (0.67 m) passes only within +-1.5 cm of the centre, i.e. an attempt collides;
# the faulty belief (0.45 m) fits through the fine obstacle layer's picture of the gap (~0.5-0.7 m:
# the faces are located to a 0.1 m cell), the nominal belief (0.67 m) does not.
GAP_M = 0.7


def test_small_footprint_fault_collides_in_a_narrow_gap_the_nominal_refuses() -> None:
    # Whether the faulty arc planner threads the gap depends on how it arrives (run seed); measured
    # on seeds 1-6: 2 collisions (seeds 3, 4), 4 timeouts. The nominal never enters, on any seed.
    w = gap_world(GAP_M)
    faulty_collisions = 0
    for seed in (1, 2, 3, 4):
        nominal = run(w, seed=seed, timeout=50.0)
        assert nominal.facts.collisions == 0, seed
        assert outcome(nominal) in ("fail-error", "fail-timeout"), (seed, nominal.classification.reason)
        assert nominal.truth[:, 1].max() < 15.0 - 0.57 + 0.1  # its front never went into the gap
        faulty = run(w, seed=seed, timeout=50.0, fault="small-footprint")
        assert outcome(faulty) != "success", seed  # the real body cannot pass cleanly
        faulty_collisions += outcome(faulty) == "fail-collision"
    assert faulty_collisions >= 1


# ---------------------------------------------------------------- 4. determinism
def test_same_seeds_same_trace_different_seeds_differ(tmp_path: Path) -> None:
    w = generate(parse_spec({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 3}}}), 2)
    d = tmp_path / "w"
    w.save(d)

    def task(name: str, seed: int) -> RunTask:
        (tmp_path / name).mkdir()
        return RunTask(run_id="e2e/0", world_dir=str(d), run_seed=seed, trace_path=str(tmp_path / name / "r.mcap"),
                       timeout_s=35.0)

    a, b, c = execute(task("a", 7)), execute(task("b", 7)), execute(task("c", 8))
    assert Path(a.trace).read_bytes() == Path(b.trace).read_bytes()
    from navstress.run.trace import read_poses
    pa, pc = read_poses(a.trace), read_poses(c.trace)
    n = min(len(pa), len(pc))
    gap = np.hypot(pa[:n, 1] - pc[:n, 1], pa[:n, 2] - pc[:n, 2])
    assert gap.max() > 0.05  # different run seeds: different trajectories


# ---------------------------------------------------------------- 5. U-shaped trap
def u_world() -> World:
    # a U open toward the start (-x), its bottom between the robot and the goal
    walls = (wall(14.0, 9.0, 14.5, 21.0), wall(6.0, 20.5, 14.5, 21.0), wall(6.0, 9.0, 14.5, 9.5))
    return flat(32.0, walls, (4.0, 15.0, 0.0), (26.0, 15.0))


def test_global_navigator_escapes_a_u_trap_the_local_one_cannot() -> None:
    w = u_world()
    local = run(w, "reference-v1", timeout=90.0)
    assert outcome(local) in ("fail-timeout", "fail-error"), local.classification.reason
    assert local.facts.collisions == 0
    glob = run(w, "reference-global-v1", timeout=120.0)
    assert outcome(glob) == "success", glob.classification.reason
    assert glob.facts.collisions == 0
