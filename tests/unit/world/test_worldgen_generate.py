"""generate(): determinism, sub-stream independence, missions, descriptors and path feasibility."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import GenerationError, SpecError
from navstress.seeding import rng
from navstress.world import World, generate
from navstress.world.descriptors import describe_world, obstacle_distance
from navstress.world.mission import make_mission
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, Obstacle, Terrain

SPEC = WorldSpec(size_m=(40.0, 40.0), ground={"subdivisions": 3, "deformation": 1.5},
                 obstacles={"obstruction": {"tree": 6, "building": 10}})


def _bytes(w: World, d: Path) -> tuple[bytes, bytes]:
    w.save(d)
    return (d / "world.json").read_bytes(), (d / "terrain.npz").read_bytes()


def test_same_seed_identical_bytes_different_seed_differs(tmp_path: Path) -> None:
    a = _bytes(generate(SPEC, 11), tmp_path / "a")
    b = _bytes(generate(SPEC, 11), tmp_path / "b")
    c = _bytes(generate(SPEC, 12), tmp_path / "c")
    assert a == b
    assert a[0] != c[0] and a[1] != c[1]
    assert World.load(tmp_path / "a") == generate(SPEC, 11)


def test_obstruction_does_not_change_terrain_or_mission() -> None:
    bare = generate(SPEC.model_copy(update={"obstacles": WorldSpec().obstacles,
                                            "mission": SPEC.mission.model_copy(update={"mode": "random",
                                                                                       "min_distance_m": 10})}), 4)
    spec = SPEC.model_copy(update={"mission": bare.spec.mission,
                                   "obstacles": WorldSpec(obstacles={"obstruction": {"building": 12}}).obstacles})
    full = generate(spec, 4)
    assert full.mission == bare.mission and len(full.obstacles) > 0
    rows, cols = spec.grid_shape
    far = obstacle_distance((rows, cols), spec.cell_m, full.obstacles, 3.0) == np.inf
    assert far.mean() > 0.3
    np.testing.assert_array_equal(full.terrain.heights[far], bare.terrain.heights[far])


def test_bad_seed_is_a_spec_error() -> None:
    with pytest.raises(SpecError, match="seed=-1"):
        generate(SPEC, -1)


def test_paper_mission_and_explicit_override() -> None:
    m = generate(WorldSpec(), 0).mission
    assert m.start[:2] == (5.0, 5.0) and m.goal == (95.0, 95.0)
    assert m.start[2] == pytest.approx(math.pi / 4)
    m2 = make_mission(WorldSpec(mission={"start": (10, 20, 1.0), "goal": (50, 60)}), rng(0))
    assert m2.start == (10.0, 20.0, 1.0) and m2.goal == (50.0, 60.0)


@given(seed=st.integers(0, 2**40), size=st.sampled_from([30.0, 100.0]), r=st.sampled_from([0.0, 5.0]))
@settings(max_examples=30, deadline=None)
def test_random_mission_constraints(seed: int, size: float, r: float) -> None:
    spec = WorldSpec(size_m=(size, size), mission={"mode": "random", "free_radius_m": r, "min_distance_m": size / 3})
    m = make_mission(spec, rng(seed, "mission"))
    assert m == make_mission(spec, rng(seed, "mission"))
    for x, y in (m.start[:2], m.goal):
        assert r <= x <= size - r and r <= y <= size - r
    assert m.straight_distance_m >= size / 3
    assert m.start[2] == pytest.approx(math.atan2(m.goal[1] - m.start[1], m.goal[0] - m.start[0]))


def test_random_mission_impossible_distance_raises() -> None:
    spec = WorldSpec(size_m=(20.0, 20.0), mission={"mode": "random", "min_distance_m": 30.0})
    with pytest.raises(GenerationError, match="min_distance_m=30 is more than the longest"):
        make_mission(spec, rng(0))


def test_descriptors_are_plain_json_without_nan() -> None:
    for spec in (SPEC, WorldSpec(size_m=(20.0, 20.0))):
        d = generate(spec, 3).descriptors
        assert json.loads(json.dumps(d, allow_nan=False)) == d


def _flat(size: float, obstacles: list[Obstacle], start: tuple[float, float], goal: tuple[float, float],
          heights: np.ndarray | None = None) -> World:
    spec = WorldSpec(size_m=(size, size))
    w = World.flat(spec, obstacles=tuple(obstacles), mission=Mission((*start, 0.0), goal, 1.0))
    if heights is not None:
        w = World(spec=spec, seed=0, terrain=Terrain(heights, spec.cell_m), obstacles=w.obstacles, mission=w.mission)
    return w


def test_empty_flat_path_is_the_octile_distance() -> None:
    d = describe_world(_flat(20.0, [], (2.0, 2.0), (18.0, 10.0)))
    dx, dy = 16.0, 8.0
    assert d["feasible"] and d["path_length_m"] == pytest.approx(dx - dy + math.sqrt(2) * dy)


def test_walled_off_goal_is_infeasible_and_a_gap_makes_it_feasible() -> None:
    wall = [Obstacle("building", 10.0, y, 0.0, (1.0, 2.0, 3.0)) for y in np.arange(1.0, 20.0, 2.0)]
    d = describe_world(_flat(20.0, wall, (4.0, 10.0), (16.0, 10.0)))
    assert d["feasible"] is False and d["path_length_m"] is None and "no traversable path" in d["infeasible_reason"]
    gap = [o for o in wall if abs(o.y - 15.0) > 0.5]  # a 2 m gap: wider than the robot
    d2 = describe_world(_flat(20.0, gap, (4.0, 10.0), (16.0, 10.0)))
    assert d2["feasible"] and d2["path_length_m"] > 12.0
    narrow = [Obstacle("building", 10.0, 7.25, 0.0, (1.0, 14.5, 3.0)), Obstacle("building", 10.0, 15.35, 0.0, (1.0, 9.3, 3.0))]
    assert describe_world(_flat(20.0, narrow, (4.0, 10.0), (16.0, 10.0)))["feasible"] is False  # 0.6 m < 0.67 m


def test_steep_ridge_blocks_path() -> None:
    spec = WorldSpec(size_m=(20.0, 20.0))
    x = np.arange(spec.grid_shape[1]) * spec.cell_m
    ridge = np.tile(np.clip(x - 9.0, 0.0, 2.0), (spec.grid_shape[0], 1)).astype(np.float32)  # 45 deg band
    d = describe_world(_flat(20.0, [], (4.0, 10.0), (16.0, 10.0), ridge))
    assert d["feasible"] is False and d["slope_max_deg"] == pytest.approx(45.0)
    gentle = (ridge * 0.2).astype(np.float32)  # 11 deg
    assert describe_world(_flat(20.0, [], (4.0, 10.0), (16.0, 10.0), gentle))["feasible"]


def test_barn_metrics_in_a_corridor() -> None:
    walls = [Obstacle("building", 10.0, 4.0, 0.0, (20.0, 8.0, 3.0)), Obstacle("building", 10.0, 16.0, 0.0, (20.0, 8.0, 3.0))]
    d = describe_world(_flat(20.0, walls, (2.0, 10.0), (18.0, 10.0)))
    assert d["barn_dist_closest_m"] == pytest.approx(1.25)  # rows 0.5, 1, 1.5, 2, 2, 1.5, 1, 0.5 m from a wall
    assert d["barn_characteristic_dim_m"] == pytest.approx(4.0, abs=0.3)
    assert d["path_length_m"] == pytest.approx(16.0)


def test_more_trees_closer_obstacles_less_visibility() -> None:
    a = generate(WorldSpec(size_m=(40.0, 40.0), obstacles={"obstruction": {"tree": 3}}), 1).descriptors
    b = generate(WorldSpec(size_m=(40.0, 40.0), obstacles={"obstruction": {"tree": 15}}), 1).descriptors
    assert b["barn_dist_closest_m"] < a["barn_dist_closest_m"]
    assert b["barn_visibility_m"] < a["barn_visibility_m"]
