"""A campaign of two robots and two navigators, end to end through the CLI (real worker processes,
a real SQLite store): every record names its robot, and the report, analyze, compare, gate and the
exports keep the robots apart (``navigator@robot``), never two robots in one row or figure.

The navigators are the Coin of tests.support (one control cycle per run, its outcome drawn from
the run's seed): the test is about the plumbing, not about how well any robot drives."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.analysis.analyze import analyze
from navstress.analysis.compare import Arm, compare
from navstress.analysis.gate import GateRule, gate
from navstress.analysis.report import build_report
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.robot import PROFILES
from navstress.run.batch import failure_record

ROOT = Path(__file__).resolve().parents[3]
COIN = "tests.support.navigators.campaign_navs:Coin"
ROBOTS = ("rmp400", "jackal")
NAVS = ("coin-a-v1", "coin-b-v1")


def _spec() -> dict[str, Any]:
    return {"name": "two-robots", "seed": 11, "robots": list(ROBOTS),
            "world": {"size_m": [12.0, 12.0], "cell_m": 0.5,
                      "mission": {"start": [5.0, 5.0, 0.0], "goal": [6.0, 5.0], "free_radius_m": 1.0}},
            "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
            "maps_per_config": 1, "runs_per_map": 2, "faults": [None], "timeout_s": 2.0,
            "navigators": [{"name": n, "target": COIN, "config": {"p": 0.5}} for n in NAVS]}


def _ns(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])}
    return subprocess.run([sys.executable, "-m", "navstress.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("robots")
    (d / "spec.yaml").write_text(yaml.safe_dump(_spec(), sort_keys=False))
    p = _ns("campaign", "run", "spec.yaml", "-o", "c", "-j", "1", "-q", cwd=d)
    assert p.returncode == 0, p.stderr[-2000:]
    return d


def test_records_name_their_robot(ran: Path) -> None:
    with Store.open(ran / "c") as s:
        recs = s.records()
    assert len(recs) == 2 * len(NAVS) * len(ROBOTS)
    assert {(r.robot, r.robot_digest) for r in recs} == {(n, PROFILES[n].digest) for n in ROBOTS}
    for r in recs:
        assert r.run_id.split("/")[-2] == f"{r.navigator}@{r.robot}"


def test_analyze_and_report_keep_the_robots_apart(ran: Path) -> None:
    a = analyze(ran / "c")
    variants = [f"{n}@{r}" for n in NAVS for r in ROBOTS]
    assert a.navigators == variants and a.navigator == "coin-a-v1@rmp400"
    assert [n for n, _ in a.robots] == list(ROBOTS)
    assert {s.navigator for s in a.stats} == set(variants)
    for s in a.stats:  # each row's runs are one robot's
        assert s.recorded == 2
    out = build_report(ran / "c", ran / "report.html")

    class Rows(HTMLParser):
        def __init__(self) -> None:
            super().__init__()
            self.navs: list[str] = []
            self.robots: list[str] = []

        def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
            d = dict(attrs)
            if d.get("data-navigator"):
                self.navs.append(str(d["data-navigator"]))
            if d.get("data-robot"):
                self.robots.append(str(d["data-robot"]))

    rows = Rows()
    rows.feed(out.read_text(encoding="utf-8"))
    assert rows.robots == list(ROBOTS)
    assert rows.navs and set(rows.navs) <= set(variants) and set(variants) <= set(rows.navs)
    data = a.to_json()
    assert [r["name"] for r in data["robots"]] == list(ROBOTS) and data["navigators"] == variants


def test_compare_pairs_across_robots(ran: Path) -> None:
    cmp = compare(ran / "c", Arm("coin-a-v1@rmp400"), Arm("coin-a-v1@jackal"))
    assert cmp.overall.pairs == 2 and cmp.unpaired_a == cmp.unpaired_b == 0
    assert cmp.robot_a.startswith("rmp400 (") and cmp.robot_b.startswith("jackal (")
    # the same navigator, the same seeds: the Coin's outcomes agree pair by pair, whatever the robot
    assert cmp.overall.a_only == cmp.overall.b_only == 0
    with pytest.raises(SpecError, match=r"coin-a-v1@rmp400"):  # a navigator without its robot: which one?
        compare(ran / "c", Arm("coin-a-v1"), Arm("coin-b-v1"))
    p = _ns("compare", "c", "--a", "coin-a-v1@jackal", "--b", "coin-b-v1@jackal", "--json", "ab.json", cwd=ran)
    assert p.returncode == 0, p.stderr[-2000:]
    data = json.loads((ran / "ab.json").read_text())
    assert data["a"]["robot"].startswith("jackal") and data["b"]["robot"].startswith("jackal")
    assert "robot jackal" in p.stdout


def test_gate_and_exports_per_robot(ran: Path) -> None:
    g = gate(ran / "c", GateRule(min_success=0.0))
    assert {c.navigator for c in g.configs} == {f"{n}@{r}" for n in NAVS for r in ROBOTS}
    only = gate(ran / "c", GateRule(min_success=0.0), navigators=("coin-b-v1",))
    assert {c.navigator for c in only.configs} == {f"coin-b-v1@{r}" for r in ROBOTS}
    p = _ns("campaign", "export", "c", "--format", "csv", "-o", "runs.csv", cwd=ran)
    assert p.returncode == 0, p.stderr[-2000:]
    with open(ran / "runs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {(r["robot"], r["robot_digest"]) for r in rows} == {(n, PROFILES[n].digest) for n in ROBOTS}


def _synthetic(d: Path, robot: str) -> None:
    """A campaign of one robot, its records made by hand (the same outcomes whatever the robot)."""
    data = {**_spec(), "robot": robot, "navigators": [{"name": "nav-a-v1"}]}
    del data["robots"]
    with Store.create(d, parse_campaign(data)) as s:
        for i, t in enumerate(s.plan().tasks):
            s.add(replace(failure_record(t, "synthetic"), outcome="success" if i % 2 else "fail-error"))


def test_compare_two_campaigns_of_one_robot_each(tmp_path: Path) -> None:
    _synthetic(tmp_path / "a", "rmp400")
    _synthetic(tmp_path / "b", "jackal")
    cmp = compare(tmp_path / "a", Arm("nav-a-v1"), Arm("nav-a-v1"), tmp_path / "b")
    assert cmp.overall.pairs == 2 and cmp.robot_a.startswith("rmp400 (") and cmp.robot_b.startswith("jackal (")
    assert cmp.to_json()["b"]["robot"] == f"jackal ({PROFILES['jackal'].digest})"
