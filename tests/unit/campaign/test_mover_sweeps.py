"""Mover counts, mover types' parameters and behaviour parameters are WorldSpec paths that a
campaign sweeps."""

from __future__ import annotations

from typing import Any

import pytest

from navstress.campaign.spec import parse_campaign
from navstress.errors import SpecError

BASE_WORLD: dict[str, Any] = {"size_m": [40.0, 40.0], "movers": {
    "count": {"pedestrian": 1}, "behaviour": {"pedestrian": {"kind": "intercept"}}}}


def campaign(sweep: dict[str, Any], world: dict[str, Any] | None = None) -> Any:
    return parse_campaign({"name": "m", "world": BASE_WORLD if world is None else world,
                           "experiments": [{"name": "e", "sweep": sweep}], "maps_per_config": 1, "runs_per_map": 1})


def test_a_campaign_sweeps_mover_count_type_and_behaviour_parameters() -> None:
    spec = campaign({"movers.count.pedestrian": {"values": [0, 5]},
                     "movers.types.pedestrian.speed_max_m_s": {"values": [1.0, 2.0]},
                     "movers.behaviour.pedestrian.ttc_s": {"start": 0.0, "stop": 2.0, "step": 2.0}})
    cfgs = spec.experiments[0].configurations(spec.world)
    assert [c.key for c in cfgs][:2] == ["pedestrian=0,speed_max_m_s=1,ttc_s=0", "pedestrian=0,speed_max_m_s=1,ttc_s=2"]
    assert len(cfgs) == 8
    last = cfgs[-1].world_spec()
    assert last.movers.counts(last.size_m) == {"pedestrian": 5}
    assert last.movers.all_types()["pedestrian"].speed_max_m_s == 2.0
    assert last.movers.all_types()["pedestrian"].length_m == 0.5  # the built-in's other fields kept
    assert last.movers.behaviour_of("pedestrian").kind == "intercept"
    assert last.movers.behaviour_of("pedestrian").ttc_s == 2.0


def test_a_density_sweep_on_a_world_without_movers() -> None:
    spec = campaign({"movers.density_per_ha.vehicle": {"values": [0, 6.25]}}, world={"size_m": [40.0, 40.0]})
    worlds = [c.world_spec() for c in spec.experiments[0].configurations(spec.world)]
    assert [w.movers.counts(w.size_m) for w in worlds] == [{"vehicle": 0}, {"vehicle": 1}]


@pytest.mark.parametrize("path,field", [
    ("movers.count.pedestrian.x", "experiments[0].sweep"),
    ("movers.behaviour.pedestrian.nosuch", "experiments[0].sweep"),
    ("movers.behaviour.pedestrian", "experiments[0].sweep"),
])
def test_bad_mover_sweep_paths(path: str, field: str) -> None:
    with pytest.raises(SpecError) as e:
        campaign({path: {"values": [1]}})
    assert e.value.field == field and e.value.value == path


def test_a_swept_behaviour_parameter_its_kind_does_not_take_is_refused() -> None:
    with pytest.raises(SpecError) as e:
        campaign({"movers.behaviour.pedestrian.trigger_m": {"values": [5]}})
    assert e.value.field == "experiments[0].sweep[trigger_m=5].movers.behaviour.pedestrian.trigger_m"
    assert "kind intercept" in str(e.value)
