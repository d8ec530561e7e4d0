"""Difficulty levels (the paper's Q1), assigned a posteriori per configuration.

1. A configuration whose success rate is below ``threshold`` (default 0.25) is
   **very difficult**; one without any run has no level (``"no data"``), nor has one whose every
   recorded run is on a map the world generator refused (``"no generated maps"``: its spec
   measures the generator, not the navigation; :class:`~navstress.analysis.stats.Refused`).
2. The others are clustered by k-means (``k`` = 2 by default, scikit-learn, ``n_init=10``,
   fixed ``random_state``) on three features: success rate, median duration of successful
   runs, median tortuousness of successful runs. Each feature is min-max normalised to
   [0, 1] over the clustered configurations (a constant feature becomes 0), then multiplied
   by ``sqrt(weight)`` so that the squared Euclidean distance k-means minimises is
   ``sum_i weight_i * (delta feature_i)^2`` with the paper's weights 0.5, 0.25, 0.25.
3. The cluster that holds the *reference* configuration (flat ground, no obstacles) is
   **easy**, the other(s) **challenging**. When several reference configurations are
   clustered (one per experiment class), the cluster holding most of them wins (ties: the
   cluster with the higher mean success rate). With no clustered reference configuration,
   the cluster with the higher mean success rate is easy (reported in ``notes``).
   With fewer than two distinct feature points (or fewer points than ``k``) everything
   clustered is easy: there is nothing to split.

Per experiment class, :func:`level_ranges` reports which values of the swept parameter got
which level and where the levels' ranges overlap (the paper's "fuzzy thresholds"); an
experiment of explicit worlds has no swept parameter and no ranges (its configurations are
levelled like any other).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sklearn.cluster import KMeans

from navstress.analysis.stats import ConfigStats
from navstress.errors import SpecError
from navstress.world.spec import parse_spec

EASY = "easy"
CHALLENGING = "challenging"
VERY_DIFFICULT = "very difficult"
NO_DATA = "no data"
#: The level of a configuration whose every recorded run is on a map the world generator refused.
NO_MAPS = "no generated maps"
#: The "levels" of a configuration that has none.
NO_LEVEL: tuple[str, ...] = (NO_DATA, NO_MAPS)
LEVELS: tuple[str, ...] = (EASY, CHALLENGING, VERY_DIFFICULT)
#: Ordinal of each level (for correlations): easy 0, challenging 1, very difficult 2.
LEVEL_RANK = {EASY: 0, CHALLENGING: 1, VERY_DIFFICULT: 2}


@dataclass(frozen=True)
class DifficultyParams:
    """The knobs of :func:`assign_levels` (the paper's values by default)."""

    threshold: float = 0.25
    k: int = 2
    weights: tuple[float, float, float] = (0.5, 0.25, 0.25)
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.threshold <= 1.0:
            raise SpecError("threshold", self.threshold, "a success rate in [0, 1], e.g. 0.25")
        if self.k < 2:
            raise SpecError("k", self.k, "an integer >= 2 (clusters)")
        if len(self.weights) != 3 or any(not (w >= 0 and math.isfinite(w)) for w in self.weights) \
                or sum(self.weights) <= 0:
            raise SpecError("weights", self.weights, "three finite weights >= 0 (success, duration, tortuousness), "
                            "not all zero")


@dataclass(frozen=True)
class Difficulty:
    """Levels per configuration ``(experiment, config_key)`` and how they were found."""

    levels: dict[tuple[str, str], str]
    clusters: dict[tuple[str, str], int]  # k-means label of each clustered configuration
    features: dict[tuple[str, str], tuple[float, float, float]]  # weighted normalised features
    reference: tuple[tuple[str, str], ...]
    params: DifficultyParams
    notes: tuple[str, ...] = field(default_factory=tuple)

    def level(self, experiment: str, key: str) -> str:
        return self.levels.get((experiment, key), NO_DATA)


def _norm(col: np.ndarray) -> np.ndarray:
    lo, hi = float(np.min(col)), float(np.max(col))
    return np.zeros_like(col) if hi - lo <= 1e-12 * max(1.0, abs(hi)) else (col - lo) / (hi - lo)


def assign_levels(stats: list[ConfigStats], is_reference: Callable[[ConfigStats], bool],
                  params: DifficultyParams | None = None) -> Difficulty:
    """Levels for ``stats`` (one entry per configuration: pass the nominal runs of one navigator).

    ``is_reference(cs)`` says whether a configuration is flat and obstacle-free."""
    p = params or DifficultyParams()
    levels: dict[tuple[str, str], str] = {}
    notes: list[str] = []
    seen: set[tuple[str, str]] = set()
    for cs in stats:
        if cs.key in seen:
            raise SpecError("stats", f"{cs.experiment}/{cs.config_key}", "one entry per configuration",
                            "filter to one navigator and fault first")
        seen.add(cs.key)
    clustered = []
    for cs in stats:
        rate = cs.success_rate
        if rate is None:
            levels[cs.key] = NO_MAPS if cs.refused.runs else NO_DATA
        elif rate < p.threshold:
            levels[cs.key] = VERY_DIFFICULT
        else:
            clustered.append(cs)
    refs = tuple(cs.key for cs in stats if is_reference(cs))
    clusters: dict[tuple[str, str], int] = {}
    feats: dict[tuple[str, str], tuple[float, float, float]] = {}
    if clustered:
        raw = np.array([[cs.success_rate or 0.0,
                         np.nan if cs.median_duration_s is None else cs.median_duration_s,
                         np.nan if cs.median_tortuousness is None else cs.median_tortuousness]
                        for cs in clustered], dtype=np.float64)
        for j in range(3):  # a success without a finite metric: use the column mean (rare; noted)
            bad = ~np.isfinite(raw[:, j])
            if bad.any():
                raw[bad, j] = float(np.nanmean(raw[:, j])) if (~bad).any() else 0.0
                notes.append(f"{int(bad.sum())} configuration(s) lack feature {j}; the column mean was used")
        x = np.column_stack([_norm(raw[:, j]) * math.sqrt(p.weights[j]) for j in range(3)])
        distinct = len(np.unique(np.round(x, 12), axis=0))
        if distinct < 2 or len(clustered) < p.k:
            labels = np.zeros(len(clustered), dtype=int)
            notes.append("fewer distinct points than clusters: every clustered configuration is easy")
        else:
            k = min(p.k, distinct)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                labels = KMeans(n_clusters=k, n_init=10, random_state=p.seed).fit_predict(x)
        for cs, lab, row in zip(clustered, labels, x):
            clusters[cs.key] = int(lab)
            feats[cs.key] = (float(row[0]), float(row[1]), float(row[2]))
        ids = sorted(set(int(v) for v in labels))
        mean_rate = {c: float(np.mean([cs.success_rate or 0.0 for cs, lab in zip(clustered, labels) if lab == c]))
                     for c in ids}
        ref_count = {c: sum(1 for r in refs if clusters.get(r) == c) for c in ids}
        if sum(ref_count.values()) == 0:
            notes.append("no flat obstacle-free configuration among the clustered ones: "
                         "the cluster with the higher mean success rate is easy")
        easy = max(ids, key=lambda c: (ref_count[c], mean_rate[c], -c))
        for cs in clustered:
            levels[cs.key] = EASY if clusters[cs.key] == easy else CHALLENGING
    return Difficulty(levels=levels, clusters=clusters, features=feats, reference=refs, params=p,
                      notes=tuple(notes))


def is_flat_empty(world: dict[str, Any]) -> bool:
    """Whether a WorldSpec mapping describes flat ground without obstacles (the reference)."""
    spec = parse_spec(world)
    g = spec.ground
    flat = (g.amplitude_m == 0) if g.model == "fractal" else (g.deformation == 0)
    return flat and all(v == 0 for v in spec.obstacles.targets().values())


def reference_keys(spec: Any) -> set[tuple[str, str]]:
    """The flat, obstacle-free configurations of a campaign spec."""
    out: set[tuple[str, str]] = set()
    for exp in spec.experiments:
        for cfg in exp.configurations(spec.world):
            if is_flat_empty(cfg.world):
                out.add((exp.name, cfg.key))
    return out


@dataclass(frozen=True)
class LevelRange:
    """The swept values of one experiment class that got one level."""

    experiment: str
    parameter: str
    level: str
    values: tuple[Any, ...]
    lo: float | None  # numeric range (None for non-numeric values)
    hi: float | None


@dataclass(frozen=True)
class Overlap:
    """Two levels whose value ranges intersect within one experiment class (a fuzzy threshold)."""

    experiment: str
    a: str
    b: str
    lo: float
    hi: float


def finite_number(v: Any) -> float | None:
    """``v`` as a finite float, or None (a bool, a non-number, NaN or infinity)."""
    if isinstance(v, bool):
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def level_ranges(stats: list[ConfigStats], diff: Difficulty,
                 explicit: Collection[str] = ()) -> tuple[list[LevelRange], list[Overlap]]:
    """Per experiment class: the swept values per level and the overlapping ranges.

    The swept parameter is the first key of ``params`` (experiments sweeping several
    parameters are reported along the first one). Configurations without a level are left out,
    and so are the experiments named in ``explicit`` (explicit worlds: no swept parameter; their
    configurations still get levels)."""
    by_exp: dict[str, list[ConfigStats]] = {}
    for cs in stats:
        if cs.experiment not in explicit:
            by_exp.setdefault(cs.experiment, []).append(cs)
    ranges: list[LevelRange] = []
    overlaps: list[Overlap] = []
    for exp, items in by_exp.items():
        param = next(iter(items[0].params), "(base)")
        per: dict[str, list[Any]] = {}
        for cs in items:
            lev = diff.level(cs.experiment, cs.config_key)
            if lev in NO_LEVEL:
                continue
            per.setdefault(lev, []).append(cs.params.get(param, cs.config_key))
        spans: dict[str, tuple[float, float]] = {}
        for lev in LEVELS:
            if lev not in per:
                continue
            nums = [n for n in (finite_number(v) for v in per[lev]) if n is not None]
            lo, hi = (min(nums), max(nums)) if len(nums) == len(per[lev]) else (None, None)
            ranges.append(LevelRange(exp, param, lev, tuple(per[lev]), lo, hi))
            if lo is not None and hi is not None:
                spans[lev] = (lo, hi)
        levs = [lv for lv in LEVELS if lv in spans]
        for i, a in enumerate(levs):
            for b in levs[i + 1:]:
                lo, hi = max(spans[a][0], spans[b][0]), min(spans[a][1], spans[b][1])
                if lo <= hi:
                    overlaps.append(Overlap(exp, a, b, lo, hi))
    return ranges, overlaps
