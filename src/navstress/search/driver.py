"""The generation loop of a search (DRAFT: not wired to the CLI, not tested yet).

A search directory is a campaign directory: generation ``g`` is the experiment ``gNNNN`` of
explicit worlds (one entry per distinct candidate of the generation), appended to the campaign
spec with :meth:`Store.extend`; the elites' confirmation is the experiment ``confirm`` (fresh run
seeds: another experiment name). A generation is a barrier: all its runs are recorded before the
algorithm is told, so the asks depend on the seed and the outcomes only, never on workers or
interruptions. Resume is replay: generation ``g`` is asked again, checked against the stored
experiment, its runs completed by :func:`resume`, its records told.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from navstress.campaign.local import LocalExecutor
from navstress.campaign.scheduler import resume
from navstress.campaign.spec import CampaignSpec, parse_campaign
from navstress.campaign.store import DB_NAME, Store
from navstress.errors import StoreError
from navstress.run.batch import default_wall_limit_s
from navstress.run.record import RunRecord
from navstress.search.algorithms import make_algorithm
from navstress import _files, _json
from navstress.search.objectives import Confirmation, by_world, confirm, descriptor_values, evaluate, world_feasible
from navstress.search.space import Candidate, Space
from navstress.search.spec import SearchSpec, load_search, with_budget

CONFIRM = "confirm"


def generation_name(g: int) -> str:
    return f"g{g:04d}"


@dataclass
class Evaluated:
    """One candidate of one generation: its world, fitness, descriptors and run count."""

    generation: int
    candidate: Candidate
    fitness: float
    descriptors: tuple[float, ...]
    runs: int


@dataclass
class SearchResult:
    directory: Path
    generations: int
    runs: int
    evaluated: list[Evaluated] = field(default_factory=list)
    elites: list[tuple[Candidate, float, Confirmation]] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {"generations": self.generations, "runs": self.runs,
                "evaluated": [{"generation": e.generation, "key": e.candidate.key, "map_seed": e.candidate.map_seed,
                               "params": e.candidate.params, "fitness": e.fitness,
                               "descriptors": list(e.descriptors), "runs": e.runs} for e in self.evaluated],
                "elites": [{"key": c.key, "map_seed": c.map_seed, "params": c.params, "world": c.world_overrides,
                            "fitness": f, "confirmed": k.confirmed, "confirmation": k.kind, "reason": k.reason,
                            "events": k.events, "trials": k.trials, "interval": list(k.interval)}
                           for c, f, k in self.elites]}


#: the confirmation each objective asks of its elites
CONFIRM_KIND = {"failure": "failing", "illumination": "failing", "fault-revealing": "revealing",
                "boundary": "boundary"}


def _entry(c: Candidate) -> dict[str, Any]:
    return {"key": c.key, "map_seed": c.map_seed, "world": c.world_overrides}


def _campaign(spec: SearchSpec, experiments: list[dict[str, Any]]) -> tuple[CampaignSpec, str]:
    data = {**spec.campaign_fields(), "experiments": experiments}
    text = yaml.safe_dump(data, sort_keys=False)
    return parse_campaign(data, max_runs=None), text


def _max_runs(spec: SearchSpec) -> int:
    r = spec.runs_per_candidate
    return r if isinstance(r, int) else r.adaptive.max


def _descriptors(spec: SearchSpec, c: Candidate, world_dir: Path) -> tuple[float, ...]:
    descs = spec.archive_descriptors()
    names = [d.name for d in descs]
    reg = [n for n in names if n not in c.params]
    vals = dict(zip(reg, descriptor_values(reg, world_dir))) if reg else {}
    return tuple(float(c.params[n]) if n in c.params else float(vals[n]) for n in names)


def _evaluate(spec: SearchSpec, records: list[RunRecord], world_dir: Path) -> float:
    obj = spec.objective
    feasible = world_feasible(world_dir) if world_dir.exists() else None
    fault = obj.fault if obj.name == "fault-revealing" else None
    return evaluate(obj.name, records, fault=fault, failure_class=obj.outcome, target=obj.target,
                    feasible=feasible).fitness


def run_search(spec_path: str | Path, directory: str | Path, *, budget: int | None = None,
               workers: int = 2, wall_limit_s: float | None = None) -> SearchResult:
    """Run (or resume) the search of ``spec_path`` into ``directory`` (DRAFT)."""
    spec, _ = load_search(spec_path)
    if budget is not None:
        spec = with_budget(spec, budget)
    space = Space.from_spec(spec)
    algo = make_algorithm(spec, space)
    root = Path(directory)
    stored: list[dict[str, Any]] = []
    finished = False  # the elites' confirmation is stored: the search ran to its end
    stored_confirm: list[dict[str, Any]] = []
    if (root / DB_NAME).exists():
        with Store.open(root) as s:
            stored = [{"name": e.name, "worlds": [w.model_dump(mode="json") for w in e.worlds or []]}
                      for e in s.spec.experiments if e.name != CONFIRM]
            confirmed = [e for e in s.spec.experiments if e.name == CONFIRM]
            finished = bool(confirmed)
            stored_confirm = [{"name": CONFIRM, "worlds": [w.model_dump(mode="json") for w in e.worlds or []],
                               "runs_per_map": e.runs_per_map} for e in confirmed]
    limit = wall_limit_s if wall_limit_s is not None else default_wall_limit_s(spec.timeout_s)
    ex = LocalExecutor(workers, {})
    experiments: list[dict[str, Any]] = []
    result = SearchResult(root, 0, 0)
    store: Store | None = None
    t0 = time.monotonic()
    per_candidate = _max_runs(spec) * len(spec.faults)
    try:
        if stored:  # resume: the store as it is (the same search spec gives the same campaign text)
            store = Store.create(root, *_campaign(spec, stored + stored_confirm))
        g = 0
        while True:
            X = algo.ask()
            cands = [space.decode(x) for x in X]
            uniq = {c.key: c for c in cands}
            name = generation_name(g)
            exp = {"name": name, "worlds": [_entry(c) for c in uniq.values()]}
            if g < len(stored):
                if [w["key"] for w in stored[g].get("worlds", [])] != list(uniq):
                    raise StoreError(f"search={str(root)!r}: generation {g} differs from the stored one (another "
                                     "spec, seed or navstress version); resume with the same, or choose a new -o")
            elif finished or result.runs + len(uniq) * per_candidate > spec.budget.runs:
                break
            experiments.append(exp)
            cspec, text = _campaign(spec, experiments)
            if store is None:
                store = Store.create(root, cspec, text)
            elif g >= len(stored):
                store.extend(cspec, text)
            resume(store, ex, wall_limit_s=limit)
            recs = [r for r in store.records() if r.experiment == name]
            groups = by_world(recs)
            fit: dict[str, float] = {}
            desc: dict[str, tuple[float, ...]] = {}
            for key, c in uniq.items():
                wdir = root / "worlds" / name / key / "m0"
                rs = groups.get((name, key, 0), [])
                fit[key] = _evaluate(spec, rs, wdir)
                desc[key] = _descriptors(spec, c, wdir)
                result.evaluated.append(Evaluated(g, c, fit[key], desc[key], len(rs)))
            algo.tell(X, np.array([fit[c.key] for c in cands]), np.array([desc[c.key] for c in cands]))
            result.runs += len(recs)
            g += 1
            result.generations = g
            hours = sum(r.duration_s for r in store.records()) / 3600.0
            if spec.budget.sim_hours is not None and hours >= spec.budget.sim_hours:
                break
            if spec.budget.wall_s is not None and time.monotonic() - t0 >= spec.budget.wall_s:
                break
        # the elites, re-run with fresh run seeds (another experiment name) before they are reported
        assert store is not None
        elites: dict[str, tuple[Candidate, float]] = {}
        for el in algo.elites():
            c = space.decode(np.asarray(el.x))
            elites.setdefault(c.key, (c, el.fitness))
        conf = {"name": CONFIRM, "worlds": [_entry(c) for c, _ in elites.values()], "runs_per_map": spec.confirm_runs}
        if CONFIRM not in {e.name for e in store.spec.experiments}:
            cspec, text = _campaign(spec, [*experiments, conf])
            store.extend(cspec, text)
        resume(store, ex, wall_limit_s=limit)
        groups = by_world(r for r in store.records() if r.experiment == CONFIRM)
        obj = spec.objective
        for key, (c, f) in elites.items():
            rs = groups.get((CONFIRM, key, 0), [])
            k = confirm(rs, CONFIRM_KIND[obj.name], fault=obj.fault if obj.name == "fault-revealing" else None,
                        failure_class=obj.outcome, target=obj.target)
            result.elites.append((c, f, k))
        _files.write_atomic(root / "search.json", _json.dumps(result.to_json(), indent=1, sort_keys=True))
    finally:
        if store is not None:
            store.close()
    return result
