"""A search varies mover counts, mover types' parameters and behaviour parameters (WorldSpec paths)."""

from __future__ import annotations

from typing import Any

import pytest

from navstress.errors import SpecError
from navstress.search.space import Space
from navstress.search.spec import parse_search
from navstress.world.spec import parse_spec

BASE: dict[str, Any] = {
    "name": "s", "seed": 1,
    "world": {"size_m": [40.0, 40.0], "movers": {"behaviour": {"pedestrian": {"kind": "intercept"}}}},
    "space": {"map_seed": False, "parameters": [
        {"path": "movers.count.pedestrian", "low": 0, "high": 8, "kind": "int"},
        {"path": "movers.behaviour.pedestrian.ttc_s", "low": 0.0, "high": 3.0},
        {"path": "movers.behaviour.pedestrian.speed_m_s", "low": 0.5, "high": 2.0},
        {"path": "movers.types.pedestrian.speed_max_m_s", "low": 1.5, "high": 3.0},
        {"path": "movers.density_per_ha.vehicle", "low": 0.0, "high": 10.0},
    ]},
    "objective": {"name": "failure"}, "budget": {"runs": 100},
}


def test_search_parameters_on_movers_decode_to_valid_worlds() -> None:
    spec = parse_search(BASE)
    space = Space.from_spec(spec)
    c = space.decode([1.0, 0.5, 0.0, 1.0, 1.0])
    assert c.params == {"movers.count.pedestrian": 8, "movers.behaviour.pedestrian.ttc_s": 1.5,
                        "movers.behaviour.pedestrian.speed_m_s": 0.5, "movers.types.pedestrian.speed_max_m_s": 3.0,
                        "movers.density_per_ha.vehicle": 10.0}
    w = parse_spec(space.world(c))
    assert w.movers.counts(w.size_m) == {"pedestrian": 8, "vehicle": 2}
    assert w.movers.behaviour_of("pedestrian").ttc_s == 1.5 and w.movers.behaviour_of("pedestrian").kind == "intercept"
    assert w.movers.all_types()["pedestrian"].speed_max_m_s == 3.0


def test_a_count_searched_as_float_is_refused() -> None:
    data = {**BASE, "space": {"parameters": [{"path": "movers.count.pedestrian", "low": 0, "high": 8}]}}
    with pytest.raises(SpecError) as e:
        parse_search(data)
    assert e.value.field == "space.parameters[0].kind"


def test_corners_that_make_invalid_movers_are_refused() -> None:
    data = {**BASE, "space": {"parameters": [{"path": "movers.types.pedestrian.speed_min_m_s", "low": 0.0, "high": 3.0}]}}
    with pytest.raises(SpecError) as e:
        parse_search(data)
    assert e.value.field == "space" and "speed_min_m_s" in str(e.value)
