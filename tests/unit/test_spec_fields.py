"""Every integer, number and boolean field of every spec a user writes (world, campaign, search,
the reference navigators' configuration, the simulation's ``sim:`` overrides), and every required
field, checked one by one against the loader the user's file goes through:

- a value of the wrong kind (``true`` for an integer or a number, ``"10"``, ``1.5`` or ``3.0`` for
  an integer, ``1`` or ``"yes"`` for a boolean, NaN and infinities, integers far out of every
  range) is refused with one line naming the field's path in the user's own spec
  (``experiments[0].worlds[0].map_seed``, ``navigator...`` in a search spec) and that value;
- a required field left out reads ``PATH is missing: ...`` and never shows the mapping that lacks it.

The fields are enumerated from the models (a field added later is covered without editing this
file) over base specs that hold every nested model; :data:`BASES` lists them.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import types
import typing
from collections.abc import Callable, Iterator
from typing import Any, Literal

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from navstress._models import parse, path_text
from navstress.campaign.executors import check_runnable
from navstress.campaign.spec import CampaignSpec, ExperimentSpec, NavigatorSpec, WorldEntry, parse_campaign
from navstress.errors import MISSING, SpecError
from navstress.nav.reference.config import GlobalConfig, ReferenceConfig, parse_config
from navstress.robot import RobotSpec
from navstress.search.spec import SearchSpec, parse_search
from navstress.sim.config import SimConfig
from navstress.sim.lidar import LidarConfig
from navstress.world.spec import WorldSpec, parse_spec

Path_ = tuple[str | int, ...]

WORLD: dict[str, Any] = {
    "size_m": [20.0, 20.0], "cell_m": 0.5,
    "ground": {"model": "subdivide", "subdivisions": 2, "deformation": 0.3, "octaves": 3, "persistence": 0.5,
               "wavelength_m": 10.0, "amplitude_m": 0.5},
    "obstacles": {"types": {"rock": {"base_m": [1.0, 1.0], "height_m": 1.0, "variability": 0.1}},
                  "obstruction": {"tree": 2.0, "rock": 1.0}, "moves": [{"at": [5.0, 5.0], "by": [1.0, 0.0]}]},
    "mission": {"mode": "paper", "start": [2.0, 2.0, 0.0], "goal": [18.0, 18.0], "inset_m": 2.0,
                "free_radius_m": 2.0, "min_distance_m": 5.0},
    "movers": {"types": {"cart": {"shape": "box", "length_m": 1.0, "width_m": 1.0, "height_m": 1.0,
                                  "speed_min_m_s": 0.1, "speed_max_m_s": 1.0, "accel_m_s2": 1.0, "variability": 0.1}},
               "count": {"cart": 1}, "density_per_ha": {"pedestrian": 1.0},
               "behaviour": {"cart": {"kind": "intercept", "waypoints": 3, "pause_max_s": 1.0, "aim": "ttc",
                                      "ttc_s": 2.0, "clearance_m": 2.0, "reaction_s": 0.5, "engage_m": 30.0,
                                      "cross_m": 3.0, "speed_m_s": 1.0, "accel_m_s2": 1.0},
                             "pedestrian": {"kind": "still-then-move", "trigger_m": 5.0}}},
}
WORLD_TOTAL: dict[str, Any] = {"size_m": [20.0, 20.0], "cell_m": 0.5,
                               "obstacles": {"total": 5.0, "mix": {"tree": 1.0, "building": 0.5}}}
CAMPAIGN: dict[str, Any] = {
    "name": "c", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
    "experiments": [
        {"name": "swept", "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 2, "step": 1}},
         "overrides": {"ground": {"subdivisions": 1, "deformation": 0.1}}, "faults": [None],
         "runs_per_map": {"adaptive": {"min": 2, "max": 5, "threshold": 0.8, "confidence": 0.9, "indifference": 0.0}}},
        {"name": "listed", "worlds": [{"key": "k", "map_seed": 4, "world": {"obstacles": {"obstruction": {"tree": 1.0}}}}],
         "runs_per_map": 2},
    ],
    "maps_per_config": 1, "runs_per_map": 1, "timeout_s": 5.0, "goal_tolerance_m": 2.0, "record_lidar": False,
    "record_navigator": False,
    "navigators": [{"name": "reference-v1", "config": {"n_arcs": 22, "cost_jitter": 0.0, "turn_in_place": True}}],
    "sim": {"timestep_s": 0.01, "solver_iterations": 20, "noise": True, "lidar": {"channels": 8, "rate_hz": 10.0}},
}
_SEARCH: dict[str, Any] = {
    "name": "s", "seed": 1, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 10, "kind": "float"}],
              "moves": {"count": 2, "radius_m": 1.0}, "map_seed": True, "map_seeds": 100},
    "budget": {"runs": 100, "sim_hours": 1.0, "wall_s": 100.0}, "runs_per_candidate": 1,
    "confirm_runs": 1, "elites": 1, "timeout_s": 5.0, "goal_tolerance_m": 2.0,
}
SEARCHES: dict[str, dict[str, Any]] = {
    "illumination, map-elites": {**_SEARCH, "objective": {
        "name": "illumination", "outcome": "any",
        "descriptors": [{"name": "obstruction", "low": 0, "high": 10, "cells": 4},
                        {"name": "path_ratio", "low": 1, "high": 2, "cells": 4}]},
        "algorithm": {"name": "map-elites", "batch": 2, "sigma": 0.1, "emitters": 1},
        "runs_per_candidate": {"adaptive": {"min": 1, "max": 2, "threshold": 0.5, "confidence": 0.9}}},
    "boundary, cma-me": {**_SEARCH, "objective": {"name": "boundary", "target": 0.5},
                         "algorithm": {"name": "cma-me", "batch": 4, "sigma0": 0.2, "emitters": 2, "descriptors": [
                             {"name": "obstruction", "low": 0, "high": 10, "cells": 4},
                             {"name": "path_ratio", "low": 1, "high": 2, "cells": 4}]}},
    "failure, ga": {**_SEARCH, "objective": {"name": "failure", "outcome": "collision"},
                    "algorithm": {"name": "ga", "batch": 2, "crossover_prob": 0.9, "crossover_eta": 15.0,
                                  "mutation_eta": 20.0}},
}


def _campaign_checked(data: dict[str, Any]) -> None:
    """What ``campaign run`` checks before anything is written: the spec, then its navigators'
    configurations and ``sim:`` (navstress.campaign.executors.check_runnable)."""
    check_runnable(parse_campaign(data))


# ---- the fields, from the models ----------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Leaf:
    """A field of one kind (int, float, bool) at ``path`` in a base spec."""

    base: str
    path: Path_
    kind: str
    optional: bool = False
    infinite_ok: bool = False
    rule: bool = False  # an integer, or a mapping (runs_per_map: {adaptive: ...}) checked on its own

    def __str__(self) -> str:
        return f"{self.base}:{path_text(self.path)}"


def _unoptional(ann: Any) -> tuple[Any, bool]:
    """``(X, True)`` for ``X | None``, ``(ann, False)`` otherwise."""
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(ann) if a is not type(None)]
        optional = len(args) != len(typing.get_args(ann))
        return (args[0] if len(args) == 1 else typing.Union[tuple(args)]), optional
    return ann, False


def _kind(ann: Any) -> str | None:
    return {bool: "bool", int: "int", float: "float"}.get(ann) if isinstance(ann, type) else None


#: Mappings that hold another model than their annotation says (a dict validated separately).
NESTED: dict[tuple[type[BaseModel], str], Any] = {
    (CampaignSpec, "world"): WorldSpec, (SearchSpec, "world"): WorldSpec, (ExperimentSpec, "overrides"): WorldSpec,
    (WorldEntry, "world"): WorldSpec, (NavigatorSpec, "config"): ReferenceConfig, (CampaignSpec, "sim"): SimConfig,
}


def leaves(base: str, model: Any, data: dict[str, Any], path: Path_ = ()) -> Iterator[Leaf]:
    """Every int/float/bool field under ``model`` (a pydantic model or a dataclass) at ``path``:
    each scalar field (given or not), each item of a tuple of numbers, each value of a mapping of
    numbers, and the fields of each nested model that ``data`` holds."""
    if dataclasses.is_dataclass(model):
        for f in dataclasses.fields(model):
            if isinstance(f.default, LidarConfig) or f.name == "lidar":
                if isinstance(data.get(f.name), dict):
                    yield from leaves(base, LidarConfig, data[f.name], (*path, f.name))
                continue
            kind = _kind(type(f.default))
            if kind is not None:
                yield Leaf(base, (*path, f.name), kind)
        return
    for name, field in model.model_fields.items():
        here = (*path, name)
        nested = NESTED.get((model, name))
        if nested is not None:
            if isinstance(data.get(name), dict):
                yield from leaves(base, nested, data[name], here)
            continue
        ann, optional = _unoptional(field.annotation)
        kind = _kind(ann)
        if kind is not None:
            inf_ok = bool(field.json_schema_extra) or any(getattr(m, "allow_inf_nan", None) for m in field.metadata)
            yield Leaf(base, here, kind, optional, inf_ok)
            continue
        value = data.get(name)
        origin = typing.get_origin(ann)
        args = typing.get_args(ann)
        if origin is tuple and isinstance(value, list):
            for i, a in enumerate(args if Ellipsis not in args else [args[0]] * len(value)):
                if _kind(a) is not None:
                    yield Leaf(base, (*here, i), _kind(a) or "")
                elif isinstance(a, type) and issubclass(a, BaseModel) and isinstance(value[i], dict):
                    yield from leaves(base, a, value[i], (*here, i))
        elif origin is list and isinstance(value, list):
            item = args[0]
            for i, v in enumerate(value):
                if isinstance(item, type) and issubclass(item, BaseModel) and isinstance(v, dict):
                    yield from leaves(base, item, v, (*here, i))
        elif origin is dict and isinstance(value, dict):
            vt = args[1]
            for key, v in value.items():
                if _kind(vt) is not None:
                    yield Leaf(base, (*here, key), _kind(vt) or "")
                elif isinstance(vt, type) and issubclass(vt, BaseModel) and isinstance(v, dict):
                    yield from leaves(base, vt, v, (*here, key))
        elif isinstance(ann, type) and issubclass(ann, BaseModel) and isinstance(value, dict):
            yield from leaves(base, ann, value, here)
        elif typing.get_origin(ann) in (typing.Union, types.UnionType) and isinstance(value, dict):
            for a in typing.get_args(ann):  # int | AdaptiveRuns: the model the mapping is
                if isinstance(a, type) and issubclass(a, BaseModel):
                    yield from leaves(base, a, value, here)
        elif typing.get_origin(ann) in (typing.Union, types.UnionType) and int in typing.get_args(ann):
            yield Leaf(base, here, "int", optional, rule=True)  # runs_per_map: an integer or a rule


BASES: dict[str, tuple[Any, dict[str, Any], Callable[[dict[str, Any]], Any]]] = {
    "world": (WorldSpec, WORLD, parse_spec),
    "world total": (WorldSpec, WORLD_TOTAL, parse_spec),
    "campaign": (CampaignSpec, CAMPAIGN, _campaign_checked),
    **{f"search {k}": (SearchSpec, v, parse_search) for k, v in SEARCHES.items()},
    "reference config": (ReferenceConfig, {}, parse_config),
    "global config": (GlobalConfig, {}, lambda d: parse_config(d, cls=GlobalConfig)),
    "robot": (RobotSpec, {"mounts": {"lidar": {"xyz": [0.3, 0.0, 0.75]}}, "inertia_kgm2": [5.0, 9.0, 12.0]},
              lambda d: parse(RobotSpec, d)),
}
LEAVES = [leaf for name, (model, data, _f) in BASES.items() for leaf in leaves(name, model, data)]
WRONG: dict[str, list[Any]] = {
    "int": [True, False, "3", "10", 1.5, 3.0, 10**30, -(10**30), [1], None],
    "float": [True, False, "0.5", "1", math.nan, math.inf, -math.inf, [1.0], None],
    "bool": [1, 0, "true", "yes", 1.0, None],
}


def _set(data: dict[str, Any], path: Path_, value: Any) -> dict[str, Any]:
    out = copy.deepcopy(data)
    node: Any = out
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value
    return out


def _delete(data: dict[str, Any], path: Path_) -> dict[str, Any]:
    out = copy.deepcopy(data)
    node: Any = out
    for p in path[:-1]:
        node = node[p]
    del node[path[-1]]
    return out


def _parent(data: dict[str, Any], path: Path_) -> Any:
    node: Any = data
    for p in path[:-1]:
        node = node[p]
    return node


def _refused(leaf: Leaf, value: Any) -> SpecError:
    _model, data, load = BASES[leaf.base]
    bad = _set(data, leaf.path, value)
    with pytest.raises(SpecError) as info:
        load(bad)
    err = info.value
    text = str(err)
    assert "\n" not in text
    assert err.field == path_text(leaf.path), f"{leaf} = {value!r}: {text}"
    same = err.value == value or (isinstance(value, float) and isinstance(err.value, float) and math.isnan(value)
                                  and math.isnan(err.value))
    assert same and type(err.value) is type(value), f"{leaf} = {value!r}: the error shows {err.value!r}"
    parent = _parent(bad, leaf.path)
    if isinstance(parent, dict) and len(parent) > 1:
        assert repr(parent) not in text, f"{leaf}: the parent mapping is shown: {text}"
    return err


def test_the_bases_are_valid_and_every_kind_of_field_is_reached() -> None:
    for name, (_model, data, load) in BASES.items():
        load(copy.deepcopy(data))
    kinds = {leaf.kind for leaf in LEAVES}
    assert kinds == {"int", "float", "bool"}
    paths = {str(leaf) for leaf in LEAVES}
    for must in ("campaign:seed", "campaign:experiments[1].worlds[0].map_seed", "campaign:runs_per_map",
                 "campaign:experiments[0].runs_per_map.adaptive.min", "campaign:navigators[0].config.n_arcs",
                 "campaign:sim.solver_iterations", "campaign:sim.lidar.channels", "world:obstacles.moves[0].at[1]",
                 "world:movers.count.cart", "world:mission.start[2]", "search illumination, map-elites:budget.runs",
                 "search boundary, cma-me:objective.target", "search failure, ga:algorithm.mutation_eta",
                 "campaign:experiments[0].overrides.ground.subdivisions", "world total:obstacles.mix.building"):
        assert must in paths, must
    assert len(LEAVES) > 250


@pytest.mark.parametrize("leaf", LEAVES, ids=str)
def test_a_wrong_kind_of_value_is_refused_naming_the_field(leaf: Leaf) -> None:
    for value in WRONG[leaf.kind]:
        if value is None and leaf.optional:
            continue  # null: the field's "not set"
        if leaf.infinite_ok and value == math.inf:
            continue  # a field whose value may be infinite says so (unknown_cell_cost)
        _refused(leaf, value)


_text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=12)


@settings(max_examples=300, deadline=None)
@given(leaf=st.sampled_from(LEAVES), value=st.one_of(
    st.booleans(), _text, st.integers(-10**6, 10**6).map(str), st.floats(allow_nan=True).map(repr),
    st.integers(min_value=2**63), st.integers(max_value=-(2**63) - 1),
    st.lists(st.integers(0, 3), max_size=2), st.dictionaries(_text, st.integers(), max_size=2)))
def test_random_values_of_the_wrong_kind_are_refused_naming_the_field(leaf: Leaf, value: Any) -> None:
    if leaf.kind == "bool" and isinstance(value, bool):
        return
    if leaf.kind == "float" and isinstance(value, int) and not isinstance(value, bool):
        return  # an integer is a number (how large a number may be is each field's range)
    if leaf.rule and isinstance(value, dict):
        return  # a rule's own keys are checked, and named, one by one
    _refused(leaf, value)


def _required() -> Iterator[tuple[str, Path_]]:
    """Every required field (no default) of every model the bases hold, with its path."""
    def walk(base: str, model: Any, data: Any, path: Path_) -> Iterator[tuple[str, Path_]]:
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or not isinstance(data, dict):
            return
        for name, field in model.model_fields.items():
            here = (*path, name)
            if name not in data:
                continue
            if field.is_required():
                yield base, here
            nested = NESTED.get((model, name))
            if nested is not None:
                yield from walk(base, nested, data[name], here)
                continue
            ann, _ = _unoptional(field.annotation)
            value = data[name]
            origin = typing.get_origin(ann)
            args = typing.get_args(ann)
            if isinstance(ann, type) and issubclass(ann, BaseModel):
                yield from walk(base, ann, value, here)
            elif origin in (list, tuple) and isinstance(value, list):
                for i, v in enumerate(value):
                    yield from walk(base, args[0], v, (*here, i))
            elif origin is dict and isinstance(value, dict):
                for k, v in value.items():
                    yield from walk(base, args[1], v, (*here, k))
            elif origin in (typing.Union, types.UnionType):
                for a in args:
                    yield from walk(base, a, value, here)

    for name, (model, data, _f) in BASES.items():
        yield from walk(name, model, data, ())


REQUIRED = sorted(set(_required()), key=str)


def test_required_fields_are_reached() -> None:
    got = {f"{b}:{path_text(p)}" for b, p in REQUIRED}
    for must in ("campaign:experiments", "campaign:experiments[0].name", "campaign:experiments[1].worlds[0].map_seed",
                 "world:obstacles.types.rock.base_m", "world:movers.types.cart.speed_max_m_s",
                 "world:obstacles.moves[0].by", "search illumination, map-elites:budget.runs",
                 "search illumination, map-elites:objective", "search illumination, map-elites:space.moves.radius_m",
                 "search boundary, cma-me:algorithm.descriptors[0].low"):
        assert must in got, must


@pytest.mark.parametrize("base,path", REQUIRED, ids=[f"{b}:{path_text(p)}" for b, p in REQUIRED])
def test_a_missing_field_names_its_path_and_never_shows_its_parent(base: str, path: Path_) -> None:
    _model, data, load = BASES[base]
    bad = _delete(data, path)
    with pytest.raises(SpecError) as info:
        load(bad)
    err = info.value
    text = str(err)
    assert err.field == path_text(path) and err.value is MISSING, text
    assert text.startswith(f"{path_text(path)} is missing: expected ") and "\n" not in text, text
    parent = _parent(bad, path)
    if isinstance(parent, dict) and parent:
        assert repr(parent) not in text, text
    assert len(text) < 400, text


@pytest.mark.parametrize("seed", [2**63, 2**64, 10**30, -1])
@pytest.mark.parametrize("what", ["campaign", "search"])
def test_seeds_are_refused_outside_0_to_2_63_minus_1(what: str, seed: int) -> None:
    data = copy.deepcopy(CAMPAIGN if what == "campaign" else SEARCHES["failure, ga"])
    data["seed"] = seed
    with pytest.raises(SpecError) as info:
        (parse_campaign if what == "campaign" else parse_search)(data)
    assert info.value.field == "seed" and info.value.value == seed
    data["seed"] = 2**63 - 1
    (parse_campaign if what == "campaign" else parse_search)(data)


def test_literal_and_kind_words_cover_the_annotations() -> None:
    # the missing-field words come from the annotation: no "a value" for the kinds users meet
    from navstress._models import describe

    for ann, word in ((int, "an integer"), (float, "a number"), (bool, "true or false"), (str, "a string"),
                      (list[int], "a list"), (tuple[float, float], "a list of 2 values"), (dict[str, int],
                      "a mapping of fields"), (Literal["a", "b"], "one of ['a', 'b']"), (int | None, "an integer")):
        assert describe(ann) == word
