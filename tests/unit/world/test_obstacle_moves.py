"""Local moves of generated obstacles (``obstacles.moves``): applied exactly when the moved
obstacle keeps every placement constraint, deterministic, and absent from the files of worlds
that have none."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import GenerationError, SpecError
from navstress.world.generate import generate
from navstress.world.spec import MAX_MOVES, WorldSpec, parse_spec
from navstress.world.world import Obstacle
from test_worldgen_placement import box_disc_distance, check_world, sat_overlap

BASE = {"size_m": [30.0, 30.0], "obstacles": {"obstruction": {"tree": 8.0}, "types": {"tree": {
    "base_m": [1.0, 1.0], "height_m": 5.0, "variability": 0.5}}}, "ground": {"subdivisions": 3, "deformation": 1.0}}


def with_moves(base: dict, moves: list[dict]) -> WorldSpec:
    return parse_spec({**base, "obstacles": {**base["obstacles"], "moves": moves}})


def allowed(obs: list[Obstacle], k: int, moved: Obstacle, spec: WorldSpec, start: tuple, goal: tuple,
            free_r: float) -> bool:
    """Whether ``moved`` may replace obstacle ``k``: an independent check of each constraint."""
    c = moved.corners()
    sx, sy = spec.size_m
    if c.min() < 0 or c[:, 0].max() > sx or c[:, 1].max() > sy:
        return False
    if any(box_disc_distance(moved, x, y) < free_r for x, y in (start, goal)):
        return False
    return not any(sat_overlap(c, o.corners(), eps=0.0) for j, o in enumerate(obs) if j != k)


moves_st = st.lists(st.fixed_dictionaries({
    "at": st.tuples(st.floats(0, 30), st.floats(0, 30)),
    "by": st.tuples(st.floats(-4, 4), st.floats(-4, 4)),
}), min_size=1, max_size=6)


@given(moves=moves_st, seed=st.integers(0, 2**32), tree=st.sampled_from([3.0, 8.0, 15.0]))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_each_move_is_applied_exactly_when_the_moved_obstacle_keeps_every_constraint(
        moves: list[dict], seed: int, tree: float) -> None:
    base = {**BASE, "obstacles": {**BASE["obstacles"], "obstruction": {"tree": tree}}}
    try:
        plain = generate(parse_spec(base), seed)
    except GenerationError:
        return
    w = generate(with_moves(base, moves), seed)
    check_world(w)   # inside the map, no overlap, out of the free discs, on the levelled ground
    m = w.mission
    # replay the moves on the unmoved obstacles, judging each with the independent check
    obs = [Obstacle(o.kind, o.x, o.y, o.yaw, o.size) for o in plain.obstacles]
    applied = 0
    for mv in moves:
        d = [math.hypot(o.x - mv["at"][0], o.y - mv["at"][1]) for o in obs]
        k = int(np.argmin(d))
        if sorted(d)[:2] != [d[k]] * 2 or len(d) == 1:   # a clear nearest (ties are the generator's rule)
            cand = Obstacle(obs[k].kind, obs[k].x + mv["by"][0], obs[k].y + mv["by"][1], obs[k].yaw, obs[k].size)
            if allowed(obs, k, cand, w.spec, m.start[:2], m.goal, m.free_radius_m):
                obs[k] = cand
                applied += 1
        else:
            return   # an exact tie between two centres: not judged here
    assert [(o.kind, o.size[:2]) for o in w.obstacles] == [(o.kind, o.size[:2]) for o in obs]
    assert [(o.x, o.y) for o in w.obstacles] == [(o.x, o.y) for o in obs]
    assert w.descriptors["moves_applied"] == applied
    assert w.descriptors["obstruction_pct"] == plain.descriptors["obstruction_pct"]


def test_a_small_move_moves_the_nearest_obstacle_and_an_impossible_one_moves_nothing() -> None:
    plain = generate(parse_spec(BASE), 7)
    o = plain.obstacles[5]
    w = generate(with_moves(BASE, [{"at": [o.x + 0.01, o.y], "by": [0.0, 0.0]},
                                   {"at": [o.x, o.y], "by": [100.0, 0.0]}]), 7)
    assert w.obstacles == plain.obstacles  # a zero move and a move off the map change nothing...
    assert w.descriptors["moves_applied"] == 1  # ...but the zero move counts as applied
    # a move onto its neighbour is refused
    nb = min((p for p in plain.obstacles if p is not o), key=lambda p: math.hypot(p.x - o.x, p.y - o.y))
    w = generate(with_moves(BASE, [{"at": [o.x, o.y], "by": [nb.x - o.x, nb.y - o.y]}]), 7)
    assert w.obstacles == plain.obstacles and w.descriptors["moves_applied"] == 0


def test_same_spec_and_seed_give_the_same_files(tmp_path) -> None:
    spec = with_moves(BASE, [{"at": [10, 10], "by": [0.4, -0.3]}, {"at": [20, 5], "by": [-0.5, 0.2]}])
    generate(spec, 3).save(tmp_path / "a")
    generate(parse_spec(spec.model_dump(mode="json")), 3).save(tmp_path / "b")
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_a_world_without_moves_keeps_its_files(tmp_path) -> None:
    generate(parse_spec(BASE), 3).save(tmp_path / "a")
    generate(with_moves(BASE, []), 3).save(tmp_path / "b")
    for f in (tmp_path / "a").rglob("*"):
        if f.is_file():
            assert f.read_bytes() == (tmp_path / "b" / f.relative_to(tmp_path / "a")).read_bytes(), f
    assert '"moves"' not in (tmp_path / "a" / "world.json").read_text()
    assert "moves" not in parse_spec(BASE).model_dump()["obstacles"]


@pytest.mark.parametrize("moves, field", [
    ([{"at": [1.0, float("nan")], "by": [0, 0]}], "obstacles.moves[0].at"),
    ([{"at": [1.0, 1.0], "by": [float("inf"), 0]}], "obstacles.moves[0].by"),
    ([{"at": [31.0, 1.0], "by": [0, 0]}], "obstacles.moves[0].at"),
    ([{"at": [1.0, -0.5], "by": [0, 0]}], "obstacles.moves[0].at"),
    ([{"at": [1.0, 1.0], "by": [0, 0]}, {"at": [1.0], "by": [0, 0]}], "obstacles.moves[1].at"),
    ([{"at": [1.0, 1.0]}], "obstacles.moves[0].by"),
    ([{"at": [1.0, 1.0], "by": [0, 0], "index": 3}], "obstacles.moves[0].index"),
    ([{"at": [1.0, 1.0], "by": [0, 0]}] * (MAX_MOVES + 1), "obstacles.moves"),
    ("here", "obstacles.moves"),
])
def test_bad_moves_are_one_line_errors_naming_the_field(moves: object, field: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_spec({**BASE, "obstacles": {**BASE["obstacles"], "moves": moves}})
    text = str(err.value)
    assert "\n" not in text and text.startswith(field), text


@pytest.mark.parametrize("edge", ["left", "right", "bottom", "top"])
def test_a_move_past_each_edge_of_the_map_is_refused_and_one_up_to_it_applied(edge: str) -> None:
    plain = generate(parse_spec(BASE), 11)
    size = plain.spec.size_m
    # the obstacle nearest the edge, pushed to 1 mm inside it, then 1 mm past it
    gap = {"left": lambda o: o.x - o.size[0] / 2, "right": lambda o: size[0] - o.x - o.size[0] / 2,
           "bottom": lambda o: o.y - o.size[1] / 2, "top": lambda o: size[1] - o.y - o.size[1] / 2}[edge]
    axis, sign = {"left": (0, -1), "right": (0, 1), "bottom": (1, -1), "top": (1, 1)}[edge]
    k = min(range(len(plain.obstacles)), key=lambda i: gap(plain.obstacles[i]))
    o = plain.obstacles[k]
    for past, applied in ((-0.001, 1), (0.001, 0)):
        by = [0.0, 0.0]
        by[axis] = sign * (gap(o) + past)
        w = generate(with_moves(BASE, [{"at": [o.x, o.y], "by": by}]), 11)
        assert w.descriptors["moves_applied"] == applied, (edge, past, gap(o))
        if applied:
            check_world(w)
            assert (w.obstacles[k].x, w.obstacles[k].y) == (o.x + by[0], o.y + by[1])
