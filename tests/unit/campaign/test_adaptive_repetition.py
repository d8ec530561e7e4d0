"""Adaptive repetition in campaigns: the spec form, the plan's streams, and the scheduling rule.

The scheduling is checked as the scheduler runs it (:class:`Repetition`, :meth:`Plan.due`, the
store's records as the state on resume) against a simulated pool of workers that completes runs
in random orders and is killed at random moments: the final set of runs is always the one the
rule gives when the stream is read in run order. The same with real missions, real processes
and SIGKILL is in tests/integration/test_campaign_adaptive.py.
"""

from __future__ import annotations

import hashlib
import random
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.cli_inputs import assert_one_line_error, invoke
from navstress.campaign.plan import Plan, plan
from navstress.campaign.scheduler import Repetition
from navstress.campaign.spec import AdaptiveRuns, parse_campaign, planned_runs
from navstress.errors import SpecError
from navstress.run.record import RunTask
from navstress.sequential import AdaptiveRule, should_continue

RULE = {"min": 3, "max": 12, "threshold": 0.7, "confidence": 0.8}


def _spec(**over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "a", "seed": 5, "world": {"size_m": [20.0, 20.0]},
        "experiments": [{"name": "e", "sweep": {"obstacles.obstruction.tree": {"values": [0, 2]}}},
                        {"name": "f", "runs_per_map": {"adaptive": dict(RULE)}}],
        "maps_per_config": 2, "runs_per_map": 2, "faults": [None, "small-footprint"]}
    d.update(over)
    return d


# ---- the spec ------------------------------------------------------------------------------


def test_adaptive_form_per_campaign_and_per_experiment() -> None:
    spec = parse_campaign(_spec())
    e, f = spec.experiments
    assert spec.rule_of(e) is None and spec.max_runs_of(e) == 2
    assert spec.rule_of(f) == AdaptiveRule(3, 12, 0.7, 0.8) and spec.max_runs_of(f) == 12
    # plan size counts the max: 2 configs x 2 maps x 2 runs x 2 faults + 1 x 2 x 12 x 2
    assert planned_runs(spec) == 16 + 48
    whole = parse_campaign(_spec(runs_per_map={"adaptive": {"max": 9}}, experiments=[{"name": "e"}]))
    assert whole.rule_of(whole.experiments[0]) == AdaptiveRule(3, 9, 0.8, 0.95)
    # the stored text round-trips, and a fixed spec keeps its text (and digest) of before
    again = parse_campaign(yaml.safe_load(spec.canonical_json()))
    assert again.digest() == spec.digest() and isinstance(again.experiments[1].runs_per_map, AdaptiveRuns)
    assert '"runs_per_map"' not in parse_campaign(_spec(experiments=[{"name": "e"}])).canonical_json().split(
        '"faults":[null,"small-footprint"]')[0].split('"experiments"')[1]


def test_indifference_is_part_of_the_rule_and_absent_from_the_text_when_zero() -> None:
    """An indifference zone reaches the rule; a rule without one (or with 0) keeps the stored text
    and digest it had before the key existed, so campaigns made before still resume."""
    zone = parse_campaign(_spec(runs_per_map={"adaptive": {"min": 2, "max": 5, "threshold": 0.5, "confidence": 0.8,
                                                           "indifference": 0.25}}, experiments=[{"name": "e"}]))
    assert zone.rule_of(zone.experiments[0]) == AdaptiveRule(2, 5, 0.5, 0.8, indifference=0.25)
    assert parse_campaign(yaml.safe_load(zone.canonical_json())).digest() == zone.digest()
    plain, zero = (parse_campaign(_spec(experiments=[{"name": "e"}, {"name": "f", "runs_per_map": {"adaptive": r}}]))
                   for r in (dict(RULE), dict(RULE, indifference=0)))
    assert "indifference" not in plain.canonical_json() and plain.digest() == zero.digest()
    assert plain.digest() != parse_campaign(_spec(experiments=[{"name": "e"}, {"name": "f", "runs_per_map": {
        "adaptive": dict(RULE, indifference=0.1)}}])).digest()


def test_plan_size_limit_counts_the_max() -> None:
    big = _spec(experiments=[{"name": "e", "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 99,
                                                                                     "step": 1}}}],
                maps_per_config=100, runs_per_map={"adaptive": {"min": 1, "max": 10}}, faults=[None])
    with pytest.raises(SpecError, match="100,000 planned runs"):  # 100 x 100 x 10: fine at min, not at max
        parse_campaign(big, max_runs=99_999)
    assert planned_runs(parse_campaign(big, max_runs=None)) == 100_000


BAD: list[tuple[Any, str, str]] = [
    ({"adaptive": {"min": 5, "max": 3}}, "runs_per_map.adaptive.max=3", "make max at least min"),
    ({"adaptive": {"confidence": 1.5}}, "runs_per_map.adaptive.confidence=1.5", "strictly between 0 and 1"),
    ({"adaptive": {"confidence": 0}}, "runs_per_map.adaptive.confidence=0", "strictly between 0 and 1"),
    ({"adaptive": {"threshold": 1}}, "runs_per_map.adaptive.threshold=1", "strictly between 0 and 1"),
    ({"adaptive": {"threshold": ".nan"}}, "runs_per_map.adaptive.threshold=", "strictly between 0 and 1"),
    ({"adaptive": {"min": 0}}, "runs_per_map.adaptive.min=0", "an integer in [1, 10000]"),
    ({"adaptive": {"min": 2.5}}, "runs_per_map.adaptive.min=2.5", "an integer in [1, 10000]"),
    ({"adaptive": {"min": True}}, "runs_per_map.adaptive.min=True", "an integer in [1, 10000]"),
    ({"adaptive": {"max": 10_001}}, "runs_per_map.adaptive.max=10001", "to 10000"),
    ({"adaptive": {"mni": 3}}, "runs_per_map.adaptive.mni=3", "one of the keys min, max"),
    ({"adaptive": {"indifference": -0.1}}, "runs_per_map.adaptive.indifference=-0.1", "a number >= 0"),
    ({"adaptive": {"indifference": 0.2}}, "runs_per_map.adaptive.indifference=0.2", "inside the flaky band"),
    ({"adaptive": {"threshold": 0.5, "indifference": "wide"}}, "runs_per_map.adaptive.indifference='wide'",
     "a number >= 0"),
    ({"adaptive": 3}, "runs_per_map.adaptive=3", "a mapping of min, max"),
    ({"adaptiv": {}}, "runs_per_map.adaptiv=", "only the key 'adaptive'"),
    ({"adaptive": {}, "max": 3}, "runs_per_map.max=3", "only the key 'adaptive'"),
    ("five", "runs_per_map='five'", "an integer in [1, 10000], or {adaptive"),
    (0, "runs_per_map=0", "an integer in [1, 10000]"),
    ([3, 25], "runs_per_map=[3, 25]", "an integer in [1, 10000]"),
]


@pytest.mark.parametrize("where", ["campaign", "experiment"])
@pytest.mark.parametrize("value,field,expected", BAD, ids=[b[1] for b in BAD])
def test_bad_runs_per_map_is_one_line_exit_2(tmp_path: Path, value: Any, field: str, expected: str,
                                             where: str) -> None:
    """Through `campaign run`: one line naming the field, exit 2, nothing written."""
    data = _spec(experiments=[{"name": "e"}])
    if isinstance(value, dict) and isinstance(value.get("adaptive"), dict) and value["adaptive"].get("threshold") == ".nan":
        value = {"adaptive": {"threshold": float("nan")}}
    if where == "campaign":
        data["runs_per_map"] = value
    else:
        data["experiments"][0]["runs_per_map"] = value
        field = "experiments[0]." + field
    spec = tmp_path / "s.yaml"
    spec.write_text(yaml.safe_dump(data))
    argv = ["campaign", "run", str(spec), "-q", "-o", str(tmp_path / "out")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith(f"error: {field}") and expected in line, line
    assert not (tmp_path / "out").exists()


# ---- the plan's streams --------------------------------------------------------------------


def test_streams_share_run_seeds_across_navigators_and_faults() -> None:
    spec = parse_campaign(_spec(navigators=[{"name": "reference-v1"}, {"name": "reference-v2"}]))
    p = plan(spec, "/tmp/c")
    tasks = {t.run_id: t for t in p.tasks}
    adaptive = [s for s in p.streams if s.rule is not None]
    assert len(adaptive) == 2 * 2 * 2 and all(len(s.run_ids) == 12 for s in adaptive)  # maps x navs x faults
    ids = [r for s in p.streams for r in s.run_ids]  # the streams partition the tasks
    assert sorted(ids) == sorted(tasks) and len(ids) == len(set(ids))
    for s in p.streams:
        assert [tasks[r].run_index for r in s.run_ids] == list(range(len(s.run_ids)))
        first = tasks[s.run_ids[0]]
        assert all((tasks[r].experiment, tasks[r].config, tasks[r].map_index, tasks[r].navigator, tasks[r].fault)
                   == (first.experiment, first.config, first.map_index, first.navigator, first.fault)
                   for r in s.run_ids)
    by_slot: dict[tuple[str, Any, int, int], set[int]] = {}
    for t in p.tasks:
        by_slot.setdefault((t.experiment, str(t.config), t.map_index, t.run_index), set()).add(t.run_seed)
    assert all(len(v) == 1 for v in by_slot.values())  # paired: one seed per (map, run index)


# ---- the scheduling rule, as the scheduler runs it -----------------------------------------


def _outcome(run_id: str, p_success: float) -> str:
    """A deterministic outcome per run (as a run's seeds make it)."""
    u = int.from_bytes(hashlib.blake2b(run_id.encode(), digest_size=8).digest(), "big") / 2**64
    return "success" if u < p_success else "fail-error"


def _reference(p: Plan, outcome: dict[str, str]) -> set[str]:
    """Each stream read in run order: run n exists iff the rule continued after runs 0..n-1."""
    out: set[str] = set()
    for s in p.streams:
        if s.rule is None:
            out.update(s.run_ids)
            continue
        succ = 0
        for n, r in enumerate(s.run_ids):
            if n >= s.rule.min_runs and not should_continue(succ, n, s.rule):
                break
            out.add(r)
            succ += outcome[r] == "success"
    return out


def _simulate(p: Plan, outcome: dict[str, str], rng: random.Random, workers: int, kill_every: int) -> dict[str, str]:
    """Sessions as :func:`navstress.campaign.scheduler.resume` runs them (the store's records are the
    state; a session may be killed after ``kill_every`` completions, its in-flight runs lost)."""
    store: dict[str, str] = {}
    for _ in range(10_000):
        due = p.due(store)
        queue: list[RunTask] = [t for t in p.tasks if t.run_id in due and t.run_id not in store]
        if not queue:
            return store
        rep = Repetition(p, store)
        inflight: list[RunTask] = []
        ended = 0
        while queue or inflight:
            while len(inflight) < workers and queue:
                inflight.append(queue.pop(0))
            t = inflight.pop(rng.randrange(len(inflight)))  # completions in any order
            assert t.run_id not in store, "a run handed out twice"
            store[t.run_id] = outcome[t.run_id]

            class _R:
                run_id = t.run_id
                outcome = store[t.run_id]
            queue.extend(rep.recorded(_R()))  # type: ignore[arg-type]
            assert rep.at_most == p.at_most(store)
            ended += 1
            if kill_every and ended >= kill_every:
                break  # SIGKILL: in-flight runs are lost, the next session resumes from the store
    raise AssertionError("did not finish")


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), workers=st.integers(1, 6), kill_every=st.sampled_from([0, 0, 1, 3, 7]),
       p_success=st.sampled_from([0.0, 0.3, 0.6, 0.9, 1.0]),
       rule=st.tuples(st.integers(1, 5), st.integers(0, 12), st.sampled_from([0.5, 0.8]),
                      st.sampled_from([0.7, 0.9])))
def test_final_set_is_the_rule_read_in_run_order(seed: int, workers: int, kill_every: int, p_success: float,
                                                 rule: tuple[int, int, float, float]) -> None:
    lo, extra, threshold, confidence = rule
    spec = parse_campaign(_spec(experiments=[
        {"name": "fixed", "faults": [None]},
        {"name": "e", "sweep": {"obstacles.obstruction.tree": {"values": [0, 2]}},
         "runs_per_map": {"adaptive": {"min": lo, "max": lo + extra, "threshold": threshold,
                                       "confidence": confidence}}}]))
    p = plan(spec, "/tmp/c")
    outcome = {t.run_id: _outcome(f"{seed}:{t.run_id}", p_success) for t in p.tasks}
    final = _simulate(p, outcome, random.Random(seed), workers, kill_every)
    expected = _reference(p, outcome)
    assert set(final) == expected
    assert p.at_most(final) == len(final) and p.due(final) == expected
