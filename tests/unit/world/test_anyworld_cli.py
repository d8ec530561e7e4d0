"""Issue 37's done-when for item 5, end to end through the CLI (real processes, real SQLite): an
office map (PGM + YAML written here) used by a campaign and by a search with the Jackal profile, a
UST-10-class 2D scanner and reference-2d-v1; every run row names the map and its digest; a map
changed before a resume is refused (one line, exit 2, nothing run), the unchanged one resumes;
analyze and gate read the campaign."""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.office import write_office

HEAD = """\
name: {name}
seed: 3
robot: jackal
sensors:
  - {{name: front_laser, kind: lidar2d, profile: ust10, mount: {{xyz: [0.12, 0, 0.3], rpy: [0, 0, 0]}}}}
timeout_s: 15.0
goal_tolerance_m: 0.5
"""
CAMPAIGN = HEAD + """\
world:
  source: {{path: maps/office.yaml}}
  mission: {{mode: random, min_distance_m: 4.0}}
  obstacles: {{types: {{box: {{base_m: [0.4, 0.4], height_m: 0.8}}}}}}
experiments:
  - name: boxes
    sweep: {{obstacles.obstruction.box: {{values: [0, 2]}}}}
maps_per_config: 1
runs_per_map: 1
navigators: [{{name: reference-2d-v1}}]
"""
SEARCH = HEAD + """\
world:
  source: {{path: maps/office.yaml}}
  mission: {{goal: [13.0, 11.0]}}
  obstacles: {{types: {{box: {{base_m: [0.4, 0.4], height_m: 0.8}}}}}}
space:
  parameters:
    - {{path: mission.start.x, low: 8.0, high: 9.5}}
    - {{path: mission.start.y, low: 10.0, high: 12.0}}
    - {{path: obstacles.obstruction.box, low: 0, high: 2}}
  moves: {{count: 1, radius_m: 0.3}}
  map_seed: false
navigator: {{name: reference-2d-v1}}
faults: [null]
objective: {{name: failure}}
algorithm: {{name: random, batch: 2}}
runs_per_candidate: 1
confirm_runs: 1
budget: {{runs: 4}}
"""


def ns(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "navstress.cli", *args], cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "COLUMNS": "200"}, timeout=600)


def _rows(db: Path) -> list[sqlite3.Row]:
    con = sqlite3.connect(db)
    con.row_factory = sqlite3.Row
    try:
        return list(con.execute("SELECT * FROM runs"))
    finally:
        con.close()


@pytest.fixture()
def specs(tmp_path: Path) -> Path:
    d = tmp_path / "specs"
    write_office(d / "maps", origin=(-3.0, 2.0))
    (d / "campaign.yaml").write_text(CAMPAIGN.format(name="office"))
    (d / "search.yaml").write_text(SEARCH.format(name="office-search"))
    return d


def test_office_map_campaign_resume_and_search(specs: Path, tmp_path: Path) -> None:
    elsewhere = tmp_path / "cwd"  # the commands run from another folder: the map is found from the spec's
    elsewhere.mkdir()
    yaml = (specs / "maps" / "office.yaml").resolve()
    r = ns("campaign", "run", str(specs / "campaign.yaml"), "-o", str(tmp_path / "c"), "-j", "2", "-q", cwd=elsewhere)
    assert r.returncode == 0, r.stderr
    rows = _rows(tmp_path / "c" / "campaign.sqlite")
    assert len(rows) == 2 and all(row["outcome"] for row in rows)
    sha = {row["source_sha256"] for row in rows}
    assert {(row["source_kind"], row["source_path"]) for row in rows} == {("map", str(yaml))}
    assert len(sha) == 1 and len(next(iter(sha))) == 64
    worlds = [json.loads(p.read_text()) for p in (tmp_path / "c" / "worlds").rglob("world.json")]
    assert len(worlds) == 2 and all(w["source"]["sha256"] in sha for w in worlds)

    # analyze and gate read it; analyze names the source
    r = ns("analyze", str(tmp_path / "c"), "--json", "-", cwd=elsewhere)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["sources"] == [{"kind": "map", "path": str(yaml), "sha256": next(iter(sha))}]
    r = ns("gate", str(tmp_path / "c"), "--min-success", "0.0", cwd=elsewhere)
    assert r.returncode == 0, r.stdout + r.stderr

    # the map changes: the resume is refused (one line naming the file), nothing is written
    pgm = specs / "maps" / "office.pgm"
    before = pgm.read_bytes()
    pgm.write_bytes(before[:-1] + bytes([0 if before[-1] else 254]))
    db_before = (tmp_path / "c" / "campaign.sqlite").read_bytes()
    r = ns("campaign", "run", str(specs / "campaign.yaml"), "-o", str(tmp_path / "c"), "-j", "2", "-q", cwd=elsewhere)
    assert r.returncode == 2
    err = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(err) == 1 and str(yaml) in err[0] and "sha256" in err[0], r.stderr
    assert (tmp_path / "c" / "campaign.sqlite").read_bytes() == db_before
    # restored: it resumes (nothing left to run)
    pgm.write_bytes(before)
    r = ns("campaign", "run", str(specs / "campaign.yaml"), "-o", str(tmp_path / "c"), "-j", "2", "-q", cwd=elsewhere)
    assert r.returncode == 0, r.stderr
    assert len(_rows(tmp_path / "c" / "campaign.sqlite")) == 2

    # a search in the same office: starts and added boxes and a moved wall piece
    r = ns("search", "run", str(specs / "search.yaml"), "-o", str(tmp_path / "s"), "-j", "2", "-q", cwd=elsewhere)
    assert r.returncode == 0, r.stdout + r.stderr
    result = json.loads((tmp_path / "s" / "search.json").read_text())
    assert len(result["evaluated"]) >= 2
    for e in result["evaluated"]:
        assert 8.0 <= e["params"]["mission.start.x"] <= 9.5 and "moves.0.at_x" in e["params"]
        assert -3.0 <= e["params"]["moves.0.at_x"] <= 17.0  # drawn over the map in its own frame
    rows = _rows(tmp_path / "s" / "campaign.sqlite")
    assert rows and {(row["source_kind"], row["source_path"]) for row in rows} == {("map", str(yaml))}
    starts = [json.loads(p.read_text())["mission"]["start"] for p in (tmp_path / "s" / "worlds").rglob("world.json")]
    # in the world's frame: the source's point minus the origin (-3, 2)
    assert starts and all(11.0 - 1e-9 <= s[0] <= 12.5 + 1e-9 and 8.0 - 1e-9 <= s[1] <= 10.0 + 1e-9 for s in starts)
