"""Maps the world generator refused (``navstress.run.record.ungenerated``) are counted apart from the
navigation in every consumer of run records: analyze (text and JSON), the report, verdicts and their
export, fault power, compare and the gate.

The refusals are real: the reason is what ``campaign.work.attempt_world`` returns for a spec whose
building obstruction cannot be reached (a real GenerationError), recorded by the scheduler's own
``Recorder.world_failed`` (or, without a store, by the ``failure_record`` it uses), and one campaign
is run end to end (``navstress campaign run``) with every map refused. Families of mixes of refused
and generated maps (hypothesis) check that every figure equals the one computed without the refused
maps' records."""

from __future__ import annotations

import csv
import dataclasses
import json
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import pytest
import yaml
from tests.support.analysis_synth import spec_dict
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_analyze_report import _Cells

from tests.support import junit_schemas
from tests.support.cli_inputs import assert_one_line_error, invoke

from navstress.analysis.analyze import analyze
from navstress.analysis.compare import Arm, compare
from navstress.analysis.difficulty import NO_DATA, NO_MAPS, assign_levels
from navstress.analysis.fault_power import FaultPower, fault_power
from navstress.analysis.gate import GateRule, gate, junit_xml, lower_bound
from navstress.analysis.report import build_report
from navstress.analysis.stats import OUTCOMES, ConfigStats, Refused, config_key, config_stats, split_refused
from navstress.analysis.verdicts import CONFIGURATION_COLUMNS, read_verdicts, verdicts
from navstress.campaign.plan import MapJob, config_key_of, plan
from navstress.campaign.scheduler import Recorder
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.campaign.work import attempt_world
from navstress.errors import StoreError
from navstress.run.batch import failure_record
from navstress.run.record import GENERATION_FAILED, RunRecord, RunTask, ungenerated

NAV = "reference-v1"
FAULT = "small-footprint"
BLOCKED = {"size_m": [20.0, 20.0], "cell_m": 0.5, "obstacles": {"obstruction": {"building": 70}}}


@lru_cache(maxsize=1)
def real_reason() -> str:
    """What the campaign's worker says of a world whose building obstruction cannot be reached: a
    real GenerationError of the world generator, as ``attempt_world`` returns it."""
    with tempfile.TemporaryDirectory() as d:
        why = attempt_world(MapJob("blocked/b/m0", "blocked", "b", 0, 11, BLOCKED, str(Path(d) / "w")))
    assert isinstance(why, str) and "obstruction of 'building'" in why, why
    return why


def refused_record(t: RunTask) -> RunRecord:
    """The record the scheduler writes for each run of a map whose spec cannot be generated."""
    return failure_record(t, f"{GENERATION_FAILED}: {real_reason()}")


def nav_record(t: RunTask, outcome: str, *, duration: float = 10.0, collisions: int = 0,
               reason: str = "synthetic") -> RunRecord:
    """A navigation result for ``t`` (its own ids and seeds)."""
    ok = outcome == "success"
    return RunRecord(run_id=t.run_id, experiment=t.experiment, config=dict(t.config), map_index=t.map_index,
                     run_index=t.run_index, map_seed=t.map_seed, run_seed=t.run_seed, navigator=t.navigator,
                     fault=t.fault, outcome=outcome, reason=reason, duration_s=duration, wall_s=1.0,
                     goal_distance_m=1.0 if ok else 6.0, path_length_m=10.0, tortuousness=0.05 + duration / 1000,
                     collisions=collisions, first_collision_s=1.0 if collisions else None, errors=[], trace=None)


def key_of(t: RunTask) -> str:
    return config_key_of(t.run_id, t.experiment, t.config)


def fill(root: Path, spec: dict[str, Any], refused: set[tuple[str, int]],
         outcome: Any = lambda t: "success") -> Path:
    """A store of ``spec`` at ``root``: every run of the maps ``refused`` ((config, map)) recorded by
    the scheduler's Recorder as the generator's refusal, every other run recorded with
    ``outcome(task)`` (None: not recorded)."""
    with Store.create(root, parse_campaign(spec), yaml.safe_dump(spec)) as s:
        tasks = list(s.plan().tasks)
        gone = [t for t in tasks if (key_of(t), t.map_index) in refused]
        by_map: dict[tuple[str, int], list[RunTask]] = {}
        for t in gone:
            by_map.setdefault((key_of(t), t.map_index), []).append(t)
        rec = Recorder(s)
        for ts in by_map.values():
            assert rec.world_failed(ts, real_reason()) == []  # recorded, never retried
        for t in tasks:
            if t not in gone and (o := outcome(t)) is not None:
                s.add(nav_record(t, o) if isinstance(o, str) else nav_record(t, o[0], collisions=o[1]))
    return root


def flat(text: str) -> str:
    """``text`` with every run of white space one space (a terminal table wraps its lines)."""
    return " ".join(text.split())


def small(**kw: Any) -> dict[str, Any]:
    return spec_dict(**{"trees": [0, 4, 8], "defs": [], "maps": 2, "runs": 2, "faults": [None, FAULT], **kw})


# ---- the predicate ---------------------------------------------------------------------------


@pytest.mark.parametrize("outcome", OUTCOMES)
@pytest.mark.parametrize("reason,expected", [
    (f"{GENERATION_FAILED}: obstruction of 'building' reached 40.50% of the map", True),
    (f"{GENERATION_FAILED}: start area cannot be made drivable", True),
    (GENERATION_FAILED, True),
    ("robot tipped over at t=0.4 s", False),
    (f"navigator said: {GENERATION_FAILED}", False),
    ("World generation failed: capitalised", False),
    ("", False),
])
def test_ungenerated_is_fail_other_with_the_generation_reason(outcome: str, reason: str, expected: bool) -> None:
    t = plan(parse_campaign(small()), "/tmp/x").tasks[0]
    r = dataclasses.replace(nav_record(t, outcome), reason=reason)
    assert ungenerated(r) is (expected and outcome == "fail-other")
    from navstress.search.objectives import ungenerated as search_ungenerated
    assert search_ungenerated is ungenerated  # one predicate, the search's too


# ---- a real refusal, end to end --------------------------------------------------------------


def test_a_real_refusal_is_counted_apart_by_analyze_and_fails_the_gate(tmp_path: Path) -> None:
    """A campaign whose every map the world generator refuses, run by ``navstress campaign run``."""
    spec = {"name": "blocked", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
            "experiments": [{"name": "blocked", "sweep": {"obstacles.obstruction.building": {"values": [60, 70]}}}],
            "maps_per_config": 2, "runs_per_map": 2, "timeout_s": 30.0}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(spec), encoding="utf-8")
    d = tmp_path / "c"
    code, out, err = invoke(["campaign", "run", str(tmp_path / "s.yaml"), "-o", str(d), "--workers", "1"])
    assert code == 0, err
    with Store.open(d) as s:
        recs = s.records()
    assert len(recs) == 8 and all(ungenerated(r) for r in recs)
    assert {r.reason.split(":")[0] for r in recs} == {GENERATION_FAILED}
    code, out, err = invoke(["analyze", str(d), "--json", str(tmp_path / "a.json")])
    assert code == 0, err
    out = flat(out)
    assert "8 runs on 4 maps the world generator refused, left out of every statistic" in out
    assert "0 fail-other" in out and "no generated maps" in out
    assert "refused maps in blocked building=60: 2 of 2" in out and "obstruction of 'building'" in out
    a = json.loads((tmp_path / "a.json").read_text())
    assert a["outcomes"]["fail-other"] == 0 and (a["refused"]["runs"], a["refused"]["maps"]) == (8, 4)
    for c in a["configurations"]:
        assert (c["runs"], c["success_rate"], c["level"], c["refused"]["maps"], c["refused"]["runs"]) == \
            (0, None, NO_MAPS, 2, 4)
        assert c["refused"]["first_reason"].startswith(f"{GENERATION_FAILED}: obstruction of 'building'")
    assert a["verdicts"]["configurations"] == [] and len(a["verdicts"]["refused_configurations"]) == 2
    assert a["missing"] == []  # every planned run is recorded
    # the gate measured nothing: it fails, even at a bar of 0, and says why
    code, out, err = invoke(["gate", str(d), "--min-success", "0", "--junit", str(tmp_path / "j.xml")])
    assert code == 1, out + err
    assert "blocked/building=60 reference-v1: no generated map: 2 maps refused by the world generator" in out
    assert "gate FAILED: 2 of 2 configurations" in out and "4 maps refused by the world generator" in out
    xml = (tmp_path / "j.xml").read_text()
    junit_schemas.assert_valid(xml)
    assert xml.count("<failure ") == 4 and "the world generator refused this map: world generation failed" in xml


# ---- analyze, the report, verdicts and their export on a mixed store -------------------------


def _mixed(root: Path) -> Path:
    """tree=0: 2 maps, all successes; tree=4: map 0 refused, map 1 one success and one Fail-Other of
    the navigator's own; tree=8: both maps refused. Faulty runs collide wherever they ran."""
    def outcome(t: RunTask) -> Any:
        if t.fault:
            return ("fail-collision", 1)
        if key_of(t) == "tree=4":
            return "success" if t.run_index == 0 else "fail-other"
        return "success"
    return fill(root, small(), {("tree=4", 0), ("tree=8", 0), ("tree=8", 1)}, outcome)


def test_analyze_counts_refused_maps_apart(tmp_path: Path) -> None:
    a = analyze(_mixed(tmp_path / "c"))
    nom = {s.config_key: s for s in a.nominal}
    assert (nom["tree=4"].runs, nom["tree=4"].successes, nom["tree=4"].success_rate) == (2, 1, 0.5)
    assert nom["tree=4"].outcomes["fail-other"] == 1  # the navigator's own, not the refusal
    assert (nom["tree=4"].refused.maps, nom["tree=4"].refused.runs) == ((0,), 2)
    assert nom["tree=4"].maps == (1,)
    assert (nom["tree=8"].runs, nom["tree=8"].refused.maps, nom["tree=8"].refused.runs) == (0, (0, 1), 4)
    assert a.level("trees", "tree=8") == NO_MAPS and a.level("trees", "tree=0") != NO_MAPS
    assert not any(r.level == NO_MAPS for r in a.ranges)
    assert a.outcome_counts["fail-other"] == 1 and a.refused_runs == 12 and a.refused_maps == 3
    assert a.missing == [] and (a.done, a.planned) == (24, 24)
    (p,) = [p for p in a.power if p.config_key == "tree=4"]
    assert (p.runs, p.collisions, p.nominal_runs, p.refused) == (2, 2, 2, 2)
    assert [p.config_key for p in a.power] == ["tree=0", "tree=4"]  # tree=8's faulty runs never ran
    cfg = {(c.config_key, c.fault): c for c in a.verdicts.configurations}
    assert (cfg["tree=4", "nominal"].worlds, cfg["tree=4", "nominal"].refused_worlds) == (1, 1)
    assert cfg["tree=4", "nominal"].refused_reason == nom["tree=4"].refused.reason
    assert ("tree=8", "nominal") not in cfg
    assert {(g.config_key, g.fault, g.worlds, g.runs) for g in a.verdicts.refused} == {
        ("tree=8", "nominal", 2, 4), ("tree=8", FAULT, 2, 4)}
    assert {(w.config_key, w.map_index) for w in a.verdicts.worlds} == {
        ("tree=0", 0), ("tree=0", 1), ("tree=4", 1)}
    j = json.loads(json.dumps(a.to_json()))
    assert [(c["config"], c["maps"], c["map_indices"], c["runs"], c["maps_planned"]) for c in j["refused"]["configurations"]] \
        == [("tree=4", 1, [0], 4, 2), ("tree=8", 2, [0, 1], 8, 2)]


def test_analyze_text_and_json_on_stdout(tmp_path: Path) -> None:
    d = _mixed(tmp_path / "c")
    code, out, err = invoke(["analyze", str(d)])
    assert code == 0, err
    out = flat(out)
    assert "12 runs on 3 maps the world generator refused, left out of every statistic" in out
    assert "refused maps in trees tree=4: 1 of 2 (runs left out: 4); first: world generation failed: " in out
    assert "no generated maps" in out
    code, js, err = invoke(["analyze", str(d), "--json", "-"])
    assert code == 0, err
    by = {c["config"]: c for c in json.loads(js)["configurations"] if c["fault"] == "nominal"}
    assert (by["tree=4"]["runs"], by["tree=4"]["success_rate"], by["tree=4"]["refused"]["maps"]) == (2, 0.5, 1)
    assert by["tree=8"]["level"] == NO_MAPS and by["tree=0"]["refused"]["runs"] == 0


def test_report_shows_refused_maps_apart(tmp_path: Path) -> None:
    d = _mixed(tmp_path / "c")
    text = build_report(d, tmp_path / "r.html").read_text()
    p = _Cells()
    p.feed(text)
    assert p.ids["outcome-fail-other"] == "1" and p.ids["refused-runs"] == "12" and p.ids["refused-maps"] == "3"
    rows = {(r["data-config"], r["data-fault"]): r for r in p.rows if "f:success-rate" in r}
    assert rows["tree=4", "nominal"]["f:success-rate"] == "0.5" and rows["tree=4", "nominal"]["f:runs"] == "2"
    assert rows["tree=4", "nominal"]["f:refused-maps"] == "1" and rows["tree=4", "nominal"]["f:n-fail-other"] == "1"
    assert rows["tree=8", "nominal"]["f:level"] == NO_MAPS and rows["tree=8", "nominal"]["f:refused-maps"] == "2"
    assert rows["tree=8", "nominal"]["f:success-rate"] == ""
    vrows = {(r["data-config"], r["data-fault"]): r for r in p.rows if "f:refused_worlds" in r}
    assert vrows["tree=4", "nominal"]["f:refused_worlds"] == "1" and ("tree=8", "nominal") not in vrows
    assert 'id="verdicts-refused"' in text and 'data-refused-map="0"' in text
    assert "map m0: refused by the world generator, its runs never ran: world generation failed: " in text
    # the runs tables keep every record as it was recorded
    assert text.count('data-outcome="fail-other"') == 1 + 12


def test_the_configurations_export_counts_refused_worlds(tmp_path: Path) -> None:
    d = _mixed(tmp_path / "c")
    code, out, err = invoke(["campaign", "export", str(d), "--table", "configurations", "-f", "csv", "-o",
                             str(tmp_path / "c.csv")])
    assert code == 0, err
    rows = read_verdicts(tmp_path / "c.csv", "configurations")
    assert all(list(r) == list(CONFIGURATION_COLUMNS) for r in rows)
    by = {(r["config"], r["fault"]): r for r in rows}
    assert (by["tree=4", "nominal"]["runs"], by["tree=4", "nominal"]["refused_worlds"]) == (2, 1)
    assert (by["tree=0", "nominal"]["refused_worlds"]) == 0 and ("tree=8", "nominal") not in by
    code, out, err = invoke(["campaign", "export", str(d), "--table", "runs", "-f", "csv", "-o",
                             str(tmp_path / "r.csv")])
    assert code == 0, err
    with open(tmp_path / "r.csv", newline="", encoding="utf-8") as f:
        runs = list(csv.DictReader(f))
    assert len(runs) == 24  # the raw records, unchanged
    assert sum(r["outcome"] == "fail-other" and r["reason"].startswith(GENERATION_FAILED) for r in runs) == 12


# ---- the gate --------------------------------------------------------------------------------


def test_gate_judges_the_generated_maps_and_lists_the_refused_ones(tmp_path: Path) -> None:
    """tree=0: 12 successes on maps 0-2 and map 3 refused: judged on its 12 runs it passes a bar
    that 12 of 16 would miss; tree=4: every map refused: it fails, whatever the bar."""
    spec = small(trees=[0, 4], maps=4, runs=4, faults=[None])
    d = fill(tmp_path / "c", spec, {("tree=0", 3)} | {("tree=4", m) for m in range(4)})
    rule = GateRule(0.75)
    res = gate(d, rule)
    by = {c.config_key: c for c in res.configs}
    t0, t4 = by["tree=0"], by["tree=4"]
    assert (t0.runs, t0.successes, t0.refused_maps, t0.refused_runs) == (12, 12, (3,), 4)
    assert t0.lower == pytest.approx(lower_bound(12, 12)) and t0.passed and lower_bound(12, 16) < 0.75
    assert t0.line(rule).startswith("trees/tree=0 reference-v1: success 12/12 = 100%, lower 95% bound ")
    assert "; left out: 1 map refused by the world generator (first: world generation failed: " in t0.line(rule)
    assert [w.map_index for w in t0.worlds] == [0, 1, 2] and [w.map_index for w in t0.refused_worlds] == [3]
    assert t4.no_generated_map and not t4.passed and t4.runs == 0
    assert not gate(d, GateRule(0.0)).passed  # a bar of 0 does not pass what was never run
    assert [c.config_key for c in gate(d, GateRule(0.0)).failing] == ["tree=4"]
    assert "5 maps refused by the world generator, left out (1 configuration(s) without a generated map)" \
        in res.summary()
    xml = junit_xml(res)
    junit_schemas.assert_valid(xml)
    assert "trees/tree=0/m3/reference-v1/nominal: refused by the world generator, left out of the gate" in xml
    assert xml.count("<failure ") == 4  # tree=4's four refused worlds
    j = res.to_json()
    c0 = next(c for c in j["configurations"] if c["config"] == "tree=0")
    assert (c0["refused_maps"], c0["refused_runs"], c0["runs"], c0["passed"]) == (1, 4, 12, True)
    code, out, err = invoke(["gate", str(d), "--min-success", "0.75", "--json"])
    assert code == 1 and json.loads(out)["passed"] is False, err


# ---- compare ---------------------------------------------------------------------------------


def test_compare_leaves_out_pairs_on_refused_maps_and_counts_them(tmp_path: Path) -> None:
    d = fill(tmp_path / "c", small(), {("tree=4", 0)},
             lambda t: ("fail-collision", 1) if t.fault and key_of(t) == "tree=8" else "success")
    cmp = compare(d, Arm(NAV), Arm(NAV, FAULT))
    assert cmp.overall.pairs == 10 and cmp.refused_pairs == 2 and (cmp.unpaired_a, cmp.unpaired_b) == (0, 0)
    assert {c.config_key: c.pairs for c in cmp.configs} == {"tree=0": 4, "tree=4": 2, "tree=8": 4}
    assert cmp.overall.rate_a == 1.0 and cmp.overall.rate_b == pytest.approx(6 / 10)
    assert any(n.startswith("left out, on maps the world generator refused: 2 pairs (first: world generation "
                            "failed: ") for n in cmp.notes)
    code, out, err = invoke(["compare", str(d), "--a", NAV, "--b", f"{NAV}:{FAULT}", "--json", str(tmp_path / "j")])
    assert code == 0, err
    assert "left out, on maps the world generator refused: 2 pairs" in out
    j = json.loads((tmp_path / "j").read_text())
    assert (j["refused_pairs"], j["overall"]["pairs"]) == (2, 10)
    assert j["refused_reason"].startswith(GENERATION_FAILED)


def test_compare_with_every_pair_refused_is_one_line(tmp_path: Path) -> None:
    d = fill(tmp_path / "c", small(trees=[8], maps=1), {("tree=8", 0)})
    argv = ["compare", str(d), "--a", NAV, "--b", f"{NAV}:{FAULT}"]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "every one of the 2 pairs is on a map it refused" in line
    with pytest.raises(StoreError, match="pairs=0"):
        compare(d, Arm(NAV), Arm(NAV, FAULT))


# ---- families: every figure equals the one computed without the refused maps -----------------

SPEC = small(maps=3, runs=3)
TASKS = plan(parse_campaign(SPEC), "/tmp/refused-family").tasks
KEYS = ("tree=0", "tree=4", "tree=8")


@st.composite
def mixes(draw: st.DrawFn) -> tuple[set[tuple[str, int]], dict[str, Any]]:
    """Which maps are refused and, for every run of the others, an outcome (None: not recorded yet)
    with a collision count; refused maps' runs recorded or not (a partial campaign)."""
    refused = {(k, m) for k in KEYS for m in range(3) if draw(st.booleans())}
    outs: dict[str, Any] = {}
    for t in TASKS:
        if (key_of(t), t.map_index) in refused:
            outs[t.run_id] = "refused" if draw(st.integers(0, 4)) else None
            continue
        o = draw(st.sampled_from((*OUTCOMES, None)))
        outs[t.run_id] = None if o is None else (o, int(o == "fail-collision") or draw(st.integers(0, 1)))
    return refused, outs


def _refused_ids(outs: dict[str, Any]) -> set[str]:
    """The runs the family recorded as refused (known without the predicate under test)."""
    return {rid for rid, o in outs.items() if o == "refused"}


def _records(outs: dict[str, Any]) -> list[RunRecord]:
    recs = []
    for t in TASKS:
        o = outs[t.run_id]
        if o == "refused":
            recs.append(refused_record(t))
        elif o is not None:
            recs.append(nav_record(t, o[0], collisions=o[1], duration=10.0 + t.run_index + 3 * t.map_index))
    return recs


def _group(r: RunRecord) -> tuple[tuple[str, str], str, str]:
    return (r.experiment, config_key(r)), r.navigator, r.fault or "nominal"


def _without_refused(x: Any) -> Any:
    """``x`` (ConfigStats, FaultPower or WorldVerdict) with its count of refused maps blanked."""
    if isinstance(x, ConfigStats):
        return dataclasses.replace(x, refused=Refused())
    if isinstance(x, FaultPower):
        return dataclasses.replace(x, refused=0)
    return dataclasses.replace(x, refused_worlds=0, refused_reason=None)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mixes())
def test_every_figure_equals_the_one_without_refused_maps(mix: tuple[set[tuple[str, int]], dict[str, Any]]) -> None:
    refused, outs = mix
    recs = _records(outs)
    kept = [r for r in recs if r.run_id not in _refused_ids(outs)]
    assert split_refused(recs)[0] == kept
    # per configuration: the statistics of the generated maps, the refused ones counted apart
    full, clean = config_stats(recs), config_stats(kept)
    by_full = {(s.key, s.navigator, s.fault): s for s in full}
    by_clean = {(s.key, s.navigator, s.fault): s for s in clean}
    assert set(by_clean) <= set(by_full)
    for g, s in by_full.items():
        gone = [r for r in recs if r.run_id in _refused_ids(outs) and _group(r) == g]
        assert s.refused.runs == len(gone) and s.refused.maps == tuple(sorted({r.map_index for r in gone}))
        assert s.recorded == s.runs + len(gone)
        if gone:
            assert s.refused.reason == f"{GENERATION_FAILED}: {real_reason()}"
        if g in by_clean:
            assert _without_refused(s) == by_clean[g]
        else:  # only refused runs: no navigation figure
            assert s.runs == 0 and s.success_rate is None and sum(s.outcomes.values()) == 0
        mine = [r for r in kept if _group(r) == g]
        assert s.successes == sum(r.outcome == "success" for r in mine) and s.runs == len(mine)
    # levels: the same, except that a configuration without a generated run is "no generated maps"
    nominal = [s for s in full if s.fault == "nominal"]
    lv_full = assign_levels(nominal, lambda s: s.config_key == "tree=0").levels
    lv_clean = assign_levels([s for s in clean if s.fault == "nominal"], lambda s: s.config_key == "tree=0").levels
    for s in nominal:
        want = NO_MAPS if s.runs == 0 and s.refused.runs else lv_clean.get(s.key, NO_DATA)
        assert lv_full[s.key] == want
    # verdicts
    vf, vc = verdicts(recs), verdicts(kept)
    assert vf.worlds == vc.worlds
    assert [_without_refused(c) for c in vf.configurations] == vc.configurations
    for c in vf.configurations:
        g = by_full[((c.experiment, c.config_key), c.navigator, c.fault)]
        assert (c.refused_worlds, c.refused_reason) == (len(g.refused.maps), g.refused.reason)
    assert {(g.config_key, g.fault, g.worlds, g.runs) for g in vf.refused} == {
        (s.config_key, s.fault, len(s.refused.maps), s.refused.runs) for s in full if s.runs == 0 and s.refused.runs}
    # fault power
    pf, pc = fault_power(recs), fault_power(kept)
    assert [_without_refused(p) for p in pf] == pc
    for p in pf:
        assert p.refused == by_full[((p.experiment, p.config_key), p.navigator, p.fault)].refused.runs


def _configs_without_refused(doc: dict[str, Any]) -> list[dict[str, Any]]:
    out = []
    for c in doc["configurations"]:
        c = dict(c)
        c.pop("refused")
        if c["level"] == NO_MAPS:
            c["level"] = NO_DATA
        out.append(c)
    return out


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mixes(), st.sampled_from([0.0, 0.3, 0.6]))
def test_stores_with_and_without_refused_maps_agree(mix: tuple[set[tuple[str, int]], dict[str, Any]],
                                                    bar: float) -> None:
    """Two real stores, one with the refused maps' records and one without: analyze, the gate and
    compare give the same navigation figures; the refused maps are counted apart."""
    _refused, outs = mix
    with tempfile.TemporaryDirectory() as tmp:
        both = {o: Path(tmp) / o for o in ("all", "kept")}
        for name, d in both.items():
            with Store.create(d, parse_campaign(SPEC), yaml.safe_dump(SPEC)) as s:
                for r in _records(outs):
                    if name == "all" or r.run_id not in _refused_ids(outs):
                        s.add(r)
        if not any(outs.values()):
            return
        a_all, a_kept = analyze(both["all"]), analyze(both["kept"])
        ja, jk = a_all.to_json(), a_kept.to_json()
        assert _configs_without_refused(ja) == _configs_without_refused(jk)
        assert ja["outcomes"] == jk["outcomes"] and ja["level_ranges"] == jk["level_ranges"]
        # a configuration whose nominal maps were all refused: its level says so with the refused
        # records ("no generated maps"), and is unknown without them ("no data")
        assert [dict(p, refused_runs=0, level="no data" if p["level"] == "no generated maps" else p["level"])
                for p in ja["fault_power"]] == jk["fault_power"]
        assert ja["verdicts"]["worlds"] == jk["verdicts"]["worlds"]
        assert ja["refused"]["runs"] == sum(o == "refused" for o in outs.values())
        assert jk["refused"] == {"runs": 0, "maps": 0, "configurations": []}
        # the gate: the same verdicts where something ran; no generated map fails
        rule = GateRule(bar)
        ga = gate(both["all"], rule)
        if sum(o not in (None, "refused") for o in outs.values()):
            gk = gate(both["kept"], rule)
            kept = {c.label: c for c in gk.configs}
            for c in ga.configs:
                k = kept[c.label]
                assert (c.runs, c.successes, c.collisions, c.lower) == (k.runs, k.successes, k.collisions, k.lower)
                assert c.passed == (k.passed and not c.no_generated_map)
        for c in ga.configs:
            assert c.no_generated_map == (c.runs == 0 and c.refused_runs > 0)
            if c.no_generated_map:
                assert not c.passed
        xml = junit_xml(ga)
        assert ("<failure " in xml) == (not ga.passed)
        # compare: the pairs with a refused side are left out and counted
        pairs = {(r.experiment, config_key(r), r.map_index, r.run_index) for r in _records(outs)
                 if r.fault is None}
        faulty = {(r.experiment, config_key(r), r.map_index, r.run_index): r for r in _records(outs)
                  if r.fault is not None}
        common = [k for k in pairs if k in faulty]
        gone = [k for k in common if faulty[k].run_id in _refused_ids(outs)]
        if len(common) > len(gone):
            cmp = compare(both["all"], Arm(NAV), Arm(NAV, FAULT))
            assert (cmp.overall.pairs, cmp.refused_pairs) == (len(common) - len(gone), len(gone))
            ck = compare(both["kept"], Arm(NAV), Arm(NAV, FAULT))
            assert cmp.overall == ck.overall and cmp.configs == ck.configs
        elif common:
            with pytest.raises(StoreError, match="refused"):
                compare(both["all"], Arm(NAV), Arm(NAV, FAULT))

