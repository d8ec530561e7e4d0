"""The illumination map's descriptors: a registry of names with units and natural ranges, values
read from a world directory, a loaded world or a spec (through navstress.world.descriptors, never
recomputed by hand), the value of a world without obstacles or path, and one SpecError for an
unknown name or a world descriptor asked of a bare spec."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from navstress.errors import SpecError
from navstress.search.objectives import DESCRIPTORS, descriptor_values, get_descriptor
from navstress.world.descriptors import describe_world
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import Mission, World
from tests.support.world_fixtures import small_world


def test_registry_names_units_and_ranges() -> None:
    assert {"obstruction", "tree_obstruction", "building_obstruction", "subdivisions", "deformation", "roughness",
            "barn_dispersion", "path_ratio"} <= set(DESCRIPTORS)
    for name, d in DESCRIPTORS.items():
        assert d.name == name and d.low < d.high and d.source in ("spec", "world") and d.description
        assert d.axis_label.startswith(d.label) and (d.unit in d.axis_label)
        assert d.low <= d.missing <= d.high
        assert d.to_json()["range"] == [d.low, d.high]
    assert get_descriptor("roughness").axis_label == "roughness [m]"
    assert get_descriptor("obstruction").unit == "%"


@pytest.mark.parametrize("name, close", [("rougness", "roughness"), ("path-ratio", "path_ratio"), ("zzz", None)])
def test_unknown_name_is_one_spec_error(name: str, close: str | None) -> None:
    with pytest.raises(SpecError) as ei:
        get_descriptor(name, "objective.descriptors")
    e = ei.value
    assert e.field == "objective.descriptors" and e.value == name and "roughness" in e.expected
    assert (close is None) or (e.fix is not None and close in e.fix)
    with pytest.raises(SpecError):
        descriptor_values([name], WorldSpec())


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> tuple[World, Path]:
    spec = WorldSpec(size_m=(30.0, 30.0), cell_m=0.5, ground={"subdivisions": 3, "deformation": 1.5},
                     obstacles={"obstruction": {"tree": 4.0, "building": 6.0}},
                     mission={"inset_m": 3.0, "min_distance_m": 10.0, "free_radius_m": 2.0})
    w = generate(spec, 5)
    d = tmp_path_factory.mktemp("desc") / "w"
    w.save(d)
    return w, d


def test_values_from_a_world_directory_match_the_worlds_descriptors(generated: tuple[World, Path]) -> None:
    w, d = generated
    names = list(DESCRIPTORS)
    vals = descriptor_values(names, d)
    assert vals == descriptor_values(names, w) and all(math.isfinite(v) for v in vals)
    got = dict(zip(names, vals))
    desc = w.descriptors
    assert got["obstruction"] == desc["obstruction_total_pct"]
    assert got["tree_obstruction"] == desc["obstruction_pct"]["tree"] > 0
    assert got["building_obstruction"] == desc["obstruction_pct"]["building"] > 0
    assert got["roughness"] == desc["roughness_m"] > 0 and got["slope_p95"] == desc["slope_p95_deg"]
    assert got["barn_dispersion"] == desc["barn_dispersion"]
    assert got["path_ratio"] == (desc["path_ratio"] if desc["feasible"] else 3.0)
    assert (got["subdivisions"], got["deformation"], got["obstruction_target"]) == (3.0, 1.5, 10.0)


def test_spec_descriptors_from_a_bare_spec_and_world_ones_refused() -> None:
    spec = WorldSpec(ground={"subdivisions": 4, "deformation": 2.0}, obstacles={"total": 12.0,
                                                                                 "mix": {"tree": 1, "building": 2}})
    assert descriptor_values(["subdivisions", "deformation", "obstruction_target"], spec) == (4.0, 2.0, 12.0)
    with pytest.raises(SpecError, match="give the generated world") as ei:
        descriptor_values(["subdivisions", "roughness"], spec, field="search.descriptors")
    assert ei.value.field == "search.descriptors" and ei.value.value == "roughness"


def test_a_world_without_stored_descriptors_is_described_by_the_world_module() -> None:
    w = small_world(3)
    assert not w.descriptors
    ref = describe_world(w)
    assert descriptor_values(["roughness", "barn_dispersion", "obstruction"], w) == (
        ref["roughness_m"], ref["barn_dispersion"], ref["obstruction_total_pct"])


def test_missing_values_take_the_descriptors_stand_in() -> None:
    """No obstacle: BARN metrics have no value (dispersion 0, visibility the ray cap); goal walled
    off: no path (the path ratio's top)."""
    empty = World.flat(WorldSpec(size_m=(20.0, 20.0), cell_m=0.5), 0)
    empty = World(empty.spec, 0, empty.terrain, (), empty.mission, describe_world(empty))
    assert empty.descriptors["barn_dispersion"] is None
    assert descriptor_values(["barn_dispersion", "barn_visibility", "tree_obstruction"], empty) == (0.0, 10.0, 0.0)
    w = small_world(1, bumpy=False)
    walled = World(w.spec, 1, w.terrain, w.obstacles, Mission((2.0, 2.0, 0.0), (12.0, 6.0), 1.0))
    walled = World(walled.spec, 1, walled.terrain, walled.obstacles, walled.mission, describe_world(walled))
    assert walled.descriptors["feasible"] is False
    assert descriptor_values(["path_ratio"], walled) == (3.0,)


def test_docs_list_every_descriptor_with_its_unit_and_range() -> None:
    text = (Path(__file__).resolve().parents[3] / "docs" / "search.md").read_text(encoding="utf-8")
    section = text.split("## Objectives", 1)[1].split("\n## ", 1)[0]
    for d in DESCRIPTORS.values():
        row = f"| `{d.name}` | {d.unit or '-'} | {d.low:g} to {d.high:g} | {d.source} |"
        assert row in section, row
