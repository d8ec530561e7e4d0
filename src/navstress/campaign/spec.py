"""CampaignSpec: what a campaign runs, validated before anything runs.

A campaign has experiment classes; each sweeps one or more WorldSpec parameters (a
cartesian product when several), on top of a base world spec plus per-experiment
overrides. Every point of a sweep is a *configuration*; its ``config`` is the mapping of
swept paths to values. Each configuration gets ``maps_per_config`` maps and each map
``runs_per_map`` runs, for every navigator and every fault (``null`` = nominal).

An experiment may list explicit worlds instead of a sweep (``worlds:``, exclusive with
``sweep``): each entry ``{key, map_seed, world}`` is one configuration (key = the entry's
key) with exactly one map (map index 0, ``maps_per_config`` does not apply) generated from
the entry's own ``map_seed``, its WorldSpec the campaign ``world``, then the experiment's
``overrides``, then the entry's ``world`` overrides. Its ``config`` is the entry's ``world``
overrides flattened to dotted paths (``{"obstacles.obstruction.tree": 6}``; ``{}`` for none).
Run seeds are derived as for a sweep, from (experiment, key, 0, run index): the navigators
and faults on an entry are paired. A regression suite is such a spec.

    >>> spec = parse_campaign({"name": "s", "experiments": [{"name": "suite", "worlds": [
    ...     {"key": "dense", "map_seed": 42, "world": {"obstacles": {"obstruction": {"tree": 12}}}}]}]})
    >>> [(c.key, c.map_seed, c.values) for c in spec.experiments[0].configurations(spec.world)]
    [('dense', 42, {'obstacles.obstruction.tree': 12})]

``runs_per_map`` (campaign-wide, or per experiment) is an integer, or an adaptive rule
``{adaptive: {min: 3, max: 25, threshold: 0.8, confidence: 0.95}}``: each (map, navigator,
fault) is run again only while its verdict is undecided (:mod:`navstress.sequential`), at
least ``min`` and at most ``max`` times; plan sizes count ``max``.

    >>> spec = parse_campaign({"name": "t", "seed": 1, "experiments": [
    ...     {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 4, "step": 2}}}]})
    >>> [c.key for c in spec.experiments[0].configurations(spec.world)]
    ['tree=0', 'tree=2', 'tree=4']

Every error is a :class:`~navstress.errors.SpecError` naming the field path, e.g.
``experiments[0].sweep.ground.deformaton=... is invalid``.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import math
import re
import typing
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, Field, field_validator, model_validator

from navstress import _json
from navstress._models import SPEC_CONFIG, parse
from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec, resolve_robot
from navstress.robot.files import robot_from_mapping
from navstress.sensors import Sensor
from navstress.run.sensors import apply_sensor_values, apply_sensors, check_suite, is_sensor_path, sensor_path_kind
from navstress.seeding import MAX_SEED
from navstress.sequential import AdaptiveRule, check_rule
from navstress.specfile import parse_text, read_text
from navstress.world.spec import WorldSpec, parse_spec, resolve_source

_STRICT = SPEC_CONFIG
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def is_name(v: str) -> bool:
    """Whether ``v`` is a name of letters, digits, '_', '.', '-' starting with a letter or digit
    (a campaign's, a search's, an experiment's, a fault's)."""
    return _NAME.match(v) is not None


def check_name(v: str) -> str:
    """``v`` when it is a name of letters, digits, '_', '.', '-' (a campaign's or a search's),
    else ValueError (pydantic turns it into the field's SpecError)."""
    if not is_name(v):
        raise ValueError("a name of letters, digits, '_', '.', '-'")
    return v


def check_faults(faults: list[str | None], field: str = "faults", *, names: bool = True) -> None:
    """A list of faults (a campaign's, an experiment's, a search's): no duplicate and (``names``)
    each a fault name or null, the nominal stack (:func:`check_fault_names`); SpecError naming ``field``."""
    if len(set(faults)) != len(faults):
        raise SpecError(field, faults, "a list without duplicates")
    if names:
        check_fault_names(faults, field)


def check_fault_names(faults: list[str | None], field: str = "faults") -> None:
    """Each of ``faults`` a name of letters, digits, '_', '.', '-' or null (SpecError naming ``field``)."""
    for f in faults:
        if f is not None and not is_name(f):
            raise SpecError(field, f, "a fault name of letters, digits, '_', '.', '-' (or null for nominal)")


def check_base_world(world: dict[str, Any]) -> WorldSpec:
    """The base ``world`` of a campaign or a search as a WorldSpec (SpecError naming ``world.FIELD``)."""
    try:
        return parse_spec(world)
    except SpecError as err:
        raise SpecError(f"world.{err.field}", err.value, err.expected, err.fix) from None
#: Most values a single experiment may expand to (guards against a typo'd step of 1e-9).
MAX_CONFIGS_PER_EXPERIMENT = 10_000
#: Most runs a campaign may plan unless the user accepts more (``campaign run --yes``).
MAX_PLANNED_RUNS = 100_000
#: Most parallel workers a campaign (or the demo) may be given.
MAX_WORKERS = 1024
#: Largest map seed of an explicit world (a SQLite INTEGER; what ``navstress world --seed`` accepts).
MAX_MAP_SEED = MAX_SEED
#: Longest key of an explicit world (it becomes a directory name).
MAX_KEY_LEN = 100
#: Wall seconds per run assumed by the size estimate of a refused plan (a rough order of magnitude).
ESTIMATED_WALL_S_PER_RUN = 10.0


class Range(BaseModel):
    """``start`` to ``stop`` inclusive with a fixed ``step`` (> 0); or an explicit ``values`` list."""

    model_config = _STRICT
    start: float | None = None
    stop: float | None = None
    step: float | None = Field(None, gt=0.0)
    values: list[float | int | str | bool] | None = None

    @model_validator(mode="after")
    def _one_form(self) -> "Range":
        ranged = (self.start, self.stop, self.step)
        if self.values is not None:
            if any(v is not None for v in ranged):
                raise ValueError("give either start/stop/step or values, not both")
            if not self.values:
                raise ValueError("values must not be empty")
        elif any(v is None for v in ranged):
            raise ValueError("give start, stop and step (all three), or a values list")
        elif self.stop < self.start:  # type: ignore[operator]
            raise ValueError(f"stop ({self.stop:g}) must be >= start ({self.start:g})")
        return self

    def count(self) -> int:
        """How many values the range has, without expanding it (ValueError when the start,
        stop and step give infinitely many or a number too large to count)."""
        if self.values is not None:
            return len(self.values)
        assert self.start is not None and self.stop is not None and self.step is not None
        q = (self.stop - self.start) / self.step
        if not math.isfinite(q) or q > 1e15:
            raise ValueError(f"the range has about {q:.3g} values: too many to count (at most "
                             f"{MAX_CONFIGS_PER_EXPERIMENT}); use a larger step or a narrower range")
        return max(0, math.floor(q + 1e-9) + 1)

    def expand(self) -> list[Any]:
        """The sampled values; integers stay integers when start and step are whole.

        Float ranges are computed as ``start + i*step`` rounded to 10 decimals (no drift),
        ``stop`` included when it lies on the grid within 1e-9 steps."""
        if self.values is not None:
            return list(self.values)
        assert self.start is not None and self.stop is not None and self.step is not None
        n = self.count()
        if n > MAX_CONFIGS_PER_EXPERIMENT:
            raise ValueError(f"the range has {n} values (at most {MAX_CONFIGS_PER_EXPERIMENT})")
        whole = float(self.start).is_integer() and float(self.step).is_integer()
        out: list[Any] = []
        for i in range(n):
            v = round(self.start + i * self.step, 10)
            out.append(int(v) if whole else v)
        return out


class AdaptiveSpec(BaseModel):
    """The parameters of an adaptive rule (:class:`navstress.sequential.AdaptiveRule`)."""

    model_config = _STRICT
    min: int = 3
    max: int = 25
    threshold: float = 0.8
    confidence: float = 0.95
    indifference: float = 0.0


class AdaptiveRuns(BaseModel):
    """``runs_per_map: {adaptive: {...}}``: run a map again while its verdict is undecided."""

    model_config = _STRICT
    adaptive: AdaptiveSpec = Field(default_factory=AdaptiveSpec)

    def rule(self) -> AdaptiveRule:
        a = self.adaptive
        return AdaptiveRule(a.min, a.max, a.threshold, a.confidence, a.indifference)


_REPETITION = "an integer in [1, 10000], or {adaptive: {min: 3, max: 25, threshold: 0.8, confidence: 0.95}}"


def repetition(value: Any, field: str = "runs_per_map") -> int | AdaptiveRuns:
    """``value`` as a runs_per_map: an integer in [1, 10000] or :class:`AdaptiveRuns` whose rule
    :func:`navstress.sequential.check_rule` accepts (SpecError naming ``field...`` otherwise)."""
    if isinstance(value, AdaptiveRuns):
        return value
    if isinstance(value, dict):
        if set(value) != {"adaptive"}:
            bad = sorted(set(value) - {"adaptive"}, key=str)
            raise SpecError(f"{field}.{bad[0]}" if bad else field, value if not bad else value[bad[0]],
                            "only the key 'adaptive' in " + _REPETITION)
        inner = value["adaptive"]
        if inner is None:
            inner = {}
        if not isinstance(inner, dict):
            raise SpecError(f"{field}.adaptive", inner, "a mapping of min, max, threshold, confidence, indifference")
        known = set(AdaptiveSpec.model_fields)
        for k in inner:
            if k not in known:
                raise SpecError(f"{field}.adaptive.{k}", inner[k], "one of the keys min, max, threshold, confidence, indifference",
                                "check its spelling")
        merged = {**AdaptiveSpec().model_dump(), **inner}
        check_rule(merged["min"], merged["max"], merged["threshold"], merged["confidence"], field=f"{field}.adaptive",
                   indifference=merged["indifference"])
        return AdaptiveRuns(adaptive=AdaptiveSpec(**merged))
    if isinstance(value, bool) or not isinstance(value, int):
        fix = ("write it without quotes" if isinstance(value, str) else
               "true and false are not numbers" if isinstance(value, bool) else None)
        raise SpecError(field, value, _REPETITION, fix)
    if not 1 <= value <= 10_000:
        raise SpecError(field, value, _REPETITION)
    return value


class NavigatorSpec(BaseModel):
    """A navigator under test: a registered name (or a ``module:attr`` target) and its config."""

    model_config = _STRICT
    name: str = "reference-v1"
    config: dict[str, Any] = Field(default_factory=dict)
    target: str | None = Field(None, description="'module:attr' factory, registered under `name` in every worker")


class WorldEntry(BaseModel):
    """One explicit world of an experiment: its configuration key, its map seed (used as
    given, not derived) and its WorldSpec overrides (on the campaign world and the experiment's
    overrides)."""

    model_config = _STRICT
    key: str
    map_seed: int = Field(strict=True, ge=0, le=MAX_MAP_SEED)
    world: dict[str, Any] = Field(default_factory=dict)
    #: the robots' sensor values of this world (``sensors.<name>.<param>``: a search's candidate)
    sensors: dict[str, Any] | None = None

    @field_validator("key")
    @classmethod
    def _key(cls, v: str) -> str:
        if not is_name(v) or len(v) > MAX_KEY_LEN:
            raise ValueError(f"a key of at most {MAX_KEY_LEN} letters, digits, '_', '.', '-', starting with a "
                             "letter or digit (it becomes a directory name)")
        return v

    def text_data(self) -> dict[str, Any]:
        """The entry as a spec's text has it: without ``sensors`` when it sets none (the text of
        before sensors were declared)."""
        out = self.model_dump(mode="json")
        if out.get("sensors") is None:
            out.pop("sensors", None)
        return out


class ExperimentSpec(BaseModel):
    """One experiment class: a sweep over world parameters, or a list of explicit worlds,
    plus base overrides."""

    model_config = _STRICT
    name: str
    sweep: dict[str, Range] = Field(default_factory=dict)
    worlds: list[WorldEntry] | None = Field(None, max_length=MAX_CONFIGS_PER_EXPERIMENT)
    overrides: dict[str, Any] = Field(default_factory=dict)
    faults: list[str | None] | None = None  # None: the campaign's faults
    runs_per_map: int | AdaptiveRuns | None = None  # None: the campaign's
    robot: RobotSpec | None = None  # None: the campaign's robot(s)
    robots: list[RobotSpec] | None = Field(None, min_length=1)  # None: the campaign's
    # applied to the experiment's robots when the spec is read (resolve_robots), then None
    sensors: list[Any] | None = Field(None, description="the sensor suite of the experiment's robots (replacing theirs)")
    sensors_add: list[Any] | None = Field(None, description="sensors added to the experiment's robots")

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        if not is_name(v):
            raise ValueError("a name of letters, digits, '_', '.', '-' (it becomes a directory name)")
        return v

    @field_validator("runs_per_map", mode="before")
    @classmethod
    def _runs(cls, v: Any) -> int | AdaptiveRuns | None:
        return None if v is None else repetition(v)

    @model_validator(mode="after")
    def _worlds(self) -> "ExperimentSpec":
        if self.worlds is None:
            return self
        if "sweep" in self.model_fields_set:
            raise SpecError("sweep", {k: r.model_dump(exclude_none=True) for k, r in self.sweep.items()},
                            "no sweep in an experiment that lists explicit worlds",
                            "give either sweep or worlds (put sweeps in an experiment of their own)")
        if not self.worlds:
            raise SpecError("worlds", [], "at least one entry {key, map_seed, world}", "or remove worlds and "
                            "give a sweep")
        seen: set[str] = set()
        for j, w in enumerate(self.worlds):
            if w.key in seen:
                raise SpecError(f"worlds[{j}].key", w.key, "a key unique among the experiment's worlds",
                                "rename one of them")
            seen.add(w.key)
        return self

    @property
    def explicit(self) -> bool:
        """Whether the experiment lists explicit worlds (no sweep)."""
        return self.worlds is not None

    def configurations(self, base: dict[str, Any]) -> list["Configuration"]:
        """Every point of the sweep (cartesian product, in sweep order), or every explicit world
        (in list order, with its map seed), with its WorldSpec."""
        merged = deep_merge(base, self.overrides)
        if self.worlds is not None:
            return [Configuration(experiment=self.name, key=w.key, values={**flatten(w.world), **(w.sensors or {})},
                                  world=deep_merge(merged, w.world), map_seed=w.map_seed) for w in self.worlds]
        paths = list(self.sweep)
        short = _short_names(paths)
        grids = [self.sweep[p].expand() for p in paths]
        out: list[Configuration] = []
        for combo in itertools.product(*grids) if grids else [()]:
            values = dict(zip(paths, combo))
            key = ",".join(f"{short[p]}={_fmt(v)}" for p, v in values.items()) or "base"
            data = copy.deepcopy(merged)
            for p, v in values.items():
                if not is_sensor_path(p):  # sensors.<name>.<param>: the robots' (Configuration.robot)
                    _set_path(data, p, v)
            out.append(Configuration(experiment=self.name, key=key, values=values, world=data))
        return out


class CampaignSpec(BaseModel):
    """A whole campaign (see module doc)."""

    model_config = _STRICT
    name: str = "campaign"
    seed: int = Field(0, ge=0, le=MAX_SEED)
    world: dict[str, Any] = Field(default_factory=dict, description="the base WorldSpec mapping")
    experiments: list[ExperimentSpec] = Field(min_length=1)
    maps_per_config: int = Field(5, ge=1, le=10_000)
    runs_per_map: int | AdaptiveRuns = 5
    navigators: list[NavigatorSpec] = Field(default_factory=lambda: [NavigatorSpec()], min_length=1)
    faults: list[str | None] = Field(default_factory=lambda: list[str | None]([None]), min_length=1)
    timeout_s: float = Field(400.0, gt=0.0, le=86_400.0)
    goal_tolerance_m: float = Field(2.0, gt=0.0, allow_inf_nan=False)
    record_lidar: bool = False
    record_navigator: bool = False
    sim: dict[str, Any] = Field(default_factory=dict, description="simulation overrides passed to every run")
    robot: RobotSpec | None = Field(None, description="the robot of every run (None: rmp400); see robots")
    robots: list[RobotSpec] | None = Field(None, min_length=1, description="several robots: every run for each")
    # applied to every robot of the spec when it is read (resolve_robots), then None
    sensors: list[Any] | None = Field(None, description="the sensor suite of every robot (replacing theirs)")
    sensors_add: list[Any] | None = Field(None, description="sensors added to every robot's suite")

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        return check_name(v)

    @field_validator("runs_per_map", mode="before")
    @classmethod
    def _runs(cls, v: Any) -> int | AdaptiveRuns:
        return repetition(v)

    def canonical_json(self) -> str:
        """A stable text of the validated spec (used to refuse resuming with another spec; an
        experiment without its own ``runs_per_map``, an adaptive rule without indifference, a spec
        that does not record the navigator's view, and one of the default robot (no ``robot:``, or
        ``robot: rmp400``), have the same text as before those keys existed). A robot is there
        with its whole description: a changed robot file changes the digest."""
        data = self.model_dump(mode="json")
        if not data["record_navigator"]:
            del data["record_navigator"]
        # no robot given, or the default robot (rmp400) alone: the text of before robots existed
        # (an experiment's own default robot only when the campaign's is the default too)
        plain = (None, RobotSpec().model_dump(mode="json"), [RobotSpec().model_dump(mode="json")])
        top_default = data.get("robot") in plain and data.get("robots") in plain
        for owner in (data, *data["experiments"]):
            for key in ("robot", "robots"):
                if owner.get(key) is None or (top_default and owner.get(key) in plain):
                    owner.pop(key, None)
            for key in ("sensors", "sensors_add"):  # in the robots' descriptions once read
                if owner.get(key) is None:
                    owner.pop(key, None)
        for exp in data["experiments"]:
            if exp.get("runs_per_map") is None:
                exp.pop("runs_per_map", None)
            if exp.get("worlds") is None:  # a sweep experiment: the text of before worlds existed
                exp.pop("worlds", None)
            else:  # explicit worlds: no sweep key (both together are refused)
                exp.pop("sweep", None)
                for w in exp["worlds"]:
                    if w.get("sensors") is None:  # a world without sensor values: its text of before
                        w.pop("sensors", None)
        for owner in (data, *data["experiments"]):
            rpm = owner.get("runs_per_map")
            if isinstance(rpm, dict) and rpm["adaptive"].get("indifference") == 0.0:
                del rpm["adaptive"]["indifference"]
        return _json.dumps(data, sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()[:16]

    def faults_of(self, exp: ExperimentSpec) -> list[str | None]:
        return list(exp.faults) if exp.faults is not None else list(self.faults)

    def rule_of(self, exp: ExperimentSpec) -> AdaptiveRule | None:
        """The adaptive rule of ``exp``'s runs, None when it runs a fixed number per map."""
        r = exp.runs_per_map if exp.runs_per_map is not None else self.runs_per_map
        return r.rule() if isinstance(r, AdaptiveRuns) else None

    def robots_of(self, exp: ExperimentSpec) -> list[RobotSpec]:
        """The robots ``exp`` runs each of its runs on: its own ``robots``/``robot``, else the
        campaign's, else the default robot (``rmp400``)."""
        for owner in (exp, self):
            if owner.robots is not None:
                return list(owner.robots)
            if owner.robot is not None:
                return [owner.robot]
        return [RobotSpec()]

    def all_robots(self) -> list[RobotSpec]:
        """Every robot of the campaign, once each (by name), in the order first listed."""
        out: dict[str, RobotSpec] = {}
        for exp in self.experiments:
            for r in self.robots_of(exp):
                out.setdefault(r.name, r)
        return list(out.values())

    @property
    def several_robots(self) -> bool:
        """Whether the campaign runs more than one robot: its run ids then name the robot
        (``.../r<j>/<navigator>@<robot>/<fault>``, :func:`navstress.campaign.plan.run_id`)."""
        return len(self.all_robots()) > 1

    def maps_of(self, exp: ExperimentSpec) -> int:
        """Maps per configuration of ``exp``: ``maps_per_config``, or 1 for explicit worlds."""
        return 1 if exp.worlds is not None else self.maps_per_config

    def max_runs_of(self, exp: ExperimentSpec) -> int:
        """The most runs per map (and navigator and fault) of ``exp``: its fixed count or the rule's max."""
        r = exp.runs_per_map if exp.runs_per_map is not None else self.runs_per_map
        return r.adaptive.max if isinstance(r, AdaptiveRuns) else r


@dataclass(frozen=True)
class Configuration:
    """One point of a sweep, or one explicit world: ``values`` maps swept paths to values (an
    explicit world: its overrides, flattened); ``world`` is its WorldSpec mapping; ``map_seed``
    the explicit world's map seed (None: a sweep's, whose map seeds are derived)."""

    experiment: str
    key: str
    values: dict[str, Any]
    world: dict[str, Any]
    map_seed: int | None = None

    def world_spec(self) -> WorldSpec:
        return parse_spec(self.world)

    @property
    def sensor_values(self) -> dict[str, Any]:
        """The swept sensor paths (``sensors.<name>.<param>``) and their values."""
        return {p: v for p, v in self.values.items() if is_sensor_path(p)}

    def robot(self, robot: RobotSpec, where: str = "") -> RobotSpec:
        """``robot`` with this configuration's sensor values set (itself when it sweeps none)."""
        values = self.sensor_values
        return apply_sensor_values(robot, values, where=where) if values else robot


# ---- validation ----------------------------------------------------------------------


def planned_runs(spec: CampaignSpec) -> int:
    """How many runs ``spec`` plans (at most: adaptive rules count their ``max``), computed from the sweep sizes without expanding any product."""
    total = 0
    for exp in spec.experiments:
        n = 1
        for rng in exp.sweep.values():
            n *= rng.count()
        if exp.worlds is not None:
            n = len(exp.worlds)
        total += (n * spec.maps_of(exp) * spec.max_runs_of(exp) * len(spec.navigators) * len(spec.faults_of(exp))
                  * len(spec.robots_of(exp)))
    return total


def check_plan_size(spec: CampaignSpec, max_runs: int | None = MAX_PLANNED_RUNS) -> int:
    """The planned run count; SpecError (with the count and a rough duration) above ``max_runs``."""
    n = planned_runs(spec)
    if max_runs is not None and n > max_runs:
        hours = n * ESTIMATED_WALL_S_PER_RUN / 3600
        size = f"{n:,}" if n < 10**15 else f"about 10^{len(str(n)) - 1}"
        raise SpecError("campaign", f"{size} planned runs", f"at most {max_runs:,} runs (this plan is about "
                        f"{hours:,.0f} h of single-worker time at ~{ESTIMATED_WALL_S_PER_RUN:g} s per run)",
                        "reduce the sweeps, maps_per_config or runs_per_map, or pass --yes to accept it")
    return n


def parse_campaign(data: Any, *, max_runs: int | None = MAX_PLANNED_RUNS,
                   base_dir: str | Path | None = None) -> CampaignSpec:
    """Validate a mapping into a CampaignSpec and check every configuration (SpecError on bad input).

    Checks, before anything runs: every field, the plan's size (at most ``max_runs`` runs, None:
    no limit; checked before any sweep is expanded), every swept path exists in WorldSpec, every
    configuration validates as a WorldSpec, experiment names are unique, no duplicate navigator/fault,
    every robot known and fitting the worlds' free areas. ``robot:`` and ``robots:`` entries (a
    profile name, a robot file relative to ``base_dir`` (default: the working directory), or a
    mapping with an optional ``base:`` profile and overrides) become RobotSpecs here
    (:func:`resolve_robots`)."""
    if not isinstance(data, dict):
        raise SpecError("campaign", type(data).__name__, "a mapping of fields at the top level")
    return check_campaign(parse(CampaignSpec, resolve_world_sources(resolve_robots(data, base_dir), base_dir)),
                          max_runs=max_runs)


def resolve_world_sources(data: Any, base_dir: str | Path | None = None) -> Any:
    """A campaign (or search) mapping whose world sources are absolute paths
    (:func:`~navstress.world.spec.resolve_source` on its ``world``, each experiment's ``overrides``
    and each explicit world's ``world``); relative ones are relative to ``base_dir``."""
    if not isinstance(data, dict):
        return data
    out = dict(data)
    out["world"] = resolve_source(out.get("world"), base_dir) if "world" in out else out.get("world")
    if "world" not in data:
        out.pop("world")
    exps = out.get("experiments")
    if isinstance(exps, list):
        new = []
        for e in exps:
            if isinstance(e, dict):
                e = dict(e)
                if "overrides" in e:
                    e["overrides"] = resolve_source(e["overrides"], base_dir)
                if isinstance(e.get("worlds"), list):
                    e["worlds"] = [{**w, "world": resolve_source(w["world"], base_dir)}
                                   if isinstance(w, dict) and "world" in w else w for w in e["worlds"]]
            new.append(e)
        out["experiments"] = new
    return out


#: What a ``robot:`` entry may be, in words (errors).
ROBOT_REF = ("a robot profile name, a robot file (.yaml, .yml, .json, .urdf, .xml), or a mapping of "
             "RobotSpec fields with an optional base: profile")


def resolve_robot_ref(ref: Any, field: str, base_dir: str | Path | None = None) -> RobotSpec:
    """The RobotSpec of one ``robot:`` entry of a spec (SpecError naming ``field``, e.g.
    ``robots[1]``, with a "did you mean" for an unknown profile). A relative file path is taken
    relative to ``base_dir`` (the spec file's folder)."""
    if isinstance(ref, RobotSpec):
        return ref
    if isinstance(ref, dict):
        return robot_from_mapping(ref, where=field, base_dir=Path(base_dir) if base_dir is not None else None)
    if not isinstance(ref, str) or not ref:
        raise SpecError(field, ref, ROBOT_REF)
    if base_dir is not None and ref.lower().endswith((".yaml", ".yml", ".json", ".urdf", ".xml")):
        if not Path(ref).is_absolute():
            ref = str(Path(base_dir) / ref)
    try:
        return resolve_robot(ref)
    except SpecError as err:
        inner = err.field if err.field != "robot" else ""
        where = field if not inner else (f"{field}.{inner[6:]}" if inner.startswith("robot.") else f"{field}.{inner}")
        raise SpecError(where, err.value, err.expected, err.fix) from None


def resolve_robots(data: dict[str, Any], base_dir: str | Path | None = None) -> dict[str, Any]:
    """``data`` (a campaign spec's mapping) with each ``robot:`` / ``robots:`` entry, at the top
    level and in each experiment, replaced by its RobotSpec (see :func:`resolve_robot_ref`);
    ``data`` itself is not changed. A null entry stays null (the default).

    ``sensors:`` / ``sensors_add:`` (docs/sensors.md) are applied here and taken out of the
    mapping: the top level's to every robot of the spec (the default robot, rmp400, when it names
    none), an experiment's to the experiment's robots (its own, else the campaign's), after the
    top level's. The robots then carry their suites: the tasks, the records' robot digests and
    the spec's digest see them."""
    out = dict(data)

    def fix(owner: dict[str, Any], where: str) -> None:
        if owner.get("robot") is not None:
            owner["robot"] = resolve_robot_ref(owner["robot"], f"{where}robot", base_dir)
        refs = owner.get("robots")
        if refs is not None:
            if not isinstance(refs, list) or not refs:
                raise SpecError(f"{where}robots", refs, f"a non-empty list, each {ROBOT_REF}")
            owner["robots"] = [resolve_robot_ref(r, f"{where}robots[{i}]", base_dir) for i, r in enumerate(refs)]

    def suites(owner: dict[str, Any]) -> tuple[Any, Any]:
        return owner.pop("sensors", None), owner.pop("sensors_add", None)

    def apply(owner: dict[str, Any], given: tuple[Any, Any], where: str, default: dict[str, Any] | None) -> None:
        """Apply ``given`` to ``owner``'s robots (or, when it names none, to ``default``'s)."""
        if given == (None, None):
            return
        src = owner if owner.get("robot") is not None or owner.get("robots") is not None else (default or {})
        if src.get("robots") is not None:
            owner["robots"] = [apply_sensors(r, sensors=given[0], sensors_add=given[1], where=where)
                               for r in src["robots"]]
        else:
            base: RobotSpec = src["robot"] if src.get("robot") is not None else RobotSpec()
            owner["robot"] = apply_sensors(base, sensors=given[0], sensors_add=given[1], where=where)

    top = suites(out)
    fix(out, "")
    exps = out.get("experiments")
    exps = [dict(e) if isinstance(e, dict) else e for e in exps] if isinstance(exps, list) else exps
    owns: list[tuple[Any, Any]] = []
    for i, e in enumerate(exps if isinstance(exps, list) else []):
        if isinstance(e, dict):
            owns.append(suites(e))
            fix(e, f"experiments[{i}].")
    apply(out, top, "", None)  # the campaign's robots (the default one when it names none)
    for i, e in enumerate(exps if isinstance(exps, list) else []):
        if isinstance(e, dict):
            own = owns.pop(0)
            if e.get("robot") is not None or e.get("robots") is not None:
                apply(e, top, "", None)  # an experiment's own robots get the campaign's sensors too
            apply(e, own, f"experiments[{i}].", out)
    if isinstance(exps, list):
        out["experiments"] = exps
    return out


def check_robots(spec: CampaignSpec) -> None:
    """The robots of ``spec``: not both ``robot`` and ``robots``; names unique in a list; one
    description per name across the campaign (records, reports and comparisons tell robots apart
    by name); each robot fits in every world's start and goal free discs (its half diagonal at
    most ``mission.free_radius_m``, where one is asked for). SpecError naming the field."""
    owners: list[tuple[str, Any]] = [("", spec), *((f"experiments[{i}].", e) for i, e in enumerate(spec.experiments))]
    for where, owner in owners:
        if owner.robot is not None and owner.robots is not None:
            raise SpecError(f"{where}robot", owner.robot.name, "either robot or robots, not both",
                            "list every robot under robots")
        names = [r.name for r in owner.robots or ()]
        for j, n in enumerate(names):
            if n in names[:j]:
                raise SpecError(f"{where}robots[{j}].name", n, "a name unique among the robots",
                                "give one of them a name: of its own")
    seen: dict[str, tuple[str, str]] = {}
    for i, exp in enumerate(spec.experiments):
        for r in spec.robots_of(exp):
            body = r.model_copy(update={"sensors": None}).digest  # its sensors may differ (experiments' sensors:)
            first = seen.setdefault(r.name, (body, f"experiments[{i}]"))
            if first[0] != body:
                raise SpecError(f"experiments[{i}].robot", r.name, f"one description per robot name (the robot "
                                f"{r.name!r} of {first[1]} is described otherwise)", "give one of them another name")
        # every free disc (the configurations' worlds are parsed once, for every robot)
        largest = max(spec.robots_of(exp), key=lambda r: r.half_diagonal_m)
        frees = {f"experiments[{i}]" + (f".worlds[{cfg.key}]" if exp.worlds is not None else f".sweep[{cfg.key}]"):
                 free for cfg, free in _free_radii(exp, spec.world)}
        for at, free in frees.items():
            if 0 < free < largest.half_diagonal_m:
                raise SpecError(f"{at}.mission.free_radius_m", free, f"a free disc the robot {largest.name!r} fits in "
                                f"(its half diagonal is {largest.half_diagonal_m:.3g} m)",
                                f"raise world.mission.free_radius_m to at least {largest.half_diagonal_m:.3g}")


def _free_radii(exp: ExperimentSpec, base: dict[str, Any]) -> list[tuple["Configuration", float]]:
    """(configuration, its ``mission.free_radius_m``) of each configuration of ``exp``, from the
    mappings (the configurations were validated as WorldSpecs before): without parsing them again."""
    default = WorldSpec.model_fields["mission"].default.free_radius_m
    out = []
    for cfg in exp.configurations(base):
        mission = cfg.world.get("mission")
        free = mission.get("free_radius_m", default) if isinstance(mission, dict) else default
        out.append((cfg, float(free)))
    return out


def check_campaign(spec: CampaignSpec, *, max_runs: int | None = MAX_PLANNED_RUNS) -> CampaignSpec:
    """``spec`` (made from a file by :func:`parse_campaign`, or in code from its parts, as a
    search makes its campaign) when every check of :func:`parse_campaign` beyond the fields'
    own passes, else SpecError naming the field."""
    for i, exp in enumerate(spec.experiments):
        for path, rng in exp.sweep.items():
            try:
                rng.expand()
            except ValueError as e:
                raise SpecError(f"experiments[{i}].sweep.{path}", rng.model_dump(exclude_none=True), str(e)) from None
    check_plan_size(spec, max_runs)
    check_base_world(spec.world)
    base_data = spec.world
    seen: set[str] = set()
    for i, exp in enumerate(spec.experiments):
        where = f"experiments[{i}]"
        if exp.name in seen:
            raise SpecError(f"{where}.name", exp.name, "a name unique among experiments", "rename one of them")
        seen.add(exp.name)
        for path, rng in exp.sweep.items():
            if is_sensor_path(path):
                for r in spec.robots_of(exp):
                    sensor_path_kind(r, path, where=f"{where}.sweep.{path}", value=path)
            elif not _path_exists(WorldSpec, path.split(".")):
                raise SpecError(f"{where}.sweep", path, "a WorldSpec parameter path such as "
                                "'obstacles.obstruction.tree', 'ground.deformation' or 'ground.subdivisions', "
                                "or a sensor's, sensors.<name>.<param>",
                                "check the spelling against `navstress world` options")
            try:
                rng.expand()
            except ValueError as e:
                raise SpecError(f"{where}.sweep.{path}", rng.model_dump(exclude_none=True), str(e)) from None
        try:
            parse_spec(deep_merge(base_data, exp.overrides))
        except SpecError as err:
            raise SpecError(f"{where}.overrides.{err.field}", err.value, err.expected, err.fix) from None
        for j, cfg in enumerate(exp.configurations(base_data)):
            try:
                cfg.world_spec()
            except SpecError as err:
                at = f"{where}.worlds[{j}].world" if exp.worlds is not None else f"{where}.sweep[{cfg.key}]"
                raise SpecError(f"{at}.{err.field}", err.value, err.expected, err.fix) from None
        check_faults(spec.faults_of(exp), f"{where}.faults" if exp.faults is not None else "faults", names=False)
    names = [n.name for n in spec.navigators]
    if len(set(names)) != len(names):
        raise SpecError("navigators", names, "navigator names without duplicates")
    check_faults(spec.faults, names=False)
    check_fault_names([f for e in spec.experiments for f in spec.faults_of(e)])
    check_robots(spec)
    check_sensors(spec)
    return spec


def check_sensors(spec: CampaignSpec) -> None:
    """Every robot's sensors as every configuration sets them (its ``sensors.<name>.<param>``
    values) valid, and runnable by the simulation of ``spec.sim`` (:func:`check_suite`: rates at
    most the step rate). SpecError naming the sweep's configuration, or the robot's sensor."""
    for i, exp in enumerate(spec.experiments):
        where = f"experiments[{i}]"
        robots = spec.robots_of(exp)
        swept = any(is_sensor_path(p) for p in exp.sweep) or any(w.sensors for w in exp.worlds or ())
        for cfg in exp.configurations(spec.world) if swept else []:
            at = f"{where}.sweep[{cfg.key}]."
            for r in robots:
                rr = cfg.robot(r, where=at)
                check_suite(rr, spec.sim, field_of=_rate_field(at))
        owner = where + "." if exp.robot is not None or exp.robots is not None else ""
        for r in robots:
            check_suite(r, spec.sim, field_of=_rate_field(owner))


def _rate_field(prefix: str) -> Callable[[Sensor], str]:
    """The field a sensor's rate error names: ``PREFIXsensors.<name>.rate_hz``."""
    def field(s: Sensor) -> str:
        return f"{prefix}sensors.{s.name}.rate_hz"
    return field


#: The order of the fields in the text of a spec made in code (:func:`spec_yaml`).
TEXT_ORDER = ("name", "seed", "world", "robot", "robots", "sensors", "sensors_add", "navigators", "faults", "maps_per_config", "runs_per_map", "timeout_s",
              "goal_tolerance_m", "record_lidar", "record_navigator", "sim", "experiments")


def spec_yaml(spec: CampaignSpec) -> str:
    """The YAML text of a spec made in code from its parts (a search's campaign), which its store
    writes as ``spec.yaml``: the fields it was given (the others have their defaults), in
    :data:`TEXT_ORDER`; each navigator without a null ``target``; each experiment with the fields
    it was given. It reads back as ``spec`` (the same digest); nothing reads it back to run."""
    given = spec.model_fields_set
    plain = spec.model_dump(mode="json", include=given - {"navigators", "experiments"})
    data: dict[str, Any] = {}
    for name in TEXT_ORDER:
        if name not in given:
            continue
        if name == "navigators":
            data[name] = [n.model_dump(mode="json", exclude_none=True) for n in spec.navigators]
        elif name == "robot" and spec.robot is not None:
            data[name] = robot_text(spec.robot)
        elif name == "robots" and spec.robots is not None:
            data[name] = [robot_text(r) for r in spec.robots]
        elif name == "experiments":
            data[name] = [e.model_dump(mode="json", include=e.model_fields_set) for e in spec.experiments]
            for e in data[name]:
                for w in e.get("worlds") or ():
                    if w.get("sensors") is None:  # a world without sensor values: the text of before
                        w.pop("sensors", None)
        else:
            data[name] = plain[name]
    return yaml.safe_dump(data, sort_keys=False)


def robot_text(robot: RobotSpec) -> Any:
    """How a spec's text writes ``robot``: its profile's name when it is that profile, else its
    fields (a mapping that reads back as the same robot)."""
    return robot.name if PROFILES.get(robot.name) == robot else robot.model_dump(mode="json")


def load_campaign(path: str | Path, *, max_runs: int | None = MAX_PLANNED_RUNS) -> tuple[CampaignSpec, str]:
    """Read and validate a campaign YAML/JSON file; returns the spec and the text as given
    (``max_runs``: see :func:`parse_campaign`).

    The file goes through :mod:`navstress.specfile` (UTF-8 text, bounded size, nesting and
    alias expansion)."""
    p = Path(path)
    text = read_text(p, field="campaign")
    return parse_campaign_text(text, str(p), max_runs=max_runs, base_dir=p.parent), text


def parse_campaign_text(text: str, name: str = "campaign", *, max_runs: int | None = MAX_PLANNED_RUNS,
                        base_dir: str | Path | None = None) -> CampaignSpec:
    """Parse and validate campaign YAML/JSON text (``name`` is what an error names; ``base_dir``:
    where robot files are, see :func:`parse_campaign`)."""
    data = parse_text(text, field="campaign", name=name)
    return parse_campaign(data if data is not None else {}, max_runs=max_runs, base_dir=base_dir)


# ---- helpers -------------------------------------------------------------------------


def _path_exists(model: type[BaseModel], parts: list[str]) -> bool:
    """Whether ``parts`` names a leaf of the pydantic ``model`` (dict fields accept any key; a
    dict of models is entered: ``movers.behaviour.pedestrian.ttc_s``)."""
    if not parts:
        return False
    field = model.model_fields.get(parts[0])
    if field is None:
        return False
    ann = field.annotation
    rest = parts[1:]
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return _path_exists(ann, rest)
    origin = typing.get_origin(ann)
    if origin is dict:
        value_type = typing.get_args(ann)[1]
        if isinstance(value_type, type) and issubclass(value_type, BaseModel):
            return len(rest) >= 2 and _path_exists(value_type, rest[1:])
        return len(rest) == 1
    return not rest


def flatten(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested mapping as dotted paths to its leaves (lists are leaves):
    ``{"ground": {"deformation": 1}}`` -> ``{"ground.deformation": 1}``."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        path = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, path + "."))
        else:
            out[path] = copy.deepcopy(v)
    return out


def _short_names(paths: list[str]) -> dict[str, str]:
    """The last path component, or the full path where two swept paths share it."""
    last = [p.rsplit(".", 1)[-1] for p in paths]
    return {p: (s if last.count(s) == 1 else p) for p, s in zip(paths, last)}


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return f"{v:g}" if abs(v) >= 1e-4 or v == 0 else repr(v)
    return str(v)


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` deep-merged onto a copy of ``base`` (mappings merged key by key, the rest replaced)."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _set_path(data: dict[str, Any], path: str, value: Any) -> None:
    parts = path.split(".")
    node = data
    for p in parts[:-1]:
        nxt = node.get(p)
        if not isinstance(nxt, dict):
            nxt = {}
            node[p] = nxt
        node = nxt
    node[parts[-1]] = value
