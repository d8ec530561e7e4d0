"""The ``rooms`` generator: over hypothesis-drawn RoomsSpecs every world keeps its constraints
(obstacles inside the map and never overlapping, doors per room in range, every room reachable
from the start with the robot's clearance by a flood fill of the test's own raster, start and goal
clear, no furniture in the free discs or a doorway, furniture near its target), is deterministic
(equal worlds, byte-identical files), differs between seeds; bad parameters are one-line SpecErrors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from navstress.errors import GenerationError, SpecError
from navstress.robot import PROFILES, RobotSpec
from navstress.world import generate, parse_spec
from navstress.world.generators.rooms import FURNITURE, door_list
from navstress.world.spec import WorldSpec
from navstress.world.world import Obstacle, World

CELL = 0.05


def rects(obstacles: tuple[Obstacle, ...]) -> np.ndarray:
    assert all(o.shape == "box" and o.yaw == 0.0 for o in obstacles)
    return np.array([(o.x - o.size[0] / 2, o.y - o.size[1] / 2, o.x + o.size[0] / 2, o.y + o.size[1] / 2)
                     for o in obstacles]).reshape(-1, 4)


def dist_to_rects(px: np.ndarray, py: np.ndarray, r: np.ndarray, reach: float = np.inf) -> np.ndarray:
    """Distance from points to the nearest axis-aligned rectangle (the test's own, numpy); on a
    grid of points (2-D, rows along y) only within ``reach`` of each rectangle (inf beyond)."""
    out = np.full(px.shape, np.inf)
    grid = px.ndim == 2 and math.isfinite(reach)
    for x0, y0, x1, y1 in r:
        if grid:
            cols = np.nonzero((px[0] >= x0 - reach) & (px[0] <= x1 + reach))[0]
            rows = np.nonzero((py[:, 0] >= y0 - reach) & (py[:, 0] <= y1 + reach))[0]
            if not len(cols) or not len(rows):
                continue
            win = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        else:
            win = (slice(None),) * px.ndim
        qx, qy = px[win], py[win]
        dx = np.maximum(np.maximum(x0 - qx, 0.0), qx - x1)
        dy = np.maximum(np.maximum(y0 - qy, 0.0), qy - y1)
        out[win] = np.minimum(out[win], np.hypot(dx, dy))
    return out


def check_world(w: World, robot: RobotSpec) -> None:
    spec, rs = w.spec, w.spec.rooms
    sx, sy = spec.size_m
    r = rects(w.obstacles)
    # inside the map
    assert (r[:, 0] >= -1e-9).all() and (r[:, 1] >= -1e-9).all()
    assert (r[:, 2] <= sx + 1e-9).all() and (r[:, 3] <= sy + 1e-9).all()
    # no two footprints share an interior point (touching is allowed)
    ox = np.minimum(r[:, None, 2], r[None, :, 2]) - np.maximum(r[:, None, 0], r[None, :, 0])
    oy = np.minimum(r[:, None, 3], r[None, :, 3]) - np.maximum(r[:, None, 1], r[None, :, 1])
    both = (ox > 1e-7) & (oy > 1e-7)
    np.fill_diagonal(both, False)
    assert not both.any(), [(w.obstacles[i], w.obstacles[j]) for i, j in zip(*np.nonzero(both))][:2]
    walls = [o for o in w.obstacles if o.kind == "wall"]
    furn = [o for o in w.obstacles if o.kind == "furniture"]
    assert len(walls) + len(furn) == len(w.obstacles)
    assert all(min(o.size[:2]) == pytest.approx(rs.wall_thickness_m) and o.size[2] == rs.wall_height_m for o in walls)
    sizes = {tuple(sorted(f[1:3])) for f in FURNITURE}
    assert all(tuple(sorted(o.size[:2])) in sizes for o in furn)
    # start and goal clear by the robot's clearance; the free discs hold no furniture
    clear = robot.width_m / 2
    m = w.mission
    for x, y in (m.start[:2], m.goal):
        assert dist_to_rects(np.array([x]), np.array([y]), r)[0] >= clear - 1e-9
        if furn:
            assert dist_to_rects(np.array([x]), np.array([y]), rects(tuple(furn)))[0] >= m.free_radius_m - 1e-9
    # doors per room in range
    d = w.descriptors["rooms"]
    assert rs.doors_min <= d["doors_per_room_min"] <= d["doors_per_room_max"] <= rs.doors_max
    # every room and the goal reachable from the start: a flood fill of the test's own raster
    xs = (np.arange(round(sx / CELL)) + 0.5) * CELL
    ys = (np.arange(round(sy / CELL)) + 0.5) * CELL
    px, py = np.meshgrid(xs, ys)
    free = dist_to_rects(px, py, r, reach=clear + CELL) >= clear
    free &= (px >= clear) & (px <= sx - clear) & (py >= clear) & (py <= sy - clear)
    labels, _ = ndimage.label(free)
    home = labels[int(m.start[1] // CELL), int(m.start[0] // CELL)]
    assert home > 0 and labels[int(m.goal[1] // CELL), int(m.goal[0] // CELL)] == home
    spaces, _edges, doors = door_list(spec, w.seed)
    t = rs.wall_thickness_m
    for s in spaces:
        inside = (px > s.x0 + t / 2) & (px < s.x1 - t / 2) & (py > s.y0 + t / 2) & (py < s.y1 - t / 2) & free
        assert inside.any(), s
        assert set(np.unique(labels[inside]).tolist()) == {home}, s
    # furniture off the doorways (the door's width, as deep as the door is wide, both sides)
    for dr in doors:
        e = _edges[dr.edge]
        zone = (dr.d0, e.at - rs.door_width_m, dr.d1, e.at + rs.door_width_m) if e.horizontal else \
            (e.at - rs.door_width_m, dr.d0, e.at + rs.door_width_m, dr.d1)
        for o in furn:
            f = rects((o,))[0]
            assert not (f[0] < zone[2] and zone[0] < f[2] and f[1] < zone[3] and zone[1] < f[3]), (o, dr)
    # the BARN metrics are there, finite, in their ranges
    b = w.descriptors["barn"]
    if b.get("reason") is None:
        assert b["dist_closest_m"] > 0 and b["visibility_m"] > 0 and b["characteristic_dim_m"] > 0
        assert 0 <= b["dispersion"] <= 16 and b["tortuosity"] >= 1.0


@st.composite
def room_specs(draw: st.DrawFn) -> dict:
    t = draw(st.sampled_from([0.1, 0.15, 0.25]))
    lo = draw(st.sampled_from([2.0, 2.5, 3.0, 4.0]))
    hi = lo + draw(st.sampled_from([0.0, 0.5, 1.5, 3.0]))
    door = draw(st.sampled_from([0.8, 0.9, 1.0, 1.2]))
    dmin = draw(st.integers(1, 2))
    dmax = dmin + draw(st.integers(0, 2))
    size = (0.5 * draw(st.integers(20, 50)), 0.5 * draw(st.integers(20, 50)))
    return {"size_m": list(size), "cell_m": 0.5, "generator": "rooms",
            "mission": {"mode": draw(st.sampled_from(["paper", "random"]))},
            "rooms": {"room_min_m": lo, "room_max_m": hi, "corridor_width_m": draw(st.sampled_from([1.2, 1.6, 2.0, 3.0])),
                      "door_width_m": door, "doors_min": dmin, "doors_max": dmax, "wall_thickness_m": t,
                      "furniture_pct": draw(st.sampled_from([0.0, 3.0, 10.0, 20.0, 30.0]))}}


def spec_or_reject(data: dict) -> WorldSpec:
    try:
        return parse_spec(data)
    except SpecError:
        assume(False)
        raise


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=room_specs(), seed=st.integers(0, 2**32))
def test_rooms_worlds_keep_their_constraints(data: dict, seed: int) -> None:
    spec = spec_or_reject(data)
    robot = RobotSpec()
    w = generate(spec, seed)
    check_world(w, robot)
    target = spec.rooms.furniture_pct
    got = w.descriptors["rooms"]["furniture_pct"]
    assert got <= target + 2.5
    if spec.rooms.room_min_m < 3.0 or spec.size_m[0] * spec.size_m[1] < 300:
        return  # small rooms or few of them: doorways and the free discs may leave no room for the share
    if target <= 20:
        assert got >= 0.6 * target - 1.0
    else:
        assert got >= 0.45 * target


@pytest.mark.parametrize("name", ["jackal", "turtlebot4", "husky"])
def test_rooms_for_other_robots(name: str) -> None:
    robot = PROFILES[name]
    spec = parse_spec({"size_m": [20, 16], "cell_m": 0.25, "generator": "rooms",
                       "rooms": {"furniture_pct": 15, "door_width_m": max(0.9, robot.width_m + 0.15)}})
    w = generate(spec, 3, robot=robot)
    check_world(w, robot)
    assert w.mission.free_radius_m == pytest.approx(robot.half_diagonal_m + 0.5)


def test_same_spec_and_seed_same_world_and_bytes(tmp_path: Path) -> None:
    spec = parse_spec({"size_m": [24, 18], "cell_m": 0.25, "generator": "rooms", "rooms": {"furniture_pct": 12}})
    a, b = generate(spec, 11), generate(spec, 11)
    assert a == b
    a.save(tmp_path / "a")
    b.save(tmp_path / "b")
    for f in ("world.json", "terrain.npz"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    assert World.load(tmp_path / "a") == a
    digests = {generate(spec, s).digest() for s in range(6)}
    assert len(digests) == 6


def test_furniture_does_not_move_the_walls() -> None:
    """The layout and doors come from their own streams: furniture changes nothing else."""
    base = {"size_m": [20, 16], "cell_m": 0.5, "generator": "rooms"}
    bare = generate(parse_spec(base), 5)
    full = generate(parse_spec({**base, "rooms": {"furniture_pct": 20}}), 5)
    assert [o for o in full.obstacles if o.kind == "wall"] == list(bare.obstacles)
    assert full.mission.start == bare.mission.start


def test_a_given_start_and_goal_are_kept_or_refused() -> None:
    base = {"size_m": [20, 16], "cell_m": 0.5, "generator": "rooms"}
    w = generate(parse_spec(base), 2)
    s, g = w.mission.start, w.mission.goal
    again = generate(parse_spec({**base, "mission": {"start": [s[0], s[1], 0.5], "goal": list(g)}}), 2)
    assert again.mission.start == (s[0], s[1], 0.5) and again.mission.goal == g
    wall = next(o for o in w.obstacles if o.kind == "wall")
    with pytest.raises(GenerationError, match="mission.start=.*from a wall") as err:
        generate(parse_spec({**base, "mission": {"start": [wall.x, wall.y, 0.0], "goal": list(g)}}), 2)
    assert "\n" not in str(err.value)


BAD = [
    ({"size_m": [10, 10], "rooms": {"room_min_m": 9, "room_max_m": 12}}, "rooms.room_min_m", "fit the 10x10 m map"),
    ({"rooms": {"room_min_m": 2.0, "door_width_m": 1.9}}, "rooms.door_width_m", "fit the smallest room's side"),
    ({"rooms": {"room_min_m": 5, "room_max_m": 4}}, "rooms.room_min_m", "rooms.room_max_m=4"),
    ({"rooms": {"doors_min": 3, "doors_max": 2}}, "rooms.doors_min", "rooms.doors_max=2"),
    ({"rooms": {"doors_min": 4, "doors_max": 4, "room_min_m": 3.0}}, "rooms.door_width_m", "4 door(s)"),
    ({"rooms": {"corridor_width_m": 0.2, "wall_thickness_m": 0.15}}, "rooms.corridor_width_m", "twice the wall"),
    ({"rooms": {"furniture_pct": 31}}, "rooms.furniture_pct", "30"),
]


@pytest.mark.parametrize("over,field,words", BAD)
def test_bad_room_parameters_are_one_line_spec_errors(over: dict, field: str, words: str) -> None:
    data = {"size_m": [20, 20], "generator": "rooms", **over}
    with pytest.raises(SpecError) as err:
        parse_spec(data)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(field) and words in msg


@pytest.mark.parametrize("field,value", [("corridor_width_m", 0.7), ("door_width_m", 0.7)])
def test_a_passage_narrower_than_the_robot_is_a_spec_error(field: str, value: float) -> None:
    spec = parse_spec({"size_m": [20, 20], "generator": "rooms", "rooms": {field: value, "room_min_m": 3}})
    with pytest.raises(SpecError) as err:
        generate(spec, 0, robot=PROFILES["rmp400"])
    assert str(err.value).startswith(f"rooms.{field}=0.7 is invalid") and "wider than the robot 'rmp400'" in str(err.value)
    assert "\n" not in str(err.value)


def test_rooms_parameters_only_with_the_rooms_generator() -> None:
    with pytest.raises(SpecError, match=r"^rooms=.*set generator: rooms"):
        parse_spec({"rooms": {"furniture_pct": 5}})
    with pytest.raises(SpecError, match=r"^obstacles=.*no obstacle targets"):
        generate(parse_spec({"size_m": [20, 20], "generator": "rooms", "obstacles": {"obstruction": {"tree": 2}}}), 0)


def test_the_outdoor_spec_text_is_unchanged() -> None:
    """A spec that does not use the rooms generator dumps no rooms/clutter/generator key (files keep their bytes)."""
    dumped = parse_spec({"size_m": [20, 20]}).model_dump(mode="json")
    assert not {"rooms", "clutter", "generator"} & set(dumped)
    rooms = parse_spec({"size_m": [20, 20], "generator": "rooms"}).model_dump(mode="json")
    assert "rooms" in rooms and "clutter" not in rooms
    assert math.isfinite(rooms["rooms"]["room_min_m"])
