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
    ({"obstacles": {"total": 20}}, "obstacles.mix", "<missing>"),
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
    if value == "<missing>":
        assert msg.startswith(field + " is missing: "), msg
    else:
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


# ---- memory: a world too large for memory is refused before anything is allocated ----------

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from navstress.world.spec import BYTES_PER_VERTEX, MAX_WORLD_GIB_ENV, max_world_bytes  # noqa: E402


def test_huge_map_is_refused_naming_size_cell_and_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(MAX_WORLD_GIB_ENV, raising=False)
    with pytest.raises(SpecError) as info:
        parse_spec({"size_m": [2000, 2000], "cell_m": 0.05})
    msg = str(info.value)
    assert "size_m=" in msg and "2000x2000" in msg and "cell_m=0.05" in msg and "GiB" in msg
    assert MAX_WORLD_GIB_ENV in msg and "40001x40001" in msg


def test_memory_limit_is_overridable_and_its_env_value_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    spec = {"size_m": [1000, 1000], "cell_m": 0.1}  # 10001^2 vertices: about 19 GiB
    with pytest.raises(SpecError, match="GiB"):
        parse_spec(spec)
    monkeypatch.setenv(MAX_WORLD_GIB_ENV, "64")
    assert parse_spec(spec).grid_shape == (10001, 10001)
    for bad in ("lots", "-1", "nan", "inf", "0"):
        monkeypatch.setenv(MAX_WORLD_GIB_ENV, bad)
        with pytest.raises(SpecError, match=MAX_WORLD_GIB_ENV):
            parse_spec(spec)


@settings(max_examples=60, deadline=None)
@given(size=st.integers(10, 2000), cell=st.sampled_from([0.05, 0.1, 0.2, 0.25, 0.4, 0.5, 1.0, 2.0]))
def test_every_size_and_cell_in_range_is_accepted_iff_its_estimate_fits(size: int, cell: float) -> None:
    n = size / cell
    if abs(n - round(n)) > 1e-6:
        return
    rows = cols = round(n) + 1
    fits = rows * cols * BYTES_PER_VERTEX < max_world_bytes() - (256 << 20)
    try:
        s = parse_spec({"size_m": [size, size], "cell_m": cell})
    except SpecError as e:
        assert not fits and "GiB" in str(e)
    else:
        assert s.memory_estimate_bytes <= max_world_bytes()


def test_campaign_checks_every_configuration_for_memory_up_front() -> None:
    from navstress.campaign.spec import parse_campaign

    with pytest.raises(SpecError, match=r"experiments\[0\].sweep\[cell_m=0.05\].size_m=.*GiB"):
        parse_campaign({"world": {"size_m": [2000, 2000]}, "experiments": [
            {"name": "e", "sweep": {"cell_m": {"values": [0.4, 0.05]}}}]})


def test_cli_generate_refuses_a_huge_map_in_one_line_without_allocating(tmp_path: Path) -> None:
    import resource

    from typer.testing import CliRunner

    import navstress.cli.world  # noqa: F401  (imported before the measure: the refusal alone is measured)
    from navstress.cli import app

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    r = CliRunner().invoke(app, ["world", "generate", "--size", "2000", "--cell", "0.05", "-o", str(tmp_path / "w")])
    assert r.exit_code == 2 and r.stderr.startswith("error: --size=") and r.stderr.count("\n") == 1, r.stderr
    assert "cell_m=0.05" in r.stderr and "GiB" in r.stderr
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KiB: nothing big allocated
    assert not (tmp_path / "w").exists()


# ---- a damaged world directory is a WorldFileError, whatever the damage ------------------------

@pytest.mark.parametrize("name,data", [
    ("world.json", bytes(range(256))), ("world.json", b"[" * 100_000), ("world.json", b"{\"a\": " * 50_000),
    ("world.json", b"[1, 2]"), ("world.json", b"null"), ("world.json", b'{"spec": "x", "seed": 1}'),
    ("world.json", b""), ("terrain.npz", b"PK\x03\x04garbage"), ("terrain.npz", b"hello"),
    ("terrain.npz", b""), ("terrain.npz", bytes(range(256)) * 10),
])
def test_damaged_world_files_are_one_world_file_error(tmp_path: Path, name: str, data: bytes) -> None:
    import shutil

    from tests.support.world_fixtures import small_world
    from navstress.errors import WorldFileError
    from navstress.world import World

    small_world().save(tmp_path / "ok")
    d = tmp_path / "bad"
    shutil.copytree(tmp_path / "ok", d)
    (d / name).write_bytes(data)
    with pytest.raises(WorldFileError, match="is corrupt"):
        World.load(d)
