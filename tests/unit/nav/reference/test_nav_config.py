"""ReferenceConfig: defaults as the paper's P3D, file loading, clear errors on bad values."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from navstress.errors import NavstressError, SpecError
from navstress.nav.reference import GlobalConfig, ReferenceConfig, load_config, parse_config


def test_defaults_match_the_paper_stack() -> None:
    cfg = ReferenceConfig()
    assert cfg.control_rate_hz == 10.0 and cfg.control_period_s == pytest.approx(0.1)
    assert cfg.n_arcs == 20 and cfg.nodes_per_arc == 15
    assert cfg.forward_arcs == 19  # + the turn on the spot = 20 paths
    assert math.isinf(cfg.unknown_cell_cost)
    assert 0.25 <= cfg.cell_m <= 0.4
    assert cfg.scan_forward_m >= 2.0 and cfg.scan_turn_deg == 360.0


def test_yaml_and_json_files_load(tmp_path: Path) -> None:
    y = tmp_path / "nav.yaml"
    y.write_text("cell_m: 0.25\nmax_speed_mps: 0.8\n")
    j = tmp_path / "nav.json"
    j.write_text(json.dumps({"replan_period_s": 5.0}))
    assert load_config(y).cell_m == 0.25
    g = load_config(j, cls=GlobalConfig)
    assert isinstance(g, GlobalConfig) and g.replan_period_s == 5.0
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert load_config(empty) == ReferenceConfig()


@pytest.mark.parametrize("data, field, words", [
    ({"cell_m": 0.0}, "cell_m", ">= 0.05"),
    ({"n_arcs": 1}, "n_arcs", ">= 2"),
    ({"n_arcs": 21}, "n_arcs", "odd"),
    ({"n_arcs": 20, "turn_in_place": False}, "n_arcs", "odd"),
    ({"max_slope_deg": 95}, "max_slope_deg", "< 90"),
    ({"unknown_cell_cost": -1.0}, "unknown_cell_cost", ">= 0"),
    ({"base_height_m": 9.0}, "base_height_m", "[0, 5]"),
    ({"arc_lenght_m": 3.0}, "arc_lenght_m", "spelling"),
    ({"control_rate_hz": "fast"}, "control_rate_hz", "number"),
    ({"obstacle_subcells": 0}, "obstacle_subcells", ">= 1"),
    ({"spin_min_bearing_deg": 200}, "spin_min_bearing_deg", "<= 180"),
    ({"curvature_spacing": "cubic"}, "curvature_spacing", "linear"),
])
def test_bad_values_name_field_value_and_range(data: dict[str, object], field: str, words: str) -> None:
    with pytest.raises(SpecError) as ei:
        parse_config(data)
    msg = str(ei.value)
    assert msg.startswith(f"{field}=") and words in msg
    assert isinstance(ei.value, NavstressError)


def test_even_fan_suggests_a_fix() -> None:
    with pytest.raises(SpecError, match="use n_arcs=22"):
        parse_config({"n_arcs": 21})


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="readable"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("cell_m: [0.3\n")
    with pytest.raises(SpecError, match="valid YAML"):
        load_config(bad)
    lst = tmp_path / "list.yaml"
    lst.write_text("- 1\n- 2\n")
    with pytest.raises(SpecError, match="mapping"):
        load_config(lst)
