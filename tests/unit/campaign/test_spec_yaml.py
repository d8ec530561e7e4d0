"""The text of a campaign spec made in code (``spec_yaml``: what a store writes as ``spec.yaml`` for
a search's campaign, which the engine never reads back to run): it reads back as the same spec, for
every preset and example rebuilt from its parts, and ``Store.create``/``Store.extend`` without a
text write exactly it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from navstress._models import parse
from navstress.campaign.presets import PRESETS, preset
from navstress.campaign.spec import (TEXT_ORDER, CampaignSpec, ExperimentSpec, WorldEntry, load_campaign,
                                     parse_campaign, parse_campaign_text, spec_yaml)
from navstress.campaign.store import Store

ROOT = Path(__file__).resolve().parents[3]


def _specs() -> dict[str, CampaignSpec]:
    out = {name: parse_campaign(preset(name), max_runs=None) for name in PRESETS}
    for name in ("suite.yaml", "jackal_2d.yaml", "jackal_2d_depth.yaml", "rooms.yaml", "clutter.yaml", "ros2/campaign.yaml"):
        out[f"examples/{name}"] = load_campaign(ROOT / "examples" / name)[0]
    return out


SPECS = _specs()


def in_code(spec: CampaignSpec) -> CampaignSpec:
    """``spec`` made again from its parts (the fields it was given, as values, not text)."""
    return parse(CampaignSpec, {k: getattr(spec, k) for k in spec.model_fields_set})


def test_the_text_order_names_every_field_once() -> None:
    assert sorted(TEXT_ORDER) == sorted(CampaignSpec.model_fields)


@pytest.mark.parametrize("name", sorted(SPECS))
def test_the_text_of_a_spec_made_in_code_reads_back_as_it(name: str) -> None:
    spec = in_code(SPECS[name])
    text = spec_yaml(spec)
    back = parse_campaign_text(text, max_runs=None)
    assert back.digest() == spec.digest() == SPECS[name].digest()
    assert back.model_fields_set == spec.model_fields_set
    assert spec_yaml(in_code(back)) == text


def _grown(spec: CampaignSpec, n: int) -> CampaignSpec:
    extra = [ExperimentSpec(name=f"g{i:04d}", worlds=[WorldEntry(key=f"w{i}", map_seed=i, world={})])
             for i in range(n)]
    data: dict[str, Any] = {k: getattr(spec, k) for k in spec.model_fields_set}
    return parse(CampaignSpec, {**data, "experiments": [*spec.experiments, *extra]})


def test_the_store_writes_the_text_of_a_spec_made_in_code(tmp_path: Path) -> None:
    base = in_code(SPECS["examples/suite.yaml"])
    with Store.create(tmp_path, base) as s:
        assert (tmp_path / "spec.yaml").read_text(encoding="utf-8") == spec_yaml(base)
        for n in (1, 2):
            grown = _grown(base, n)
            assert s.extend(grown) > 0
            assert (tmp_path / "spec.yaml").read_text(encoding="utf-8") == spec_yaml(grown)
            assert s.spec.digest() == grown.digest() and s.spec_text() == spec_yaml(grown)
    with Store.create(tmp_path, grown) as s:  # resumed with the same spec
        assert s.spec.digest() == grown.digest()


def test_a_world_entry_without_sensor_values_has_the_text_of_before() -> None:
    """A suite's or a spec's explicit world writes ``sensors`` only when it sets sensor values
    (a search's suite.yaml of before sensors were declared stays byte for byte the same)."""
    plain = WorldEntry(key="w1", map_seed=3)
    assert plain.text_data() == {"key": "w1", "map_seed": 3, "world": {}}
    valued = WorldEntry(key="w2", map_seed=4, sensors={"sensors.laser.max_range_m": 5.0})
    assert valued.text_data()["sensors"] == {"sensors.laser.max_range_m": 5.0}
