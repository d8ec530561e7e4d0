"""SearchSpec: what a search looks for, where, with which algorithm and budget; validated before
anything runs (docs/search.md).

    >>> spec = parse_search({"name": "s", "seed": 1,
    ...     "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 20}]},
    ...     "objective": {"name": "failure"}, "budget": {"runs": 400}})
    >>> spec.algorithm.name, spec.algorithm.batch, spec.space.map_seed, spec.faults
    ('map-elites', 16, True, [None])

A search varies WorldSpec parameters (``space.parameters``: a path, a range, a kind) and, with
``space.map_seed: true``, the map seed; every candidate is a world evaluated by repeated runs of
``navigator`` under each of ``faults``. Every error is a one-line
:class:`~navstress.errors.SpecError` naming the field, e.g. ``budget.runs=0 is invalid: expected
a number of runs > 0``.

The space's values become WorldSpec overrides here (:meth:`ParameterSpec.value`,
:func:`world_overrides`), so that this module can check, before anything runs, that the extreme
values of the ranges make valid worlds; :mod:`navstress.search.space` maps the algorithms'
normalised box onto these values.
"""

from __future__ import annotations

import copy
import itertools
import math
import types
import typing
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from navstress._models import SPEC_CONFIG, parse, unoptional
from navstress.campaign.spec import (AdaptiveRuns, NavigatorSpec, check_base_world, check_faults, check_name, deep_merge,
                                    is_name, repetition, resolve_robot_ref)
from navstress.errors import MISSING, SpecError
from navstress.robot import RobotSpec
from navstress.run.sensors import apply_sensor_values, apply_sensors, check_suite, is_sensor_path, sensor_path_kind
from navstress.search.objectives import DESCRIPTORS
from navstress.seeding import MAX_SEED
from navstress.specfile import parse_text, read_text
from navstress.world.spec import BUILTIN_TYPES, ObstacleType, WorldSpec, parse_spec, resolve_source

_STRICT = SPEC_CONFIG

OBJECTIVES = ("failure", "fault-revealing", "boundary", "illumination")
ALGORITHMS = ("random", "map-elites", "cma-me", "ga", "nsga2")
#: The outcome classes the failure (and illumination) objective may count: any failure, or one class.
OUTCOME_CLASSES = ("any", "collision", "timeout", "error")
#: The descriptors a descriptor spec may name (the registry of navstress.search.objectives, with
#: their units and ranges); a path of the space may be named too (the parameter's own value).
WORLD_DESCRIPTORS = tuple(DESCRIPTORS)
#: Options of each objective besides ``name``.
OBJECTIVE_OPTIONS: dict[str, tuple[str, ...]] = {
    "failure": ("outcome",), "fault-revealing": ("fault",), "boundary": ("target",),
    "illumination": ("descriptors", "outcome"),
}
#: Settings of each algorithm besides ``name`` and ``batch``.
ALGORITHM_SETTINGS: dict[str, tuple[str, ...]] = {
    "random": (),
    "map-elites": ("sigma", "emitters", "descriptors"),
    "cma-me": ("sigma0", "emitters", "descriptors"),
    "ga": ("crossover_prob", "crossover_eta", "mutation_eta"),
    "nsga2": ("crossover_prob", "crossover_eta", "mutation_eta"),
}
#: The archive of MAP-Elites and CMA-ME when the objective names no descriptors.
DEFAULT_DESCRIPTORS: tuple[dict[str, Any], ...] = (
    {"name": "obstruction", "low": 0.0, "high": 40.0, "cells": 10},
    {"name": "path_ratio", "low": 1.0, "high": 2.0, "cells": 10},
)
#: Most runs a search may be given.
MAX_BUDGET_RUNS = 10_000_000
#: The side of a square map: the one tuple-valued WorldSpec field a space may search.
SIZE_PATH = "size_m"
#: The mission's coordinates a space may search, one path each (for an imported world, in the
#: source's frame): ``mission.start.x`` -> (``start``, index 0), ...
MISSION_PATHS: dict[str, tuple[str, int]] = {
    "mission.start.x": ("start", 0), "mission.start.y": ("start", 1), "mission.start.yaw": ("start", 2),
    "mission.goal.x": ("goal", 0), "mission.goal.y": ("goal", 1)}
_NOT_SEARCHED = {"cell_m": "the terrain resolution, not a property of the world; set it under world"}
#: Most parameters whose every corner is checked (2**n WorldSpecs); above, the two extreme corners
#: and each parameter's extremes with the others at their low are checked.
MAX_CORNER_DIMS = 10


class ParameterSpec(BaseModel):
    """One searched WorldSpec parameter: a dotted ``path``, a range ``[low, high]`` (low < high) and
    its ``kind`` (``int`` values are whole numbers, each of the ``high - low + 1`` equally likely)."""

    model_config = _STRICT
    path: str
    low: float
    high: float
    kind: Literal["float", "int"] = "float"

    def value(self, u: float, cell_m: float) -> float | int:
        """The parameter's value at ``u`` in [0, 1] (``u`` clipped to it).

        ``int``: ``low + floor(u * n)`` over the n = high - low + 1 whole values (u = 1 gives high);
        ``float``: ``low + u * (high - low)`` rounded to 6 significant digits of the range's width
        and clipped to [low, high]; ``size_m``: that value snapped to a whole multiple of ``cell_m``
        inside the range (the map's side: a square map)."""
        u = min(max(float(u), 0.0), 1.0) if math.isfinite(u) else 0.0
        if self.kind == "int":
            lo, hi = int(self.low), int(self.high)
            n = hi - lo + 1
            return lo + min(int(math.floor(u * n)), n - 1)
        width = self.high - self.low
        if self.path == SIZE_PATH:
            k_lo, k_hi = math.ceil(self.low / cell_m - 1e-9), math.floor(self.high / cell_m + 1e-9)
            k = min(max(round((self.low + u * width) / cell_m), k_lo), k_hi)
            # the tolerance above may take a multiple a rounding error below low (or above high):
            # the range's own end is then the grid point, up to that error
            return min(max(round(k * cell_m, 10), self.low), self.high)
        return scaled(u, self.low, self.high)


def scaled(u: float, low: float, high: float) -> float:
    """``low + u (high - low)`` (``u`` clipped to [0, 1], NaN as 0) rounded to 6 significant digits
    of the range's width and clipped to [low, high]: a float parameter's value, and a searched
    obstacle move's coordinates."""
    u = min(max(float(u), 0.0), 1.0) if math.isfinite(u) else 0.0
    v = round(low + u * (high - low), 6 - math.floor(math.log10(high - low)))
    return min(max(v, low), high)


#: Most obstacle moves a space may search.
MAX_SEARCHED_MOVES = 16


class MovesSpec(BaseModel):
    """Local moves of single obstacles, searched with the parameters: ``count`` moves, each taking
    the generated obstacle nearest a point of the map and moving it by up to ``radius_m`` along x
    and along y (WorldSpec ``obstacles.moves``; a move that would break a placement constraint is
    not applied)."""

    model_config = _STRICT
    count: int = Field(ge=1, le=MAX_SEARCHED_MOVES)
    radius_m: float = Field(gt=0.0, allow_inf_nan=False)


class SpaceSpec(BaseModel):
    """The searched parameters, obstacle moves, and whether the map seed is searched too.

    ``map_seed: true``: one more dimension picks one of ``map_seeds`` map seeds (derived from the
    search seed); ``false``: every candidate uses the search's one map seed, so a candidate's world
    is a function of its parameters (and moves) alone."""

    model_config = _STRICT
    parameters: list[ParameterSpec] = Field(default_factory=list)
    moves: MovesSpec | None = None
    map_seed: bool = True
    map_seeds: int = Field(10_000, ge=1, le=1 << 31)


class DescriptorSpec(BaseModel):
    """One axis of an illumination map: a descriptor ``name`` (a world descriptor or a path of the
    space), its range and its number of ``cells`` (values outside fall in the edge cells)."""

    model_config = _STRICT
    name: str
    low: float
    high: float
    cells: int = Field(10, ge=1, le=1000)


class ObjectiveSpec(BaseModel):
    """What a candidate's fitness measures (docs/search.md, "Objectives"); each objective takes only
    its own options (:data:`OBJECTIVE_OPTIONS`)."""

    model_config = _STRICT
    name: Literal["failure", "fault-revealing", "boundary", "illumination"]
    outcome: Literal["any", "collision", "timeout", "error"] = "any"
    fault: str | None = None
    target: float = Field(0.5, gt=0.0, lt=1.0)
    descriptors: list[DescriptorSpec] | None = None


class BudgetSpec(BaseModel):
    """How much the search may spend: ``runs`` (the search's generations; the elites' confirmation
    comes on top), optionally ``sim_hours`` of simulated time and ``wall_s`` seconds of wall time
    (the search stops at the first generation boundary past any of them)."""

    model_config = _STRICT
    runs: int
    sim_hours: float | None = Field(None, gt=0.0)
    wall_s: float | None = Field(None, gt=0.0)


class AlgorithmSpec(BaseModel):
    """The search algorithm, ``batch`` candidates per generation, and its settings
    (:data:`ALGORITHM_SETTINGS`; each algorithm takes only its own).

    ``map-elites``: ``sigma`` (Gaussian mutation, in the normalised box), ``emitters``;
    ``cma-me``: ``sigma0`` (CMA-ES's initial step), ``emitters``; both: ``descriptors`` (the archive's
    two axes when the objective names none); ``ga``/``nsga2``: ``crossover_prob``, ``crossover_eta``
    (SBX), ``mutation_eta`` (polynomial mutation)."""

    model_config = _STRICT
    name: Literal["random", "map-elites", "cma-me", "ga", "nsga2"] = "map-elites"
    batch: int = Field(16, ge=1, le=10_000)
    sigma: float = Field(0.1, gt=0.0, le=1.0)
    sigma0: float = Field(0.2, gt=0.0, le=1.0)
    emitters: int | None = Field(None, ge=1, le=100)
    descriptors: list[DescriptorSpec] | None = None
    crossover_prob: float = Field(0.9, ge=0.0, le=1.0)
    crossover_eta: float = Field(15.0, gt=0.0, le=1000.0)
    mutation_eta: float = Field(20.0, gt=0.0, le=1000.0)

    def emitter_count(self) -> int:
        """The emitters of MAP-Elites (default 1) and CMA-ME (default 2)."""
        if self.emitters is not None:
            return self.emitters
        return 2 if self.name == "cma-me" else 1


class SearchSpec(BaseModel):
    """A whole search (see module doc and docs/search.md)."""

    model_config = _STRICT
    name: str = "search"
    seed: int = Field(0, ge=0, le=MAX_SEED)
    world: dict[str, Any] = Field(default_factory=dict, description="the base WorldSpec mapping")
    space: SpaceSpec
    navigator: NavigatorSpec = Field(default_factory=NavigatorSpec)
    faults: list[str | None] = Field(default_factory=lambda: list[str | None]([None]), min_length=1)
    objective: ObjectiveSpec
    budget: BudgetSpec
    runs_per_candidate: int | AdaptiveRuns = 5
    algorithm: AlgorithmSpec = Field(default_factory=AlgorithmSpec)
    confirm_runs: int = Field(10, ge=1, le=10_000)
    elites: int = Field(10, ge=1, le=10_000)
    timeout_s: float = Field(400.0, gt=0.0, le=86_400.0)
    goal_tolerance_m: float = Field(2.0, gt=0.0)
    sim: dict[str, Any] = Field(default_factory=dict, description="simulation overrides passed to every run")
    robot: RobotSpec | None = Field(None, description="the robot of every run (None: rmp400)")
    # applied to the robot when the spec is read (parse_search), then None
    sensors: list[Any] | None = Field(None, description="the robot's sensor suite (replacing its own)")
    sensors_add: list[Any] | None = Field(None, description="sensors added to the robot's suite")

    @model_validator(mode="before")
    @classmethod
    def _default_faults(cls, data: Any) -> Any:
        """``faults`` left out: nominal only, or nominal and the objective's fault (fault-revealing)."""
        if isinstance(data, dict) and data.get("faults") is None:
            obj = data.get("objective")
            fault = obj.get("fault") if isinstance(obj, dict) and obj.get("name") == "fault-revealing" else None
            data = {**data, "faults": [None, fault] if isinstance(fault, str) else [None]}
        return data

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        return check_name(v)

    @field_validator("runs_per_candidate", mode="before")
    @classmethod
    def _runs(cls, v: Any) -> int | AdaptiveRuns:
        return repetition(v, "runs_per_candidate")

    def max_runs_per_candidate(self) -> int:
        """The most runs one candidate gets per fault: the fixed count or the adaptive rule's max."""
        r = self.runs_per_candidate
        return r.adaptive.max if isinstance(r, AdaptiveRuns) else r

    def generation_runs(self) -> int:
        """The most runs one generation of ``algorithm.batch`` candidates takes."""
        return self.algorithm.batch * self.max_runs_per_candidate() * len(self.faults)

    def archive_descriptors(self) -> list[DescriptorSpec]:
        """The two axes of the MAP-Elites/CMA-ME archive: the illumination objective's descriptors,
        else the algorithm's, else :data:`DEFAULT_DESCRIPTORS`."""
        if self.objective.descriptors is not None:
            return list(self.objective.descriptors)
        if self.algorithm.descriptors is not None:
            return list(self.algorithm.descriptors)
        return [DescriptorSpec(**d) for d in DEFAULT_DESCRIPTORS]

    def campaign_fields(self) -> dict[str, Any]:
        """The fields of the search's campaign spec besides its experiments (name, seed, base world,
        one navigator, faults, repetition, timeout, tolerance, simulation overrides, the robot when
        one is given), as values of :class:`~navstress.campaign.spec.CampaignSpec`'s fields, in the
        order its text shows them."""
        robot = {} if self.robot is None else {"robot": self.robot}
        return {"name": self.name, "seed": self.seed, "world": copy.deepcopy(self.world), **robot,
                "navigators": [self.navigator], "faults": list(self.faults), "maps_per_config": 1,
                "runs_per_map": self.runs_per_candidate, "timeout_s": self.timeout_s,
                "goal_tolerance_m": self.goal_tolerance_m, "sim": copy.deepcopy(self.sim)}


# ---- the space's values as WorldSpec overrides -----------------------------------------------


def world_overrides(values: dict[str, float | int], base: dict[str, Any]) -> dict[str, Any]:
    """The WorldSpec overrides (a nested mapping) that set each path of ``values`` on ``base``.

    ``size_m`` sets a square map ``[v, v]``; ``obstacles.types.NAME.FIELD`` on a type the base
    world does not define starts from the built-in type NAME."""
    out: dict[str, Any] = {}
    base_types = (base.get("obstacles") or {}).get("types") or {}
    for path, v in values.items():
        if is_sensor_path(path):  # the robot's, not the world's (the campaign's WorldEntry.sensors)
            continue
        if path in MISSION_PATHS:  # a coordinate of the start or goal: the point, the rest from the base
            name, i = MISSION_PATHS[path]
            mission = out.setdefault("mission", {})
            if name not in mission:
                given = (base.get("mission") or {}).get(name)
                mission[name] = [float(c) for c in given] if isinstance(given, list) else (
                    [0.0, 0.0, 0.0] if name == "start" else [0.0, 0.0])
            mission[name][i] = float(v)
            continue
        if path == SIZE_PATH:
            out[SIZE_PATH] = [float(v), float(v)]
            continue
        parts = path.split(".")
        if parts[:2] == ["obstacles", "types"] and len(parts) == 4 and parts[2] not in base_types:
            types = out.setdefault("obstacles", {}).setdefault("types", {})
            if parts[2] not in types and parts[2] in BUILTIN_TYPES:
                types[parts[2]] = BUILTIN_TYPES[parts[2]].model_dump(mode="json")
        node = out
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = v
    return out


def base_cell_m(world: dict[str, Any]) -> float:
    """The terrain cell of the base world (WorldSpec's default when not set)."""
    return float(world.get("cell_m", WorldSpec.model_fields["cell_m"].default))


# ---- validation ------------------------------------------------------------------------------


def _leaf(model: type[BaseModel], parts: list[str]) -> Any:
    """The annotation of the field ``parts`` names in ``model`` (mappings accept any key and
    mappings of models are entered), or None when no such field."""
    if not parts:
        return None
    field = model.model_fields.get(parts[0])
    if field is None:
        return None
    ann: Any = unoptional(field.annotation)
    rest = parts[1:]
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return _leaf(ann, rest)
    if typing.get_origin(ann) is dict:
        value_type = typing.get_args(ann)[1]
        if isinstance(value_type, type) and issubclass(value_type, BaseModel):
            return _leaf(value_type, rest[1:]) if rest else None
        return value_type if len(rest) == 1 else None
    return ann if not rest else None


def _numeric_kind(ann: Any) -> str | None:
    """"int", "float" or None (not a number) for a field annotation (``X | None`` counts as X)."""
    ann = unoptional(ann)
    return "int" if ann is int else "float" if ann is float else None


_PATH_EXAMPLES = ("a numeric WorldSpec parameter path such as 'obstacles.obstruction.tree', 'obstacles.mix.building', "
                  "'obstacles.types.tree.variability', 'ground.deformation', 'ground.subdivisions' or 'size_m'")


def _check_parameter(i: int, p: ParameterSpec, base: dict[str, Any], robot: RobotSpec | None = None,
                     searched: frozenset[str] = frozenset()) -> None:
    where = f"space.parameters[{i}]"
    if is_sensor_path(p.path):  # a sensor of the robot: a numeric parameter of its kind
        skind = sensor_path_kind(robot or RobotSpec(), p.path, where=f"{where}.path")
        if skind not in ("int", "float"):
            raise SpecError(f"{where}.path", p.path, "a numeric sensor parameter (a search space is numeric)",
                            "sweep kinds and profiles in a campaign")
        if not p.low < p.high:
            raise SpecError(f"{where}", f"[{p.low:g}, {p.high:g}]", "a range with low < high")
        if skind == "int" and p.kind != "int":
            raise SpecError(f"{where}.kind", p.kind, f"int ({p.path} is a whole number)", "set kind: int")
        return
    if p.path in _NOT_SEARCHED:
        raise SpecError(f"{where}.path", p.path, _PATH_EXAMPLES, _NOT_SEARCHED[p.path])
    parts = p.path.split(".")
    if p.path in MISSION_PATHS:
        name, coord = MISSION_PATHS[p.path]
        given = (base.get("mission") or {}).get(name)
        if p.kind != "float":
            raise SpecError(f"{where}.kind", p.kind, f"float ({p.path} is a coordinate)", "set kind: float")
        if coord < 2 and not isinstance(given, list):  # the other coordinate: searched too, or the base's
            other = f"mission.{name}.{'yx'[coord]}"
            if other not in searched:
                raise SpecError(f"{where}.path", p.path, f"a {name} searched with both coordinates ({other} too), "
                                f"or given in world.mission.{name}", f"add {other} to the space or set world.mission.{name}")
    kind = ("float" if p.path == SIZE_PATH or p.path in MISSION_PATHS
            else _numeric_kind(_leaf(WorldSpec, parts)))
    if kind is None:
        raise SpecError(f"{where}.path", p.path, _PATH_EXAMPLES, "check the spelling against `navstress world` options")
    if parts[0] == "obstacles" and parts[1] in ("types", "obstruction", "mix"):
        known = set(BUILTIN_TYPES) | set(((base.get("obstacles") or {}).get("types") or {}))
        if parts[2] not in known:
            raise SpecError(f"{where}.path", p.path, f"a path of a known obstacle type {sorted(known)}",
                            "define the type under world.obstacles.types first")
        if parts[1] == "types" and parts[3] not in ObstacleType.model_fields:
            raise SpecError(f"{where}.path", p.path, _PATH_EXAMPLES)
    for end in ("low", "high"):
        v = getattr(p, end)
        if not math.isfinite(v):
            raise SpecError(f"{where}.{end}", v, "a finite number")
    if not p.low < p.high:
        raise SpecError(f"{where}", f"[{p.low:g}, {p.high:g}]", "a range with low < high (this one is "
                        f"{'empty' if p.low == p.high else 'inverted'})", "widen it, or set the value under world")
    if p.path == SIZE_PATH and p.kind == "int":
        raise SpecError(f"{where}.kind", p.kind, "float (the map side is snapped to the terrain grid)",
                        "set kind: float")
    if kind == "int" and p.kind != "int":
        raise SpecError(f"{where}.kind", p.kind, f"int ({p.path} is a whole number)", "set kind: int")
    if p.kind == "int" and not (float(p.low).is_integer() and float(p.high).is_integer()):
        raise SpecError(f"{where}", f"[{p.low:g}, {p.high:g}]", "whole-number bounds for kind: int")
    if p.kind == "int" and p.high - p.low > 1e12:
        raise SpecError(f"{where}", f"[{p.low:g}, {p.high:g}]", "an integer range of at most 10^12 values")
    if p.path == SIZE_PATH:
        cell = base_cell_m(base)
        if math.floor(p.high / cell + 1e-9) < math.ceil(p.low / cell - 1e-9):
            raise SpecError(f"{where}", f"[{p.low:g}, {p.high:g}]", f"a range holding a whole multiple of "
                            f"cell_m={cell:g} (the map side is snapped to the terrain grid)", "widen it")


def _corners(params: list[ParameterSpec]) -> list[tuple[float, ...]]:
    n = len(params)
    if n <= MAX_CORNER_DIMS:
        return [tuple(float(b) for b in bits) for bits in itertools.product((0, 1), repeat=n)]
    out = [tuple([0.0] * n), tuple([1.0] * n)]
    for i in range(n):
        out.append(tuple(1.0 if j == i else 0.0 for j in range(n)))
    return out


def _check_corners(spec: SearchSpec) -> None:
    """Every corner of the space (each parameter at its low or high value) makes a valid world.

    The WorldSpec's constraints on these parameters are bounds and sums (obstruction below 100 %,
    a weight > 0, the mission inside the map, the memory of the grid), so the corners bound them."""
    params = spec.space.parameters
    cell = base_cell_m(spec.world)
    for corner in _corners(params):
        values = {p.path: p.value(u, cell) for p, u in zip(params, corner)}
        sensor_values = {k: v for k, v in values.items() if is_sensor_path(k)}
        if sensor_values:
            try:
                check_suite(apply_sensor_values(spec.robot or RobotSpec(), sensor_values), spec.sim)
            except SpecError as err:
                shown = ", ".join(f"{k}={v:g}" for k, v in sensor_values.items())
                raise SpecError("space", shown, f"ranges whose extreme values make valid sensors (here "
                                f"{err.field}={err.value!r}: expected {err.expected})", "narrow the ranges") from None
        try:
            parse_spec(deep_merge(spec.world, world_overrides(values, spec.world)))
        except SpecError as err:
            shown = ", ".join(f"{k}={v:g}" for k, v in values.items())
            raise SpecError("space", shown, f"ranges whose extreme values make valid worlds (here "
                            f"{err.field}={err.value!r}: expected {err.expected})", "narrow the ranges") from None


def _check_descriptors(field: str, descs: list[DescriptorSpec], paths: set[str]) -> None:
    if len(descs) != 2:
        raise SpecError(field, [d.name for d in descs], "exactly two descriptors (the map's two axes)")
    if descs[0].name == descs[1].name:
        raise SpecError(field, [d.name for d in descs], "two different descriptors")
    for j, d in enumerate(descs):
        if d.name not in WORLD_DESCRIPTORS and d.name not in paths:
            raise SpecError(f"{field}[{j}].name", d.name, f"a world descriptor {list(WORLD_DESCRIPTORS)} or a "
                            "path of the space", "check its spelling")
        if not (math.isfinite(d.low) and math.isfinite(d.high)) or not d.low < d.high:
            raise SpecError(f"{field}[{j}]", f"[{d.low:g}, {d.high:g}]", "a finite range with low < high")


def _check_options(data: dict[str, Any]) -> None:
    """Unknown objective or algorithm names, and options that belong to another one."""
    obj = data.get("objective", MISSING)
    if obj is MISSING or obj is None:
        raise SpecError("objective", obj, f"a mapping with a name, one of {list(OBJECTIVES)}",
                        "`navstress search init --objective NAME` writes a ready spec")
    if not isinstance(obj, dict):
        raise SpecError("objective", obj, f"a mapping with a name, one of {list(OBJECTIVES)}")
    name = obj.get("name", MISSING)
    if not isinstance(name, str) or name not in OBJECTIVES:
        raise SpecError("objective.name", name, f"one of {list(OBJECTIVES)}")
    for k in obj:
        if k != "name" and k not in OBJECTIVE_OPTIONS[name]:
            owners = [o for o, opts in OBJECTIVE_OPTIONS.items() if k in opts]
            expected = (f"an option of the {' and '.join(owners)} objective" if owners else "a known option")
            raise SpecError(f"objective.{k}", obj[k], f"{expected} (the {name} objective takes: "
                            f"{', '.join(OBJECTIVE_OPTIONS[name])})", "remove it or check its spelling")
    algo = data.get("algorithm")
    if algo is None:
        return
    if not isinstance(algo, dict):
        raise SpecError("algorithm", algo, f"a mapping with a name, one of {list(ALGORITHMS)}")
    aname = algo.get("name", AlgorithmSpec.model_fields["name"].default)
    if not isinstance(aname, str) or aname not in ALGORITHMS:
        raise SpecError("algorithm.name", aname, f"one of {list(ALGORITHMS)}")
    for k in algo:
        if k not in ("name", "batch") and k not in ALGORITHM_SETTINGS[aname]:
            owners = [a for a, opts in ALGORITHM_SETTINGS.items() if k in opts]
            takes = ", ".join(("batch", *ALGORITHM_SETTINGS[aname]))
            expected = f"a setting of {' and '.join(owners)}" if owners else "a known setting"
            raise SpecError(f"algorithm.{k}", algo[k], f"{expected} ({aname} takes: {takes})",
                            "remove it or check its spelling")


def parse_search(data: Any, base_dir: str | Path | None = None) -> SearchSpec:
    """Validate a mapping into a SearchSpec (SpecError on bad input).

    Checks, before anything runs: every field and no unknown one; the objective and the algorithm
    are known and given only their own options; every path of the space is a numeric WorldSpec
    parameter, once, with a range low < high (whole numbers for ``kind: int``); every corner of the
    space makes a valid world; the budget holds at least one generation; the fault-revealing
    objective's fault and the nominal stack are among the faults; the descriptors are two known
    ones with ranges; the robot (``robot:``, as in a campaign spec: a profile, a file relative to
    ``base_dir``, a mapping with ``base:`` and overrides) is known and fits the free areas."""
    if not isinstance(data, dict):
        raise SpecError("search", type(data).__name__, "a mapping of fields at the top level")
    if "world" in data:  # a world source relative to the spec file's folder
        data = {**data, "world": resolve_source(data["world"], base_dir)}
    if data.get("robot") is not None:
        data = {**data, "robot": resolve_robot_ref(data["robot"], "robot", base_dir)}
    if data.get("sensors") is not None or data.get("sensors_add") is not None:
        # the robot carries its suite from here on (its digest, the campaign's tasks)
        robot = data["robot"] if data.get("robot") is not None else RobotSpec()
        data = {**data, "robot": apply_sensors(robot, sensors=data.get("sensors"), sensors_add=data.get("sensors_add"))}
    data = {k: v for k, v in data.items() if k not in ("sensors", "sensors_add")}
    _check_options(data)
    budget = data.get("budget")
    if isinstance(budget, dict):
        runs = budget.get("runs")
        if isinstance(runs, (int, float)) and not isinstance(runs, bool) and runs <= 0:
            raise SpecError("budget.runs", runs, "a number of runs > 0")
    spec = parse(SearchSpec, data)
    if spec.budget.runs > MAX_BUDGET_RUNS:
        raise SpecError("budget.runs", spec.budget.runs, f"at most {MAX_BUDGET_RUNS:,} runs")
    base = check_base_world(spec.world)
    if spec.robot is not None and 0 < base.mission.free_radius_m < spec.robot.half_diagonal_m:
        r = spec.robot
        raise SpecError("world.mission.free_radius_m", base.mission.free_radius_m, f"a free disc the robot {r.name!r} "
                        f"fits in (its half diagonal is {r.half_diagonal_m:.3g} m)",
                        f"raise it to at least {r.half_diagonal_m:.3g}")
    if spec.robot is not None:
        check_suite(spec.robot, spec.sim)
    params = spec.space.parameters
    if not params and not spec.space.map_seed and spec.space.moves is None:
        raise SpecError("space", "no parameters and map_seed: false",
                        "at least one parameter, space.moves, or map_seed: true")
    seen: set[str] = set()
    for i, p in enumerate(params):
        if p.path in seen:
            raise SpecError(f"space.parameters[{i}].path", p.path, "a path given once")
        seen.add(p.path)
        _check_parameter(i, p, spec.world, spec.robot, frozenset(q.path for q in params))
    _check_corners(spec)
    check_faults(spec.faults)
    _check_objective(spec, seen)
    _check_algorithm(spec, seen)
    need = spec.generation_runs()
    if spec.budget.runs < need:
        raise SpecError("budget.runs", spec.budget.runs, f"at least one generation's runs ({need} = batch "
                        f"{spec.algorithm.batch} x {spec.max_runs_per_candidate()} runs x {len(spec.faults)} "
                        "faults)", "raise the budget, or lower algorithm.batch or runs_per_candidate")
    return spec


def _check_objective(spec: SearchSpec, paths: set[str]) -> None:
    obj = spec.objective
    if obj.name == "fault-revealing":
        if obj.fault is None:
            raise SpecError("objective.fault", MISSING if "fault" not in obj.model_fields_set else None, "the name of the fault to reveal, e.g. small-footprint",
                            "`navstress nav faults` lists them")
        if not is_name(obj.fault):
            raise SpecError("objective.fault", obj.fault, "a fault name of letters, digits, '_', '.', '-'")
        if obj.fault not in spec.faults or None not in spec.faults:
            raise SpecError("faults", spec.faults, f"a list holding null (the nominal stack) and {obj.fault!r}",
                            "leave faults out to get exactly these two")
    if obj.name == "illumination":
        if obj.descriptors is None:
            raise SpecError("objective.descriptors", MISSING if "descriptors" not in obj.model_fields_set else None, "two descriptors, each {name, low, high, cells}",
                            "e.g. obstruction and path_ratio")
        _check_descriptors("objective.descriptors", obj.descriptors, paths)


def _check_algorithm(spec: SearchSpec, paths: set[str]) -> None:
    algo = spec.algorithm
    if algo.descriptors is not None:
        if spec.objective.descriptors is not None:
            raise SpecError("algorithm.descriptors", [d.name for d in algo.descriptors],
                            "no descriptors here when the objective names them", "keep objective.descriptors only")
        _check_descriptors("algorithm.descriptors", algo.descriptors, paths)
    n = algo.emitter_count()
    per = 2 if algo.name == "cma-me" else 1
    if algo.name in ("map-elites", "cma-me") and algo.batch < per * n:
        raise SpecError("algorithm.batch", algo.batch, f"at least {per * n} ({n} emitters x {per} candidates "
                        "each)", "raise batch or lower emitters")
    if algo.name in ("ga", "nsga2") and algo.batch < 2:
        raise SpecError("algorithm.batch", algo.batch, "at least 2 (a population to recombine)")


#: The fields of the campaign a search runs (:meth:`SearchSpec.campaign_fields`) that the search
#: spec names otherwise: an error of that campaign names the search spec's field.
CAMPAIGN_TO_SEARCH = (("navigators[0]", "navigator"), ("runs_per_map", "runs_per_candidate"),
                      ("experiments", "space"))


def as_search_error(err: SpecError, spec: SearchSpec) -> SpecError:
    """``err``, raised by the campaign a search runs, naming the search spec's field: ``navigator``
    (not ``navigators[0]``), ``runs_per_candidate`` (not ``runs_per_map``), the objective's fault
    when the faults were left out (they are then the nominal stack and that fault)."""
    field = err.field
    for theirs, ours in CAMPAIGN_TO_SEARCH:
        if field == theirs or field.startswith((theirs + ".", theirs + "[")):
            field = ours + field[len(theirs):]
            break
    if field == "faults" and spec.objective.fault is not None and err.value == spec.objective.fault:
        field = "objective.fault"
    return err if field == err.field else SpecError(field, err.value, err.expected, err.fix)


def load_search(path: str | Path) -> tuple[SearchSpec, str]:
    """Read and validate a search YAML/JSON file; returns the spec and the text as given."""
    p = Path(path)
    text = read_text(p, field="search")
    return parse_search_text(text, str(p), base_dir=p.parent), text


def parse_search_text(text: str, name: str = "search", base_dir: str | Path | None = None) -> SearchSpec:
    """Parse and validate search YAML/JSON text (``name`` is what an error names; ``base_dir``:
    where a robot file is)."""
    data = parse_text(text, field="search", name=name)
    return parse_search(data if data is not None else {}, base_dir)


def spec_data(spec: SearchSpec) -> dict[str, Any]:
    """``spec`` as the mapping a user would write: the fields set, and its robot's whole
    description (a robot's fields are all needed: a partial one reads back as another robot)."""
    data = spec.model_dump(mode="json", exclude_unset=True)
    if spec.robot is not None:
        data["robot"] = spec.robot.model_dump(mode="json")
    return data


def with_budget(spec: SearchSpec, runs: int, field: str = "--budget") -> SearchSpec:
    """``spec`` with ``budget.runs`` replaced (validated again; an error names ``field``)."""
    data = spec_data(spec)
    data["budget"] = {**data["budget"], "runs": runs}
    try:
        return parse_search(data)
    except SpecError as err:
        if err.field == "budget.runs":
            raise SpecError(field, runs, err.expected, err.fix) from None
        raise
