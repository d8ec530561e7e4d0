"""Drivable start and goal areas (navstress.world.freearea): over families of rough worlds the free
discs are flat, levelling adds at most its slope limit to any edge and leaves the ground beyond the
transition as it was; flat worlds are untouched; impossible cases are refused in one line; the free
discs lie inside the map in every mission mode."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.campaign.plan import MapJob
from navstress.campaign.work import attempt_world
from navstress.errors import GenerationError, SpecError
from navstress.seeding import rng
from navstress.world import World, generate, parse_spec
from navstress.world.freearea import MAX_ADDED_SLOPE_DEG, MAX_TRANSITION_M, level_free_areas
from navstress.world.placement import level_terrain
from navstress.world.spec import WorldSpec
from navstress.world.terrain import make_heights
from navstress.world.world import Mission, Obstacle

from test_worldgen_placement import check_world

ROUGH = st.one_of(
    st.fixed_dictionaries({"subdivisions": st.integers(2, 6), "deformation": st.sampled_from([1.0, 2.0, 3.0, 5.0])}),
    st.fixed_dictionaries({"model": st.just("fractal"), "amplitude_m": st.sampled_from([1.0, 2.0, 4.0]),
                           "wavelength_m": st.sampled_from([8.0, 20.0, 40.0])}),
    st.fixed_dictionaries({"model": st.just("blender"), "subdivisions": st.integers(2, 8),
                           "deformation": st.sampled_from([2.0, 3.5, 7.0]), "plane_m": st.sampled_from([2.0, 20.0, 40.0])}),
)
MISSIONS = st.one_of(
    st.sampled_from([1.5, 3.0, 5.0]).map(lambda r: {"mode": "paper", "free_radius_m": r, "inset_m": max(r, 5.0)}),
    st.fixed_dictionaries({"mode": st.just("random"), "free_radius_m": st.sampled_from([1.5, 3.0, 5.0]),
                           "min_distance_m": st.sampled_from([0.0, 8.0, 15.0])}),  # 0: start and goal may meet
)
DRIVABLE = re.compile(r"^the (start|goal) at \(-?[\d.]+, -?[\d.]+\)( and goal at \(-?[\d.]+, -?[\d.]+\))? cannot be made "
                      r"drivable: levelling its [\d.]+ m free disc to -?[\d.e+-]+ m would add [\d.]+ deg of slope .*, more "
                      r"than 20 deg, even with the best transition up to 25 m wide .*; use a gentler ground")
TOL = 1e-4  # m: float32 heights of a few meters


def _raw(spec: WorldSpec, seed: int) -> np.ndarray:
    return make_heights(spec.ground, spec.grid_shape, spec.cell_m, rng(seed, "terrain"))


def _distances(spec: WorldSpec, x: float, y: float) -> np.ndarray:
    rows, cols = spec.grid_shape
    yy, xx = np.mgrid[0:rows, 0:cols] * spec.cell_m
    out: np.ndarray = np.sqrt((xx - x) ** 2 + (yy - y) ** 2)  # as the generator computes it
    return out


def _edges(h: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Height differences of every grid edge (along x, y and the diagonal (i,j)-(i+1,j+1)) and its length
    in cells."""
    return [(h[:, 1:] - h[:, :-1], 1.0), (h[1:, :] - h[:-1, :], 1.0), (h[1:, 1:] - h[:-1, :-1], math.sqrt(2.0))]


def check_free_areas(w: World, raw: np.ndarray) -> None:
    """Every promise of docs/worlds.md "Drivable start and goal areas", checked from the raw heights."""
    spec, m, h = w.spec, w.mission, w.terrain.heights.astype(np.float64)
    cell, r = spec.cell_m, m.free_radius_m
    desc = w.descriptors["free_areas"]
    assert sorted(desc) == ["goal", "start"]
    r_flat = r + math.sqrt(2.0) * cell
    centres = {"start": m.start[:2], "goal": m.goal}
    together = desc["start"] == desc["goal"]
    flat_sets = {n: _distances(spec, *centres[n]) <= r_flat for n in centres}
    for n, c in centres.items():
        d = desc[n]
        assert set(d) == {"level_m", "transition_m", "step_m", "slope_max_deg"}
        flat = flat_sets[n]
        # the level: the float32 mean of the raw heights of the flat set (of both, levelled together)
        both = flat_sets["start"] | flat_sets["goal"] if together else flat
        assert d["level_m"] == float(np.float32(raw[both].mean()))
        assert np.all(h[flat] == d["level_m"]), n  # every vertex of the flat set, exactly
        g = np.random.default_rng(0)
        for _ in range(40):  # and every point of the disc on the simulator's triangulated surface
            a, q = g.uniform(0, 2 * math.pi), r * math.sqrt(g.random())
            assert w.terrain.height_at(c[0] + q * math.cos(a), c[1] + q * math.sin(a)) == pytest.approx(d["level_m"], abs=1e-6)
        assert 2.0 <= d["transition_m"] <= MAX_TRANSITION_M + 1e-9
        assert 0.0 <= d["slope_max_deg"] < 90.0
    # beyond every transition the ground is the raw ground
    beyond = np.ones(h.shape, bool)
    for n, c in centres.items():
        beyond &= _distances(spec, *c) - r_flat >= desc[n]["transition_m"]
    np.testing.assert_array_equal(h[beyond], raw.astype(np.float32)[beyond])
    # levelling adds at most MAX_ADDED_SLOPE_DEG (as a rise per metre) to any edge
    tan_max = math.tan(math.radians(MAX_ADDED_SLOPE_DEG))
    for (dl, ln), (dr, _) in zip(_edges(h), _edges(raw)):
        added = (np.abs(dl) - np.abs(dr)) / (ln * cell)
        assert float(added.max()) <= tan_max + TOL / cell, float(added.max())


@given(ground=ROUGH, mission=MISSIONS, size=st.sampled_from([30.0, 40.0, 60.0]), cell=st.sampled_from([0.25, 0.4, 0.5]),
       seed=st.integers(0, 2**40))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_rough_worlds_have_flat_free_areas_and_bounded_transitions(ground: dict[str, Any], mission: dict[str, Any],
                                                                  size: float, cell: float, seed: int) -> None:
    spec = parse_spec({"size_m": [size, size], "cell_m": cell, "ground": ground, "mission": mission})
    try:
        w = generate(spec, seed)
    except GenerationError as err:  # only the free areas can fail here (no obstacles), in one line
        assert "\n" not in str(err) and DRIVABLE.match(str(err)), str(err)
        return
    check_free_areas(w, _raw(spec, seed))


@given(ground=ROUGH, mission=MISSIONS, trees=st.sampled_from([0.0, 4.0, 12.0]), buildings=st.sampled_from([0.0, 10.0]),
       seed=st.integers(0, 2**40))
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_obstacles_keep_the_free_areas_flat_and_stand_on_the_ground(ground: dict[str, Any], mission: dict[str, Any],
                                                                    trees: float, buildings: float, seed: int) -> None:
    spec = parse_spec({"size_m": [40.0, 40.0], "ground": ground, "mission": mission,
                       "obstacles": {"obstruction": {"tree": trees, "building": buildings}}})
    try:
        w = generate(spec, seed)
    except GenerationError as err:
        assert "\n" not in str(err)
        assert DRIVABLE.match(str(err)) or "reached" in str(err), str(err)
        return
    check_world(w)  # every placement constraint, obstacles on the levelled ground included
    m, r_flat = w.mission, w.mission.free_radius_m + math.sqrt(2.0) * spec.cell_m
    for n, c in (("start", m.start[:2]), ("goal", m.goal)):
        flat = _distances(spec, *c) <= r_flat
        assert np.all(w.terrain.heights[flat] == w.descriptors["free_areas"][n]["level_m"]), n


@given(s=st.integers(0, 6), model=st.sampled_from(["subdivide", "fractal"]), mode=st.sampled_from(["paper", "random"]),
       trees=st.sampled_from([0.0, 6.0]), seed=st.integers(0, 2**40))
@settings(max_examples=15, deadline=None)
def test_flat_worlds_are_not_touched(s: int, model: str, mode: str, trees: float, seed: int) -> None:
    """d = 0 / amplitude 0: no levelling, no descriptor (the files of flat worlds keep their bytes,
    test_movers_world.GOLDEN holds hashes)."""
    spec = parse_spec({"size_m": [30.0, 30.0], "ground": {"model": model, "subdivisions": s, "deformation": 0.0,
                                                          "amplitude_m": 0.0},
                       "mission": {"mode": mode, "min_distance_m": 10.0}, "obstacles": {"obstruction": {"tree": trees}}})
    w = generate(spec, seed)
    assert not w.terrain.heights.any() and all(o.z == 0.0 for o in w.obstacles)
    assert "free_areas" not in w.descriptors
    fa = level_free_areas(np.zeros(spec.grid_shape), spec.cell_m, w.mission, spec.size_m)
    assert fa.areas == () and fa.descriptor() is None and fa.pins(spec.grid_shape, spec.cell_m) is None


def test_no_free_radius_no_levelling() -> None:
    spec = parse_spec({"size_m": [30.0, 30.0], "ground": {"subdivisions": 5, "deformation": 3.0},
                       "mission": {"free_radius_m": 0.0}})
    w = generate(spec, 1)
    np.testing.assert_array_equal(w.terrain.heights, _raw(spec, 1).astype(np.float32))
    assert "free_areas" not in w.descriptors


# ---- refusals ---------------------------------------------------------------------------------


@pytest.mark.parametrize("deg", [25.0, 30.0, 45.0])
def test_a_disc_on_a_long_steep_slope_is_refused_in_one_line(deg: float) -> None:
    h = np.fromfunction(lambda i, j: math.tan(math.radians(deg)) * 0.4 * j, (201, 201))  # 80 m at 0.4 m
    with pytest.raises(GenerationError) as ei:
        level_free_areas(h, 0.4, Mission((40.0, 30.0, 0.0), (40.0, 70.0), 5.0), (80.0, 80.0))
    msg = str(ei.value)
    assert "\n" not in msg and DRIVABLE.match(msg) and msg.startswith("the start at (40, 30) cannot be made drivable")
    added = float(re.search(r"would add ([\d.]+) deg", msg).group(1))  # type: ignore[union-attr]
    assert MAX_ADDED_SLOPE_DEG < added < deg + 20.0


@pytest.mark.parametrize("deg", [3.0, 10.0, 20.0])
def test_a_disc_on_a_moderate_slope_is_levelled_within_the_limit(deg: float) -> None:
    h = np.fromfunction(lambda i, j: math.tan(math.radians(deg)) * 0.4 * j, (201, 201))
    fa = level_free_areas(h, 0.4, Mission((40.0, 15.0, 0.0), (40.0, 65.0), 5.0), (80.0, 80.0))
    # both at x = 40: one level; 50 m apart, levelled together once the transitions are wide
    assert [a.names for a in fa.areas] == ([("start",), ("goal",)] if deg < 10 else [("start", "goal")])
    for a in fa.areas:
        assert a.level_m == pytest.approx(40.0 * math.tan(math.radians(deg)), rel=1e-6)
        assert a.transition_m <= 25.0 and (a.transition_m < 10.0 if deg < 10 else a.transition_m > 10.0)
    added = max(float(((np.abs(dl) - np.abs(dr)) / (ln * 0.4)).max()) for (dl, ln), (dr, _) in zip(_edges(fa.heights), _edges(h)))
    assert added <= math.tan(math.radians(MAX_ADDED_SLOPE_DEG)) + 1e-9


def test_generate_refuses_an_undrivable_start_and_a_campaign_worker_reports_why(tmp_path: Path) -> None:
    data = {"size_m": [40, 40], "ground": {"subdivisions": 1, "deformation": 30}}
    with pytest.raises(GenerationError) as ei:
        generate(parse_spec(data), 0)
    assert DRIVABLE.match(str(ei.value)) and str(ei.value).startswith("the start at (5, 5) cannot be made drivable")
    # a campaign's worker: the reason its runs are recorded with ("world generation failed: <reason>"), no world
    job = MapJob(key="e/c/m0", experiment="e", config_key="c", map_index=0, map_seed=0, world=data,
                 world_dir=str(tmp_path / "w"))
    assert attempt_world(job) == str(ei.value) and not (tmp_path / "w").exists()


def test_a_disc_outside_the_map_is_refused_at_generation() -> None:
    """A spec built without validation (model_copy) still cannot put a free disc outside the map."""
    spec = WorldSpec(size_m=(30.0, 30.0))
    for mission, who in ((spec.mission.model_copy(update={"inset_m": 2.0}), "start at (2, 2)"),
                         (spec.mission.model_copy(update={"goal": (29.0, 15.0)}), "goal at (29, 15)")):
        with pytest.raises(GenerationError, match=re.escape(f"the {who} has a free disc of mission.free_radius_m=5 "
                                                            "that reaches outside the 30 x 30 m map")):
            generate(spec.model_copy(update={"mission": mission}), 0)


def test_an_obstacle_base_joining_start_and_goal_gets_them_levelled_at_one_height() -> None:
    h = np.fromfunction(lambda i, j: 0.02 * j, (101, 101))  # tilted along x, 0.4 m cells
    mission = Mission((10.0, 20.0, 0.0), (30.0, 20.0), 3.0)
    fa = level_free_areas(h, 0.4, mission, (40.0, 40.0))
    assert len(fa.areas) == 2 and fa.areas[0].level_m != fa.areas[1].level_m
    short = [Obstacle("building", 16.0, 20.0, 0.0, (5.0, 1.0, 3.0))]  # touching the start's flat set: its level
    lev = level_terrain(fa.heights, 0.4, short, pins=fa.pins(h.shape, 0.4))
    assert lev.joined == -1 and lev.obstacles[0].z == fa.areas[0].level_m
    wall = [Obstacle("building", 20.0, 20.0, 0.0, (13.0, 1.0, 3.0))]  # from the start's flat set to the goal's
    assert level_terrain(fa.heights, 0.4, wall, pins=fa.pins(h.shape, 0.4)).joined == 0
    one = level_free_areas(h, 0.4, mission, (40.0, 40.0), together=True)
    (area,) = one.areas
    assert area.names == ("start", "goal") and area.level_m == float(np.float32(0.5 * (0.5 + 1.5)))
    lev = level_terrain(one.heights, 0.4, wall, pins=one.pins(h.shape, 0.4))
    assert lev.joined == -1 and lev.obstacles[0].z == area.level_m


def test_generate_levels_start_and_goal_together_when_obstacles_join_them() -> None:
    """A dense 40 m map where one cluster of obstacles reaches from the start's free area to the goal's."""
    spec = parse_spec({"size_m": [40.0, 40.0], "ground": {"subdivisions": 0, "deformation": 1.0},
                       "mission": {"mode": "random", "free_radius_m": 5.0, "min_distance_m": 20.0},
                       "obstacles": {"types": {"rock": {"base_m": [2.0, 0.7], "height_m": 1.0}},
                                     "obstruction": {"tree": 12.0, "building": 20.0, "rock": 3.0}}})
    w = generate(spec, 682)
    fa = w.descriptors["free_areas"]
    assert fa["start"] == fa["goal"]  # one level, one transition
    alone = level_free_areas(_raw(spec, 682), spec.cell_m, w.mission, spec.size_m)
    assert len(alone.areas) == 2  # without the obstacles they would be levelled apart
    check_world(w)
    r_flat = 5.0 + math.sqrt(2.0) * spec.cell_m
    for c in (w.mission.start[:2], w.mission.goal):
        assert np.all(w.terrain.heights[_distances(spec, *c) <= r_flat] == fa["start"]["level_m"])


# ---- the free discs lie inside the map, in every mission mode ---------------------------------


@given(size=st.sampled_from([(20.0, 20.0), (40.0, 20.0), (30.0, 50.0)]), r=st.sampled_from([0.0, 2.0, 5.0, 10.0, 12.0]),
       mode=st.sampled_from(["paper", "random"]), inset=st.sampled_from([0.0, 2.0, 5.0, 10.0, 18.0, 28.0]),
       start=st.none() | st.tuples(st.sampled_from([0.0, 1.0, 5.0, 15.0, 19.0]), st.sampled_from([2.0, 10.0, 18.0]), st.just(0.0)),
       goal=st.none() | st.tuples(st.sampled_from([3.0, 10.0, 17.0]), st.sampled_from([0.5, 5.0, 12.0, 19.5])))
@settings(max_examples=150, deadline=None)
def test_a_free_disc_outside_the_map_is_a_spec_error_naming_the_field(size: tuple[float, float], r: float, mode: str,
                                                                     inset: float, start: tuple[float, float, float] | None,
                                                                     goal: tuple[float, float] | None) -> None:
    sx, sy = size
    data = {"size_m": list(size), "mission": {"mode": mode, "free_radius_m": r, "inset_m": inset, "start": start,
                                              "goal": goal, "min_distance_m": 0.0}}
    ok = lambda x, y: r <= x <= sx - r and r <= y <= sy - r  # noqa: E731
    # the oracle: which field puts a free disc outside the map (the order the spec checks them in)
    bad: str | None = None
    if 2 * r > min(sx, sy):
        bad = "mission.free_radius_m"
    elif mode == "paper":
        used_start = start[:2] if start is not None else (inset, inset)
        used_goal = goal if goal is not None else (sx - inset, sy - inset)
        if (start is None and not ok(*used_start)) or (goal is None and not ok(*used_goal)):
            bad = "mission.inset_m"
        elif not ok(*used_start):
            bad = "mission.start"
        elif not ok(*used_goal):
            bad = "mission.goal"
    if bad is None:
        m = generate(parse_spec(data), 0).mission
        for x, y in (m.start[:2], m.goal):
            assert ok(x, y)
        return
    with pytest.raises(SpecError) as ei:
        parse_spec(data)
    assert ei.value.field == bad and "must lie inside the" in str(ei.value), str(ei.value)
