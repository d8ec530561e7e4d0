"""Verdicts per world and per configuration: numbers against the store and against independent
formulas, in ``analyze --json``, the HTML report and ``campaign export --table verdicts``."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
from tests.support.analysis_synth import make_store, record
from hypothesis import given, settings
from hypothesis import strategies as st
from test_analyze_report import _Cells
from typer.testing import CliRunner

from navstress.analysis.analyze import analyze
from navstress.robot import RobotSpec
from navstress.analysis.report import build_report
from navstress.analysis.stats import clopper_pearson
from navstress.analysis.verdicts import (CONFIGURATION_COLUMNS, DEFAULT_CONFIDENCE, DEFAULT_THRESHOLD,
                                         VERDICT_COLUMNS, VerdictRule, read_verdicts, rule_of, rules_of, verdicts,
                                         world_verdict, write_verdicts)
from navstress.campaign.store import Store
from navstress.cli import app
from navstress.errors import SpecError
from navstress.sequential import confidence_sequence, verdict

# (config, map) -> outcomes (True: success), chosen to give every class
WORLDS = {("tree=0", 0): [True] * 25, ("tree=0", 1): [False] * 3, ("tree=4", 0): [True, False] * 12 + [True],
          ("tree=4", 1): [True] * 20 + [False] * 5}
EXPECT = {("tree=0", 0): "passes", ("tree=0", 1): "fails", ("tree=4", 0): "flaky", ("tree=4", 1): "undecided"}


@pytest.fixture(scope="module")
def camp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("v") / "c"
    with make_store(root, trees=[0, 4], defs=[], maps=2, runs=25, faults=[None, "small"]) as s:
        for (key, m), outs in WORLDS.items():
            for r, ok in enumerate(outs):
                s.add(record("trees", key, m, r, "success" if ok else "fail-error"))
        s.add(record("trees", "tree=4", 0, 0, "fail-collision", fault="small", collisions=1))
    return root


def test_world_and_configuration_verdicts_match_the_store(camp: Path) -> None:
    a = analyze(camp)
    w = {(v.config_key, v.map_index, v.fault): v for v in a.verdicts.worlds}
    for (key, m), outs in WORLDS.items():
        v = w[(key, m, "nominal")]
        assert (v.successes, v.runs) == (sum(outs), len(outs))
        assert v.verdict == EXPECT[(key, m)]
        assert v.ci == pytest.approx(clopper_pearson(sum(outs), len(outs), DEFAULT_CONFIDENCE), abs=1e-9)
        assert v.sequence == confidence_sequence(sum(outs), len(outs), DEFAULT_CONFIDENCE)
    assert w[("tree=4", 0, "small")].verdict == "undecided" and w[("tree=4", 0, "small")].runs == 1
    cfg = {(c.config_key, c.fault): c for c in a.verdicts.configurations}
    stats = {(s.config_key, s.fault): s for s in a.stats}
    for k, c in cfg.items():  # pooled counts are the configuration's
        assert (c.successes, c.runs) == (stats[k].successes, stats[k].runs)
    t0 = cfg[("tree=0", "nominal")]
    assert t0.worlds == 2 and dict(t0.world_verdicts) == {"passes": 1, "fails": 1, "flaky": 0, "undecided": 0}
    assert t0.verdict == verdict(*confidence_sequence(25, 28, DEFAULT_CONFIDENCE), DEFAULT_THRESHOLD)


def test_analyze_json_gains_verdicts_and_keeps_its_keys(camp: Path) -> None:
    j = json.loads(json.dumps(analyze(camp).to_json()))
    old = {"campaign", "navigator", "navigators", "done", "planned", "outcomes", "difficulty", "configurations",
           "level_ranges", "overlaps", "indeterminism", "fault_power", "fault_power_by_level",
           "descriptor_correlations", "missing"}
    assert old < set(j) and set(j) - old == {"verdicts", "refused", "robots"}
    assert j["robots"] == [{"name": "rmp400", "digest": RobotSpec().digest}]  # (tests/unit/analysis/test_robots_analysis.py)
    assert j["refused"] == {"runs": 0, "maps": 0, "configurations": []}  # (tests/unit/analysis/test_refused_maps.py)
    v = j["verdicts"]
    assert (v["threshold"], v["confidence"], v["flaky_band"], v["interval"]) == (0.8, 0.95, [0.1, 0.9],
                                                                                   "clopper-pearson")
    assert {(x["config"], x["map_index"]): x["verdict"] for x in v["worlds"] if x["fault"] == "nominal"} == EXPECT
    x = v["worlds"][0]
    assert set(x) == {"experiment", "config", "map_index", "navigator", "fault", "runs", "successes",
                      "pass_probability", "ci", "sequence", "verdict", "threshold", "confidence"}
    assert v["experiments"] == {"trees": {"threshold": 0.8, "confidence": 0.95, "rule": "default", "indifference": 0.0}}
    assert {"worlds", "world_verdicts"} < set(v["configurations"][0])


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_verdicts_table(camp: Path, tmp_path: Path, fmt: str) -> None:
    from typer.testing import CliRunner

    out = tmp_path / f"v.{fmt}"
    r = CliRunner().invoke(app, ["campaign", "export", str(camp), "--table", "verdicts", "-f", fmt, "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert r.output.strip().endswith(f"({len(WORLDS) + 1} worlds)")
    rows = read_verdicts(out)
    assert all(list(row) == list(VERDICT_COLUMNS) for row in rows)
    a = analyze(camp)
    assert [(r["scope"], r["config"], r["map_index"], r["fault"], r["runs"], r["successes"], r["verdict"])
            for r in rows] == (
        [("world", w.config_key, w.map_index, w.fault, w.runs, w.successes, w.verdict) for w in a.verdicts.worlds])
    assert rows[0]["ci_low"] == pytest.approx(a.verdicts.worlds[0].ci[0])
    # the configurations' verdicts: their own table, keyed the same way less the map
    out_c = tmp_path / f"c.{fmt}"
    r = CliRunner().invoke(app, ["campaign", "export", str(camp), "--table", "configurations", "-f", fmt, "-o",
                                 str(out_c)])
    assert r.exit_code == 0 and r.output.strip().endswith("(3 configurations)"), r.output
    rows_c = read_verdicts(out_c, "configurations")
    assert all(list(row) == list(CONFIGURATION_COLUMNS) for row in rows_c)
    assert [(r["scope"], r["config"], r["fault"], r["worlds"], r["runs"], r["successes"], r["verdict"])
            for r in rows_c] == [("configuration", c.config_key, c.fault, c.worlds, c.runs, c.successes, c.verdict)
                                 for c in a.verdicts.configurations]
    if fmt == "parquet":  # the spec and version travel with the tables
        import pyarrow.parquet as pq

        import navstress

        for path, table in ((out, b"verdicts"), (out_c, b"configurations")):
            meta = pq.read_schema(path).metadata
            assert meta[b"navstress.table"] == table and meta[b"navstress.version"] == navstress.__version__.encode()
            assert meta[b"navstress.spec"].decode() == (camp / "spec.yaml").read_text()
    # the runs export is what it was
    r2 = CliRunner().invoke(app, ["campaign", "export", str(camp), "-o", str(tmp_path / "runs.csv")])
    assert r2.exit_code == 0 and (tmp_path / "runs.csv").read_text().startswith("run_id,")


def test_export_bad_table_is_one_line_error(camp: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    r = CliRunner().invoke(app, ["campaign", "export", str(camp), "--table", "worlds", "-o", str(tmp_path / "x")])
    assert r.exit_code == 2 and r.stderr.strip().startswith("error: --table='worlds' is invalid")
    assert not (tmp_path / "x").exists()


def test_report_verdict_table_matches(camp: Path, tmp_path: Path) -> None:
    text = build_report(camp, tmp_path / "r.html").read_text()
    p = _Cells()
    p.feed(text)
    a = analyze(camp)
    cfg_rows = {(r["data-config"], r["data-fault"]): r for r in p.rows if "f:worlds" in r}
    for c in a.verdicts.configurations:
        r = cfg_rows[(c.config_key, c.fault)]
        assert (r["f:verdict"], int(r["f:runs"]), int(r["f:worlds_flaky"])) == (
            c.verdict, c.runs, dict(c.world_verdicts)["flaky"])
        assert float(r["f:ci_low"]) == c.ci[0]
    world_rows = {(r["data-config"], r["data-map"], r["data-fault"]): r["f:verdict"] for r in p.rows
                  if "data-map" in r}
    assert world_rows[("tree=4", "0", "nominal")] == "flaky" and ("tree=0", "0", "nominal") not in world_rows
    assert 'data-figure="verdicts-trees-reference-v1-nominal"' in text


# ---- the rule and the numbers -------------------------------------------------------------------

@pytest.mark.parametrize("spec,rule", [
    (SimpleNamespace(runs_per_map=5), VerdictRule()),
    (SimpleNamespace(), VerdictRule()),
    (SimpleNamespace(runs_per_map={"adaptive": {"min": 3, "max": 9, "threshold": 0.6, "confidence": 0.9}}),
     VerdictRule(0.6, 0.9, "the campaign's adaptive rule")),
    (SimpleNamespace(runs_per_map=SimpleNamespace(adaptive=SimpleNamespace(threshold=0.7, confidence=0.99))),
     VerdictRule(0.7, 0.99, "the campaign's adaptive rule")),
    (SimpleNamespace(runs_per_map=5, adaptive=SimpleNamespace(threshold=0.5, confidence=0.8)),
     VerdictRule(0.5, 0.8, "the campaign's adaptive rule")),
    (SimpleNamespace(runs_per_map=SimpleNamespace(adaptive=None, fixed=5)), VerdictRule()),
    (SimpleNamespace(runs_per_map={"adaptive": {"threshold": 0.5, "confidence": 0.8, "indifference": 0.25}}),
     VerdictRule(0.5, 0.8, "the campaign's adaptive rule", 0.25)),
    (SimpleNamespace(runs_per_map={"adaptive": {"threshold": 0.5, "confidence": 0.8, "indifference": True}}),
     VerdictRule(0.5, 0.8, "the campaign's adaptive rule")),
])
def test_rule_of_reads_any_spec_shape(spec: object, rule: VerdictRule) -> None:
    assert rule_of(spec) == rule


def test_rule_of_prefers_the_experiments_own_rule() -> None:
    """Per experiment (``spec.experiments[i].runs_per_map``), then the campaign's, then the default;
    verdicts of an experiment are given under its rule."""
    ad = {"adaptive": {"min": 3, "max": 9, "threshold": 0.6, "confidence": 0.9}}
    spec = SimpleNamespace(runs_per_map=5, experiments=[SimpleNamespace(name="trees", runs_per_map=ad),
                                                        SimpleNamespace(name="slopes", runs_per_map=None)])
    assert rule_of(spec, "trees") == VerdictRule(0.6, 0.9, "the adaptive rule of experiment trees")
    assert rule_of(spec, "slopes") == rule_of(spec) == VerdictRule()
    spec.runs_per_map = {"adaptive": {"threshold": 0.7, "confidence": 0.99}}
    assert rules_of(spec) == {"trees": VerdictRule(0.6, 0.9, "the adaptive rule of experiment trees"),
                              "slopes": VerdictRule(0.7, 0.99, "the campaign's adaptive rule")}
    recs = [record("trees", "tree=0", 0, i) for i in range(12)]
    recs += [record("smooth", "deformation=0.5", 0, i) for i in range(12)]
    v = verdicts(recs, VerdictRule(), rules={"trees": VerdictRule(0.6, 0.9)})
    by = {c.experiment: c for c in v.configurations}
    assert (by["trees"].threshold, by["trees"].confidence, by["trees"].verdict) == (0.6, 0.9, "passes")
    assert (by["smooth"].threshold, by["smooth"].verdict) == (0.8, "undecided")  # 12/12 does not prove 0.8
    assert {r["threshold"] for t in ("verdicts", "configurations") for r in v.rows(t) if r["experiment"] == "trees"} \
        == {0.6}


def test_indifference_reaches_every_verdict_and_the_export(tmp_path: Path) -> None:
    """2 of 2 runs: undecided at threshold 0.5 and confidence 0.8, passes with the zone (0.25, 0.75);
    the worlds, the configurations and the exported rows carry the rule's indifference."""
    recs = [record("trees", "tree=0", 0, i) for i in range(2)] + [record("trees", "tree=0", 1, i, "fail-collision")
                                                                    for i in range(2)]
    plain = verdicts(recs, VerdictRule(0.5, 0.8))
    zone = verdicts(recs, VerdictRule(0.5, 0.8, indifference=0.25))
    assert [w.verdict for w in plain.worlds] == ["undecided", "undecided"]
    assert [w.verdict for w in zone.worlds] == ["passes", "fails"]
    assert {w.indifference for w in zone.worlds + zone.configurations} == {0.25}
    assert zone.to_json()["indifference"] == 0.25 and zone.to_json()["worlds"][0]["indifference"] == 0.25
    for table in ("verdicts", "configurations"):
        dest = write_verdicts(zone, "csv", tmp_path / f"{table}.csv", table=table)
        assert {r["indifference"] for r in read_verdicts(dest, table)} == {0.25}


def test_rule_of_the_store_spec_is_the_default(camp: Path) -> None:
    with Store.open(camp) as s:
        assert rule_of(s.spec) == VerdictRule(DEFAULT_THRESHOLD, DEFAULT_CONFIDENCE, "default")


@pytest.mark.parametrize("t,c,field", [(1.5, 0.9, "verdicts.threshold"), (0.8, 1.5, "verdicts.confidence"),
                                       (0.8, float("nan"), "verdicts.confidence")])
def test_bad_verdict_rule(t: float, c: float, field: str) -> None:
    with pytest.raises(SpecError) as e:
        VerdictRule(t, c)
    assert e.value.field == field


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 60).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))), st.floats(0.5, 0.99),
       st.floats(0.05, 0.95))
def test_world_verdict_numbers(sn: tuple[int, int], conf: float, t: float) -> None:
    s, n = sn
    w = world_verdict("e", "k", 0, "nav", "nominal", successes=s, runs=n, threshold=t, confidence=conf)
    assert w.ci == pytest.approx(clopper_pearson(s, n, conf), abs=1e-9)
    if n:
        assert w.ci[0] <= s / n <= w.ci[1] and w.pass_probability == s / n
        # the anytime-valid sequence is wider than the fixed-sample exact interval
        assert w.sequence[0] <= w.ci[0] + 1e-9 and w.sequence[1] >= w.ci[1] - 1e-9
        assert w.verdict == verdict(*w.sequence, t)
    else:
        assert w.verdict == "undecided" and w.pass_probability is None


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["a", "b"]), st.integers(0, 3), st.booleans()), max_size=60))
def test_pooled_counts_are_the_sum_of_worlds(runs: list[tuple[str, int, bool]]) -> None:
    recs = [record("trees", f"tree={ord(k)}", m, i, "success" if ok else "fail-error")
            for i, (k, m, ok) in enumerate(runs)]
    v = verdicts(recs)
    for c in v.configurations:
        ws = [w for w in v.worlds if w.config_key == c.config_key]
        assert (c.runs, c.successes, c.worlds) == (sum(w.runs for w in ws), sum(w.successes for w in ws), len(ws))
        assert sum(n for _, n in c.world_verdicts) == len(ws)
    assert sum(w.runs for w in v.worlds) == len(runs)


def test_analyze_cli_json_has_the_verdicts(camp: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    out = tmp_path / "a.json"
    r = CliRunner().invoke(app, ["analyze", str(camp), "--json", str(out)])
    assert r.exit_code == 0, r.output
    v = json.loads(out.read_text())["verdicts"]
    assert {(x["config"], x["map_index"]): x["verdict"] for x in v["worlds"] if x["fault"] == "nominal"} == EXPECT


# ---- the verdict table of `navstress analyze` -------------------------------------------------


def _analyze(*argv: str) -> str:
    r = CliRunner().invoke(app, ["analyze", *argv])
    assert r.exit_code == 0, (r.stdout, r.stderr)
    return r.stdout


def _table(out: str, title: str) -> list[list[str]]:
    """The body rows (cells stripped) of the rich table whose title starts with ``title``."""
    lines = out.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.strip().startswith(title))
    rows: list[list[str]] = []
    for ln in lines[start + 1:]:
        if ln.startswith("└"):
            break
        if ln.startswith("│"):
            rows.append([c.strip() for c in ln.strip("│").split("│")])
    return rows


def test_analyze_prints_a_verdict_table_per_configuration(camp: Path) -> None:
    from navstress._percent import percent

    out = _analyze(str(camp))
    assert "Verdicts per configuration: pass probability [exact 95% interval]; verdict: >= 80% with 95% confidence" \
        in out
    rows = {tuple(r[:4]): r[4:] for r in _table(out, "Verdicts per configuration")}
    cfgs = analyze(camp).verdicts.configurations
    assert len(rows) == len(cfgs) == 3  # tree=0, tree=4 nominal; tree=4 with the fault
    for c in cfgs:
        runs, pp, v, worlds, failing, flaky, undecided = rows[(c.experiment, c.config_key, c.navigator, c.fault)]
        tally = dict(c.world_verdicts)
        assert pp == f"{percent(c.pass_probability)} [{percent(c.ci[0])}, {percent(c.ci[1])}]"
        assert [runs, v, worlds, failing, flaky, undecided] == [
            str(c.runs), c.verdict, str(c.worlds), str(tally["fails"]), str(tally["flaky"]), str(tally["undecided"])]
    # the worlds of WORLDS: tree=0 one passing, one failing; tree=4 one flaky, one undecided
    assert rows[("trees", "tree=0", "reference-v1", "nominal")][3:] == ["2", "1", "0", "0"]
    assert rows[("trees", "tree=4", "reference-v1", "nominal")][3:] == ["2", "0", "1", "1"]
    assert rows[("trees", "tree=0", "reference-v1", "nominal")][:2] == ["28", "89% [72%, 98%]"]


def test_analyze_verdict_table_follows_navigator_and_rules(tmp_path: Path) -> None:
    """Only the asked navigator's configurations; a rule column when an experiment has its own
    adaptive rule; no table when nothing is recorded."""
    import dataclasses

    import yaml
    from tests.support.analysis_synth import spec_dict

    from navstress.campaign.spec import parse_campaign

    d = spec_dict(trees=[0], defs=[0.5], maps=1, runs=2)
    d["experiments"][0]["runs_per_map"] = {"adaptive": {"min": 2, "max": 6, "threshold": 0.6, "confidence": 0.9}}
    d["navigators"] = [{"name": "reference-v1"}, {"name": "other-v1", "target": "navstress.nav.registry:reference_v1"}]
    with Store.create(tmp_path / "c", parse_campaign(d), yaml.safe_dump(d)) as s:
        assert "Verdicts per configuration" not in _analyze(str(tmp_path / "c"))  # nothing recorded yet
        for nav in ("reference-v1", "other-v1"):
            for exp, key in (("trees", "tree=0"), ("smooth", "deformation=0.5")):
                r = record(exp, key, 0, 0)
                s.add(dataclasses.replace(r, navigator=nav, run_id=r.run_id.replace("reference-v1", nav)))
    out = _analyze(str(tmp_path / "c"), "--navigator", "other-v1")
    assert "verdict by each experiment's rule" in out
    rows = _table(out, "Verdicts per configuration")
    assert {r[2] for r in rows} == {"other-v1"} and len(rows) == 2
    assert {r[0]: r[7] for r in rows} == {"trees": ">= 60% at 90%", "smooth": ">= 80% at 95%"}
