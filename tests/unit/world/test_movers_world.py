"""Movers in the world model: the spec (errors, defaults, sweepable paths), placement constraints
(hypothesis), seeds, the static world left alone, and world.json round trips."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from navstress.errors import GenerationError, SpecError
from navstress.world import World, generate, parse_spec
from navstress.world.descriptors import describe_world
from navstress.world.movers import GAP_M, mover_descriptors
from navstress.world.spec import BUILTIN_MOVER_TYPES, MoversSpec, WorldSpec
from navstress.world.world import Mover
from test_worldgen_placement import box_disc_distance  # the placement tests' exact box-disc distance


def spec_with(movers: dict[str, Any], **world: Any) -> WorldSpec:
    return parse_spec({"size_m": [40, 40], **world, "movers": movers})


# ---- the spec -------------------------------------------------------------------------------

BAD_SPECS = [
    ({"types": {"pedestrian": {"speed_min_m_s": -1}}}, "movers.types.pedestrian.speed_min_m_s", "-1"),
    ({"types": {"vehicle": {"speed_max_m_s": -2}}}, "movers.types.vehicle.speed_max_m_s", "-2"),
    ({"types": {"pedestrian": {"speed_min_m_s": 2, "speed_max_m_s": 1}}}, "movers.types.pedestrian.speed_min_m_s", "2"),
    ({"behaviour": {"pedestrian": {"kind": "wander"}}}, "movers.behaviour.pedestrian.kind", "wander"),
    ({"count": {"robot": 2}}, "movers.count.robot", "robot"),
    ({"behaviour": {"cat": {"kind": "patrol"}}}, "movers.behaviour.cat", "cat"),
    ({"count": {"pedestrian": -1}}, "movers.count.pedestrian", "-1"),
    ({"count": {"pedestrian": 2.5}}, "movers.count.pedestrian", "2.5"),
    ({"density_per_ha": {"pedestrian": -3}}, "movers.density_per_ha.pedestrian", "-3"),
    ({"count": {"pedestrian": 1}, "density_per_ha": {"pedestrian": 3}}, "movers.density_per_ha.pedestrian", "3"),
    ({"behaviour": {"pedestrian": {"ttc_s": 3}}}, "movers.behaviour.pedestrian.ttc_s", "3"),
    ({"behaviour": {"pedestrian": {"kind": "patrol", "waypoints": 2}}}, "movers.behaviour.pedestrian.waypoints", "2"),
    ({"behaviour": {"pedestrian": {"kind": "intercept", "reaction_s": -0.1}}}, "movers.behaviour.pedestrian.reaction_s", "-0.1"),
    ({"behaviour": {"pedestrian": {"kind": "intercept", "speed_m_s": 0}}}, "movers.behaviour.pedestrian.speed_m_s", "0"),
    ({"types": {"cart": {"length_m": 1, "width_m": 1, "height_m": 1}}}, "movers.types.cart.speed_max_m_s", ""),
    ({"types": {"blob": {"shape": "disc", "length_m": 1, "width_m": 2, "height_m": 1, "speed_max_m_s": 1}}},
     "movers.types.blob.width_m", "2"),
    ({"types": {"truck": {"length_m": 30, "width_m": 3, "height_m": 4, "speed_max_m_s": 3}}, "count": {"truck": 1}},
     "movers.types.truck", "30x3"),
    ({"count": {"pedestrian": 900, "vehicle": 200}}, "movers", "1100 movers"),
    ({"bogus": 1}, "movers.bogus", "1"),
]


@pytest.mark.parametrize("movers,field,value", BAD_SPECS, ids=[b[1] for b in BAD_SPECS])
def test_bad_mover_specs_are_one_line_spec_errors(movers: dict[str, Any], field: str, value: str) -> None:
    with pytest.raises(SpecError) as e:
        spec_with(movers)
    msg = str(e.value)
    assert "\n" not in msg
    assert e.value.field == field, msg
    assert (f"{field}=" in msg or f"{field} is missing: " in msg) and value in msg and "expected" in msg, msg


def test_no_movers_by_default_and_the_dump_has_no_movers_key() -> None:
    spec = WorldSpec()
    assert spec.movers.empty and spec.movers.counts(spec.size_m) == {}
    assert "movers" not in spec.model_dump(mode="json")
    assert parse_spec({"movers": {}}).model_dump(mode="json") == spec.model_dump(mode="json")
    with_movers = spec_with({"count": {"pedestrian": 0}})
    assert with_movers.model_dump(mode="json")["movers"]["count"] == {"pedestrian": 0}
    assert WorldSpec.model_validate(with_movers.model_dump(mode="json")) == with_movers


def test_a_builtin_type_takes_only_the_fields_given() -> None:
    spec = spec_with({"types": {"pedestrian": {"speed_max_m_s": 2.5}}, "count": {"pedestrian": 1}})
    t = spec.movers.all_types()["pedestrian"]
    assert t.speed_max_m_s == 2.5
    assert t.model_copy(update={"speed_max_m_s": 1.5}) == BUILTIN_MOVER_TYPES["pedestrian"]
    assert BUILTIN_MOVER_TYPES["pedestrian"].shape == "disc" and BUILTIN_MOVER_TYPES["pedestrian"].length_m == 0.5
    assert BUILTIN_MOVER_TYPES["vehicle"].speed_max_m_s == 5.0


def test_count_or_density_per_hectare() -> None:
    m = MoversSpec.model_validate({"count": {"pedestrian": 3}, "density_per_ha": {"vehicle": 2.5}})
    assert m.counts((100.0, 100.0)) == {"pedestrian": 3, "vehicle": 3}  # 2.5 per ha x 1 ha, halves up
    assert m.counts((40.0, 40.0)) == {"pedestrian": 3, "vehicle": 0}  # 0.4 movers: rounds to 0
    w = generate(spec_with({"density_per_ha": {"pedestrian": 20}}), 1)  # 0.16 ha: 3.2 -> 3
    assert len(w.movers) == 3
    assert w.descriptors["n_movers"] == {"pedestrian": 3} and w.descriptors["movers_total"] == 3
    assert w.descriptors["mover_density_per_ha"] == pytest.approx(3 / 0.16)


# ---- byte identity of worlds without movers ---------------------------------------------------

#: sha256 of world.json and terrain.npz of worlds generated by the code before movers existed (the
#: rough one: since its start and goal areas are levelled, issue 33; without that levelling the code
#: still gives af047e8d..., 17f6fe07...)
GOLDEN = [
    ({"size_m": [30, 30], "obstacles": {"obstruction": {"tree": 8}}}, 7,
     "52dda80ec6e51a0f6ddef3ae0209086119a5ce326c297572fab1a4e1fba7747a",
     "6bf39ce07a881959db931e34d19a3cda7564ffc9345a861acc1b70fb8a96110d"),
    ({"size_m": [40, 40], "ground": {"subdivisions": 4, "deformation": 2},
      "obstacles": {"obstruction": {"tree": 4, "building": 10}}}, 7,
     "79d9542c32d2b72274de11d62184ff2d38eea1d07ccfadbfe7d9bb28eadfd6f1",
     "3926e1d517f49c812e961b1ae0363758296be9df8e448763a63e25bbd521d531"),
    ({"size_m": [30, 30], "mission": {"mode": "random", "min_distance_m": 15},
      "obstacles": {"total": 10, "mix": {"tree": 1, "building": 1}}}, 123,
     "a6d85400e4623f85d35a4f0d79ea90acf9e31db93ff47c2bfa3dc7c62ea67a6b",
     "6bf39ce07a881959db931e34d19a3cda7564ffc9345a861acc1b70fb8a96110d"),
]


@pytest.mark.parametrize("data,seed,world_sha,terrain_sha", GOLDEN)
def test_worlds_without_movers_keep_their_bytes(tmp_path: Path, data: dict[str, Any], seed: int, world_sha: str,
                                                terrain_sha: str) -> None:
    generate(parse_spec(data), seed).save(tmp_path / "w")
    text = (tmp_path / "w" / "world.json").read_bytes()
    assert b"movers" not in text
    assert hashlib.sha256(text).hexdigest() == world_sha
    assert hashlib.sha256((tmp_path / "w" / "terrain.npz").read_bytes()).hexdigest() == terrain_sha


# ---- placement ------------------------------------------------------------------------------

def check_movers(w: World) -> None:
    """Every placement constraint of docs/worlds.md, checked exactly."""
    sx, sy = w.size_m
    m0 = w.mission
    for m in w.movers:
        r = m.radius_m
        x, y, _ = m.start
        assert r <= x <= sx - r and r <= y <= sy - r, m
        for o in w.obstacles:
            assert box_disc_distance(o, x, y) >= r, (m, o)
        for cx, cy in (m0.start[:2], m0.goal):
            assert math.hypot(x - cx, y - cy) >= m0.free_radius_m + r, m
        path = [(x, y), *m.waypoints] + ([(x, y)] if m.behaviour == "patrol" else [])
        for a, b in zip(path, path[1:]):
            n = max(2, int(math.hypot(b[0] - a[0], b[1] - a[1]) / 0.05) + 1)
            for k in range(n):
                t = k / (n - 1)
                px, py = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
                assert r <= px <= sx - r and r <= py <= sy - r, (m, px, py)
                assert all(box_disc_distance(o, px, py) >= r for o in w.obstacles), (m, px, py)
    for i, a in enumerate(w.movers):
        assert a.id == i
        for b in w.movers[i + 1:]:
            assert math.hypot(a.start[0] - b.start[0], a.start[1] - b.start[1]) >= a.radius_m + b.radius_m + GAP_M


KINDS = ("crossing", "patrol", "intercept", "still-then-move")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(size=st.sampled_from([30.0, 40.0, 60.0]), trees=st.sampled_from([0.0, 2.0, 5.0]),
       buildings=st.sampled_from([0.0, 6.0]), peds=st.integers(0, 12), cars=st.integers(0, 2),
       ped_kind=st.sampled_from(KINDS), car_kind=st.sampled_from(KINDS), variability=st.sampled_from([0.0, 0.3]),
       seed=st.integers(0, 2**31))
def test_placement_constraints_hold(size: float, trees: float, buildings: float, peds: int, cars: int, ped_kind: str,
                                    car_kind: str, variability: float, seed: int) -> None:
    spec = parse_spec({"size_m": [size, size], "obstacles": {"obstruction": {"tree": trees, "building": buildings}},
                       "movers": {"types": {"pedestrian": {"variability": variability}},
                                  "count": {"pedestrian": peds, "vehicle": cars},
                                  "behaviour": {"pedestrian": {"kind": ped_kind}, "vehicle": {"kind": car_kind}}}})
    try:
        w = generate(spec, seed)
    except GenerationError as e:
        assert str(e).startswith("movers: could not place") or "obstruction" in str(e)
        assume(False)
        return
    assert len(w.movers) == peds + cars
    check_movers(w)
    for m in w.movers:
        t = spec.movers.all_types()[m.kind]
        v = t.variability
        assert t.length_m * (1 - v) <= m.size[0] <= t.length_m * (1 + v)
        assert t.speed_min_m_s <= m.speed_m_s <= m.speed_max_m_s
        assert m.behaviour == spec.movers.behaviour_of(m.kind).kind
        assert len(m.waypoints) == (0 if m.behaviour == "still-then-move" else spec.movers.behaviour_of(m.kind).waypoints)


MIXED = {"count": {"pedestrian": 6, "vehicle": 1},
         "behaviour": {"pedestrian": {"kind": "patrol"}, "vehicle": {"kind": "intercept", "ttc_s": 1.5}}}


def test_same_seed_same_movers_and_seeds_differ() -> None:
    spec = spec_with(MIXED, obstacles={"obstruction": {"tree": 2}})
    a, b, c = generate(spec, 5), generate(spec, 5), generate(spec, 6)
    assert a.movers == b.movers and len(a.movers) == 7
    assert a.movers != c.movers
    assert a.movers[-1].param("ttc_s") == 1.5 and a.movers[-1].param("aim") == "ttc"


@pytest.mark.parametrize("seed", [0, 3, 11])
def test_adding_movers_changes_nothing_else(seed: int) -> None:
    base = {"size_m": [40, 40], "ground": {"subdivisions": 3, "deformation": 1},
            "obstacles": {"obstruction": {"tree": 3, "building": 5}}, "mission": {"mode": "random", "min_distance_m": 20}}
    still = generate(parse_spec(base), seed)
    moving = generate(parse_spec({**base, "movers": MIXED}), seed)
    assert moving.movers and not still.movers
    assert moving.terrain == still.terrain and moving.obstacles == still.obstacles and moving.mission == still.mission
    extra = set(moving.descriptors) - set(still.descriptors)
    assert extra == {"n_movers", "movers_total", "mover_density_per_ha"}
    assert {k: v for k, v in moving.descriptors.items() if k not in extra} == still.descriptors
    again = describe_world(moving)
    assert {k: again[k] for k in extra} == {k: moving.descriptors[k] for k in extra}
    assert not extra & set(describe_world(still))
    # types are placed in name order, each from its own sub-stream: more vehicles (placed after
    # the pedestrians) change none of the pedestrians
    more = generate(parse_spec({**base, "movers": {**MIXED, "count": {"pedestrian": 6, "vehicle": 2}}}), seed)
    assert more.movers[:6] == moving.movers[:6] and len(more.movers) == 8


def test_save_load_round_trip_and_a_world_file_without_movers(tmp_path: Path) -> None:
    w = generate(spec_with(MIXED), 2)
    w.save(tmp_path / "w")
    back = World.load(tmp_path / "w")
    assert back == w and back.movers == w.movers
    meta = json.loads((tmp_path / "w" / "world.json").read_text())
    assert len(meta["movers"]) == 7 and meta["movers"][0]["behaviour"] == "patrol"
    plain = generate(parse_spec({"size_m": [20, 20]}), 2)
    plain.save(tmp_path / "p")
    assert "movers" not in json.loads((tmp_path / "p" / "world.json").read_text())
    assert World.load(tmp_path / "p").movers == ()


def test_a_count_that_cannot_be_placed_is_a_generation_error() -> None:
    with pytest.raises(GenerationError, match=r"movers: could not place .* type 'vehicle'"):
        generate(spec_with({"count": {"vehicle": 60}}, size_m=[20, 20], mission={"free_radius_m": 2}), 0)
    with pytest.raises(GenerationError, match="movers: could not place (the start|waypoint 1) of mover 1 of 1"):
        generate(spec_with({"count": {"vehicle": 1}}, obstacles={"obstruction": {"tree": 12}}), 0)  # a forest


def test_mover_json_and_descriptors() -> None:
    m = Mover(id=0, kind="pedestrian", shape="disc", size=(0.5, 0.5, 1.8), start=(1.0, 2.0, 0.5), speed_m_s=1.0,
              speed_max_m_s=1.5, accel_m_s2=1.0, behaviour="intercept", params=(("aim", "ttc"), ("ttc_s", 2.0)),
              waypoints=((3.0, 4.0),))
    assert Mover.from_json(json.loads(json.dumps(m.to_json()))) == m
    assert m.radius_m == 0.25 and m.param("aim") == "ttc"
    box = Mover(id=1, kind="vehicle", shape="box", size=(4.5, 1.8, 1.5), start=(0.0, 0.0, 0.0), speed_m_s=3.0,
                speed_max_m_s=5.0, accel_m_s2=2.0, behaviour="crossing")
    assert box.radius_m == pytest.approx(math.hypot(4.5, 1.8) / 2)
    spec = spec_with({"count": {"pedestrian": 2, "vehicle": 0}})
    assert mover_descriptors(spec, (m,)) == {"n_movers": {"pedestrian": 1, "vehicle": 0}, "movers_total": 1,
                                             "mover_density_per_ha": 1 / 0.16}


def test_a_corrupt_mover_in_world_json_is_a_world_file_error(tmp_path: Path) -> None:
    from navstress.errors import WorldFileError
    generate(spec_with({"count": {"pedestrian": 1}}), 0).save(tmp_path / "w")
    meta = json.loads((tmp_path / "w" / "world.json").read_text())
    meta["movers"][0]["behaviour"] = "teleport"
    (tmp_path / "w" / "world.json").write_text(json.dumps(meta))
    with pytest.raises(WorldFileError, match="is corrupt"):
        World.load(tmp_path / "w")
