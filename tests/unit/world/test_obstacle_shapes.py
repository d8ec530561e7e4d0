"""Obstacle shapes outside the simulator: the exact footprint tests (navstress.world.shapes)
against point sampling, the rasters against analytic areas and distances, walls in WorldSpec and
in generated worlds (placement constraints on families of worlds with walls), cylinders and
turned boxes under obstacle moves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from navstress.errors import GenerationError, SpecError
from navstress.world import Mission, Obstacle, World, WorldSpec, generate, parse_spec
from navstress.world import shapes
from navstress.world.descriptors import _box_arrays, _box_distance, describe_world, obstacle_distance
from navstress.world.placement import apply_moves, level_terrain

coord = st.floats(2.0, 18.0)
side = st.floats(0.1, 6.0)
yaw = st.floats(-math.pi, math.pi)


@st.composite
def obstacle(draw: st.DrawFn) -> Obstacle:
    x, y = draw(coord), draw(coord)
    if draw(st.booleans()):
        d = draw(side)
        return Obstacle("tree", x, y, draw(yaw), (d, d, 2.0), shape="cylinder")
    turned = draw(st.booleans())
    return Obstacle("wall" if turned else "building", x, y, draw(yaw) if turned else 0.0,
                    (draw(side), draw(side), 2.0))


def _inside(o: Obstacle, px: np.ndarray, py: np.ndarray, eps: float) -> np.ndarray:
    """Points strictly inside the footprint by ``eps`` (an independent test: local coordinates)."""
    if o.is_cylinder:
        return np.asarray(np.hypot(px - o.x, py - o.y) < o.size[0] / 2 - eps)
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    lx, ly = c * (px - o.x) + s * (py - o.y), -s * (px - o.x) + c * (py - o.y)
    return np.asarray((np.abs(lx) < o.size[0] / 2 - eps) & (np.abs(ly) < o.size[1] / 2 - eps))


GRID = np.meshgrid(np.linspace(0, 20, 801), np.linspace(0, 20, 801))


@settings(max_examples=150, deadline=None)
@given(obstacle(), obstacle())
def test_overlap_agrees_with_point_sampling(a: Obstacle, b: Obstacle) -> None:
    """Footprints that share a sample point well inside both overlap; footprints said to overlap
    share a point (found by sampling, unless the overlap is thinner than the samples' spacing)."""
    px, py = GRID
    common = _inside(a, px, py, 0.0) & _inside(b, px, py, 0.0)
    if common.any():
        assert shapes.overlap(a, b) and shapes.overlap(b, a)
    deep = _inside(a, px, py, 0.06) & _inside(b, px, py, 0.06)
    if not shapes.overlap(a, b):
        assert not deep.any()


@settings(max_examples=100, deadline=None)
@given(obstacle(), st.floats(0.0, 20.0), st.floats(0.0, 20.0))
def test_distance_is_the_distance_to_the_footprint(o: Obstacle, x: float, y: float) -> None:
    outline = o.outline(2000)  # a cylinder: a polygon inscribed in the circle
    d = float(shapes.distance(o, x, y))
    if _inside(o, np.array(x), np.array(y), 0.0):
        assert d == 0.0
        return
    # the distance to the outline's edges (sampled densely) is the distance to the footprint
    t = np.linspace(0, 1, 200)[:, None, None]
    pts = (outline[None] * (1 - t) + np.roll(outline, -1, axis=0)[None] * t).reshape(-1, 2)
    ref = float(np.min(np.hypot(pts[:, 0] - x, pts[:, 1] - y)))
    assert d == pytest.approx(ref, abs=0.01 + 1e-3 * o.size[0])


@settings(max_examples=80, deadline=None)
@given(obstacle(), st.sampled_from([0.1, 0.25, 0.4]))
def test_the_cells_a_footprint_touches_cover_it_and_no_more(o: Obstacle, cell: float) -> None:
    """Every point inside the footprint lies in a marked cell; every marked cell comes within
    rounding of the footprint."""
    n = round(20 / cell)
    occ = np.zeros((n, n), np.uint8)
    shapes.mark(occ, cell, cell, o)
    px, py = GRID
    inside = _inside(o, px, py, 0.0) & (px < 20) & (py < 20)
    a, b = (px[inside] // cell).astype(int), (py[inside] // cell).astype(int)
    assert occ[b, a].all()
    bb, aa = np.nonzero(occ)
    # a marked cell's centre lies within half its diagonal of the footprint
    d = shapes.distance(o, (aa + 0.5) * cell, (bb + 0.5) * cell)
    assert np.all(d <= cell * math.sqrt(0.5) + 1e-6)


@settings(max_examples=60, deadline=None)
@given(obstacle(), st.sampled_from([0.05, 0.1, 0.2]))
def test_the_rasterised_area_matches_the_analytic_area(o: Obstacle, cell: float) -> None:
    """The descriptors' occupancy raster (a cell is occupied when its centre is inside a footprint:
    boxes as turned rectangles, cylinders as discs) has the footprint's area, within one cell
    along its perimeter."""
    assume(shapes.inside_map(o, 20.0, 20.0))
    n = round(20 / cell)
    boxes = _box_arrays((o,))
    d = _box_distance(n, n, cell, boxes._replace(x=boxes.x - 0.5 * cell, y=boxes.y - 0.5 * cell), 0.0)
    raster = float(np.count_nonzero(d <= 0.0)) * cell * cell
    perimeter = math.pi * o.size[0] if o.is_cylinder else 2 * (o.size[0] + o.size[1])
    assert abs(raster - o.area) <= perimeter * cell + 4 * cell * cell


@settings(max_examples=40, deadline=None)
@given(st.lists(obstacle(), min_size=1, max_size=4))
def test_the_traversability_distance_is_exact_for_every_shape(obs: list[Obstacle]) -> None:
    grid = obstacle_distance((41, 41), 0.5, tuple(obs), 3.0)
    ys, xs = np.mgrid[0:41, 0:41] * 0.5
    ref = np.min([shapes.distance(o, xs, ys) for o in obs], axis=0)
    near = ref <= 3.0
    assert np.allclose(grid[near], ref[near], atol=1e-9)


def test_a_cylinder_keeps_its_shape_through_levelling_and_its_disc_is_levelled() -> None:
    h = np.arange(41 * 41, dtype=np.float64).reshape(41, 41) * 1e-3
    cyl = Obstacle("tree", 10.0, 10.0, 0.7, (3.0, 3.0, 2.0), shape="cylinder")
    lev = level_terrain(h, 0.5, [cyl])
    (out,) = lev.obstacles
    assert out.is_cylinder and out.size == cyl.size and out.yaw == cyl.yaw
    # the footprint's bounding box x +- r is levelled (not the bounding square turned by its yaw)
    assert np.all(lev.heights[17:24, 17:24] == np.float32(out.z))
    assert lev.heights[15, 15] != np.float32(out.z) and lev.heights[16, 20] != np.float32(out.z)


def _constraints_hold(w: World) -> None:
    sx, sy = w.size_m
    m = w.mission
    for k, o in enumerate(w.obstacles):
        assert shapes.inside_map(o, sx, sy), o
        for cx, cy in ((m.start[0], m.start[1]), m.goal):
            assert shapes.disc_clear(o, cx, cy, m.free_radius_m - 1e-9), (o, (cx, cy))
        for q in w.obstacles[k + 1:]:
            if not (o.kind == q.kind == shapes.WALL_KIND):  # a wall's own segments meet at their joints
                assert not shapes.overlap(o, q), (o, q)


@st.composite
def wall_specs(draw: st.DrawFn) -> list[dict[str, object]]:
    walls = []
    for _ in range(draw(st.integers(1, 3))):
        n = draw(st.integers(2, 4))
        pts = [[draw(st.floats(1.0, 29.0)), draw(st.floats(1.0, 29.0))] for _ in range(n)]
        walls.append({"points": pts, "thickness_m": draw(st.floats(0.1, 0.6))})
    return walls


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(wall_specs(), st.sampled_from(["paper", "random"]), st.floats(0.0, 8.0), st.integers(0, 2**16))
def test_generated_worlds_with_walls_keep_the_placement_constraints(walls: list[dict[str, object]], mode: str,
                                                                   trees: float, seed: int) -> None:
    data = {"size_m": [30, 30], "obstacles": {"obstruction": {"tree": trees, "building": 4}, "walls": walls},
            "mission": {"mode": mode, "min_distance_m": 10.0, "free_radius_m": 3.0}}
    try:
        spec = parse_spec(data)
    except SpecError:
        assume(False)
        raise
    try:
        w = generate(spec, seed)
    except GenerationError:
        assume(False)
        raise
    n_walls = sum(len(wall["points"]) - 1 for wall in walls)  # type: ignore[arg-type]
    assert [o.kind for o in w.obstacles[:n_walls]] == ["wall"] * n_walls  # walls first
    assert w.descriptors["n_obstacles"]["wall"] == n_walls
    _constraints_hold(w)


def test_wall_boxes_close_their_joints_and_cap_their_ends() -> None:
    t = 0.4
    boxes = shapes.wall_boxes([(2.0, 2.0), (10.0, 2.0), (10.0, 8.0)], t, 3.0)
    assert [b.kind for b in boxes] == ["wall", "wall"]
    a, b = boxes
    assert (a.x, a.y, a.yaw) == (6.0, 2.0, 0.0) and a.size == pytest.approx((8.0 + t, t, 3.0))
    assert b.yaw == pytest.approx(math.pi / 2) and b.size == pytest.approx((6.0 + t, t, 3.0))
    # the outer corner of the joint is covered, the free ends stick out half the thickness
    assert shapes.distance(a, 10.0 + t / 2, 2.0 - t / 2) == 0.0
    assert shapes.distance(b, 10.0 + t / 2, 2.0 - t / 2) == 0.0
    assert shapes.distance(a, 2.0 - t / 2, 2.0) == 0.0 and shapes.distance(a, 2.0 - t / 2 - 0.01, 2.0) > 0
    assert shapes.overlap(a, b)  # the joint's square


@pytest.mark.parametrize(("walls", "field", "says"), [
    ([{"points": [[10, 10]]}], "obstacles.walls[0].points=", "2 to"),
    ([{"points": [[10, 10], [12, 10], [12, 10]]}], "obstacles.walls[0].points[2]=", "length 0"),
    ([{"points": [[10, 10], [12, 10]]}, {"points": [[10, 12], [31, 12]]}], "obstacles.walls[1].points[1]=",
     "inside the map"),
    ([{"points": [[10, 10], [12, 10], [12, 0.05]]}], "obstacles.walls[0].points[2]=", "inside the map"),
    ([{"points": [[2, 8], [8, 2]]}], "obstacles.walls[0].points[1]=", "start free disc"),
    ([{"points": [[22, 12], [22, 28]]}], "obstacles.walls[0].points[1]=", "goal free disc"),
    ([{"points": [[10, 10], [12, 10]], "thickness_m": 0}], "obstacles.walls[0].thickness_m=", "> 0"),
    ([{"points": [[10, 10], [12, 10]], "height_m": 1000}], "obstacles.walls[0].height_m=", "<= 100"),
    ([{"points": [[10, "1"], [12, 10]]}], "obstacles.walls[0].points[0][1]=", "number"),
    ([{"points": [[10, 10], [12, 10]], "kind": "x"}], "obstacles.walls[0].kind", ""),
])
def test_bad_walls_are_one_line_spec_errors_naming_the_point(walls: list[object], field: str, says: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_spec({"size_m": [30, 30], "obstacles": {"walls": walls}})
    text = str(err.value)
    assert "\n" not in text and text.startswith(field) and says in text, text


def test_a_spec_without_walls_dumps_without_the_key_and_walls_round_trip() -> None:
    assert "walls" not in WorldSpec().model_dump(mode="json")["obstacles"]
    spec = parse_spec({"size_m": [30, 30], "obstacles": {"walls": [{"points": [[10, 10], [20, 12]]}]}})
    again = parse_spec(spec.model_dump(mode="json"))
    assert again == spec and again.obstacles.walls[0].points == ((10.0, 10.0), (20.0, 12.0))


def test_a_wall_across_a_random_missions_disc_is_avoided_or_a_clear_error() -> None:
    # a wall splitting the map: random missions are drawn with free discs clear of it
    spec = parse_spec({"size_m": [30, 30], "obstacles": {"walls": [{"points": [[15, 1], [15, 29]]}]},
                       "mission": {"mode": "random", "min_distance_m": 5.0, "free_radius_m": 3.0}})
    for seed in range(5):
        w = generate(spec, seed)
        _constraints_hold(w)
    # no room at all for the discs: the generator says why, in one line
    spec = parse_spec({"size_m": [20, 20], "obstacles": {"walls": [
        {"points": [[x, 1], [x, 19]], "thickness_m": 0.2} for x in (4.0, 8.0, 12.0, 16.0)]},
        "mission": {"mode": "random", "min_distance_m": 1.0, "free_radius_m": 3.0}})
    with pytest.raises(GenerationError, match="clear of the walls") as err:
        generate(spec, 1)
    assert "\n" not in str(err.value)


@settings(max_examples=25, deadline=None)
@given(st.lists(obstacle(), min_size=2, max_size=6),
       st.lists(st.tuples(coord, coord, st.floats(-4, 4), st.floats(-4, 4)), min_size=1, max_size=6))
def test_moves_keep_the_constraints_for_cylinders_and_turned_boxes(obs: list[Obstacle],
                                                                   moves: list[tuple[float, ...]]) -> None:
    spec = WorldSpec(size_m=(20.0, 20.0), cell_m=0.5, obstacles={"moves": [
        {"at": [ax, ay], "by": [dx, dy]} for ax, ay, dx, dy in moves]})
    mission = Mission((1.0, 1.0, 0.0), (19.0, 19.0), 0.8)
    kept: list[Obstacle] = []
    for o in obs:  # a valid start: inside, apart, out of the discs
        if shapes.inside_map(o, 20, 20) and all(not shapes.overlap(o, q) for q in kept) and \
                shapes.disc_clear(o, 1, 1, 0.8) and shapes.disc_clear(o, 19, 19, 0.8):
            kept.append(o)
    assume(len(kept) >= 2)
    fixed, movable = kept[:1], kept[1:]
    out, done = apply_moves(movable, spec, mission, fixed=fixed)
    w = World.flat(spec, obstacles=tuple(fixed + out), mission=mission)
    _constraints_hold(w)
    assert [o.shape for o in out] == [o.shape for o in movable]


def test_descriptors_of_a_world_of_cylinders_and_walls() -> None:
    spec = WorldSpec(size_m=(20.0, 20.0), cell_m=0.5)
    cyl = Obstacle("tree", 10.0, 10.0, 0.0, (2.0, 2.0, 3.0), shape="cylinder")
    walls = shapes.wall_boxes([(2.0, 12.0), (8.0, 18.0)], 0.3, 2.0)
    d = describe_world(World.flat(spec, obstacles=(cyl, *walls)))
    assert d["obstruction_pct"]["tree"] == pytest.approx(100 * math.pi / 400)
    assert d["n_obstacles"] == {"tree": 1, "wall": 1} and d["feasible"]


@pytest.mark.parametrize("wall_fixed", [True, False])
def test_a_move_beside_a_turned_wall_is_tested_on_the_shapes_not_their_bounding_boxes(wall_fixed: bool) -> None:
    """A cylinder moved into the bounding box of a diagonal wall, but clear of the wall itself, is
    moved; moved onto the wall, it is not."""
    wall = Obstacle("wall", 10.0, 10.0, math.pi / 4, (4.0, 0.4, 2.0))
    cyl = Obstacle("tree", 5.0, 5.0, 0.0, (1.0, 1.0, 2.0), shape="cylinder")
    mission = Mission((1.0, 1.0, 0.0), (19.0, 19.0), 0.8)
    for by, applied in (((3.5, 6.0), True), ((4.5, 5.0), False)):
        spec = WorldSpec(size_m=(20.0, 20.0), cell_m=0.5, obstacles={"moves": [{"at": [5, 5], "by": list(by)}]})
        out, done = (apply_moves([cyl], spec, mission, fixed=[wall]) if wall_fixed
                     else apply_moves([cyl, wall], spec, mission))
        assert done == ([0] if applied else [-1])
        assert out[0].is_cylinder and (out[0].x, out[0].y) == ((5.0 + by[0], 5.0 + by[1]) if applied else (5.0, 5.0))
