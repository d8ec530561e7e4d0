"""A suite file is a campaign spec: ``examples/suite.yaml`` runs with ``navstress campaign run`` and
``navstress gate`` gates it (real missions of the reference stack on its three worlds); re-run with
another fault, the same worlds and run seeds are used (a regression suite)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from navstress.campaign.spec import load_campaign
from navstress.campaign.store import Store
from tests.support.cli_run import cli as _cli

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "suite.yaml"
KEYS = ("open", "wooded", "rough")


def test_the_example_suite_is_a_valid_campaign_spec() -> None:
    spec, _ = load_campaign(EXAMPLE)
    assert [e.name for e in spec.experiments] == ["suite"] and spec.experiments[0].explicit
    cfgs = spec.experiments[0].configurations(spec.world)
    assert tuple(c.key for c in cfgs) == KEYS and [c.map_seed for c in cfgs] == [11, 12, 13]
    for c in cfgs:
        c.world_spec()


@pytest.mark.slow
def test_campaign_run_then_gate_the_example_suite(tmp_path: Path) -> None:
    out = tmp_path / "run"
    code, stdout, err = _cli("campaign", "run", str(EXAMPLE), "-o", str(out), "-q", "-j", "2")
    assert code == 0 and stdout.startswith(f"{out}: 6/6 runs recorded"), (stdout, err)
    assert sorted(p.name for p in (out / "worlds" / "suite").iterdir()) == sorted(KEYS)
    assert (out / "spec.yaml").read_text() == EXAMPLE.read_text()
    with Store.open(out) as s:
        nominal = {(r.run_id.split("/")[1], r.run_index): r for r in s.records()}
        assert {k: r.map_seed for (k, _), r in nominal.items()} == {"open": 11, "wooded": 12, "rough": 13}

    code, stdout, err = _cli("gate", str(out), "--min-success", "0", "--json")
    assert code == 0, (stdout, err)
    data = json.loads(stdout)
    assert [(c["experiment"], c["config"], c["runs"]) for c in data["configurations"]] == [
        ("suite", k, 2) for k in KEYS]
    code, stdout, err = _cli("gate", str(out), "--min-success", "0.9")
    assert code == 1 and "gate FAILED" in stdout, (stdout, err)  # two runs per world cannot prove 90 %

    # the same suite against another version of the stack: the faulty one, same worlds and seeds
    data = yaml.safe_load(EXAMPLE.read_text())
    data["faults"] = ["small-footprint"]
    other = tmp_path / "faulty.yaml"
    other.write_text(yaml.safe_dump(data, sort_keys=False))
    code, stdout, err = _cli("campaign", "run", str(other), "-o", str(tmp_path / "faulty"), "-q", "-j", "2")
    assert code == 0, (stdout, err)
    with Store.open(tmp_path / "faulty") as s:
        faulty = {(r.run_id.split("/")[1], r.run_index): r for r in s.records()}
    assert faulty.keys() == nominal.keys()
    assert all((faulty[k].map_seed, faulty[k].run_seed) == (nominal[k].map_seed, nominal[k].run_seed) for k in faulty)
    code, stdout, err = _cli("gate", str(tmp_path / "faulty"), "--min-success", "0", "--fault", "small-footprint")
    assert code == 0 and stdout.startswith("gate passed: all 3 configurations"), (stdout, err)
    code, stdout, err = _cli("compare", str(out), str(tmp_path / "faulty"), "--a", "reference-v1",
                             "--b", "reference-v1:small-footprint")
    assert code == 0 and "6 pairs of runs with the same map and run seeds" in stdout.splitlines()[0], (stdout, err)
