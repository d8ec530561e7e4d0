"""``navstress gate`` on a real small campaign (real missions on a 20 m world, two navigators: the
reference stack, which arrives, and one that raises, which fails every run): exit 0, 1 and 2;
the JUnit file read back with junitparser names the failed runs' seeds and traces, which exist;
``campaign run``, ``run`` keep exiting 0 when runs fail, and their ``--json`` outputs parse."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from tests.support.junit_schemas import assert_valid
from junitparser import Failure, JUnitXml

from tests.support.built_once import built_once
from navstress.campaign.store import Store
from navstress.run.record import RunRecord
from tests.support.cli_run import cli as _cli

pytestmark = pytest.mark.slow

SPEC: dict[str, Any] = {
    "name": "gated", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
    "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
    "maps_per_config": 2, "runs_per_map": 2,
    "navigators": [{"name": "reference-v1"},
                   {"name": "raises-v1", "target": "tests.support.navigators.campaign_navs:Raises", "config": {"after_s": 0.5}}],
    "timeout_s": 60.0, "goal_tolerance_m": 2.0}


def _campaign(root: Path) -> str:
    (root / "spec.yaml").write_text(yaml.safe_dump(SPEC, sort_keys=False))
    code, out, err = _cli("campaign", "run", str(root / "spec.yaml"), "-o", str(root / "c"), "-q", "-j", "1")
    assert code == 0, (out, err)  # four runs failed: results, not errors
    return str(root / "c")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[RunRecord]]:
    """The campaign, built once in the session (the tests only read it), and its records."""
    c = Path(built_once(tmp_path_factory, "gate-campaign", _campaign))
    with Store.open(c) as s:
        recs = s.records()
    ends = {n: sorted({r.outcome for r in recs if r.navigator == n}) for n in ("reference-v1", "raises-v1")}
    assert ends == {"reference-v1": ["success"], "raises-v1": ["fail-other"]}, ends
    return c, recs


def test_exit_0_when_every_gated_configuration_meets_the_bar(campaign: tuple[Path, list[RunRecord]]) -> None:
    d, _ = campaign
    code, out, err = _cli("gate", str(d), "--min-success", "0.4", "--navigator", "reference-v1")
    assert code == 0, (out, err)
    # 4/4 successes: lower 95% bound 0.05 ** (1/4) = 47% >= 40%
    assert out.splitlines() == ["gate passed: the 1 configuration meets the bar (success >= 40% with 95% "
                                "confidence); campaign gated: 8/8 runs recorded"]


def test_exit_1_with_the_evidence_and_a_junit_file(campaign: tuple[Path, list[RunRecord]], tmp_path: Path) -> None:
    d, recs = campaign
    junit = tmp_path / "ci" / "gate.xml"
    code, out, err = _cli("gate", str(d), "--min-success", "0.4", "--junit", str(junit))
    assert code == 1, (out, err)
    lines = out.splitlines()
    assert lines[0] == "flat/tree=0 raises-v1: success 0/4 = 0%, lower 95% bound 0% < 40%"
    assert lines[1].startswith("gate FAILED: 1 of 2 configurations below the bar") and lines[2] == f"wrote {junit}"
    xml = JUnitXml.fromfile(str(junit))
    cases = {f"{c.classname}/{c.name}": c for suite in xml for c in suite}
    assert sorted(cases) == [f"flat/tree=0/m{m}/{n}/nominal" for m in (0, 1) for n in ("raises-v1", "reference-v1")]
    assert (sum(s.tests for s in xml), sum(s.failures for s in xml)) == (4, 2)
    assert_valid(junit.read_text(encoding="utf-8"))  # Ant's and Jenkins' schemas, times from the real runs
    for m in (0, 1):
        assert not cases[f"flat/tree=0/m{m}/reference-v1/nominal"].result
        f = next(r for r in cases[f"flat/tree=0/m{m}/raises-v1/nominal"].result if isinstance(r, Failure))
        assert f.message.startswith("success 0/2 on this world; configuration flat/tree=0 raises-v1: success 0/4")
        for r in (x for x in recs if x.navigator == "raises-v1" and x.map_index == m):
            assert f"{r.run_id}: fail-other" in f.text
            assert f"map_seed={r.map_seed} run_seed={r.run_seed}" in f.text
            assert r.trace and f"trace: {d / r.trace};" in f.text and (d / r.trace).is_file()


def test_exit_1_when_the_bar_cannot_be_proven(campaign: tuple[Path, list[RunRecord]]) -> None:
    d, _ = campaign
    code, out, _ = _cli("gate", str(d), "--min-success", "0.8", "--navigator", "reference-v1")
    assert code == 1 and out.splitlines()[0] == \
        "flat/tree=0 reference-v1: success 4/4 = 100%, lower 95% bound 47% < 80%"


@pytest.mark.parametrize("args", [["--min-success", "1.5"], ["--min-success", "0.5", "--confidence", "1.5"],
                                  ["--min-success", "0.5", "--navigator", "absent-v1"],
                                  ["--min-success", "0.5", "--max-collisions", "-2"]])
def test_exit_2_on_bad_input(campaign: tuple[Path, list[RunRecord]], args: list[str]) -> None:
    d, _ = campaign
    code, out, err = _cli("gate", str(d), *args)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and err.startswith("error: "), (out, err)


def test_status_json_holds_the_counts(campaign: tuple[Path, list[RunRecord]]) -> None:
    d, _ = campaign
    code, out, err = _cli("campaign", "status", str(d), "--json")
    assert code == 0, err
    data = json.loads(out)
    assert (data["planned"], data["recorded"], data["pending"]) == (8, 8, 0)
    assert data["counts"] == {"success": 4, "fail-collision": 0, "fail-error": 0, "fail-timeout": 0, "fail-other": 4}
    assert {(n["navigator"], n["counts"]["success"]) for n in data["navigators"]} == {("reference-v1", 4),
                                                                                      ("raises-v1", 0)}


def test_run_json_exits_0_when_its_runs_fail(campaign: tuple[Path, list[RunRecord]], tmp_path: Path) -> None:
    d, _ = campaign
    world = d / "worlds" / "flat" / "tree=0" / "m0"
    code, out, err = _cli("run", str(world), "-o", str(tmp_path / "r"), "--runs", "2", "--timeout", "1", "--json")
    assert code == 0, err
    data = json.loads(out)  # stdout holds the JSON alone (the progress went to stderr)
    assert data["runs"] == 2 and data["counts"]["fail-timeout"] == 2 and sum(data["counts"].values()) == 2
    assert [r["outcome"] for r in data["records"]] == ["fail-timeout"] * 2
    assert [r["run_id"] for r in data["records"]] == ["run-000", "run-001"]
    assert all(Path(r["trace"]).is_file() for r in data["records"])
    assert Path(data["picture"]).is_file() and Path(data["records_file"]).is_file()
