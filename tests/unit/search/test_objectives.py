"""The search's objectives over families of run-record sets (hypothesis): fitness in [0, 1], its
interval around the estimate, monotone in failures, invariant to the records' order; pairing counts
only runs with a partner of the same run seed and says how many it left out; bad inputs are one
SpecError naming the field."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.campaign.plan import plan
from navstress.campaign.scheduler import Recorder
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.campaign.work import attempt_world
from navstress.errors import SpecError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord
from navstress.search.objectives import (FAILURE_CLASSES, OBJECTIVES, boundary, by_world, evaluate, failure,
                                         confirm, fault_names, fault_revealing, illumination, kills,
                                         mutation_score, pair_key, pairs, reveals, ungenerated, world_feasible,
                                         world_key)
from navstress.world.world import Mission, World
from tests.support.world_fixtures import small_world

OUTCOMES = [o.value for o in Outcome]
FAULT = "small-footprint"


def rec(run: int, outcome: str, fault: str | None = None, *, seed: int | None = None, navigator: str = "nav",
        experiment: str = "g0000", key: str = "w0") -> RunRecord:
    """A record as the campaign writes it (run id in the plan's format; the run seed shared by every
    fault of a run index unless ``seed`` says otherwise)."""
    return RunRecord(f"{experiment}/{key}/m0/r{run}/{navigator}/{fault or 'nominal'}", experiment, {}, 0, run, 11,
                     1000 + run if seed is None else seed, navigator, fault, outcome, "", 1.0, 0.1, 0.0, 1.0, 0.0,
                     int(outcome == "fail-collision"), None, [], None)


outcomes = st.lists(st.sampled_from(OUTCOMES), max_size=30)
classes = st.sampled_from(sorted(FAILURE_CLASSES))


def nominal_runs(outs: list[str]) -> list[RunRecord]:
    return [rec(i, o) for i, o in enumerate(outs)]


@settings(max_examples=60, deadline=None)
@given(outs=outcomes, cls=classes, data=st.data())
def test_failure_fitness_bounds_interval_and_order(outs: list[str], cls: str, data: st.DataObject) -> None:
    recs = nominal_runs(outs)
    e = failure(recs, failure_class=cls)
    want = sum(o in FAILURE_CLASSES[cls] for o in outs)
    assert (e.events, e.trials, e.ignored) == (want, len(outs), 0)
    assert 0.0 <= e.fitness <= 1.0
    assert e.fitness == (want / len(outs) if outs else 0.0)
    lo, hi = e.interval
    assert 0.0 <= lo <= hi <= 1.0
    if outs:
        assert lo - 1e-9 <= e.fitness <= hi + 1e-9
    else:
        assert (lo, hi) == (0.0, 1.0) and e.estimate is None
    shuffled = data.draw(st.permutations(recs))
    assert failure(shuffled, failure_class=cls) == e


@settings(max_examples=60, deadline=None)
@given(outs=outcomes, cls=classes, extra=st.sampled_from(OUTCOMES))
def test_one_more_failure_never_lowers_the_failure_fitness(outs: list[str], cls: str, extra: str) -> None:
    """Adding a failed run never lowers it, a successful one never raises it; turning any run into
    a failure never lowers it (nor the interval's ends)."""
    recs = nominal_runs(outs)
    e = failure(recs, failure_class=cls)
    more = failure(recs + [rec(len(outs), extra)], failure_class=cls)
    if extra in FAILURE_CLASSES[cls]:
        assert more.fitness >= e.fitness
    if extra == "success" and outs:
        assert more.fitness <= e.fitness
    for i, o in enumerate(outs):
        if o not in FAILURE_CLASSES[cls]:
            worse = recs[:i] + [rec(i, sorted(FAILURE_CLASSES[cls])[0])] + recs[i + 1:]
            w = failure(worse, failure_class=cls)
            assert w.fitness >= e.fitness and w.interval[0] >= e.interval[0] - 1e-12
            assert w.interval[1] >= e.interval[1] - 1e-12


def test_failure_reads_one_stack_and_counts_the_rest_as_ignored() -> None:
    recs = [rec(0, "success"), rec(1, "fail-collision"), rec(0, "fail-error", FAULT), rec(1, "fail-error", FAULT)]
    assert (failure(recs).events, failure(recs).ignored) == (1, 2)
    assert failure(recs, fault=FAULT).events == 2
    assert failure(recs, fault="nominal") == failure(recs)
    assert failure(recs, failure_class="error").events == 0
    assert failure(recs, fault=FAULT, failure_class="error").fitness == 1.0
    other = recs + [rec(2, "fail-timeout", navigator="other")]
    with pytest.raises(SpecError, match="navigator=None"):
        failure(other)
    assert failure(other, navigator="nav") == replace(failure(recs), ignored=3)
    with pytest.raises(SpecError, match="records="):
        failure(recs + [recs[0]])
    with pytest.raises(SpecError, match="failure_class='crash'"):
        failure(recs, failure_class="crash")
    with pytest.raises(SpecError, match="confidence=1.5"):
        failure(recs, confidence=1.5)


@settings(max_examples=60, deadline=None)
@given(outs=outcomes, target=st.floats(0.05, 0.95), data=st.data())
def test_boundary_bounds_peak_and_order(outs: list[str], target: float, data: st.DataObject) -> None:
    recs = nominal_runs(outs)
    e = boundary(recs, target=target)
    assert 0.0 <= e.fitness <= 1.0
    s = outs.count("success")
    assert (e.events, e.trials) == (s, len(outs))
    if outs:
        p = s / len(outs)
        assert e.fitness == pytest.approx(1 - abs(p - target) / max(target, 1 - target))
        # closer to the target is never worse
        for q in range(len(outs) + 1):
            alt = boundary(nominal_runs(["success"] * q + ["fail-timeout"] * (len(outs) - q)), target=target)
            if abs(q / len(outs) - target) <= abs(p - target):
                assert alt.fitness >= e.fitness - 1e-12
    else:
        assert e.fitness == 0.0
    assert boundary(data.draw(st.permutations(recs)), target=target) == e


def test_boundary_at_the_target_and_the_ends() -> None:
    half = nominal_runs(["success", "fail-collision"] * 5)
    assert boundary(half).fitness == 1.0
    assert boundary(nominal_runs(["success"] * 6)).fitness == 0.0
    assert boundary(nominal_runs(["fail-error"] * 6)).fitness == 0.0
    assert boundary(nominal_runs(["success"] * 3 + ["fail-error"]), target=0.75).fitness == 1.0
    for bad in (0.0, 1.0, -1.0, float("nan")):
        with pytest.raises(SpecError, match="objective.target"):
            boundary(half, target=bad)


# ---------------------------------------------------------------- pairs

pair_outcomes = st.lists(st.tuples(st.sampled_from(OUTCOMES + [None]), st.sampled_from(OUTCOMES + [None])),
                         max_size=25)


def paired_records(rows: list[tuple[str | None, str | None]], *, reseed: frozenset[int] = frozenset(),
                   fault: str = FAULT) -> list[RunRecord]:
    """Run ``i``'s nominal and faulty outcomes (None: that run is missing); runs in ``reseed`` ran
    the faulty stack with another seed (not a pair)."""
    out = []
    for i, (n, f) in enumerate(rows):
        if n is not None:
            out.append(rec(i, n))
        if f is not None:
            out.append(rec(i, f, fault, seed=7 if i in reseed else None))
    return out


@settings(max_examples=80, deadline=None)
@given(rows=pair_outcomes, cls=classes, data=st.data())
def test_fault_revealing_counts_only_pairs(rows: list[tuple[str | None, str | None]], cls: str,
                                            data: st.DataObject) -> None:
    """Revealing pairs: faulty fails (of the class) and nominal succeeds; a run without its partner
    (missing, or run with another seed) is left out and counted in ``unpaired``."""
    reseed = frozenset(data.draw(st.sets(st.integers(0, max(len(rows) - 1, 0)))))
    recs = paired_records(rows, reseed=reseed)
    e = fault_revealing(recs, FAULT, failure_class=cls)
    full = [(n, f) for i, (n, f) in enumerate(rows) if n is not None and f is not None and i not in reseed]
    want = sum(n == "success" and f in FAILURE_CLASSES[cls] for n, f in full)
    assert (e.events, e.trials) == (want, len(full))
    assert e.unpaired == len(recs) - 2 * len(full)
    assert 0.0 <= e.fitness <= 1.0 and e.fitness == (want / len(full) if full else 0.0)
    lo, hi = e.interval
    assert lo - 1e-9 <= e.fitness <= hi + 1e-9 or not full
    assert fault_revealing(data.draw(st.permutations(recs)), FAULT, failure_class=cls) == e
    # adding unpaired runs (a lone faulty failure, a lone nominal success) changes nothing but the count
    lone = recs + [rec(100, "fail-collision", FAULT), rec(101, "success")]
    e2 = fault_revealing(lone, FAULT, failure_class=cls)
    assert (e2.fitness, e2.events, e2.trials, e2.unpaired) == (e.fitness, e.events, e.trials, e.unpaired + 2)
    # one more revealing pair never lowers the fitness
    more = recs + [rec(200, "success"), rec(200, sorted(FAILURE_CLASSES[cls])[0], FAULT)]
    assert fault_revealing(more, FAULT, failure_class=cls).fitness >= e.fitness


def test_pairs_are_per_experiment_and_world_and_ignore_other_faults() -> None:
    recs = [rec(0, "success", experiment="g0000"), rec(0, "fail-collision", FAULT, experiment="g0000"),
            rec(0, "success", experiment="g0001"), rec(0, "success", FAULT, experiment="g0001"),
            rec(0, "success", key="w1"), rec(0, "fail-error", "dropped-scans", key="w1")]
    p = pairs(recs, FAULT)
    assert len(p.pairs) == 2 and p.unpaired == 1 and p.ignored == 1
    assert {a.experiment for a, _ in p.pairs} == {"g0000", "g0001"}
    assert all(pair_key(a) == pair_key(b) and a.run_seed == b.run_seed for a, b in p.pairs)
    assert reveals(*p.pairs[0]) and not reveals(*p.pairs[1])
    with pytest.raises(SpecError, match="fault='nominal'"):
        pairs(recs, "nominal")


def test_records_of_another_origin_pair_on_their_fields() -> None:
    """Records whose run id is not the plan's pair on (navigator, experiment, config, map, seed, run)."""
    def r(i: int, outcome: str, fault: str | None) -> RunRecord:
        return RunRecord(f"run-{i}-{fault}", "batch", {"k": 1}, 0, i, 5, 77 + i, "nav", fault, outcome, "", 1.0,
                         0.1, 0.0, 1.0, 0.0, 0, None, [], None)
    e = fault_revealing([r(0, "success", None), r(0, "fail-timeout", FAULT), r(1, "success", None)], FAULT)
    assert (e.events, e.trials, e.unpaired) == (1, 1, 1)


def test_evaluate_dispatches_every_objective_and_refuses_unknown_ones() -> None:
    recs = paired_records([("success", "fail-collision"), ("fail-error", "fail-error"), ("success", "success")])
    assert evaluate("failure", recs) == failure(recs)
    assert evaluate("fault-revealing", recs, fault=FAULT) == fault_revealing(recs, FAULT)
    assert evaluate("boundary", recs, target=0.3) == boundary(recs, target=0.3)
    il = evaluate("illumination", recs, descriptors=(2.0, 0.5))
    assert il.descriptors == (2.0, 0.5) and il.fitness == failure(recs).fitness
    assert il == illumination(recs, [2.0, 0.5])
    assert {o for o in OBJECTIVES} == {"failure", "fault-revealing", "boundary", "illumination"}
    with pytest.raises(SpecError, match="objective='falure'.*did you mean failure"):
        evaluate("falure", recs)
    with pytest.raises(SpecError, match="objective.fault=None"):
        evaluate("fault-revealing", recs)
    with pytest.raises(SpecError, match="descriptors="):
        illumination(recs, [math.nan, 1.0])
    assert set(evaluate("failure", recs).to_json()) >= {"fitness", "events", "trials", "interval", "unpaired"}


def test_kills_and_mutation_score() -> None:
    """A world kills a fault when its paired runs confirm it revealing; a suite's score is the share
    of the catalogue's faults that one of its worlds kills."""
    assert len(fault_names()) == 6 and FAULT in fault_names()
    strong = paired_records([("success", "fail-collision")] * 25)
    strong += [rec(i, "success", "dropped-scans") for i in range(25)]
    k = kills(strong)
    assert set(k) == set(fault_names())
    assert k[FAULT].killed and not k["dropped-scans"].killed and not k["odometry-scale"].killed
    assert k["odometry-scale"].confirmation.trials == 0
    shared = paired_records([("fail-error", "fail-error"), ("success", "fail-error"), ("fail-error", "success")] * 10)
    assert not kills(shared, [FAULT])[FAULT].killed  # both stacks fail alike: not the fault's doing
    few = paired_records([("success", "fail-collision")] * 2)
    assert not kills(few, [FAULT])[FAULT].killed  # too few pairs to confirm
    ms = mutation_score({"w0": k, "w1": kills(few)})
    assert ms.killed == (FAULT,) and ms.score == pytest.approx(1 / 6) and ms.by == {FAULT: ("w0",)}
    assert mutation_score({}).score == 0.0 and mutation_score({}, faults=[]).score == 0.0
    assert ms.to_json()["killed_by"] == {FAULT: ["w0"]}


def test_records_grouped_by_world() -> None:
    recs = [rec(1, "success", key="w1"), rec(0, "success", FAULT, key="w1"), rec(0, "fail-error", key="w1"),
            rec(0, "success", key="w0", experiment="g0001"), rec(0, "success", key="a/b")]
    g = by_world(recs)
    assert list(g) == [("g0000", "a/b", 0), ("g0000", "w1", 0), ("g0001", "w0", 0)]
    assert [(r.run_index, r.fault) for r in g[("g0000", "w1", 0)]] == [(0, None), (0, FAULT), (1, None)]
    assert by_world(list(reversed(recs))) == g
    odd = RunRecord("x", "batch", {"k": 2}, 0, 0, 1, 1, "nav", None, "success", "", 1.0, 0.1, 0.0, 1.0, 0.0, 0,
                    None, [], None)
    assert world_key(odd) == '{"k": 2}'


def test_runs_of_a_world_that_could_not_be_generated_count_for_no_objective(tmp_path: Path) -> None:
    """A world spec the generator cannot realise is recorded by the campaign as Fail-Other runs
    (the real path: plan, attempt_world, Recorder, Store); they are about the spec, not the stack,
    so a search for failures must not climb towards them: no objective counts them."""
    d = {"name": "s", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
         "experiments": [{"name": "g0000", "sweep": {"obstacles.obstruction.building": {"values": [90]}}}],
         "maps_per_config": 1, "runs_per_map": 2, "faults": [None, FAULT], "timeout_s": 10.0}
    spec = parse_campaign(d)
    with Store.create(tmp_path / "c", spec, yaml.safe_dump(d)) as store:
        p = plan(spec, tmp_path / "c")
        (job,) = p.maps
        reason = attempt_world(job)
        assert isinstance(reason, str) and "obstruction" in reason
        Recorder(store).world_failed(list(p.tasks), reason)
        recs = store.records()
    assert len(recs) == 4 and all(r.outcome == "fail-other" and ungenerated(r) for r in recs)
    for e in (failure(recs), failure(recs, fault=FAULT), boundary(recs), fault_revealing(recs, FAULT),
              evaluate("illumination", recs, descriptors=(1.0, 1.0))):
        assert (e.fitness, e.trials, e.events) == (0.0, 0, 0) and e.ignored >= 2 and e.unpaired == 0
    assert not confirm(recs, "failing").confirmed and confirm(recs, "failing").trials == 0
    # a Fail-Other of the stack itself (its process died) is still a failure
    own = replace(recs[0], reason="run killed its worker process (signal SIGSEGV), in 3 of 3 attempts")
    assert not ungenerated(own) and failure([own]).fitness == 1.0


def test_an_impossible_world_has_no_failure_fitness() -> None:
    """A world with no traversable path fails every stack: its failures teach nothing, so the
    failure and illumination fitness are 0 there (the counts kept); feasibility is the world's own
    descriptor."""
    w = small_world(1, bumpy=False)
    walled = World(w.spec, 1, w.terrain, w.obstacles, Mission((2.0, 2.0, 0.0), (12.0, 6.0), 1.0))
    assert world_feasible(walled) is False and world_feasible(w) is True
    recs = nominal_runs(["fail-timeout"] * 4)
    e = failure(recs, feasible=world_feasible(walled))
    assert (e.fitness, e.events, e.trials, e.estimate) == (0.0, 4, 4, 1.0)
    assert evaluate("illumination", recs, descriptors=(0.0, 0.0), feasible=False).fitness == 0.0
    assert evaluate("failure", recs, feasible=True).fitness == 1.0 == failure(recs).fitness
