"""Explicit-world experiments (``worlds:``): configurations, plan, seeds, sizes, canonical text,
and every bad input as a one-line error with exit 2 from ``campaign run`` (nothing written)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.campaign.plan import map_seed, plan, run_seed
from navstress.campaign.spec import (MAX_MAP_SEED, check_plan_size, flatten, parse_campaign, parse_campaign_text,
                                     planned_runs)
from navstress.errors import SpecError

from tests.support.cli_inputs import assert_one_line_error, invoke

ENTRIES: list[dict[str, Any]] = [
    {"key": "dense", "map_seed": 42, "world": {"obstacles": {"obstruction": {"tree": 12}}}},
    {"key": "rough.1", "map_seed": 7, "world": {"ground": {"deformation": 1.5}}},
    {"key": "base", "map_seed": 0},
]


def _spec(**over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "mixed", "seed": 9, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 4]}}},
                        {"name": "suite", "overrides": {"ground": {"subdivisions": 3}}, "worlds": ENTRIES}],
        "maps_per_config": 3, "runs_per_map": 2,
        "navigators": [{"name": "reference-v1"}, {"name": "other-v1"}], "faults": [None, "small-footprint"]}
    d.update(over)
    return d


def test_each_entry_is_one_configuration_with_its_world_and_values() -> None:
    spec = parse_campaign(_spec())
    cfgs = spec.experiments[1].configurations(spec.world)
    assert [(c.key, c.map_seed) for c in cfgs] == [("dense", 42), ("rough.1", 7), ("base", 0)]
    assert [c.values for c in cfgs] == [{"obstacles.obstruction.tree": 12}, {"ground.deformation": 1.5}, {}]
    ws = [c.world_spec() for c in cfgs]  # campaign world, then experiment overrides, then the entry's
    assert all(w.size_m == (20.0, 20.0) and w.ground.subdivisions == 3 for w in ws)
    assert ws[0].obstacles.obstruction["tree"] == 12 and ws[1].ground.deformation == 1.5
    assert spec.experiments[1].explicit and not spec.experiments[0].explicit
    assert spec.maps_of(spec.experiments[1]) == 1 and spec.maps_of(spec.experiments[0]) == 3


def test_plan_one_map_per_entry_with_its_seed_and_paired_derived_run_seeds() -> None:
    spec = parse_campaign(_spec())
    p = plan(spec, "/tmp/c")
    maps = [m for m in p.maps if m.experiment == "suite"]
    assert [(m.config_key, m.map_index, m.map_seed) for m in maps] == [("dense", 0, 42), ("rough.1", 0, 7),
                                                                       ("base", 0, 0)]
    assert maps[0].world_dir == str(Path("/tmp/c").resolve() / "worlds" / "suite" / "dense" / "m0")
    # the sweep experiment keeps its derived map seeds and its maps_per_config
    sweep_maps = [m for m in p.maps if m.experiment == "trees"]
    assert len(sweep_maps) == 2 * 3 and sweep_maps[1].map_seed == map_seed(9, "trees", "tree=0", 1)
    tasks = [t for t in p.tasks if t.experiment == "suite"]
    assert len(tasks) == 3 * 2 * 2 * 2
    for t in tasks:
        key = t.run_id.split("/")[1]
        assert t.map_index == 0 and t.map_seed == {"dense": 42, "rough.1": 7, "base": 0}[key]
        assert t.run_seed == run_seed(9, "suite", key, 0, t.run_index)  # same for every navigator and fault
        assert t.config == {"dense": {"obstacles.obstruction.tree": 12}, "rough.1": {"ground.deformation": 1.5},
                            "base": {}}[key]
    assert {t.run_id for t in tasks if t.run_id.startswith("suite/dense/m0/r1/")} == {
        f"suite/dense/m0/r1/{n}/{f}" for n in ("reference-v1", "other-v1") for f in ("nominal", "small-footprint")}


def test_another_experiment_on_the_same_world_gets_fresh_run_seeds_and_the_same_map() -> None:
    d = _spec()
    d["experiments"].append({"name": "confirm", "worlds": [ENTRIES[0]]})
    p = plan(parse_campaign(d), "/tmp/c")
    a = {t.run_index: t for t in p.tasks if t.run_id.startswith("suite/dense/") and t.navigator == "reference-v1"}
    b = {t.run_index: t for t in p.tasks if t.run_id.startswith("confirm/dense/") and t.navigator == "reference-v1"}
    assert {t.map_seed for t in a.values()} == {t.map_seed for t in b.values()} == {42}
    assert all(a[r].run_seed != b[r].run_seed for r in a)


def test_adaptive_runs_per_map_on_explicit_worlds() -> None:
    d = _spec()
    d["experiments"][1]["runs_per_map"] = {"adaptive": {"min": 2, "max": 6}}
    spec = parse_campaign(d)
    p = plan(spec, "/tmp/c")
    streams = [s for s in p.streams if s.run_ids[0].startswith("suite/")]
    assert len(streams) == 3 * 2 * 2 and all(s.rule is not None and len(s.run_ids) == 6 for s in streams)
    assert len(p.due({})) == 2 * 3 * 2 * 2 + 2 * 3 * 2 * 2 * 2  # suite: min runs; trees: every run
    assert planned_runs(spec) == len(p.tasks) == 2 * 3 * 2 * 2 * 2 + 3 * 6 * 2 * 2


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 6), maps=st.integers(1, 4), runs=st.integers(1, 3), navs=st.integers(1, 2),
       faults=st.sampled_from([[None], [None, "small-footprint"]]), sweep=st.booleans())
def test_planned_runs_counts_explicit_worlds(n: int, maps: int, runs: int, navs: int, faults: list[str | None],
                                             sweep: bool) -> None:
    exps: list[dict[str, Any]] = [{"name": "w", "worlds": [{"key": f"k{i}", "map_seed": i} for i in range(n)]}]
    if sweep:
        exps.insert(0, {"name": "s", "sweep": {"ground.deformation": {"values": [0, 1, 2]}}})
    spec = parse_campaign(_spec(experiments=exps, maps_per_config=maps, runs_per_map=runs, faults=faults,
                                navigators=[{"name": f"n{i}-v1"} for i in range(navs)]))
    p = plan(spec, "/tmp/c")
    assert planned_runs(spec) == len(p.tasks) == len({t.run_id for t in p.tasks})
    assert len(p.tasks) == (n + (3 * maps if sweep else 0)) * runs * navs * len(faults)
    with pytest.raises(SpecError, match="planned runs"):
        check_plan_size(spec, len(p.tasks) - 1)


@settings(max_examples=40, deadline=None)
@given(seeds=st.lists(st.integers(0, MAX_MAP_SEED), min_size=1, max_size=4, unique=True),
       tree=st.integers(0, 10))
def test_canonical_text_round_trips_and_names_every_entry(seeds: list[int], tree: int) -> None:
    d = _spec(experiments=[{"name": "w", "worlds": [
        {"key": f"k{i}", "map_seed": s, "world": {"obstacles": {"obstruction": {"tree": tree}}}}
        for i, s in enumerate(seeds)]}])
    spec = parse_campaign(d)
    text = spec.canonical_json()
    again = parse_campaign(json.loads(text))
    assert again == spec and again.canonical_json() == text  # what the store re-reads is the same spec
    assert '"sweep"' not in text and '"worlds"' in text
    d["experiments"][0]["worlds"][0]["map_seed"] = seeds[0] + 1 if seeds[0] < MAX_MAP_SEED else 0
    assert parse_campaign(d).digest() != spec.digest()


def test_a_sweep_experiment_has_no_worlds_key_in_its_text() -> None:
    spec = parse_campaign(_spec())
    data = json.loads(spec.canonical_json())
    assert "worlds" not in data["experiments"][0] and "sweep" not in data["experiments"][1]


def test_flatten() -> None:
    assert flatten({"a": {"b": 1, "c": {"d": [1, 2]}}, "e": "x", "f": {}}) == {"a.b": 1, "a.c.d": [1, 2], "e": "x"}


def _worlds(*entries: Any, **exp: Any) -> dict[str, Any]:
    return _spec(experiments=[{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}},
                              {"name": "suite", "worlds": list(entries), **exp}])


#: Every way an explicit-world experiment can be wrong: (spec, field named, words of the expectation).
BAD: list[tuple[str, dict[str, Any], str, str]] = [
    ("worlds and sweep", _worlds(ENTRIES[0], sweep={"ground.deformation": {"values": [1]}}),
     "experiments[1].sweep", "no sweep in an experiment that lists explicit worlds"),
    ("worlds and an empty sweep", _worlds(ENTRIES[0], sweep={}), "experiments[1].sweep", "no sweep"),
    ("empty worlds", _worlds(), "experiments[1].worlds", "at least one entry"),
    ("worlds not a list", _spec(experiments=[{"name": "s", "worlds": {"key": "a", "map_seed": 1}}]),
     "experiments[0].worlds", "a list"),
    ("duplicate keys", _worlds({"key": "a", "map_seed": 1}, {"key": "b", "map_seed": 2}, {"key": "a", "map_seed": 3}),
     "experiments[1].worlds[2].key", "unique"),
    ("slash in key", _worlds({"key": "a/b", "map_seed": 1}), "experiments[1].worlds[0].key", "directory name"),
    ("dot-dot key", _worlds({"key": "..", "map_seed": 1}), "experiments[1].worlds[0].key", "directory name"),
    ("space in key", _worlds({"key": "a b", "map_seed": 1}), "experiments[1].worlds[0].key", "directory name"),
    ("empty key", _worlds({"key": "", "map_seed": 1}), "experiments[1].worlds[0].key", "directory name"),
    ("long key", _worlds({"key": "k" * 101, "map_seed": 1}), "experiments[1].worlds[0].key", "at most 100"),
    ("int key", _worlds({"key": 3, "map_seed": 1}), "experiments[1].worlds[0].key", "a string"),
    ("no key", _worlds({"map_seed": 1}), "experiments[1].worlds[0].key", "required"),
    ("negative map_seed", _worlds({"key": "a", "map_seed": -1}), "experiments[1].worlds[0].map_seed", ">= 0"),
    ("huge map_seed", _worlds({"key": "a", "map_seed": 2**63}), "experiments[1].worlds[0].map_seed", "<="),
    ("float map_seed", _worlds({"key": "a", "map_seed": 1.0}), "experiments[1].worlds[0].map_seed", "an integer"),
    ("string map_seed", _worlds({"key": "a", "map_seed": "1"}), "experiments[1].worlds[0].map_seed", "an integer"),
    ("bool map_seed", _worlds({"key": "a", "map_seed": True}), "experiments[1].worlds[0].map_seed", "an integer"),
    ("no map_seed", _worlds({"key": "a"}), "experiments[1].worlds[0].map_seed", "required"),
    ("unknown entry field", _worlds({"key": "a", "map_seed": 1, "seed": 2}), "experiments[1].worlds[0].seed",
     "a known field"),
    ("entry not a mapping", _worlds(3), "experiments[1].worlds[0]", "a mapping"),
    ("unknown world path", _worlds({"key": "a", "map_seed": 1, "world": {"ground": {"deformaton": 1}}}),
     "experiments[1].worlds[0].world.ground.deformaton", "a known field"),
    ("unknown obstacle type", _worlds({"key": "a", "map_seed": 1},
                                      {"key": "b", "map_seed": 1, "world": {"obstacles": {"obstruction": {"tre": 1}}}}),
     "experiments[1].worlds[1].world.obstacles.obstruction.tre", "obstacle types"),
    ("bad world value", _worlds({"key": "a", "map_seed": 1, "world": {"ground": {"deformation": -1}}}),
     "experiments[1].worlds[0].world.ground.deformation", ">= 0"),
    ("world not a mapping", _worlds({"key": "a", "map_seed": 1, "world": [1, 2]}), "experiments[1].worlds[0].world",
     "a mapping"),
    ("world a string", _worlds({"key": "a", "map_seed": 1, "world": "dense"}), "experiments[1].worlds[0].world",
     "a mapping"),
]


@pytest.mark.parametrize("data,field,expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_explicit_worlds_name_the_field(data: dict[str, Any], field: str, expected: str) -> None:
    with pytest.raises(SpecError) as ei:
        parse_campaign(data)
    assert ei.value.field == field, str(ei.value)
    assert expected in str(ei.value) and "\n" not in str(ei.value)
    with pytest.raises(SpecError) as again:  # the same error from the text of a spec file
        parse_campaign_text(yaml.safe_dump(data))
    assert again.value.field == field


@pytest.mark.parametrize("data,field,expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_explicit_worlds_exit_2_with_one_line_and_write_nothing(tmp_path: Path, data: dict[str, Any],
                                                                    field: str, expected: str) -> None:
    spec = tmp_path / "suite.yaml"
    spec.write_text(yaml.safe_dump(data), encoding="utf-8")
    argv = ["campaign", "run", str(spec), "-q", "-o", str(tmp_path / "out")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith((f"error: {field}=", f"error: {field} is missing: ")) and expected in line, line
    assert not (tmp_path / "out").exists()
