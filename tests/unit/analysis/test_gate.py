"""The CI gate (navstress.analysis.gate and ``navstress gate``) on real SQLite stores with
hand-written records: the lower bound, the verdict per configuration and per world, the JUnit
file read back with junitparser and valid against Ant's and Jenkins' JUnit schemas (times,
timestamps, hostnames as CI readers need them), exit codes and one-line errors;
``campaign status --json``."""

from __future__ import annotations

import json
import math
import sqlite3
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from tests.support.analysis_synth import make_store, record
from hypothesis import given, settings
from hypothesis import strategies as st
from junitparser import Failure, JUnitXml, TestCase
from scipy import stats

from tests.support import junit_schemas
from tests.support.cli_inputs import assert_one_line_error, invoke, snapshot
from navstress.analysis.gate import (ConfigResult, GateResult, GateRule, RunEvidence, WorldCase, gate, junit_xml,
                                     lower_bound)
from navstress.errors import SpecError, StoreError

# ---- the lower bound ------------------------------------------------------------------------


@pytest.mark.parametrize("s,n,c,want", [
    (12, 20, 0.95, 0.3936),   # the evidence line's example
    (20, 20, 0.95, 0.8609),   # 0.05 ** (1/20)
    (3, 3, 0.95, 0.3684),     # 0.05 ** (1/3): three successes prove little
    (29, 29, 0.95, 0.9019),   # 0.05 ** (1/29)
    (59, 59, 0.95, 0.9505),   # the "rule of 59": 59/59 proves 95 % at 95 %
    (1, 10, 0.95, 0.0051),
    (9, 10, 0.90, 0.6632),
    (50, 100, 0.99, 0.3807),
    (14, 16, 0.95, 0.6562),
])
def test_lower_bound_known_values(s: int, n: int, c: float, want: float) -> None:
    assert lower_bound(s, n, c) == pytest.approx(want, abs=1e-4)


def _oracle(s: int, n: int, c: float) -> float:
    """The bound by bisection on the exact binomial tail P(X >= s | p) = 1 - c (no scipy)."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        tail = sum(math.comb(n, k) * mid**k * (1 - mid) ** (n - k) for k in range(s, n + 1))
        lo, hi = (mid, hi) if tail < 1 - c else (lo, mid)
    return lo


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 60), data=st.data(), c=st.sampled_from([0.8, 0.9, 0.95, 0.99]))
def test_lower_bound_matches_the_binomial_tail_oracle(n: int, data: st.DataObject, c: float) -> None:
    s = data.draw(st.integers(1, n))
    assert lower_bound(s, n, c) == pytest.approx(_oracle(s, n, c), abs=1e-9)


def test_lower_bound_all_successes_is_the_closed_form() -> None:
    for n in (1, 2, 5, 30, 300):
        for c in (0.5, 0.9, 0.95, 0.999):
            assert lower_bound(n, n, c) == pytest.approx((1 - c) ** (1 / n), rel=1e-9)


@settings(max_examples=200, deadline=None)
@given(n=st.integers(1, 400), data=st.data(), c=st.floats(0.5, 0.999))
def test_lower_bound_properties(n: int, data: st.DataObject, c: float) -> None:
    s = data.draw(st.integers(0, n))
    lo = lower_bound(s, n, c)
    assert 0.0 <= lo <= s / n  # never above the observed rate
    if s == 0:
        assert lo == 0.0
    else:
        assert lo > 0.0
        # exact: at p = lo, seeing s or more successes has probability 1 - c
        assert stats.binom.sf(s - 1, n, lo) == pytest.approx(1 - c, rel=1e-6, abs=1e-12)
    if s < n:
        assert lower_bound(s + 1, n, c) > lo  # monotone in successes
    assert lower_bound(s, n + 1, c) <= lo  # one more failure never raises it
    assert lower_bound(s, n, min(c + 0.0005, 0.9995)) <= lo + 1e-12  # more confidence, lower bound


@pytest.mark.parametrize("p", [0.3, 0.8, 0.95])
@pytest.mark.parametrize("n", [5, 20, 60])
def test_lower_bound_is_wrong_at_most_one_minus_confidence_of_the_time(p: float, n: int) -> None:
    rng = np.random.default_rng(7)
    k = rng.binomial(n, p, size=20_000)
    lo = np.where(k > 0, stats.beta.ppf(0.05, np.maximum(k, 1), n - k + 1), 0.0)
    assert lo[:50] == pytest.approx([lower_bound(int(x), n, 0.95) for x in k[:50]])
    assert float(np.mean(lo > p)) <= 0.05 + 0.006  # 0.006: ~4 standard errors of the estimate


@pytest.mark.parametrize("bad", [dict(s=-1, n=3), dict(s=4, n=3), dict(s=1, n=3, c=1.0), dict(s=1, n=3, c=0.0),
                                 dict(s=1, n=3, c=math.nan)])
def test_lower_bound_refuses_bad_input(bad: dict[str, float]) -> None:
    with pytest.raises(SpecError):
        lower_bound(int(bad["s"]), int(bad["n"]), bad.get("c", 0.95))


@pytest.mark.parametrize("kw,field", [({"min_success": 1.5}, "min_success"), ({"min_success": -0.1}, "min_success"),
                                      ({"min_success": math.nan}, "min_success"),
                                      ({"min_success": 0.5, "confidence": 1.5}, "confidence"),
                                      ({"min_success": 0.5, "max_collisions": -1}, "max_collisions"),
                                      ({"min_success": 0.5, "max_collisions": True}, "max_collisions")])
def test_rule_refuses_bad_parameters(kw: dict[str, float], field: str) -> None:
    with pytest.raises(SpecError, match=f"^{field}="):
        GateRule(**kw)  # type: ignore[arg-type]


# ---- the verdicts ---------------------------------------------------------------------------


def _store(root: Path) -> Path:
    """trees: tree=0 all successes (16 runs); tree=4 one failing world; tree=8 a collision and a
    failure; smooth: nothing recorded. Faulty runs (small-footprint) all collide."""
    d = root / "c"
    with make_store(d, maps=4, runs=4, faults=[None, "small-footprint"]) as s:
        for m in range(4):
            for r in range(4):
                s.add(record("trees", "tree=0", m, r))
                bad4 = m == 2 and r in (0, 1)
                s.add(record("trees", "tree=4", m, r, "fail-timeout" if bad4 else "success",
                             trace=f"traces/trees/tree=4/m{m}/r{r}-reference-v1-nominal.mcap"))
                o8 = "fail-collision" if (m, r) == (1, 3) else "fail-error" if (m, r) == (3, 0) else "success"
                s.add(record("trees", "tree=8", m, r, o8, collisions=int(o8 == "fail-collision")))
                s.add(record("trees", "tree=0", m, r, "fail-collision", fault="small-footprint", collisions=1))
    return d


def test_verdicts_per_configuration(tmp_path: Path) -> None:
    d = _store(tmp_path)
    res = gate(d, GateRule(0.75))
    by = {(c.experiment, c.config_key): c for c in res.configs}
    assert set(by) == {("trees", "tree=0"), ("trees", "tree=4"), ("trees", "tree=8"), ("smooth", "deformation=0.5")}
    assert all(c.fault == "nominal" for c in res.configs)  # faults gated only when asked
    assert (by["trees", "tree=0"].successes, by["trees", "tree=0"].runs) == (16, 16)
    assert by["trees", "tree=0"].passed  # lower bound 0.05 ** (1/16) = 0.83 >= 0.75
    assert not by["trees", "tree=4"].passed  # 14/16: lower bound 0.62
    assert not by["trees", "tree=8"].passed
    assert not by["smooth", "deformation=0.5"].passed and by["smooth", "deformation=0.5"].runs == 0
    assert not res.passed and len(res.failing) == 3
    assert by["trees", "tree=4"].line(res.rule) == \
        "trees/tree=4 reference-v1: success 14/16 = 88%, lower 95% bound 66% < 75%"
    assert res.summary().startswith("gate FAILED: 3 of 4 configurations below the bar (success >= 75% with 95% "
                                    "confidence); campaign synth: 64/")
    low = gate(d, GateRule(0.5), navigators=("reference-v1",), faults=("nominal",))
    assert [c.config_key for c in low.failing] == ["deformation=0.5"]  # nothing recorded there
    assert "no run recorded" in low.failing[0].line(low.rule)


def test_collision_bar_and_faults(tmp_path: Path) -> None:
    d = _store(tmp_path)
    res = gate(d, GateRule(0.0, max_collisions=0), faults=("nominal", "small-footprint"))
    failing = {(c.config_key, c.fault) for c in res.failing}
    assert failing == {("tree=8", "nominal"), ("tree=0", "small-footprint")}
    tree8 = next(c for c in res.failing if c.config_key == "tree=8")
    assert tree8.collisions == 1 and "collision runs 1 > 0" in tree8.line(res.rule)
    assert [w.map_index for w in tree8.worlds if w.failed] == [1]  # only the world with the collision
    assert gate(d, GateRule(0.0, max_collisions=1)).passed
    faulty = gate(d, GateRule(0.5), faults=("small-footprint",))
    assert [(c.label, c.runs) for c in faulty.failing] == [  # tree=4 and tree=8: planned, none recorded
        ("trees/tree=0 reference-v1 + small-footprint", 16), ("trees/tree=4 reference-v1 + small-footprint", 0),
        ("trees/tree=8 reference-v1 + small-footprint", 0)]


def test_a_bound_just_under_the_bar_never_reads_equal_to_it(tmp_path: Path) -> None:
    d = _store(tmp_path)
    bar = lower_bound(16, 16, 0.95) + 1e-6  # 82.9% vs 82.9%: shown with more decimals
    line = next(c for c in gate(d, GateRule(bar)).failing if c.config_key == "tree=0").line(GateRule(bar))
    lo, hi = line.split("bound ")[1].split(" < ")
    assert lo != hi, line


def test_bad_input_is_refused(tmp_path: Path) -> None:
    d = _store(tmp_path)
    with pytest.raises(SpecError, match="navigator='nope-v1'"):
        gate(d, GateRule(0.5), navigators=("nope-v1",))
    with pytest.raises(SpecError, match="fault='nope'"):
        gate(d, GateRule(0.5), faults=("nope",))
    with make_store(tmp_path / "faulty", defs=[], maps=1, runs=2, faults=["small-footprint"]) as s:
        for r in range(2):
            s.add(record("trees", "tree=0", 0, r, "fail-collision", fault="small-footprint", collisions=1))
    # a campaign of faulty runs only: the default gate (the nominal stack) has nothing to judge and
    # would pass vacuously; it is refused, naming the faults there are
    with pytest.raises(SpecError, match=r"--fault='nominal'.*its faults: small-footprint.*--fault small-footprint"):
        gate(tmp_path / "faulty", GateRule(0.5))
    assert not gate(tmp_path / "faulty", GateRule(0.5), faults=("small-footprint",)).passed
    make_store(tmp_path / "empty").close()
    with pytest.raises(StoreError, match="recorded runs"):
        gate(tmp_path / "empty", GateRule(0.5))
    with pytest.raises(StoreError, match="not a campaign directory"):
        gate(tmp_path / "missing", GateRule(0.5))


# ---- JUnit ----------------------------------------------------------------------------------


def _cases(xml: JUnitXml) -> dict[str, TestCase]:
    return {f"{c.classname}/{c.name}": c for suite in xml for c in suite}


def _totals(xml: JUnitXml) -> tuple[int, int]:
    """(tests, failures) over the suites (the root carries no counts: Ant's schema allows none)."""
    return sum(s.tests for s in xml), sum(s.failures for s in xml)


_valid = junit_schemas.assert_valid


@pytest.mark.parametrize("rule", [GateRule(0.0), GateRule(0.5), GateRule(0.75), GateRule(0.0, max_collisions=0),
                                  GateRule(1.0)])
@pytest.mark.parametrize("faults", [None, ("small-footprint",), ("nominal", "small-footprint")])
def test_junit_is_valid_for_ant_and_jenkins(tmp_path: Path, rule: GateRule, faults: tuple[str, ...] | None) -> None:
    d = _store(tmp_path)
    _valid(junit_xml(gate(d, rule, faults=faults)))


def test_junit_times_timestamps_and_host_come_from_the_runs(tmp_path: Path) -> None:
    """A case's time is its world's runs' wall seconds, summed; a suite's timestamp is when its
    first run started (its record's time less its wall time, UTC); the host is the gate's; the
    simulated seconds are a property; a configuration without a run is stamped with the gate's time."""
    d = tmp_path / "c"
    with make_store(d, maps=2, runs=2) as s:
        for m in range(2):
            for r in range(2):
                s.add(replace(record("trees", "tree=4", m, r, "fail-error" if (m, r) == (1, 0) else "success",
                                     duration=30.0 + r), wall_s=1.25 + m + 0.5 * r))
    res = gate(d, GateRule(0.5))
    text = junit_xml(res, hostname="ci-runner 7\n", now=0.0)
    _valid(text)
    with sqlite3.connect(d / "campaign.sqlite") as con:
        start = min(at - wall for at, wall in con.execute("SELECT recorded_at, wall_s FROM runs"))
    suites = {x.get("name"): x for x in ET.fromstring(text)}
    tree4 = suites["trees/tree=4 reference-v1"]
    assert tree4.get("timestamp") == datetime.fromtimestamp(start, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    assert tree4.get("hostname") == "ci-runner 7"
    cases = {c.get("name"): c for c in tree4.iter("testcase")}
    assert cases["m0/reference-v1/nominal"].get("time") == "3.000"  # 1.25 + 1.75
    assert cases["m1/reference-v1/nominal"].get("time") == "5.000"  # 2.25 + 2.75
    assert tree4.get("time") == "8.000"
    props = {p.get("name"): p.get("value") for p in tree4.iter("property")}
    assert props["simulated_s"] == "122.000" and props["campaign"] == "synth" and props["passed"] == "false"
    failure = cases["m1/reference-v1/nominal"].find("failure")
    assert failure is not None and "simulated 30.0 s, wall 2.2 s" in (failure.text or "")
    # nothing recorded: no time, stamped with the gate's time (here the epoch)
    for name in ("trees/tree=0 reference-v1", "smooth/deformation=0.5 reference-v1"):
        assert suites[name].get("timestamp") == "1970-01-01T00:00:00" and suites[name].get("time") == "0.000"


_TEXT = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=40)
_SECONDS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(0, 1e6))


@st.composite
def _results(draw: st.DrawFn) -> GateResult:
    """Gate results with any text (control characters, line breaks, white space only, markup) in
    every name and message, and any number (NaN, infinite, negative, huge) as run times."""
    configs = []
    for _ in range(draw(st.integers(0, 3))):
        worlds = []
        for m in range(draw(st.integers(0, 3))):
            runs = tuple(RunEvidence(draw(_TEXT), draw(st.sampled_from(["success", "fail-error", "fail-collision"])),
                                     draw(_TEXT), draw(st.integers(0, 2**63 - 1)), draw(st.integers(0, 2**63 - 1)),
                                     draw(st.none() | _TEXT), draw(_SECONDS), draw(_SECONDS),
                                     draw(st.none() | _SECONDS))
                         for _ in range(draw(st.integers(0, 3))))
            worlds.append(WorldCase(draw(_TEXT), draw(_TEXT), m, draw(_TEXT), draw(_TEXT), runs,
                                    failed=draw(st.booleans()), reason=draw(_TEXT)))
        ok = draw(st.booleans())
        configs.append(ConfigResult(draw(_TEXT), draw(_TEXT), draw(_TEXT), draw(_TEXT), draw(st.integers(0, 50)),
                                    0, 0, 0.0, ok, True, tuple(worlds)))
    return GateResult(draw(_TEXT), draw(_TEXT), GateRule(0.5), 1, 1, tuple(configs))


@settings(max_examples=150, deadline=None)
@given(res=_results(), host=st.none() | _TEXT, now=st.none() | _SECONDS)
def test_junit_is_valid_whatever_the_names_and_numbers(res: GateResult, host: str | None, now: float | None) -> None:
    _valid(junit_xml(res, hostname=host, now=None if now is None or not math.isfinite(now) else now))


def test_junit_read_back_with_junitparser(tmp_path: Path) -> None:
    d = _store(tmp_path)
    res = gate(d, GateRule(0.75))
    (tmp_path / "g.xml").write_text(junit_xml(res), encoding="utf-8")
    xml = JUnitXml.fromfile(str(tmp_path / "g.xml"))
    cases = _cases(xml)
    # one case per world x navigator x fault: 4 configurations x 4 maps, nominal only
    assert len(cases) == 16 and _totals(xml)[0] == 16
    assert {s.name for s in xml} == {"trees/tree=0 reference-v1", "trees/tree=4 reference-v1",
                                     "trees/tree=8 reference-v1", "smooth/deformation=0.5 reference-v1"}
    failed = {k for k, c in cases.items() if any(isinstance(r, Failure) for r in c.result)}
    assert failed == {"trees/tree=4/m2/reference-v1/nominal",  # the world with the two timeouts
                      "trees/tree=8/m1/reference-v1/nominal", "trees/tree=8/m3/reference-v1/nominal",
                      *(f"smooth/deformation=0.5/m{m}/reference-v1/nominal" for m in range(4))}
    assert _totals(xml)[1] == len(failed) == 7
    f = next(r for r in cases["trees/tree=4/m2/reference-v1/nominal"].result if isinstance(r, Failure))
    assert f.message == ("success 2/4 on this world; configuration trees/tree=4 reference-v1: success 14/16 = "
                         "88%, lower 95% bound 66% < 75%")
    text = f.text or ""
    for r in (0, 1):
        rid = f"trees/tree=4/m2/r{r}/reference-v1/nominal"
        assert f"{rid}: fail-timeout (synthetic); map_seed=102 run_seed={200 + r}" in text
        assert f"trace: {d}/traces/trees/tree=4/m2/r{r}-reference-v1-nominal.mcap" in text
        assert f"replay: navstress replay {d} {rid}" in text
    assert "r2/" not in text  # successes are not listed
    pending = next(r for r in cases["smooth/deformation=0.5/m0/reference-v1/nominal"].result)
    assert "no run recorded on this world" in pending.message and "not enough runs" in pending.message
    # a passing world of a passing configuration carries nothing; tree=0 passes whole
    assert all(not c.result for k, c in cases.items() if k.startswith("trees/tree=0/"))


def test_junit_failures_exactly_when_the_gate_fails(tmp_path: Path) -> None:
    d = _store(tmp_path)
    for rule in (GateRule(0.0), GateRule(0.5), GateRule(0.75), GateRule(0.0, max_collisions=0), GateRule(1.0)):
        for faults in (None, ("small-footprint",), ("nominal", "small-footprint")):
            res = gate(d, rule, faults=faults)
            xml = JUnitXml.fromstring(junit_xml(res).encode("utf-8"))
            assert (_totals(xml)[1] > 0) == (not res.passed), (rule, faults)
            bad_suites = {s.name for s in xml if s.failures}
            assert bad_suites == {c.label for c in res.failing}


def test_junit_text_is_valid_xml_whatever_the_reason_holds(tmp_path: Path) -> None:
    d = tmp_path / "c"
    with make_store(d, maps=1, runs=1, defs=[]) as s:
        rec = record("trees", "tree=0", 0, 0, "fail-error")
        s.add(rec.__class__(**{**rec.__dict__, "reason": "bad \x00\x1b[31m <&> ]]> end"}))
    res = gate(d, GateRule(0.5))
    xml = JUnitXml.fromstring(junit_xml(res).encode("utf-8"))
    f = next(r for c in _cases(xml).values() for r in c.result)
    assert "<&> ]]>" in f.text and "\\x1b" in f.text and " end" in f.text


# ---- the command ----------------------------------------------------------------------------


def test_gate_command_exit_codes_and_lines(tmp_path: Path) -> None:
    d = str(_store(tmp_path))
    code, out, err = invoke(["gate", d, "--min-success", "0.5", "--navigator", "reference-v1"])
    assert code == 1, err
    lines = out.strip().splitlines()
    assert lines == ["smooth/deformation=0.5 reference-v1: no run recorded, lower 95% bound 0% < 50%",
                     lines[-1]] and lines[-1].startswith("gate FAILED: 1 of 4 configurations")
    code, out, err = invoke(["gate", d, "--min-success", "0", "--junit", str(tmp_path / "j" / "g.xml")])
    assert code == 0 and out.startswith("gate passed: all 4 configurations meet the bar"), out
    assert _totals(JUnitXml.fromfile(str(tmp_path / "j" / "g.xml")))[1] == 0
    _valid((tmp_path / "j" / "g.xml").read_text(encoding="utf-8"))
    code, out, _ = invoke(["gate", d, "--min-success", "0", "--max-collisions", "0", "--fault", "small-footprint"])
    assert code == 1 and "collision runs 16 > 0" in out


def test_gate_json_holds_every_configuration(tmp_path: Path) -> None:
    d = str(_store(tmp_path))
    code, out, err = invoke(["gate", d, "--min-success", "0.75", "--json"])
    assert code == 1, err
    data = json.loads(out)
    assert data["passed"] is False and data["summary"].startswith("gate FAILED: 3 of 4")
    assert (data["min_success"], data["confidence"], data["max_collisions"]) == (0.75, 0.95, None)
    by = {c["config"]: c for c in data["configurations"]}
    assert (by["tree=4"]["runs"], by["tree=4"]["successes"], by["tree=4"]["passed"]) == (16, 14, False)
    assert by["tree=4"]["lower_bound"] == pytest.approx(lower_bound(14, 16, 0.95))
    assert [w["failed"] for w in by["tree=4"]["worlds"]] == [False, False, True, False]
    assert by["tree=0"]["passed"] and by["deformation=0.5"]["success_rate"] is None
    code, out, _ = invoke(["gate", d, "--min-success", "0.5", "--navigator", "reference-v1", "--fault", "nominal",
                           "--json"])
    assert code == 1 and [c["config"] for c in json.loads(out)["configurations"] if not c["passed"]] == \
        ["deformation=0.5"]


@pytest.mark.parametrize("args,flag", [
    (["--min-success", "1.5"], "--min-success"), (["--min-success", "-0.1"], "--min-success"),
    (["--min-success", "nan"], "--min-success"), (["--min-success", "x"], "--min-success"),
    (["--min-success", "0.5", "--confidence", "1.5"], "--confidence"),
    (["--min-success", "0.5", "--confidence", "0"], "--confidence"),
    (["--min-success", "0.5", "--confidence", "inf"], "--confidence"),
    (["--min-success", "0.5", "--max-collisions", "-1"], "--max-collisions"),
    (["--min-success", "0.5", "--max-collisions", "1.5"], "--max-collisions"),
    (["--min-success", "0.5", "--navigator", "nope-v1"], "navigator"),
    (["--min-success", "0.5", "--fault", "nope"], "fault"),
    (["--min-success", "0.5", "--junit", "{tmp}"], "--junit"),
    (["--min-success", "0.5", "--junit", "{tmp}/afile/x.xml"], "path"),
    ([], "--min-success"),
])
def test_each_bad_option_is_one_line_exit_2_nothing_written(tmp_path: Path, args: list[str], flag: str) -> None:
    d = _store(tmp_path)
    (tmp_path / "afile").write_text("a file")
    before = snapshot(tmp_path)
    argv = ["gate", str(d), *(a.replace("{tmp}", str(tmp_path)) for a in args)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert flag in line, line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("where", ["missing", "empty", "afile"])
def test_gate_on_a_missing_or_empty_store_is_exit_2(tmp_path: Path, where: str) -> None:
    make_store(tmp_path / "empty").close()
    (tmp_path / "afile").write_text("a file")
    argv = ["gate", str(tmp_path / where), "--min-success", "0"]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "campaign=" in line, line


# ---- campaign status --json -----------------------------------------------------------------


def test_campaign_status_json_holds_the_counts(tmp_path: Path) -> None:
    d = _store(tmp_path)
    code, out, err = invoke(["campaign", "status", str(d), "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert (data["campaign"], data["planned"], data["recorded"], data["pending"]) == ("synth", 112, 64, 48)
    assert data["counts"] == {"success": 44, "fail-collision": 17, "fail-error": 1, "fail-timeout": 2,
                              "fail-other": 0}
    exps = {e["experiment"]: e for e in data["experiments"]}
    assert (exps["trees"]["recorded"], exps["smooth"]["recorded"], exps["smooth"]["pending"]) == (64, 0, 16)
    navs = {(n["navigator"], n["fault"]): n for n in data["navigators"]}
    assert navs["reference-v1", "small-footprint"]["counts"]["fail-collision"] == 16
    assert navs["reference-v1", "nominal"]["recorded"] == 48
    assert data["failed_attempts"] == {"attempts": 0, "runs": 0}
