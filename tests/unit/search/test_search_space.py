"""The search space: every point of the box decodes to a valid world within the ranges, the same
point to the same candidate, different worlds to different keys (properties over random spaces)."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.campaign.spec import _NAME
from navstress.search.space import MAP_SEED_PATH, Candidate, Space, candidate_key
from navstress.search.spec import ParameterSpec, SearchSpec, parse_search
from navstress.seeding import derive_seed
from navstress.world.spec import parse_spec
from navstress.world.world import World

# searchable parameters and the widest range each may take in a space of this test (their corners
# together still make valid worlds: obstruction sums below 100 %, maps holding the mission)
CHOICES: list[dict[str, Any]] = [
    {"path": "obstacles.obstruction.tree", "low": 0.0, "high": 30.0},
    {"path": "obstacles.obstruction.building", "low": 0.0, "high": 30.0},
    {"path": "obstacles.types.tree.variability", "low": 0.0, "high": 0.95},
    {"path": "obstacles.types.building.height_m", "low": 1.0, "high": 20.0},
    {"path": "ground.deformation", "low": 0.0, "high": 5.0},
    {"path": "ground.subdivisions", "low": 0, "high": 8, "kind": "int"},
    {"path": "ground.octaves", "low": 1, "high": 12, "kind": "int"},
    {"path": "size_m", "low": 20.0, "high": 60.0},
    {"path": "mission.free_radius_m", "low": 0.0, "high": 5.0},
]


@st.composite
def spaces(draw: st.DrawFn) -> SearchSpec:
    picked = draw(st.lists(st.sampled_from(range(len(CHOICES))), min_size=1, max_size=len(CHOICES), unique=True))
    params = []
    for i in picked:
        c = dict(CHOICES[i])
        lo, hi = c["low"], c["high"]
        if c.get("kind") != "int" and c["path"] != "size_m" and math.floor(hi) - math.ceil(lo) >= 1 and draw(st.booleans()):
            c["kind"] = "int"  # a float field searched over whole numbers
            lo, hi = math.ceil(lo), math.floor(hi)
        if c.get("kind") == "int":
            a = draw(st.integers(int(lo), int(hi) - 1))
            b = draw(st.integers(a + 1, int(hi)))
        else:
            a = draw(st.floats(lo, hi, allow_nan=False))
            b = draw(st.floats(lo, hi, allow_nan=False))
            a, b = min(a, b), max(a, b)
            if b - a < 1e-3 or (c["path"] == "size_m" and math.floor(b / 0.5) < math.ceil(a / 0.5)):
                a, b = lo, hi
        params.append({**c, "low": a, "high": b})
    map_seed = draw(st.booleans())
    seeds = draw(st.integers(1, 1 << 31))
    space: dict[str, Any] = {"parameters": params, "map_seed": map_seed, "map_seeds": seeds}
    if draw(st.booleans()):
        space["moves"] = {"count": draw(st.integers(1, 3)), "radius_m": draw(st.floats(1e-3, 50.0))}
    world: dict[str, Any] = {"size_m": [40.0, 40.0], "cell_m": 0.5}
    if draw(st.booleans()):  # the base world's own moves come first
        world["obstacles"] = {"moves": [{"at": [1.0, 2.0], "by": [0.5, 0.0]}]}
    return parse_search({"seed": draw(st.integers(0, 2**40)), "world": world, "space": space,
                         "objective": {"name": "failure"}, "budget": {"runs": 80}})


_coord = st.floats(0.0, 1.0) | st.sampled_from([0.0, 1.0, 1 - 1e-16, 1e-300, -0.5, 1.5, float("nan"),
                                                  float("inf"), -float("inf")])


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=spaces(), data=st.data())
def test_every_point_decodes_to_a_valid_world_within_the_ranges(spec: SearchSpec, data: st.DataObject) -> None:
    space = Space.from_spec(spec)
    x = data.draw(st.lists(_coord, min_size=space.dimension, max_size=space.dimension))
    c = space.decode(x)
    world = parse_spec(space.world(c))  # a valid WorldSpec (raises otherwise)
    for p in spec.space.parameters:
        v = c.params[p.path]
        assert p.low <= v <= p.high, (p, v)
        if p.kind == "int":
            assert isinstance(v, int)
        if p.path == "size_m":
            assert world.size_m == (v, v)
    m = spec.space.moves
    base_moves = list(parse_spec(spec.world).obstacles.moves)
    assert space.dimension == len(spec.space.parameters) + 4 * (m.count if m else 0) + spec.space.map_seed
    assert list(world.obstacles.moves[:len(base_moves)]) == base_moves
    searched = world.obstacles.moves[len(base_moves):]
    assert len(searched) == (m.count if m else 0)
    for i, mv in enumerate(searched):
        assert 0 <= mv.at[0] <= world.size_m[0] and 0 <= mv.at[1] <= world.size_m[1]
        assert m is not None and all(-m.radius_m <= v <= m.radius_m for v in mv.by)
        assert (c.params[f"moves.{i}.at_x"], c.params[f"moves.{i}.at_y"]) == mv.at
        assert (c.params[f"moves.{i}.dx"], c.params[f"moves.{i}.dy"]) == mv.by
    assert _NAME.match(c.key) and re.fullmatch(r"w[0-9a-f]{12}", c.key)
    assert space.decode(x) == c  # the same point, the same candidate
    assert space.decode(np.asarray(x)) == c
    if spec.space.map_seed:
        assert c.seed_index is not None and 0 <= c.seed_index < spec.space.map_seeds
        assert c.map_seed == derive_seed(spec.seed, MAP_SEED_PATH, c.seed_index)
    else:
        assert c.seed_index is None and c.map_seed == derive_seed(spec.seed, MAP_SEED_PATH)


@settings(max_examples=100, deadline=None)
@given(spec=spaces(), data=st.data())
def test_different_worlds_have_different_keys(spec: SearchSpec, data: st.DataObject) -> None:
    space = Space.from_spec(spec)
    xs = data.draw(st.lists(st.lists(st.floats(0, 1), min_size=space.dimension, max_size=space.dimension),
                            min_size=2, max_size=6))
    cands = [space.decode(x) for x in xs]
    by_key: dict[str, Candidate] = {}
    for c in cands:
        other = by_key.setdefault(c.key, c)
        assert (other.params, other.map_seed) == (c.params, c.map_seed)


def _spec(params: list[dict[str, Any]], **space: Any) -> SearchSpec:
    return parse_search({"seed": 5, "world": {"size_m": [40.0, 40.0], "cell_m": 0.5},
                         "space": {"parameters": params, **space}, "objective": {"name": "failure"},
                         "budget": {"runs": 80}})


def test_integers_are_equal_width_bins_over_the_whole_range() -> None:
    space = Space.from_spec(_spec([{"path": "ground.subdivisions", "low": 2, "high": 5, "kind": "int"}], map_seed=False))
    u = np.linspace(0, 1, 4001)
    values = [space.decode([v]).params["ground.subdivisions"] for v in u]
    assert values[0] == 2 and values[-1] == 5
    counts = np.bincount(values)[2:]
    assert list(counts) == [1000, 1000, 1000, 1001]


def test_floats_are_rounded_and_the_map_side_snapped_to_the_grid() -> None:
    space = Space.from_spec(_spec([{"path": "ground.deformation", "low": 0, "high": 3},
                                   {"path": "size_m", "low": 30.2, "high": 60.1}], map_seed=False))
    c = space.decode([1 / 3, 0.0])
    assert c.params["ground.deformation"] == 1.0 and c.params["size_m"] == 30.5
    assert space.decode([0.5, 1.0]).params["size_m"] == 60.0
    assert c.world_overrides == {"ground": {"deformation": 1.0}, "size_m": [30.5, 30.5]}


def test_a_builtin_type_is_completed_when_its_field_is_searched() -> None:
    space = Space.from_spec(_spec([{"path": "obstacles.types.building.variability", "low": 0, "high": 0.5},
                                   {"path": "obstacles.obstruction.building", "low": 0, "high": 20}]))
    c = space.decode([0.5, 0.5, 0.5])
    assert c.world_overrides["obstacles"]["types"]["building"] == {"base_m": [9.0, 9.0], "height_m": 8.0,
                                                                   "variability": 0.25}
    assert parse_spec(space.world(c)).obstacles.all_types()["building"].variability == 0.25


def test_the_map_seed_is_the_last_dimension_or_fixed() -> None:
    params = [{"path": "ground.deformation", "low": 0, "high": 3}]
    searched = Space.from_spec(_spec(params, map_seed=True, map_seeds=4))
    assert searched.dimension == 2 and searched.names == ["ground.deformation", "map_seed"]
    lo, hi = searched.bounds
    assert list(lo) == [0, 0] and list(hi) == [1, 1]
    idx = [searched.decode([0.5, u]).seed_index for u in (0.0, 0.24, 0.25, 0.99, 1.0)]
    assert idx == [0, 0, 1, 3, 3]
    assert len({searched.decode([0.5, u]).key for u in (0.0, 0.3, 0.6, 0.9)}) == 4
    fixed = Space.from_spec(_spec(params, map_seed=False))
    assert fixed.dimension == 1
    assert {fixed.decode([u]).map_seed for u in (0.0, 0.5, 1.0)} == {derive_seed(5, MAP_SEED_PATH)}
    with pytest.raises(ValueError):
        fixed.decode([0.5, 0.5])


def test_the_key_depends_on_values_and_map_seed_only() -> None:
    assert candidate_key({"a": 1.0}, 3) == candidate_key({"a": 1.0}, 3)
    assert candidate_key({"a": 1.0}, 3) != candidate_key({"a": 1.0}, 4)
    assert candidate_key({"a": 1.0}, 3) != candidate_key({"a": 1.5}, 3)


@pytest.mark.parametrize("low,high,cell", [(20.000000000000004, 21.0, 0.5), (20.0, 20.999999999999996, 0.5),
                                           (10.1, 12.0, 0.4), (30.0, 30.0000000001, 0.5)])
def test_size_snaps_to_the_grid_inside_its_range(low: float, high: float, cell: float) -> None:
    """A bound a rounding error off the grid (found by the property test above on a fresh run):
    the snapped side never leaves [low, high], and makes a valid world, at both ends and between."""
    p = ParameterSpec(path="size_m", low=low, high=high, kind="float")
    for u in (0.0, 0.25, 0.5, 1.0):
        v = p.value(u, cell)
        assert low <= v <= high, (u, v)
        parse_spec({"size_m": [v, v], "cell_m": cell})


def test_moves_take_four_coordinates_each_between_the_parameters_and_the_map_seed() -> None:
    space = Space.from_spec(_spec([{"path": "size_m", "low": 20, "high": 40}], map_seed=True, map_seeds=4,
                                  moves={"count": 2, "radius_m": 1.5}))
    assert space.names == ["size_m", "moves.0.at_x", "moves.0.at_y", "moves.0.dx", "moves.0.dy",
                           "moves.1.at_x", "moves.1.at_y", "moves.1.dx", "moves.1.dy", "map_seed"]
    c = space.decode([0.5, 0.5, 1.0, 0.0, 1.0, 0.25, 0.0, 0.5, 0.75, 0.6])
    # at: over the candidate's own map (size 30 here); by: over [-radius, radius]
    assert c.world_overrides["obstacles"]["moves"] == [{"at": [15.0, 30.0], "by": [-1.5, 1.5]},
                                                       {"at": [7.5, 0.0], "by": [0.0, 0.75]}]
    assert c.seed_index == 2
    other = space.decode([0.5, 0.5, 1.0, 0.0, 1.0, 0.25, 0.0, 0.5, 0.76, 0.6])
    assert other.key != c.key and other.map_seed == c.map_seed


@pytest.mark.parametrize("moves, field", [
    ({"count": 0, "radius_m": 1.0}, "space.moves.count"),
    ({"count": 17, "radius_m": 1.0}, "space.moves.count"),
    ({"count": 2, "radius_m": 0.0}, "space.moves.radius_m"),
    ({"count": 2, "radius_m": -1.0}, "space.moves.radius_m"),
    ({"count": 2, "radius_m": float("inf")}, "space.moves.radius_m"),
    ({"count": 2, "radius_m": float("nan")}, "space.moves.radius_m"),
    ({"count": 2}, "space.moves.radius_m"),
    ({"count": 2, "radius_m": 1.0, "corridor": 3}, "space.moves.corridor"),
    ({"count": 1.5, "radius_m": 1.0}, "space.moves.count"),
])
def test_bad_moves_in_a_space_are_one_line_errors_naming_the_field(moves: dict[str, Any], field: str) -> None:
    from navstress.errors import SpecError
    with pytest.raises(SpecError) as err:
        _spec([], map_seed=False, moves=moves)
    text = str(err.value)
    assert "\n" not in text and text.startswith((field + "=", field + " is missing: ")), text


def test_a_space_of_moves_alone_is_a_space() -> None:
    space = Space.from_spec(_spec([], map_seed=False, moves={"count": 1, "radius_m": 2.0}))
    assert space.dimension == 4
    assert parse_spec(space.world(space.decode([0.5, 0.5, 0.5, 0.5]))).obstacles.moves[0].by == (0.0, 0.0)


def test_a_candidate_with_moves_is_the_same_world_through_the_campaign_store(tmp_path: Any) -> None:
    """The moves travel through the search's campaign spec, its store and a worker's generation
    unchanged: each planned world is the one generated straight from the candidate."""
    from navstress.campaign.store import Store
    from navstress.campaign.work import generate_world
    from navstress.search.driver import _campaign, _experiment, generation_name
    from navstress.world.generate import generate

    spec = parse_search({"seed": 9, "world": {"size_m": [20.0, 20.0], "obstacles": {"obstruction": {"tree": 10}}},
                         "space": {"parameters": [], "moves": {"count": 3, "radius_m": 2.0}, "map_seed": True},
                         "objective": {"name": "failure"}, "budget": {"runs": 80}})
    space = Space.from_spec(spec)
    g = np.random.default_rng(1)
    cands = [space.decode(g.random(space.dimension)) for _ in range(4)]
    with Store.create(tmp_path / "s", _campaign(spec, [_experiment(generation_name(0), cands)])) as store:
        jobs = {j.config_key: j for j in store.plan().maps}
    assert sorted(jobs) == sorted(c.key for c in cands)
    applied = 0
    for c in cands:
        generate_world(jobs[c.key])
        stored = World.load(jobs[c.key].world_dir)
        direct = generate(parse_spec(space.world(c)), c.map_seed)
        assert stored.obstacles == direct.obstacles and stored.spec == direct.spec
        assert len(stored.spec.obstacles.moves) == 3
        applied += stored.descriptors["moves_applied"]
    assert applied > 0  # some of the twelve moves moved a tree
