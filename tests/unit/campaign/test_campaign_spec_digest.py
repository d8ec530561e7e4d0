"""Stored campaigns keep resuming: the canonical text (and digest) of specs written before a
field was added stays byte-identical (``Store.create`` refuses a stored campaign whose digest differs)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.campaign.presets import paper
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store

FULL: dict[str, Any] = {
    "name": "full", "seed": 5, "world": {"size_m": [30, 30]},
    "experiments": [{"name": "a", "sweep": {"ground.deformation": {"values": [0, 1]}},
                     "overrides": {"ground": {"subdivisions": 3}}, "faults": [None], "runs_per_map": 2},
                    {"name": "b", "runs_per_map": {"adaptive": {"min": 2, "max": 4}}}],
    "maps_per_config": 2, "runs_per_map": 3, "navigators": [{"name": "reference-v1", "config": {"a": 1}}],
    "faults": [None, "small-footprint"], "timeout_s": 50, "sim": {"physics_hz": 500}, "record_lidar": True}

#: The demo preset as it was before its ``movers`` class (a campaign stored from it keeps resuming).
DEMO_BEFORE_MOVERS: dict[str, Any] = {
    "name": "demo", "seed": 7, "world": {"size_m": [40.0, 40.0], "cell_m": 0.4},
    "experiments": [
        {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 6, 10, 14]}}},
        {"name": "smooth-s4", "overrides": {"ground": {"subdivisions": 4}},
         "sweep": {"ground.deformation": {"values": [0.5, 1.0, 1.5]}}, "faults": [None],
         "runs_per_map": {"adaptive": {"min": 2, "max": 5, "threshold": 0.5, "confidence": 0.75}}}],
    "maps_per_config": 2, "runs_per_map": 3, "navigators": [{"name": "reference-v1", "config": {}}],
    "faults": [None, "small-footprint"], "timeout_s": 120.0, "goal_tolerance_m": 2.0}

#: The paper preset as it was before its ground classes moved to ``model: blender`` (issue 33).
PAPER_BEFORE_BLENDER: dict[str, Any] = {
    "name": "paper", "seed": 2016, "world": {"size_m": [100.0, 100.0], "cell_m": 0.4},
    "experiments": [
        {"name": "buildings", "sweep": {"obstacles.obstruction.building": {"start": 0, "stop": 28, "step": 2}}},
        {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 14, "step": 1}}},
        *({"name": f"smooth-s{s}", "overrides": {"ground": {"subdivisions": s}},
           "sweep": {"ground.deformation": {"start": 0.0, "stop": 3.0, "step": 0.25}}, "faults": [None]}
          for s in (2, 4, 6))],
    "maps_per_config": 5, "runs_per_map": 5, "navigators": [{"name": "reference-v1", "config": {}}],
    "faults": [None, "small-footprint"], "timeout_s": 400.0, "goal_tolerance_m": 2.0}

#: The canonical text of FULL as stored by navstress before explicit-world experiments existed.
FULL_JSON = (
    '{"experiments":[{"faults":[null],"name":"a","overrides":{"ground":{"subdivisions":3}},"runs_per_map":2,'
    '"sweep":{"ground.deformation":{"start":null,"step":null,"stop":null,"values":[0,1]}}},{"faults":null,'
    '"name":"b","overrides":{},"runs_per_map":{"adaptive":{"confidence":0.95,"max":4,"min":2,"threshold":0.8}},'
    '"sweep":{}}],"faults":[null,"small-footprint"],"goal_tolerance_m":2.0,"maps_per_config":2,"name":"full",'
    '"navigators":[{"config":{"a":1},"name":"reference-v1","target":null}],"record_lidar":true,"runs_per_map":3,'
    '"seed":5,"sim":{"physics_hz":500},"timeout_s":50.0,"world":{"size_m":[30,30]}}')


@pytest.mark.parametrize("data,digest", [(DEMO_BEFORE_MOVERS, "9423f7840da77591"),
                                         (PAPER_BEFORE_BLENDER, "59e25e1a2a87f2fb"), (FULL, "67b728d246383c1b")])
def test_digest_of_existing_specs_is_unchanged(data: dict[str, Any], digest: str) -> None:
    assert parse_campaign(data, max_runs=None).digest() == digest


def test_the_paper_preset_changed_with_its_ground() -> None:
    """A campaign stored from the preset before issue 33 is another spec: it resumes as it was
    (above), and the new preset starts a new campaign (the store refuses to mix them)."""
    assert parse_campaign(paper(), max_runs=None).digest() != "59e25e1a2a87f2fb"


def test_recording_the_navigators_view_is_another_spec_and_reaches_every_run() -> None:
    from navstress.campaign.plan import plan as build_plan

    spec = parse_campaign({**FULL, "record_navigator": True})
    assert spec.digest() != parse_campaign(FULL).digest()
    assert json.loads(spec.canonical_json())["record_navigator"] is True
    assert parse_campaign({**FULL, "record_navigator": False}).canonical_json() == FULL_JSON
    tasks = build_plan(spec, Path("/nowhere")).tasks
    assert tasks and all(t.record_navigator for t in tasks)
    assert not any(t.record_navigator for t in build_plan(parse_campaign(FULL), Path("/nowhere")).tasks)


def test_canonical_text_of_an_existing_spec_is_unchanged() -> None:
    spec = parse_campaign(FULL)
    assert spec.canonical_json() == FULL_JSON
    assert parse_campaign(json.loads(FULL_JSON)).canonical_json() == FULL_JSON


def test_a_store_made_before_explicit_worlds_resumes(tmp_path: Path) -> None:
    """A store whose meta holds the text and digest written before explicit worlds existed."""
    spec = parse_campaign(FULL)
    text = yaml.safe_dump(FULL)
    with Store.create(tmp_path, spec, text) as s:
        ids = s.planned_ids()
        s.con.execute("UPDATE meta SET value = ? WHERE key = 'spec_json'", (FULL_JSON,))
        s.con.execute("UPDATE meta SET value = '67b728d246383c1b' WHERE key = 'spec_digest'")
    with Store.create(tmp_path, parse_campaign(yaml.safe_load(text)), text) as s:
        assert s.spec == spec and s.planned_ids() == ids
        assert [t.run_id for t in s.pending()] == [i for i in ids if i in s.plan().due({})]
