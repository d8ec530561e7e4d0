"""The generation loop of a search: ``navstress search SPEC -o DIR`` (docs/search.md, "Running").

A search directory is a campaign directory, and a search runs through the campaign engine as
``campaign run`` does (:func:`navstress.campaign.executors.open_runner`: the same checks, executor
registry and store; the executor's workers kept from one generation to the next). Generation ``g``
is the experiment ``gNNNN`` of explicit worlds (one entry per distinct candidate of the
generation), appended to the search's :class:`~navstress.campaign.spec.CampaignSpec`, made in code
(never read back from a text), with :meth:`CampaignRunner.extend`; the elites' confirmation is the
experiment ``confirm`` (fresh run seeds: run seeds derive from the experiment's name). So every
evaluated world and every run is in the store, and ``campaign status``, ``analyze``, ``replay`` and
``export`` read a search as they read any campaign.

Determinism. A generation is a barrier: all its runs are recorded before the algorithm is told,
and the algorithm's draws derive from the search's seed alone. So the points it asks depend on the
seed and the recorded outcomes only, never on the number of workers, the executor or the order in
which runs finish; and every run's outcome depends on its world and run seed only (docs/design.md).

Resume is replay: each stored generation is asked again, checked against the stored experiment
(a different spec, seed or navstress version gives other points: refused), its missing runs are
run by the campaign runner (:meth:`CampaignRunner.run`), its records told. A
search killed at any moment therefore resumes with no evaluation lost or doubled, and ends with
the same result as one never interrupted.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from collections.abc import Callable, Iterable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from navstress import _files, _json
from navstress._models import parse
from navstress.campaign.executors import CampaignRunner, check_workers, open_runner
from navstress.campaign.registry import DEFAULT_EXECUTOR, check_executor
from navstress.campaign.scheduler import RecordCallback
from navstress.run.sensors import is_sensor_path
from navstress.campaign.spec import (AdaptiveRuns, CampaignSpec, ExperimentSpec, WorldEntry, check_campaign, parse_campaign,
                                    robot_text)
from navstress.campaign.store import DB_NAME, Store
from navstress.errors import NavstressError, SpecError, StoreError
from navstress.run.record import RunRecord
from navstress.search.objectives import (Confirmation, by_world, confirm, descriptor_values, evaluate,
                                         get_descriptor, world_feasible)
from navstress.search.space import Candidate, Space
from navstress.search.spec import SearchSpec, as_search_error, load_search, spec_data, with_budget
from navstress.world.world import World

#: The experiment of the elites' confirmation runs.
CONFIRM = "confirm"
#: The search's result, in its directory.
RESULT_NAME = "search.json"
#: The search spec as run (budget override included), in its directory.
SEARCH_SPEC_NAME = "search.yaml"
#: The suite of confirmed worlds, in its directory.
SUITE_DIR = "suite"
FORMAT = "navstress-search/1"
_GENERATION = re.compile(r"^g\d{4,}$")

#: The confirmation each objective asks of its elites (objectives.confirm's kinds).
CONFIRM_KIND = {"failure": "failing", "illumination": "failing", "fault-revealing": "revealing",
                "boundary": "boundary"}
#: What a found world is called, per objective (progress lines, the report).
FOUND_WHAT = {"failure": "failing worlds", "illumination": "failing worlds",
              "fault-revealing": "revealing worlds", "boundary": "boundary worlds"}


def generation_name(g: int) -> str:
    return f"g{g:04d}"


@dataclass(frozen=True)
class Evaluated:
    """One candidate of one generation: its world, fitness, descriptors, runs, and whether its
    runs showed what the objective looks for (``found``; before any confirmation)."""

    generation: int
    candidate: Candidate
    fitness: float
    estimate: float | None
    events: int
    trials: int
    descriptors: tuple[float, ...]
    runs: int
    runs_spent: int  # the search's runs when this candidate's generation ended
    found: bool

    def to_json(self) -> dict[str, Any]:
        c = self.candidate
        return {"generation": self.generation, "experiment": generation_name(self.generation), "config": c.key,
                "key": c.key, "map_seed": c.map_seed, "params": c.params,
                "fitness": self.fitness, "estimate": self.estimate, "events": self.events, "trials": self.trials,
                "descriptors": list(self.descriptors), "runs": self.runs, "runs_spent": self.runs_spent,
                "found": self.found}


@dataclass(frozen=True)
class Elite:
    """An elite of the search (best first) and its confirmation with fresh run seeds."""

    candidate: Candidate
    fitness: float
    descriptors: tuple[float, ...]
    generation: int
    confirmation: Confirmation

    def to_json(self) -> dict[str, Any]:
        c = self.candidate
        return {"experiment": CONFIRM, "config": c.key, "key": c.key, "map_seed": c.map_seed, "params": c.params,
                "world": c.world_overrides,
                "fitness": self.fitness, "descriptors": list(self.descriptors), "generation": self.generation,
                "confirmed": self.confirmation.confirmed, "confirmation": self.confirmation.to_json()}


@dataclass
class SearchResult:
    """What a search did (``search.json`` holds its :meth:`to_json`)."""

    directory: Path
    spec: SearchSpec
    generations: int = 0
    runs: int = 0  # the generations' runs (the budget counts these)
    confirm_runs: int = 0
    sim_hours: float = 0.0
    stopped: str = ""  # why the generations stopped: budget.runs, budget.sim_hours, budget.wall_s
    evaluated: list[Evaluated] = field(default_factory=list)
    elites: list[Elite] = field(default_factory=list)
    recorded: int = 0  # runs recorded by this call (0 when a finished search is run again)
    wall_s: float = 0.0
    workers: int = 0
    unfinished: dict[str, str] = field(default_factory=dict)  # run_id -> why (machinery failures)
    suite: Path | None = None
    ended_before: bool = False  # the generations had ended in an earlier call (its confirmation stored)
    budget_unused: int | None = None  # a run budget given to a search whose generations had ended: not used

    @property
    def found_keys(self) -> set[str]:
        """The distinct worlds whose runs showed what the objective looks for (seen, not confirmed)."""
        return {e.candidate.key for e in self.evaluated if e.found}

    @property
    def confirmed(self) -> list[Elite]:
        return [e for e in self.elites if e.confirmation.confirmed]

    def found_curve(self) -> list[tuple[int, int]]:
        """(runs spent, distinct worlds found so far) after each generation, from (0, 0)."""
        seen: set[str] = set()
        curve = [(0, 0)]
        for g in range(self.generations):
            evs = [e for e in self.evaluated if e.generation == g]
            seen.update(e.candidate.key for e in evs if e.found)
            if evs:
                curve.append((evs[0].runs_spent, len(seen)))
        return curve

    def to_json(self) -> dict[str, Any]:
        s = self.spec
        descs = [d.model_dump(mode="json") for d in s.archive_descriptors()]
        return {"format": FORMAT, "name": s.name, "seed": s.seed, "objective": s.objective.model_dump(mode="json"),
                "algorithm": s.algorithm.name, "batch": s.algorithm.batch,
                "navigator": s.navigator.model_dump(mode="json", exclude_none=True), "faults": list(s.faults),
                "budget": s.budget.model_dump(mode="json"), "descriptors": descs,
                "parameters": [p.path for p in s.space.parameters], "found_what": FOUND_WHAT[s.objective.name],
                "generations": self.generations, "runs": self.runs, "confirm_runs": self.confirm_runs,
                "sim_hours": self.sim_hours, "stopped": self.stopped,
                "evaluated": [e.to_json() for e in self.evaluated],
                "found_curve": [list(p) for p in self.found_curve()],
                "found": len(self.found_keys),
                "elites": [e.to_json() for e in self.elites], "confirmed": len(self.confirmed),
                "suite": f"{SUITE_DIR}/suite.yaml" if self.confirmed else None}


@dataclass(frozen=True)
class GenerationReport:
    """What ``on_generation`` is told after each generation (and once for the confirmation)."""

    generation: int  # -1: the confirmation
    runs: int
    budget: int
    best: float
    found: int
    evaluated: int


GenerationCallback = Callable[[GenerationReport], None]
StartCallback = Callable[[int, int], None]  # (runs already spent, run budget)


def _entry(c: Candidate) -> WorldEntry:
    """The explicit world of candidate ``c`` in the search's campaign."""
    sensors = {p: v for p, v in c.params.items() if is_sensor_path(p)}
    if sensors:  # the robot's searched sensor values (the configuration's robot)
        return WorldEntry(key=c.key, map_seed=c.map_seed, world=c.world_overrides, sensors=sensors)
    return WorldEntry(key=c.key, map_seed=c.map_seed, world=c.world_overrides)


def _experiment(name: str, cands: Iterable[Candidate], runs_per_map: int | None = None) -> ExperimentSpec:
    """The experiment ``name`` of the candidates ``cands`` (a generation; the confirmation, with its
    ``runs_per_map``)."""
    worlds = [_entry(c) for c in cands]
    if runs_per_map is None:
        return ExperimentSpec(name=name, worlds=worlds)
    return ExperimentSpec(name=name, worlds=worlds, runs_per_map=runs_per_map)


def _campaign(spec: SearchSpec, experiments: list[ExperimentSpec]) -> CampaignSpec:
    """The campaign a search runs: its fields (:meth:`SearchSpec.campaign_fields`) and ``experiments``,
    checked as a campaign spec file is (an error names the search spec's field)."""
    try:
        return check_campaign(parse(CampaignSpec, {**spec.campaign_fields(), "experiments": experiments}),
                              max_runs=None)
    except SpecError as err:
        raise as_search_error(err, spec) from None


def _under_test(spec: SearchSpec) -> str | None:
    """The fault whose runs the failure, boundary and illumination objectives read: the first of
    ``faults`` (null: the nominal stack); fault-revealing reads the objective's fault."""
    return spec.objective.fault if spec.objective.name == "fault-revealing" else spec.faults[0]


def _descriptors(spec: SearchSpec, c: Candidate, world: World | None) -> tuple[float, ...]:
    """The archive's descriptor values of ``c``: a path of the space is the parameter's value,
    a registry descriptor is read from the generated world (its ``missing`` value when the world
    could not be generated)."""
    out = []
    for d in spec.archive_descriptors():
        if d.name in c.params:
            out.append(float(c.params[d.name]))
        elif world is not None:
            out.append(float(descriptor_values([d.name], world)[0]))
        else:
            out.append(float(get_descriptor(d.name).missing))
    return tuple(out)


def _objectives(spec: SearchSpec, fitness: list[float], descriptors: list[tuple[float, ...]]) -> np.ndarray:
    """What the algorithm is told: the fitness; for NSGA-II a second objective too, the first
    archive descriptor's closeness to its low end (1 at ``low``, 0 at ``high``), so that its Pareto
    front holds the worlds that fail most for the least of that descriptor (by default the least
    obstruction: failures in the simplest worlds, the most telling)."""
    f = np.asarray(fitness, dtype=np.float64)
    if spec.algorithm.name != "nsga2":
        return f
    d = spec.archive_descriptors()[0]
    v = np.array([x[0] for x in descriptors], dtype=np.float64)
    return np.column_stack([f, np.clip((d.high - v) / (d.high - d.low), 0.0, 1.0)])


def _found(spec: SearchSpec, events: int, trials: int, fitness: float) -> bool:
    """Whether a candidate's runs showed what the objective looks for: a failure of a feasible world
    (failure, illumination), a revealing pair (fault-revealing), both outcomes (boundary)."""
    if spec.objective.name == "boundary":
        return 0 < events < trials
    return fitness > 0.0


def _stored(root: Path) -> tuple[list[ExperimentSpec], list[ExperimentSpec], list[int]]:
    """The generations and the confirmation stored in ``root`` (empty when there is no store), as a
    search makes them (name and worlds; the confirmation's runs_per_map), and the runs recorded in
    each generation; StoreError when ``root`` holds a campaign that is no search."""
    if not (root / DB_NAME).exists():
        return [], [], []
    with Store.open(root) as s:
        exps = s.spec.experiments
        gens: list[ExperimentSpec] = []
        conf: list[ExperimentSpec] = []
        recorded = s.recorded_by_experiment()
        for e in exps:
            worlds = list(e.worlds or [])
            if e.name == CONFIRM:
                conf.append(ExperimentSpec(name=CONFIRM, worlds=worlds, runs_per_map=e.runs_per_map))
            elif _GENERATION.match(e.name) and e.worlds:
                gens.append(ExperimentSpec(name=e.name, worlds=worlds))
            else:
                raise StoreError(f"output={str(root)!r} holds campaign {s.spec.name!r}, which is not a search "
                                 f"(experiment {e.name!r}); choose a new -o")
    return gens, conf, [recorded[g.name] for g in gens]


def run_search(spec_path: str | Path, directory: str | Path, *, budget: int | None = None,
               workers: int | None = None, executor: str = DEFAULT_EXECUTOR,
               ray_address: str | None = None, wall_limit_s: float | None = None,
               on_record: RecordCallback | None = None, on_generation: GenerationCallback | None = None,
               on_start: StartCallback | None = None) -> SearchResult:
    """Run (or resume) the search of ``spec_path`` into ``directory``; ``budget`` replaces the
    spec's ``budget.runs``; ``executor``: a name of :mod:`navstress.campaign.registry`. The runs go
    through the campaign engine (:func:`~navstress.campaign.executors.open_runner`, the executor's
    workers kept from one generation to the next). Writes ``search.json``, ``search.yaml`` and the
    suite of confirmed worlds (``suite/``) at the end. Raises SpecError / StoreError before running
    anything when the spec, its navigator, the executor or the directory is unusable. When some runs
    stay pending after repeated failures of the machinery, returns early with ``unfinished`` set (run
    again to retry them)."""
    spec, _ = load_search(spec_path)
    if budget is not None:
        spec = with_budget(spec, budget)
    check_workers(workers)
    check_executor(executor)
    # here: pyribs and pymoo take 1-3 s to import, and the report and analysis commands, which
    # import this module for its file names and readers, never run an algorithm
    from navstress.search.algorithms import make_algorithm

    space = Space.from_spec(spec)
    algo = make_algorithm(spec, space, n_obj=2 if spec.algorithm.name == "nsga2" else 1)
    root = Path(directory)
    if root.exists() and not root.is_dir():
        raise StoreError(f"output={str(root)!r} exists and is not a directory; choose another -o")
    if root.is_dir():  # before its files are read: a planted link is refused (Store.create checks again)
        _files.refuse_links(root)
    stored, stored_confirm, stored_runs = _stored(root)
    if stored_confirm and stored_confirm[0].runs_per_map != spec.confirm_runs:
        raise StoreError(f"output={str(root)!r} holds this search's confirmation, run with confirm_runs="
                         f"{_runs_text(stored_confirm[0].runs_per_map)}, not {spec.confirm_runs}; resume with the spec "
                         "it was made with, or choose a new -o")
    t0 = time.monotonic()
    ended = _ended_budget(root) if stored_confirm else None
    unused = None
    if ended is not None and ended != spec.budget.runs:
        # the generations ended under another budget: they stay as they are (the confirmation
        # follows them in the campaign), and the result says the budget they ended with
        unused, spec = spec.budget.runs, with_budget(spec, ended)
    result = SearchResult(root, spec, ended_before=bool(stored_confirm), budget_unused=unused)
    per_candidate = spec.max_runs_per_candidate() * len(spec.faults)
    # the least budget that makes every stored generation (the loop's test before each one)
    need = max((sum(stored_runs[:g]) + len(gen.worlds or []) * per_candidate for g, gen in enumerate(stored)),
               default=0)
    if need > spec.budget.runs:
        raise StoreError(f"output={str(root)!r} holds {len(stored)} generations of this search, more than a budget of "
                         f"{spec.budget.runs} runs makes; resume it with the budget it was run with (--budget {need} "
                         "holds them), or choose a new -o")
    X = algo.ask()
    first = [space.decode(x) for x in X]
    exp0 = _experiment(generation_name(0), {c.key: c for c in first}.values())
    # resume: the store as it is (the same search spec gives the same campaign); a new search: its
    # store with the first generation, before anything is shown or run
    opened = _campaign(spec, [*stored, *stored_confirm] if stored else [exp0])
    with ExitStack() as stack:
        try:  # checked (navigator, faults, sim) before anything is written or started
            runner = stack.enter_context(open_runner(opened, root, executor=executor, workers=workers,
                                                     address=ray_address, wall_limit_s=wall_limit_s, keep=True))
        except SpecError as err:  # named as the search spec names it (navigator, not navigators[0])
            raise as_search_error(err, spec) from None
        result.workers = runner.workers
        stored = stored or [exp0]
        if on_start is not None:
            on_start(runner.store.progress()[0], spec.budget.runs)
        experiments = _generations(spec, space, algo, runner, stored, X=X, confirm_stored=bool(stored_confirm),
                                   result=result, on_record=on_record, on_generation=on_generation, t0=t0)
        if result.unfinished:
            result.wall_s = time.monotonic() - t0
            return result
        _write_spec(root, spec)  # before the confirmation: the budget the generations ended with
        _confirm(spec, space, algo, runner, experiments, result, on_record=on_record)
        if result.unfinished:
            result.wall_s = time.monotonic() - t0
            return result
        if on_generation is not None:
            on_generation(GenerationReport(-1, result.runs, spec.budget.runs,
                                           max((e.fitness for e in result.evaluated), default=0.0),
                                           len(result.confirmed), len(result.elites)))
        result.suite = write_suite(spec, result, root)
        _write_spec(root, spec)
        _files.write_atomic(root / RESULT_NAME, _json.dumps(result.to_json(), indent=1, sort_keys=True) + "\n")
    result.wall_s = time.monotonic() - t0
    return result


def _runs_text(r: int | AdaptiveRuns | None) -> Any:
    return r.model_dump(mode="json") if isinstance(r, AdaptiveRuns) else r


def _generations(spec: SearchSpec, space: Space, algo: Any, runner: CampaignRunner, stored: list[ExperimentSpec],
                 *, X: np.ndarray, confirm_stored: bool, result: SearchResult,
                 on_record: RecordCallback | None, on_generation: GenerationCallback | None,
                 t0: float) -> list[ExperimentSpec]:
    """The generations: each asked of ``algo`` (the first, ``X``, asked already), checked against the
    ``stored`` one or added to the campaign, its runs run by ``runner``, its candidates evaluated and
    told; until the budget (or unfinished runs: ``result.unfinished``). Returns the generations'
    experiments (for the confirmation's campaign)."""
    root, store = runner.store.root, runner.store
    fault = _under_test(spec)
    obj = spec.objective
    per_candidate = spec.max_runs_per_candidate() * len(spec.faults)
    experiments: list[ExperimentSpec] = []
    sim_s = 0.0  # simulated seconds of the generations' runs so far, summed in plan order
    g = 0
    while True:
        if g > 0:
            X = algo.ask()
        cands = [space.decode(x) for x in X]
        uniq = {c.key: c for c in cands}
        name = generation_name(g)
        if g < len(stored):
            if [w.key for w in stored[g].worlds or []] != list(uniq):
                raise StoreError(f"output={str(root)!r}: generation {g} of the stored search differs from this "
                                 "spec's (another spec, seed or navstress version); run it with the spec it was "
                                 "made with, or choose a new -o")
        elif result.runs + len(uniq) * per_candidate > spec.budget.runs:
            result.stopped = "budget.runs"
            break
        elif confirm_stored:
            # the generations ended in an earlier call, neither at budget.runs nor at
            # budget.sim_hours (both checked again, as then): at budget.wall_s
            result.stopped = "budget.wall_s" if spec.budget.wall_s is not None else _previous_stop(root)
            break
        experiments.append(_experiment(name, uniq.values()))
        if g >= len(stored):
            runner.extend(_campaign(spec, experiments))
        session = runner.run(on_record=on_record)
        result.recorded += session.recorded
        if session.unfinished:
            result.unfinished = dict(session.unfinished)
            return experiments
        recs = store.records(name)
        groups = by_world(recs)
        result.runs += len(recs)
        for r in recs:
            sim_s += r.duration_s
        fit: dict[str, float] = {}
        desc: dict[str, tuple[float, ...]] = {}
        for key, c in uniq.items():
            wdir = root / "worlds" / name / key / "m0"
            rs = groups.get((name, key, 0), [])
            world = World.load(wdir) if wdir.exists() else None  # read once: feasibility and descriptors
            feasible = world_feasible(world) if world is not None else None
            ev = evaluate(obj.name, rs, fault=fault, failure_class=obj.outcome, target=obj.target,
                          feasible=feasible)
            fit[key] = ev.fitness
            desc[key] = _descriptors(spec, c, world)
            result.evaluated.append(Evaluated(g, c, ev.fitness, ev.estimate, ev.events, ev.trials, desc[key],
                                              len(rs), result.runs, _found(spec, ev.events, ev.trials, ev.fitness)))
        algo.tell(X, _objectives(spec, [fit[c.key] for c in cands], [desc[c.key] for c in cands]),
                  np.array([desc[c.key] for c in cands]))
        g += 1
        result.generations = g
        result.sim_hours = sim_s / 3600.0
        if on_generation is not None:
            on_generation(GenerationReport(g - 1, result.runs, spec.budget.runs,
                                           max(e.fitness for e in result.evaluated),
                                           len(result.found_keys),
                                           len(result.evaluated)))
        if g < len(stored):
            continue
        if spec.budget.sim_hours is not None and result.sim_hours >= spec.budget.sim_hours:
            result.stopped = "budget.sim_hours"
            break
        if spec.budget.wall_s is not None and time.monotonic() - t0 >= spec.budget.wall_s:
            result.stopped = "budget.wall_s"
            break
    return experiments


def _write_spec(root: Path, spec: SearchSpec) -> None:
    """``search.yaml``: the spec as run (its budget override included)."""
    _files.write_atomic(root / SEARCH_SPEC_NAME, yaml.safe_dump(spec_data(spec),
                                                                sort_keys=False))


def _ended_budget(root: Path) -> int | None:
    """The run budget the stored generations ended with (search.yaml, written when they ended);
    None when it cannot be read."""
    try:
        return load_search(root / SEARCH_SPEC_NAME)[0].budget.runs
    except (NavstressError, OSError):
        return None


def _previous_stop(root: Path) -> str:
    try:
        return str(json.loads((root / RESULT_NAME).read_text(encoding="utf-8")).get("stopped", ""))
    except (OSError, ValueError, AttributeError):
        return ""


def _confirm(spec: SearchSpec, space: Space, algo: Any, runner: CampaignRunner, experiments: list[ExperimentSpec],
             result: SearchResult, *, on_record: RecordCallback | None) -> None:
    """Re-run the elites (best first, those whose runs showed what the objective looks for) with
    fresh run seeds in the experiment ``confirm``, and judge each with the confirmation rule."""
    found = {e.candidate.key: e for e in result.evaluated if e.found}
    elites: dict[str, tuple[Candidate, float, tuple[float, ...], int]] = {}
    for el in algo.elites(len(result.evaluated)):
        c = space.decode(np.asarray(el.x))
        if c.key in found and c.key not in elites:
            first = min(e.generation for e in result.evaluated if e.candidate.key == c.key)
            elites[c.key] = (c, el.fitness, found[c.key].descriptors, first)
        if len(elites) >= spec.elites:
            break
    if not elites:
        return
    store = runner.store
    if CONFIRM not in {e.name for e in store.spec.experiments}:
        conf = _experiment(CONFIRM, [c for c, *_ in elites.values()], spec.confirm_runs)
        runner.extend(_campaign(spec, [*experiments, conf]))
    else:
        stored = next(e for e in store.spec.experiments if e.name == CONFIRM)
        if [w.key for w in stored.worlds or []] != list(elites):
            raise StoreError(f"output={str(store.root)!r}: the stored confirmation differs from this search's elites "
                             "(another spec or navstress version); choose a new -o")
    session = runner.run(on_record=on_record)
    result.recorded += session.recorded
    if session.unfinished:
        result.unfinished = dict(session.unfinished)
        return
    recs = store.records(CONFIRM)
    result.confirm_runs = len(recs)
    groups = by_world(recs)
    obj = spec.objective
    for key, (c, f, d, g) in elites.items():
        k = confirm(groups.get((CONFIRM, key, 0), []), CONFIRM_KIND[obj.name], fault=_under_test(spec),
                    failure_class=obj.outcome, target=obj.target)
        result.elites.append(Elite(c, f, d, g, k))


_SUITE_HEAD = """\
# navstress regression suite, written by `navstress search` ({name}, objective {objective}).
# Its worlds are those the search found and confirmed with fresh run seeds ({confirmed} of {elites}
# elites); suite.json holds their measured verdicts and how they were found, worlds/ the worlds.
#
#   navstress campaign run {path} -o suite-run
#   navstress gate suite-run --min-success 0.5
#
# To test another version of the stack, edit `navigators` (or `faults`) and run it into a new
# directory: the worlds and the run seeds stay the same.
"""


def distinct_worlds(elites: list[Elite], root: Path) -> tuple[list[Elite], dict[str, str]]:
    """The elites whose generated worlds differ from every earlier one's (in order), and for each
    other elite the key of the earlier one with the same world (:meth:`World.digest`).

    Different keys can make the same world: obstacle moves that were not applied, or two moves
    that take the same obstacle the same way. An elite whose world is not on disk is kept."""
    first: dict[str, str] = {}
    kept: list[Elite] = []
    same: dict[str, str] = {}
    for e in elites:
        d = root / "worlds" / CONFIRM / e.candidate.key / "m0"
        digest = World.load(d).digest() if d.is_dir() else e.candidate.key
        if digest in first:
            same[e.candidate.key] = first[digest]
        else:
            first[digest] = e.candidate.key
            kept.append(e)
    return kept, same


def write_suite(spec: SearchSpec, result: SearchResult, root: Path) -> Path | None:
    """Write ``suite/``: suite.yaml (a campaign spec, one experiment ``suite`` of the confirmed
    worlds), suite.json (their verdicts and provenance) and worlds/KEY (the generated worlds).
    Returns suite.yaml's path, or None when no world was confirmed (then suite/ holds suite.json
    alone). A confirmed world that is the same generated world as a better one (different keys,
    same world: :func:`distinct_worlds`) is listed once; suite.json names it ``same_world_as``.
    The directory is built aside and renamed into place."""
    final = root / SUITE_DIR
    tmp = root / f".{SUITE_DIR}.tmp"
    _files.remove_tree(tmp)  # what a killed write left; a link there is refused, never followed
    tmp.mkdir()
    ok, same = distinct_worlds(result.confirmed, root)
    data = {"name": f"{spec.name}-suite", "seed": spec.seed, "world": spec.world,
            "experiments": [{"name": "suite", "worlds": [_entry(e.candidate).text_data() for e in ok]}],
            "runs_per_map": spec.confirm_runs,
            "navigators": [spec.navigator.model_dump(mode="json", exclude_none=True)],
            "faults": list(spec.faults), "timeout_s": spec.timeout_s, "goal_tolerance_m": spec.goal_tolerance_m,
            "sim": spec.sim, **({} if spec.robot is None else {"robot": robot_text(spec.robot)})}
    path: Path | None = None
    if ok:
        parse_campaign(data, max_runs=None)  # the suite is a valid campaign spec
        text = _SUITE_HEAD.format(name=spec.name, objective=spec.objective.name, confirmed=len(ok),
                                  elites=len(result.elites), path=final / "suite.yaml")
        (tmp / "suite.yaml").write_text(text + yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        path = final / "suite.yaml"
        for e in ok:
            src = root / "worlds" / CONFIRM / e.candidate.key / "m0"
            if src.is_dir():
                shutil.copytree(src, tmp / "worlds" / e.candidate.key)
    info = {"format": FORMAT, "search": spec.name, "objective": spec.objective.model_dump(mode="json"),
            "algorithm": spec.algorithm.name, "worlds": [
                {**e.to_json(), "found_in_generation": e.generation,
                 **({"same_world_as": same[e.candidate.key]} if e.candidate.key in same else {})}
                for e in result.elites]}
    (tmp / "suite.json").write_text(_json.dumps(info, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    _files.replace_dir(tmp, final)  # the old suite via .suite.old
    _files.fsync_dir(root)
    return path


def load_result(directory: str | Path) -> dict[str, Any] | None:
    """The ``search.json`` of ``directory`` (None when it holds none): for the report and status."""
    p = Path(directory) / RESULT_NAME
    if not p.is_file():
        return None
    data = json.loads(p.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise StoreError(f"{p}: not a navstress search result (format {FORMAT!r} expected)")
    return data
