"""WorldSpec validation: every bad value names its field, its value and what is allowed."""

from pathlib import Path

import pytest

from navstress.errors import SpecError
from navstress.world import WorldSpec, load_spec, parse_spec

BAD = [
    ({"size_m": [-100, 100]}, "size_m.x", "-100"),
    ({"size_m": [100, 0]}, "size_m.y", "0"),
    ({"size_m": [100.3, 100]}, "size_m.x", "100.3"),
    ({"cell_m": "fine"}, "cell_m", "fine"),
    ({"cell_m": 0}, "cell_m", "0"),
    ({"ground": {"subdivisions": -1}}, "ground.subdivisions", "-1"),
    ({"ground": {"deformation": -0.5}}, "ground.deformation", "-0.5"),
    ({"ground": {"model": "perlin"}}, "ground.model", "perlin"),
    ({"obstacles": {"obstruction": {"tree": 100}}}, "obstacles.obstruction.tree", "100"),
    ({"obstacles": {"obstruction": {"tree": -1}}}, "obstacles.obstruction.tree", "-1"),
    ({"obstacles": {"obstruction": {"rock": 5}}}, "obstacles.obstruction.rock", "rock"),
    ({"obstacles": {"obstruction": {"tree": 60, "building": 45}}}, "obstacles.obstruction", "105"),
    ({"obstacles": {"total": 20}}, "obstacles.mix", "None"),
    ({"obstacles": {"total": 20, "mix": {"shrub": 1}}}, "obstacles.mix.shrub", "shrub"),
    ({"obstacles": {"total": 120, "mix": {"tree": 1}}}, "obstacles.total", "120"),
    ({"mission": {"goal": [150, 50]}}, "mission.goal", "150"),
    ({"groundz": {}}, "groundz", "{}"),
]


@pytest.mark.parametrize("data,field,value", BAD, ids=[b[1] + "=" + b[2] for b in BAD])
def test_bad_spec_names_field_and_value(data: dict, field: str, value: str) -> None:
    with pytest.raises(SpecError) as info:
        parse_spec(data)
    msg = str(info.value)
    assert msg.startswith(field + "="), msg
    assert value in msg.split("is invalid")[0], msg
    assert "expected" in msg and "\n" not in msg


def test_defaults_are_the_papers() -> None:
    s = WorldSpec()
    assert s.size_m == (100.0, 100.0)
    assert 0.25 <= s.cell_m <= 0.4
    assert s.grid_shape == (251, 251)
    assert s.obstacles.all_types()["tree"].base_m == (1.0, 1.0)
    assert s.obstacles.all_types()["building"].base_m == (9.0, 9.0)


def test_total_and_mix_split_by_weights() -> None:
    s = parse_spec({"obstacles": {"total": 20, "mix": {"tree": 3, "building": 1}}})
    assert s.obstacles.targets() == {"building": 5.0, "tree": 15.0}


def test_user_types_with_variability() -> None:
    s = parse_spec({"obstacles": {"types": {"rock": {"base_m": [2, 3], "height_m": 1, "variability": 0.3}},
                                  "obstruction": {"rock": 4}}})
    assert s.obstacles.targets() == {"rock": 4.0}


def test_load_spec_yaml_json_and_errors(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text("ground:\n  subdivisions: 4\n  deformation: 2\n")
    assert load_spec(tmp_path / "a.yaml").ground.subdivisions == 4
    (tmp_path / "a.json").write_text('{"obstacles": {"obstruction": {"tree": 6}}}')
    assert load_spec(tmp_path / "a.json").obstacles.targets() == {"tree": 6.0}
    (tmp_path / "bad.yaml").write_text("ground: [1, 2\n")
    with pytest.raises(SpecError, match="valid YAML"):
        load_spec(tmp_path / "bad.yaml")
    with pytest.raises(SpecError, match="readable"):
        load_spec(tmp_path / "missing.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(SpecError, match="mapping"):
        load_spec(tmp_path / "list.yaml")
