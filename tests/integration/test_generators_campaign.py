"""A ``rooms`` and a ``clutter`` campaign run end to end (examples/rooms.yaml and clutter.yaml cut
to 2 maps x 1 run of one configuration with a short timeout): the Jackal with its 2D scanner and
reference-2d-v1, real missions; every run is recorded on a world of the right generator, and the
worlds carry their BARN metrics."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from navstress.campaign.store import Store
from tests.support.cli_run import cli as _cli

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.slow
@pytest.mark.parametrize("name,path,value", [("rooms", "rooms.furniture_pct", 10), ("clutter", "clutter.fill_pct", 20)])
def test_a_tiny_generator_campaign_runs(tmp_path: Path, name: str, path: str, value: float) -> None:
    data = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    data["experiments"][0]["sweep"] = {path: {"values": [value]}}
    data.update(maps_per_config=2, runs_per_map=1, timeout_s=15.0)
    spec = tmp_path / f"{name}.yaml"
    spec.write_text(yaml.safe_dump(data, sort_keys=False))
    out = tmp_path / "run"
    code, stdout, err = _cli("campaign", "run", str(spec), "-o", str(out), "-q", "-j", "1")
    assert code == 0 and stdout.startswith(f"{out}: 2/2 runs recorded"), (stdout, err)
    with Store.open(out) as s:
        records = list(s.records())
    assert len(records) == 2 and len({r.map_seed for r in records}) == 2
    worlds = sorted((out / "worlds").rglob("world.json"))
    assert len(worlds) == 2
    for w in worlds:
        meta = json.loads(w.read_text())
        assert meta["spec"]["generator"] == name and "barn" in meta["descriptors"]
