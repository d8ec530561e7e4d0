"""SearchSpec validation: a table of bad inputs (each one SpecError naming its field, on one line),
the defaults, loading from a file, the budget override, and arbitrary input never raising
anything but SpecError."""

from __future__ import annotations

import copy
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.search.spec import (ALGORITHM_SETTINGS, DEFAULT_DESCRIPTORS, OBJECTIVE_OPTIONS, AdaptiveRuns,
                                   SearchSpec, load_search, parse_search, parse_search_text, with_budget)

BASE: dict[str, Any] = {
    "name": "s", "seed": 1, "world": {"size_m": [40.0, 40.0], "cell_m": 0.5},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 20},
                             {"path": "ground.subdivisions", "low": 0, "high": 6, "kind": "int"}]},
    "objective": {"name": "failure"}, "budget": {"runs": 400},
}


def _with(mod: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    d = copy.deepcopy(BASE)
    mod(d)
    return d


def _param(path: str, low: float, high: float, kind: str = "float") -> Callable[[dict[str, Any]], None]:
    return lambda d: d["space"]["parameters"].append({"path": path, "low": low, "high": high, "kind": kind})


def _set(*keys: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def mod(d: dict[str, Any]) -> None:
        node = d
        for k in keys[:-1]:
            node = node.setdefault(k, {})
        node[keys[-1]] = value
    return mod


# (what, mutation of BASE, the field the error names)
BAD: list[tuple[str, Callable[[dict[str, Any]], None], str]] = [
    ("unknown parameter", _param("ground.deformaton", 0, 1), "space.parameters[2].path"),
    ("unknown parameter section", _param("grund.deformation", 0, 1), "space.parameters[2].path"),
    ("unknown obstacle type", _param("obstacles.obstruction.tre", 0, 1), "space.parameters[2].path"),
    ("unknown type's variability", _param("obstacles.types.bush.variability", 0, 0.5), "space.parameters[2].path"),
    ("a type's tuple field", _param("obstacles.types.tree.base_m", 0, 1), "space.parameters[2].path"),
    ("not a number", _param("ground.model", 0, 1), "space.parameters[2].path"),
    ("a tuple", _param("mission.start", 0, 1), "space.parameters[2].path"),
    ("the terrain cell", _param("cell_m", 0.2, 1), "space.parameters[2].path"),
    ("a path too long", _param("ground.deformation.x", 0, 1), "space.parameters[2].path"),
    ("a path too short", _param("ground", 0, 1), "space.parameters[2].path"),
    ("a path given twice", _param("obstacles.obstruction.tree", 0, 5), "space.parameters[2].path"),
    ("an empty range", _param("ground.deformation", 1, 1), "space.parameters[2]"),
    ("an inverted range", _param("ground.deformation", 2, 1), "space.parameters[2]"),
    ("an infinite bound", _param("ground.deformation", 0, float("inf")), "space.parameters[2].high"),
    ("a NaN bound", _param("ground.deformation", float("nan"), 1), "space.parameters[2].low"),
    ("float kind on an integer", _param("ground.octaves", 1, 5), "space.parameters[2].kind"),
    ("fractional int bounds", _param("ground.deformation", 0, 2.5, "int"), "space.parameters[2]"),
    ("an unknown kind", _param("ground.deformation", 0, 2, "double"), "space.parameters[2].kind"),
    ("a corner beyond the world's bounds", _param("ground.deformation", 0, 60), "space"),
    ("corners summing over 100 %", _param("obstacles.obstruction.building", 0, 85), "space"),
    ("a map side with no grid multiple", _param("size_m", 30.1, 30.2), "space.parameters[2]"),
    ("an integer map side", _param("size_m", 30, 40, "int"), "space.parameters[2].kind"),
    ("a map too small for the mission", _param("size_m", 4, 40), "space"),
    ("no parameters and a fixed seed", lambda d: d.update(space={"parameters": [], "map_seed": False}), "space"),
    ("zero map seeds", _set("space", "map_seeds", value=0), "space.map_seeds"),
    ("an unknown key", _set("colour", value=1), "colour"),
    ("an unknown space key", _set("space", "colour", value=1), "space.colour"),
    ("an unknown parameter key", lambda d: d["space"]["parameters"][0].update(step=1),
     "space.parameters[0].step"),
    ("an unknown budget key", _set("budget", "hours", value=1), "budget.hours"),
    ("a budget of 0", _set("budget", "runs", value=0), "budget.runs"),
    ("a negative budget", _set("budget", "runs", value=-10), "budget.runs"),
    ("a fractional budget", _set("budget", "runs", value=10.5), "budget.runs"),
    ("a budget below one generation", _set("budget", "runs", value=79), "budget.runs"),
    ("a huge budget", _set("budget", "runs", value=10**12), "budget.runs"),
    ("zero sim hours", _set("budget", "sim_hours", value=0), "budget.sim_hours"),
    ("negative wall time", _set("budget", "wall_s", value=-1), "budget.wall_s"),
    ("no budget", lambda d: d.pop("budget"), "budget"),
    ("no space", lambda d: d.pop("space"), "space"),
    ("no objective", lambda d: d.pop("objective"), "objective"),
    ("an objective that is not a mapping", _set("objective", value="failure"), "objective"),
    ("an unknown objective", _set("objective", "name", value="failures"), "objective.name"),
    ("an unknown outcome class", _set("objective", "outcome", value="crash"), "objective.outcome"),
    ("another objective's option", _set("objective", "target", value=0.3), "objective.target"),
    ("an unknown objective option", _set("objective", "colour", value=0.3), "objective.colour"),
    ("boundary target 1", lambda d: d.update(objective={"name": "boundary", "target": 1.0}), "objective.target"),
    ("boundary target 0", lambda d: d.update(objective={"name": "boundary", "target": 0}), "objective.target"),
    ("fault-revealing without a fault", lambda d: d.update(objective={"name": "fault-revealing"}), "objective.fault"),
    ("fault-revealing, faults without nominal", lambda d: d.update(
        objective={"name": "fault-revealing", "fault": "small-footprint"}, faults=["small-footprint"]), "faults"),
    ("fault-revealing, faults without the fault", lambda d: d.update(
        objective={"name": "fault-revealing", "fault": "small-footprint"}, faults=[None, "stale-map"]), "faults"),
    ("a bad fault name", lambda d: d.update(faults=[None, "a b"]), "faults"),
    ("duplicate faults", lambda d: d.update(faults=[None, None]), "faults"),
    ("illumination without descriptors", lambda d: d.update(objective={"name": "illumination"}),
     "objective.descriptors"),
    ("illumination with one descriptor", lambda d: d.update(objective={"name": "illumination", "descriptors": [
        {"name": "roughness", "low": 0, "high": 1}]}), "objective.descriptors"),
    ("illumination with an unknown descriptor", lambda d: d.update(objective={"name": "illumination", "descriptors": [
        {"name": "roughness", "low": 0, "high": 1}, {"name": "rugosity", "low": 0, "high": 1}]}),
     "objective.descriptors[1].name"),
    ("illumination with a descriptor twice", lambda d: d.update(objective={"name": "illumination", "descriptors": [
        {"name": "roughness", "low": 0, "high": 1}, {"name": "roughness", "low": 0, "high": 2}]}),
     "objective.descriptors"),
    ("illumination with an empty descriptor range", lambda d: d.update(objective={
        "name": "illumination", "descriptors": [{"name": "roughness", "low": 1, "high": 1},
                                                {"name": "path_ratio", "low": 1, "high": 2}]}),
     "objective.descriptors[0]"),
    ("illumination with zero cells", lambda d: d.update(objective={"name": "illumination", "descriptors": [
        {"name": "roughness", "low": 0, "high": 1, "cells": 0}, {"name": "path_ratio", "low": 1, "high": 2}]}),
     "objective.descriptors[0].cells"),
    ("descriptors in both places", lambda d: d.update(
        objective={"name": "illumination", "descriptors": [dict(x) for x in DEFAULT_DESCRIPTORS]},
        algorithm={"name": "map-elites", "descriptors": [dict(x) for x in DEFAULT_DESCRIPTORS]}),
     "algorithm.descriptors"),
    ("an unknown algorithm", _set("algorithm", "name", value="cmaes"), "algorithm.name"),
    ("another algorithm's setting", lambda d: d.update(algorithm={"name": "ga", "sigma": 0.2}), "algorithm.sigma"),
    ("an unknown setting", lambda d: d.update(algorithm={"name": "random", "pop": 3}), "algorithm.pop"),
    ("an algorithm that is not a mapping", _set("algorithm", value="ga"), "algorithm"),
    ("a batch of 0", _set("algorithm", "batch", value=0), "algorithm.batch"),
    ("a GA population of one", lambda d: d.update(algorithm={"name": "ga", "batch": 1}), "algorithm.batch"),
    ("more emitters than candidates", lambda d: d.update(algorithm={"name": "cma-me", "batch": 4, "emitters": 3}),
     "algorithm.batch"),
    ("a sigma of 0", lambda d: d.update(algorithm={"name": "map-elites", "sigma": 0}), "algorithm.sigma"),
    ("runs per candidate 0", _set("runs_per_candidate", value=0), "runs_per_candidate"),
    ("an inverted adaptive rule", _set("runs_per_candidate", value={"adaptive": {"min": 5, "max": 2}}),
     "runs_per_candidate.adaptive.max"),
    ("an unknown adaptive key", _set("runs_per_candidate", value={"adaptive": {"mn": 5}}),
     "runs_per_candidate.adaptive.mn"),
    ("confirm_runs 0", _set("confirm_runs", value=0), "confirm_runs"),
    ("elites 0", _set("elites", value=0), "elites"),
    ("a negative seed", _set("seed", value=-1), "seed"),
    ("a bad name", _set("name", value="a/b"), "name"),
    ("a bad base world", _set("world", "cell_m", value=-1), "world.cell_m"),
    ("an unknown navigator key", _set("navigator", "colour", value=1), "navigator.colour"),
    ("a timeout of 0", _set("timeout_s", value=0), "timeout_s"),
]


@pytest.mark.parametrize("what,mod,field", BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_one_spec_error_naming_its_field(what: str, mod: Callable[[dict[str, Any]], None],
                                                      field: str) -> None:
    with pytest.raises(SpecError) as info:
        parse_search(_with(mod))
    err = info.value
    assert err.field == field, str(err)
    assert "\n" not in str(err) and str(err).startswith((f"{field}=", f"{field} is missing: "))


def test_the_base_spec_and_its_defaults() -> None:
    spec = parse_search(BASE)
    assert spec.algorithm.name == "map-elites" and spec.algorithm.batch == 16
    assert spec.space.map_seed is True and spec.faults == [None]
    assert spec.runs_per_candidate == 5 and spec.confirm_runs == 10 and spec.elites == 10
    assert spec.generation_runs() == 16 * 5
    assert [d.name for d in spec.archive_descriptors()] == [d["name"] for d in DEFAULT_DESCRIPTORS]


def test_fault_revealing_defaults_to_nominal_and_its_fault() -> None:
    spec = parse_search({**BASE, "objective": {"name": "fault-revealing", "fault": "small-footprint"}})
    assert spec.faults == [None, "small-footprint"] and spec.generation_runs() == 160


def test_adaptive_runs_per_candidate_count_their_max() -> None:
    spec = parse_search({**BASE, "runs_per_candidate": {"adaptive": {"min": 2, "max": 5}}, "budget": {"runs": 80}})
    assert isinstance(spec.runs_per_candidate, AdaptiveRuns) and spec.max_runs_per_candidate() == 5
    with pytest.raises(SpecError, match="budget.runs"):
        parse_search({**BASE, "runs_per_candidate": {"adaptive": {"min": 2, "max": 6}}, "budget": {"runs": 80}})


@pytest.mark.parametrize("objective", list(OBJECTIVE_OPTIONS))
@pytest.mark.parametrize("algorithm", list(ALGORITHM_SETTINGS))
def test_every_objective_with_every_algorithm(objective: str, algorithm: str) -> None:
    obj: dict[str, Any] = {"name": objective}
    if objective == "fault-revealing":
        obj["fault"] = "small-footprint"
    if objective == "illumination":
        obj["descriptors"] = [{"name": "roughness", "low": 0, "high": 0.5, "cells": 5},
                              {"name": "obstacles.obstruction.tree", "low": 0, "high": 20, "cells": 4}]
    spec = parse_search({**BASE, "objective": obj, "algorithm": {"name": algorithm, "batch": 8},
                         "budget": {"runs": 1000}})
    assert spec.objective.name == objective and spec.algorithm.name == algorithm
    if objective == "illumination":
        assert [d.cells for d in spec.archive_descriptors()] == [5, 4]


def test_searched_parameters_of_every_kind_parse() -> None:
    spec = parse_search(_with(lambda d: d["space"]["parameters"].extend([
        {"path": "obstacles.types.tree.variability", "low": 0, "high": 0.9},
        {"path": "obstacles.types.building.height_m", "low": 2, "high": 12},
        {"path": "ground.deformation", "low": 0, "high": 3},
        {"path": "size_m", "low": 30, "high": 60},
        {"path": "mission.free_radius_m", "low": 2, "high": 5},
    ])))
    assert len(spec.space.parameters) == 7


def test_load_search_file_and_text(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(BASE), encoding="utf-8")
    spec, text = load_search(p)
    assert spec == parse_search(BASE) and text == p.read_text(encoding="utf-8")
    with pytest.raises(SpecError, match=r"^search="):
        load_search(tmp_path / "missing.yaml")
    with pytest.raises(SpecError, match=r"^search="):
        parse_search_text("- a list")


def test_with_budget_revalidates_and_names_the_flag() -> None:
    spec = parse_search({**BASE, "objective": {"name": "boundary", "target": 0.3}})
    more = with_budget(spec, 5000)
    assert more.budget.runs == 5000 and more.objective.target == 0.3 and more.space == spec.space
    for bad in (0, -1, 10):
        with pytest.raises(SpecError) as info:
            with_budget(spec, bad)
        assert info.value.field == "--budget"


def test_campaign_fields_make_a_campaign_spec() -> None:
    from navstress.campaign.spec import parse_campaign
    spec = parse_search({**BASE, "objective": {"name": "fault-revealing", "fault": "small-footprint"},
                         "runs_per_candidate": {"adaptive": {"min": 2, "max": 4}}})
    fields = spec.campaign_fields()
    camp = parse_campaign({**fields, "experiments": [{"name": "g0000", "sweep": {
        "obstacles.obstruction.tree": {"values": [1]}}}]})
    assert camp.faults == [None, "small-footprint"] and camp.rule_of(camp.experiments[0]) is not None
    assert camp.world == spec.world and camp.navigators[0].name == spec.navigator.name


_json = st.recursive(st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats() | st.text(max_size=8),
                     lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
                     max_leaves=12)
_keys = st.sampled_from(["name", "seed", "world", "space", "navigator", "faults", "objective", "budget",
                         "runs_per_candidate", "algorithm", "confirm_runs", "elites", "timeout_s", "sim"])


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(key=_keys, sub=st.one_of(st.none(), st.sampled_from(["name", "runs", "parameters", "batch", "fault", "map_seed",
                                                                "descriptors", "low", "kind"])), value=_json)
def test_arbitrary_values_are_a_spec_or_a_spec_error(key: str, sub: str | None, value: Any) -> None:
    data = copy.deepcopy(BASE)
    if sub is None or not isinstance(data.get(key), dict):
        data[key] = value
    else:
        data[key][sub] = value
    try:
        spec = parse_search(data)
    except SpecError as err:  # (user text in it may hold newlines: the CLI prints it on one line)
        top = re.split(r"[.\[]", err.field, maxsplit=1)[0]
        assert top in SearchSpec.model_fields or top in ("search", "--budget"), err.field
        return
    assert isinstance(spec, SearchSpec)
