"""Planning: deterministic tasks, stable run ids, paired seeds derived from the campaign seed."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.campaign.plan import map_seed, plan, run_seed
from navstress.campaign.presets import demo
from navstress.campaign.spec import parse_campaign
from navstress.seeding import derive_seed


def _spec(seed: int, maps: int = 2, runs: int = 3, faults: list[Any] | None = None) -> Any:
    return parse_campaign({
        "name": "p", "seed": seed, "world": {"size_m": [30, 30]}, "maps_per_config": maps, "runs_per_map": runs,
        "navigators": [{"name": "a-v1"}, {"name": "b-v1", "config": {"k": 1}}],
        "faults": faults if faults is not None else [None, "small-footprint"],
        "experiments": [
            {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 5]}}},
            {"name": "smooth", "sweep": {"ground.deformation": {"values": [1.0]}}, "faults": [None]}]})


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**62), maps=st.integers(1, 3), runs=st.integers(1, 3))
def test_plan_deterministic_unique_and_complete(seed: int, maps: int, runs: int) -> None:
    spec = _spec(seed, maps, runs)
    a, b = plan(spec, "/tmp/c"), plan(spec, "/tmp/c")
    assert a == b
    ids = [t.run_id for t in a.tasks]
    assert len(set(ids)) == len(ids)
    # trees: 2 configs x 2 navs x 2 faults; smooth: 1 config x 2 navs x 1 fault
    assert len(ids) == maps * runs * (2 * 2 * 2 + 1 * 2 * 1)
    assert len(a.maps) == 3 * maps


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**62))
def test_seeds_are_derived_and_paired(seed: int) -> None:
    p = plan(_spec(seed), "/tmp/c")
    by_map: dict[tuple[str, int], set[int]] = defaultdict(set)
    by_run: dict[tuple[str, int, int], set[int]] = defaultdict(set)
    for t in p.tasks:
        key = f"{t.experiment}/" + t.run_id.split("/")[1]
        assert t.map_seed == derive_seed(seed, "map", t.experiment, t.run_id.split("/")[1], t.map_index)
        assert t.run_seed == derive_seed(seed, "run", t.experiment, t.run_id.split("/")[1], t.map_index, t.run_index)
        by_map[(key, t.map_index)].add(t.map_seed)
        by_run[(key, t.map_index, t.run_index)].add(t.run_seed)
        assert t.world_dir.endswith(f"worlds/{key}/m{t.map_index}")
    # one map seed per map and one run seed per (map, run) whatever the navigator/fault: paired runs
    assert all(len(v) == 1 for v in by_map.values()) and all(len(v) == 1 for v in by_run.values())
    # and they all differ from each other
    map_seeds = [next(iter(v)) for v in by_map.values()]
    run_seeds = [next(iter(v)) for v in by_run.values()]
    assert len(set(map_seeds)) == len(map_seeds) and len(set(run_seeds)) == len(run_seeds)


def test_different_campaign_seed_changes_every_seed_but_not_ids() -> None:
    a, b = plan(_spec(1), "/tmp/c"), plan(_spec(2), "/tmp/c")
    assert [t.run_id for t in a.tasks] == [t.run_id for t in b.tasks]
    assert all(x.map_seed != y.map_seed and x.run_seed != y.run_seed for x, y in zip(a.tasks, b.tasks))


def test_adding_a_fault_keeps_existing_seeds_and_ids() -> None:
    a = plan(_spec(3, faults=[None]), "/tmp/c")
    b = plan(_spec(3), "/tmp/c")
    seeds_b = {t.run_id: (t.map_seed, t.run_seed) for t in b.tasks}
    assert all(seeds_b[t.run_id] == (t.map_seed, t.run_seed) for t in a.tasks)


def test_task_carries_campaign_settings() -> None:
    spec = parse_campaign(demo())
    t = [t for t in plan(spec, "/tmp/c").tasks if t.experiment == "smooth-s4"][-1]
    smooth = next(e for e in spec.experiments if e.name == "smooth-s4")
    last = spec.max_runs_of(smooth) - 1  # the adaptive class plans its max
    assert t.timeout_s == spec.timeout_s and t.goal_tolerance_m == spec.goal_tolerance_m
    assert t.config == {"ground.deformation": 1.5} and t.experiment == "smooth-s4"
    assert t.map_seed == map_seed(spec.seed, "smooth-s4", "deformation=1.5", 1)
    assert t.run_seed == run_seed(spec.seed, "smooth-s4", "deformation=1.5", 1, last)
    assert t.run_id == f"smooth-s4/deformation=1.5/m1/r{last}/reference-v1/nominal"
    assert t.trace_path == f"/tmp/c/traces/smooth-s4/deformation=1.5/m1/r{last}-reference-v1-nominal.mcap"
