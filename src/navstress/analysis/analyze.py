"""The whole analysis of one campaign directory (Q1, Q2, Q3 and more) in one value.

    >>> a = analyze("demo-campaign")                      # doctest: +SKIP
    >>> a.difficulty.level("trees", "tree=8")              # doctest: +SKIP
    'very difficult'

Works on a finished, partial (still running) or empty campaign: configurations without a
run are listed with ``runs == 0`` and level ``"no data"``; :attr:`Analysis.missing` says
what is not done yet. Runs on maps the world generator refused
(:func:`navstress.run.record.ungenerated`) are counted apart (:attr:`Analysis.refused`, each
configuration's ``refused``) and left out of every statistic: a configuration whose every
recorded map was refused has level ``"no generated maps"``. Difficulty, indeterminism and descriptor correlations use the nominal
runs of one navigator (``navigator``, default: the spec's first); fault power compares each
fault with that navigator's nominal runs on the same maps. Given explicitly, ``navigator``
also restricts what is drawn and listed per run (:meth:`Analysis.shows`): the report then
shows that navigator alone; by default every navigator is shown, each figure naming its own.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navstress.analysis.barn import BarnScores, barn_scores, barn_worlds
from navstress.analysis.descriptors_corr import Correlation, correlations, mean_descriptors, world_descriptors
from navstress.analysis.difficulty import (LEVEL_RANK, LEVELS, Difficulty, DifficultyParams, LevelRange, Overlap,
                                           assign_levels, level_ranges, reference_keys)
from navstress.analysis.fault_power import FaultPower, LevelPower, by_level, fault_power
from navstress.analysis.indeterminism import Curve, config_curves
from navstress.analysis.stats import (NOMINAL, OUTCOMES, ConfigStats, Refused, config_key, config_stats, fault_name,
                                      planned_configs, split_refused, variants, with_variants)
from navstress.analysis.trajectories import TrajectoryCache
from navstress.analysis.verdicts import Verdicts, VerdictRule, rule_of, rules_of, verdicts
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated


@dataclass
class Analysis:
    """Everything the report shows (see module doc)."""

    root: Path
    name: str
    navigator: str
    done: int
    planned: int
    outcome_counts: dict[str, int]  # of the runs on generated maps (every navigator and fault)
    per_experiment: list[tuple[str, int, int, dict[str, int]]]  # (experiment, recorded, planned, outcome counts)
    records: list[RunRecord]  # every record, as stored (those of refused maps included)
    stats: list[ConfigStats]  # every (config, navigator, fault)
    nominal: list[ConfigStats]  # the difficulty navigator's nominal runs, one per configuration
    difficulty: Difficulty
    ranges: list[LevelRange]
    overlaps: list[Overlap]
    indeterminism: dict[tuple[str, str], dict[str, Curve]]
    power: list[FaultPower]
    power_levels: list[LevelPower]
    correlations: list[Correlation]
    world_dirs: dict[tuple[str, str], list[tuple[int, Path]]]
    dt: float
    notes: list[str] = field(default_factory=list)
    #: per configuration, (maps whose mission is infeasible a priori, maps generated so far): the
    #: world generator's shortest-path check for the nominal robot (``descriptors.feasible``)
    infeasible: dict[tuple[str, str], tuple[int, int]] = field(default_factory=dict)
    #: the campaign's navigators, in spec order
    navigators: list[str] = field(default_factory=list)
    #: the navigator asked for explicitly (``--navigator``), whose runs alone are shown; None: all
    only_navigator: str | None = None
    #: pass probability, exact interval and class per world and per configuration
    #: (:mod:`navstress.analysis.verdicts`)
    verdicts: Verdicts = field(default_factory=lambda: Verdicts(VerdictRule(), [], []))
    #: the experiments of explicit worlds (levelled, but no swept parameter: no level ranges)
    explicit: frozenset[str] = frozenset()
    #: per configuration with a map the world generator refused: those maps, their runs (every
    #: navigator and fault) and the first reason; their runs are in no statistic
    refused: dict[tuple[str, str], Refused] = field(default_factory=dict)
    #: the campaign's robots, (name, digest) in spec order; in a campaign of several, each
    #: navigator above is ``navigator@robot`` (:func:`navstress.analysis.stats.variants`)
    robots: list[tuple[str, str]] = field(default_factory=list)
    #: the imported worlds' sources of the recorded runs, (kind, path, sha256) once each in run
    #: order; empty for a campaign of generated worlds (whose JSON then has no ``sources`` key)
    sources: list[tuple[str, str, str]] = field(default_factory=list)
    #: BARN's score of the runs on BARN worlds (:mod:`navstress.analysis.barn`); None: no BARN world
    barn: BarnScores | None = None

    @property
    def refused_runs(self) -> int:
        """Recorded runs on refused maps (in no statistic)."""
        return sum(r.runs for r in self.refused.values())

    @property
    def refused_maps(self) -> int:
        """Maps the world generator refused, over every configuration."""
        return sum(len(r.maps) for r in self.refused.values())

    def refused_by_experiment(self) -> dict[str, int]:
        """Runs on refused maps per experiment."""
        out: dict[str, int] = {}
        for (e, _k), r in self.refused.items():
            out[e] = out.get(e, 0) + r.runs
        return out

    def maps_of(self, key: tuple[str, str]) -> int:
        """The maps a configuration plans."""
        return len(self.world_dirs.get(key, []))

    def shows(self, navigator: str) -> bool:
        """Whether runs of ``navigator`` are drawn and listed (all, unless one was asked for)."""
        return self.only_navigator is None or navigator == self.only_navigator

    @property
    def shown_navigators(self) -> list[str]:
        """The navigators whose runs are drawn and listed, in spec order."""
        return [n for n in self.navigators if self.shows(n)]

    @property
    def missing(self) -> list[tuple[str, str, int, int]]:
        """(experiment, config, recorded, planned) of every configuration not complete yet
        (runs of every navigator and fault together)."""
        acc: dict[tuple[str, str], list[int]] = {}
        for s in self.stats:
            v = acc.setdefault(s.key, [0, 0])
            v[0] += s.recorded
            v[1] += s.planned
        return [(e, k, d, p) for (e, k), (d, p) in acc.items() if p and d < p]

    def level(self, experiment: str, key: str) -> str:
        return self.difficulty.level(experiment, key)

    def to_json(self) -> dict[str, Any]:
        """A JSON-able summary (numbers only; no trajectories); ``barn`` only for a campaign on
        BARN worlds."""
        out = self._json()
        if self.barn is not None:
            out["barn"] = self.barn.to_json()
        return out

    def _json(self) -> dict[str, Any]:
        return {
            "campaign": self.name, "navigator": self.navigator, "navigators": self.shown_navigators,
            "robots": [{"name": n, "digest": d} for n, d in self.robots],
            "done": self.done, "planned": self.planned,
            "outcomes": self.outcome_counts,
            "refused": {"runs": self.refused_runs, "maps": self.refused_maps,
                        "configurations": [{"experiment": e, "config": k, "maps_planned": self.maps_of((e, k)),
                                            **r.to_json()} for (e, k), r in self.refused.items()]},
            "difficulty": {"threshold": self.difficulty.params.threshold, "k": self.difficulty.params.k,
                           "weights": list(self.difficulty.params.weights), "notes": list(self.difficulty.notes),
                           "reference": ["/".join(r) for r in self.difficulty.reference]},
            "configurations": [dict(s.to_json(), level=self.level(s.experiment, s.config_key),
                                    infeasible_maps=list(self.infeasible.get(s.key, (0, 0))))
                               for s in self.stats],
            "level_ranges": [{"experiment": r.experiment, "parameter": r.parameter, "level": r.level,
                              "values": list(r.values), "lo": r.lo, "hi": r.hi} for r in self.ranges],
            "overlaps": [{"experiment": o.experiment, "levels": [o.a, o.b], "lo": o.lo, "hi": o.hi}
                         for o in self.overlaps],
            "indeterminism": [{"experiment": e, "config": k, **c.summary()}
                              for (e, k), cs in self.indeterminism.items() for c in cs.values()],
            "fault_power": [p.to_json() for p in self.power],
            "fault_power_by_level": [{"level": p.level, "fault": p.fault, "configs": p.configs, "runs": p.runs,
                                      "collisions": p.collisions, "collision_share": p.collision_share,
                                      "new_failures": p.new_failures, "nominal_runs": p.nominal_runs,
                                      "nominal_collisions": p.nominal_collisions,
                                      "nominal_collision_share": p.nominal_collision_share}
                                     for p in self.power_levels],
            "descriptor_correlations": [c.to_json() for c in self.correlations],
            "missing": [{"experiment": e, "config": k, "recorded": d, "planned": p} for e, k, d, p in self.missing],
            "verdicts": self.verdicts.to_json(),
            **({"sources": [{"kind": k, "path": p, "sha256": h} for k, p, h in self.sources]} if self.sources else {}),
        }


def infeasible_maps(world_dirs: list[Path]) -> tuple[int, int]:
    """(maps flagged infeasible before simulation, maps present) among ``world_dirs``."""
    bad = seen = 0
    for d in world_dirs:
        try:
            desc = json.loads((d / "world.json").read_text(encoding="utf-8")).get("descriptors", {})
        except (OSError, ValueError):
            continue  # not generated yet (a partial campaign)
        seen += 1
        bad += desc.get("feasible") is False
    return bad, seen


def trace_path(root: Path, rec: RunRecord) -> Path | None:
    if not rec.trace:
        return None
    p = Path(rec.trace)
    return p if p.is_absolute() else root / p


def analyze(directory: str | Path, *, params: DifficultyParams | None = None, navigator: str | None = None,
            dt: float = 1.0, cache: TrajectoryCache | None = None, confidence: float = 0.95,
            interval: str = "wilson", is_reference: Callable[[ConfigStats], bool] | None = None) -> Analysis:
    """Analyse the campaign in ``directory`` (read only; see module doc)."""
    root = Path(directory)
    owned = cache is None
    cache = cache or TrajectoryCache()
    with Store.open(root) as store:
        spec = store.spec
        records = with_variants(store.spec, store.records())
        done, planned = store.progress()
        per_exp_all = store.per_experiment()
        maps = store.plan().maps
        planned_runs = store.planned_by_config()
    navs = variants(spec)
    nav = navigator or navs[0]
    if nav not in navs:
        raise SpecError("navigator", nav, f"one of the campaign's navigators {navs}")
    generated, _ = split_refused(records)
    counts = {o: 0 for o in OUTCOMES}
    for r in generated:
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    per_exp = []
    for e, d, p, _c in per_exp_all:
        c = {o: 0 for o in OUTCOMES}
        for r in generated:
            if r.experiment == e:
                c[r.outcome] = c.get(r.outcome, 0) + 1
        per_exp.append((e, d, p, c))
    by_key: dict[tuple[str, str], list[RunRecord]] = {}
    for r in records:
        if ungenerated(r):
            by_key.setdefault((r.experiment, config_key(r)), []).append(r)
    barn = barn_worlds(spec)
    barn_keys = {(w.experiment, w.key) for w in barn}
    timed = [r for r in generated if r.outcome == Outcome.SUCCESS.value and (r.experiment, config_key(r)) in barn_keys]
    try:
        # the trajectories Q2 reads (and BARN's score: its successful runs'): read by worker processes
        # (when there are many) while the rest is computed
        cache.prefetch(list(dict.fromkeys(
            [trace_path(root, r) for r in generated if r.navigator == nav and fault_name(r.fault) == NOMINAL]
            + [trace_path(root, r) for r in timed])), wait=False)
        stats = config_stats(records, planned_configs(spec, planned_runs), confidence=confidence, interval=interval)
        refused = {k: split_refused(by_key[k])[1] for k in dict.fromkeys([s.key for s in stats] + list(by_key))
                   if k in by_key}
        nominal = [s for s in stats if s.navigator == nav and s.fault == NOMINAL]
        refs = reference_keys(spec)
        diff = assign_levels(nominal, is_reference or (lambda s: s.key in refs), params)
        explicit = frozenset(e.name for e in spec.experiments if e.explicit)
        ranges, overlaps = level_ranges(nominal, diff, explicit)

        levels = {s.key: diff.level(*s.key) for s in nominal}
        power = fault_power([r for r in records if r.navigator == nav], levels)
        power_levels = by_level(power, LEVELS)

        world_dirs: dict[tuple[str, str], list[tuple[int, Path]]] = {}
        for m in maps:
            world_dirs.setdefault((m.experiment, m.config_key), []).append((m.map_index, Path(m.world_dir)))
        desc: dict[tuple[str, str], dict[str, float]] = {}
        for key, dirs in world_dirs.items():
            ds = [d for d in (world_descriptors(p) for _, p in dirs) if d is not None]
            if ds:
                desc[key] = mean_descriptors(ds)
        infeasible = {key: infeasible_maps([p for _, p in dirs]) for key, dirs in world_dirs.items()}
        rank = {k: LEVEL_RANK[v] for k, v in levels.items() if v in LEVEL_RANK}
        succ = {s.key: s.success_rate for s in nominal if s.success_rate is not None}
        corr = correlations(desc, rank, {k: float(v) for k, v in succ.items() if v is not None})
        verd = verdicts(records, rule_of(spec), [(s.experiment, s.config_key, s.navigator, s.fault) for s in stats],
                        rules_of(spec))
        cache.wait()
        scores = barn_scores(spec, records, lambda r: cache.get(trace_path(root, r)), worlds=barn) if barn else None
    finally:
        if owned:
            cache.close()  # (its reading processes; a caller's cache keeps them for its next reads)
    # Q2: nominal runs of the navigator, grouped per configuration and map
    by_cfg: dict[tuple[str, str], dict[int, list[tuple[bool, np.ndarray]]]] = {}
    for r in generated:
        if r.navigator != nav or fault_name(r.fault) != NOMINAL:
            continue
        tr = cache.get(trace_path(root, r))
        if tr is None:
            continue
        by_cfg.setdefault((r.experiment, config_key(r)), {}).setdefault(r.map_index, []).append(
            (r.outcome == Outcome.SUCCESS.value, tr[:, :3]))
    indet = {k: config_curves(v, dt) for k, v in by_cfg.items()}
    indet = {k: v for k, v in indet.items() if v}
    return Analysis(root=root, name=spec.name, navigator=nav, done=done, planned=planned, outcome_counts=counts,
                    per_experiment=per_exp, records=records, stats=stats, nominal=nominal, difficulty=diff,
                    ranges=ranges, overlaps=overlaps, indeterminism=indet, power=power, power_levels=power_levels,
                    correlations=corr, world_dirs=world_dirs, dt=dt, infeasible=infeasible, navigators=navs,
                    only_navigator=navigator, verdicts=verd, explicit=explicit, refused=refused,
                    robots=[(r.name, r.digest) for r in spec.all_robots()],
                    sources=list(dict.fromkeys((r.source_kind, r.source_path or "", r.source_sha256 or "")
                                               for r in records if r.source_kind is not None)), barn=scores)
