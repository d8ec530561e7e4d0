"""Every command that reads a campaign, on one small real campaign that mixes a sweep experiment
with an experiment of explicit worlds (real missions of the reference stack and its
small-footprint fault on 20 m worlds): status, analyze, report, export (both tables, both
formats), gate (with JUnit), compare and replay each work and name the explicit worlds by key."""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
import yaml
from junitparser import JUnitXml

from tests.support.built_once import built_once
from navstress.campaign.store import Store
from tests.support.cli_run import cli as _cli

pytestmark = pytest.mark.slow

SUITE = [{"key": "open", "map_seed": 11},
         {"key": "wooded", "map_seed": 12, "world": {"obstacles": {"obstruction": {"tree": 6}}}}]
SPEC: dict[str, Any] = {
    "name": "mixed", "seed": 8, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
    "experiments": [{"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 6]}}},
                    {"name": "suite", "worlds": SUITE}],
    "maps_per_config": 1, "runs_per_map": 2, "navigators": [{"name": "reference-v1"}],
    "faults": [None, "small-footprint"], "timeout_s": 20.0}
RUNS = 4 * 2 * 2  # (2 swept + 2 explicit configurations) x 2 runs x 2 faults


def _campaign(root: Path) -> str:
    (root / "spec.yaml").write_text(yaml.safe_dump(SPEC, sort_keys=False))
    code, out, err = _cli("campaign", "run", str(root / "spec.yaml"), "-o", str(root / "c"), "-q", "-j", "2")
    assert code == 0, (out, err)
    assert out.startswith(f"{root / 'c'}: {RUNS}/{RUNS} runs recorded"), out
    return str(root / "c")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The campaign, built once in the session (every reader only reads it)."""
    return Path(built_once(tmp_path_factory, "explicit-worlds-campaign", _campaign))


def _suite_rows(rows: list[dict[str, Any]], key: str = "experiment") -> list[dict[str, Any]]:
    return [r for r in rows if r[key] == "suite"]


def check_status(d: Path, tmp: Path) -> None:
    code, out, err = _cli("campaign", "status", str(d))
    assert code == 0 and f"{RUNS}/{RUNS}" in out, (out, err)
    assert [ln for ln in out.splitlines() if " suite " in ln and "8/8" in ln], out
    code, out, _ = _cli("campaign", "status", str(d), "--json")
    data = json.loads(out)
    assert {e["experiment"]: (e["planned"], e["recorded"]) for e in data["experiments"]} == {
        "trees": (8, 8), "suite": (8, 8)}


def check_analyze(d: Path, tmp: Path) -> None:
    code, out, err = _cli("analyze", str(d), "--json", str(tmp / "a.json"))
    assert code == 0, (out, err)
    data = json.loads((tmp / "a.json").read_text())
    cfgs = {(c["experiment"], c["config"], c["fault"]): c for c in data["configurations"]}
    for key, seed in (("open", 11), ("wooded", 12)):
        c = cfgs[("suite", key, "nominal")]
        assert c["runs"] == c["planned"] == 2 and c["maps"] == [0] and c["level"] != "no data", c
    assert cfgs[("suite", "wooded", "nominal")]["params"] == {"obstacles.obstruction.tree": 6}
    assert cfgs[("suite", "open", "nominal")]["params"] == {}
    assert {r["experiment"] for r in data["level_ranges"]} == {"trees"}  # no swept parameter in the suite
    assert "suite" not in {o["experiment"] for o in data["overlaps"]}


def check_report(d: Path, tmp: Path) -> None:
    code, out, err = _cli("report", str(d), "-o", str(tmp / "r.html"))
    assert code == 0, (out, err)
    html = (tmp / "r.html").read_text()
    for key in ("open", "wooded"):
        assert f'data-experiment="suite" data-config="{key}"' in html
    # an explicit world's key, then (in small type below it) its class and its overrides
    assert re.search(r'>wooded <small class="sub">suite \u00b7 [^<]*tree=6</small>', html)
    assert re.search(r'>open <small class="sub">suite \u00b7 [^<]*\(base\)</small>', html)
    assert 'id="class-suite"' in html or "class-suite" in html


def check_export_runs(d: Path, tmp: Path) -> None:
    for fmt in ("csv", "parquet"):
        out_file = tmp / f"runs.{fmt}"
        code, out, err = _cli("campaign", "export", str(d), "--format", fmt, "-o", str(out_file))
        assert code == 0 and f"({RUNS} runs)" in out, (out, err)
        rows = list(csv.DictReader(out_file.open())) if fmt == "csv" else pq.read_table(out_file).to_pylist()
        suite = _suite_rows(rows)
        assert len(rows) == RUNS and len(suite) == 8
        for r in suite:
            key = r["run_id"].split("/")[1]
            assert int(r["map_seed"]) == {"open": 11, "wooded": 12}[key] and int(r["map_index"]) == 0
            assert json.loads(r["params"]) == ({"obstacles.obstruction.tree": 6} if key == "wooded" else {})
            assert r["config"] == key  # an explicit world's key is its configuration's


def check_export_verdicts(d: Path, tmp: Path) -> None:
    for fmt in ("csv", "parquet"):
        out_file = tmp / f"verdicts.{fmt}"
        code, out, err = _cli("campaign", "export", str(d), "--table", "verdicts", "--format", fmt, "-o",
                              str(out_file))
        assert code == 0, (out, err)
        rows = list(csv.DictReader(out_file.open())) if fmt == "csv" else pq.read_table(out_file).to_pylist()
        suite = _suite_rows(rows)
        worlds = {(r["config"], r["fault"]) for r in suite if r["scope"] == "world"}
        assert worlds == {(k, f) for k in ("open", "wooded") for f in ("nominal", "small-footprint")}, suite
        assert all(int(r["runs"]) == 2 for r in suite)


def check_gate(d: Path, tmp: Path) -> None:
    junit = tmp / "gate.xml"
    code, out, err = _cli("gate", str(d), "--min-success", "0", "--junit", str(junit))
    assert code == 0 and out.startswith("gate passed: all 4 configurations meet the bar"), (out, err)
    cases = {f"{c.classname}/{c.name}" for suite in JUnitXml.fromfile(str(junit)) for c in suite}
    assert cases == {"trees/tree=0/m0/reference-v1/nominal", "trees/tree=6/m0/reference-v1/nominal",
                     "suite/open/m0/reference-v1/nominal", "suite/wooded/m0/reference-v1/nominal"}
    code, out, err = _cli("gate", str(d), "--min-success", "0.99", "--json")
    assert code == 1, (out, err)  # two runs cannot prove 99 %
    data = json.loads(out)
    assert {(c["experiment"], c["config"]) for c in data["configurations"]} >= {("suite", "open"), ("suite", "wooded")}


def check_compare(d: Path, tmp: Path) -> None:
    code, out, err = _cli("compare", str(d), "--a", "reference-v1", "--b", "reference-v1:small-footprint",
                          "--json", str(tmp / "c.json"))
    assert code == 0, (out, err)
    data = json.loads((tmp / "c.json").read_text())
    assert [(c["experiment"], c["config"]) for c in data["configurations"]] == [
        ("trees", "tree=0"), ("trees", "tree=6"), ("suite", "open"), ("suite", "wooded")]
    assert data["overall"]["pairs"] == 8


def check_replay(d: Path, tmp: Path) -> None:
    with Store.open(d) as s:
        rid = next(r.run_id for r in s.records() if r.experiment == "suite" and r.fault == "small-footprint")
    code, out, err = _cli("replay", str(d), rid)
    assert code == 0 and "identical" in out, (out, err)


@dataclass(frozen=True)
class Reader:
    name: str
    check: Callable[[Path, Path], None]


READERS = [Reader("campaign status", check_status), Reader("analyze", check_analyze), Reader("report", check_report),
           Reader("campaign export runs", check_export_runs),
           Reader("campaign export verdicts", check_export_verdicts), Reader("gate", check_gate),
           Reader("compare", check_compare), Reader("replay", check_replay)]


@pytest.mark.parametrize("reader", READERS, ids=[r.name for r in READERS])
def test_every_reader_works_on_explicit_worlds(campaign: Path, tmp_path: Path, reader: Reader) -> None:
    reader.check(campaign, tmp_path)
