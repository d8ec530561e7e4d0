"""Per-configuration statistics of a campaign's runs (the paper's Q1 inputs) and confidence intervals.

A *configuration* is one point of an experiment's sweep; its runs are grouped by
``(experiment, config_key, navigator, fault)``. For each group:

- ``runs``, ``successes``, ``success_rate`` with a Wilson score interval (95 % by default;
  Clopper-Pearson available with :func:`clopper_pearson`; which scipy routine gives each:
  docs/statistics.md, "Intervals and scipy");
- ``outcomes``: counts per outcome (every outcome listed, zeros included);
- ``median_duration_s`` and ``median_tortuousness``: medians over *successful* runs only
  (None without a success). Tortuousness is the record's ``tortuousness`` column
  (:mod:`navstress.run.metrics`: positions resampled every 0.5 m of travelled distance after
  dropping moves shorter than 0.1 m, so sensor jitter and stops do not dominate the angle);
- ``mean_goal_distance_m``: mean final real distance to the goal over every run (NaN values,
  which SQLite stores as NULL, are left out; None if none is finite).

Runs on a map the world generator refused (:func:`navstress.run.record.ungenerated`: the map's
spec could not be generated, so nothing ran) are no navigation result: every figure above leaves
them out, and ``refused`` counts them apart (:class:`Refused`: the refused maps, their runs and
the first map's reason).

    >>> round(wilson(8, 10)[0], 4), round(wilson(8, 10)[1], 4)
    (0.4902, 0.9433)
"""

from __future__ import annotations

import dataclasses

import math
import statistics
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from scipy import stats as _st

from navstress import _json
from navstress._tables import NOMINAL as NOMINAL  # the fault of the nominal stack
from navstress.campaign.plan import config_key_of, variant
from navstress.errors import SpecError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, cap_message, ungenerated

OUTCOMES: tuple[str, ...] = tuple(o.value for o in Outcome)


def _check(successes: int, n: int, confidence: float) -> None:
    if n < 0 or successes < 0 or successes > n:
        raise SpecError("successes", f"{successes} of {n}", "0 <= successes <= n")
    if not 0.0 < confidence < 1.0:
        raise SpecError("confidence", confidence, "a probability in (0, 1), e.g. 0.95")


def wilson(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (``scipy.stats.binomtest``'s); (0, 1) when
    ``n`` is 0 (scipy has none there)."""
    _check(successes, n, confidence)
    if n == 0:
        return 0.0, 1.0
    ci = _st.binomtest(successes, n).proportion_ci(confidence_level=confidence, method="wilson")
    lo = 0.0 if successes == 0 else max(0.0, float(ci.low))  # exact ends (no rounding residue)
    hi = 1.0 if successes == n else min(1.0, float(ci.high))
    return lo, hi


def clopper_pearson(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval from beta quantiles; (0, 1) when ``n`` is 0."""
    _check(successes, n, confidence)
    if n == 0:
        return 0.0, 1.0
    a = 1 - confidence
    lo = 0.0 if successes == 0 else float(_st.beta.ppf(a / 2, successes, n - successes + 1))
    hi = 1.0 if successes == n else float(_st.beta.ppf(1 - a / 2, successes + 1, n - successes))
    return lo, hi


def config_key(rec: RunRecord) -> str:
    """The configuration key of a record: the second part of its run id
    (``experiment/config_key/m<k>/r<j>/navigator/fault``), else a stable text of ``config``."""
    return config_key_of(rec.run_id, rec.experiment, rec.config)


def fault_name(fault: str | None) -> str:
    return fault or NOMINAL


@dataclass(frozen=True)
class Refused:
    """The maps of a configuration (for one navigator and fault) that the world generator refused:
    their indices, the runs recorded on them (left out of every statistic) and the reason of the
    lowest refused map."""

    maps: tuple[int, ...] = ()
    runs: int = 0
    reason: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {"maps": len(self.maps), "map_indices": list(self.maps), "runs": self.runs,
                "first_reason": self.reason}


def split_refused(records: Iterable[RunRecord]) -> tuple[list[RunRecord], Refused]:
    """``records`` less those of refused maps (:func:`~navstress.run.record.ungenerated`), and
    what was left out (:class:`Refused`)."""
    kept: list[RunRecord] = []
    out: list[RunRecord] = []
    for r in records:
        (out if ungenerated(r) else kept).append(r)
    if not out:
        return kept, Refused()
    first = min(out, key=lambda r: (r.map_index, r.run_index, r.run_id))
    return kept, Refused(tuple(sorted({r.map_index for r in out})), len(out), first.reason)


#: Most characters of a refused map's reason where a line quotes it (the records keep it whole).
MAX_REASON_CHARS = 300


def reason_line(reason: str | None, limit: int = MAX_REASON_CHARS) -> str:
    """A refused map's reason as one line of at most ``limit`` characters (white space collapsed,
    head and tail kept)."""
    return cap_message(" ".join(str(reason or "").split()), limit)


@dataclass(frozen=True)
class ConfigStats:
    """Statistics of one configuration for one navigator and fault (see module doc)."""

    experiment: str
    config_key: str
    params: dict[str, Any]
    navigator: str
    fault: str  # "nominal" or the fault's name
    runs: int
    successes: int
    ci_low: float
    ci_high: float
    outcomes: dict[str, int]
    median_duration_s: float | None
    median_tortuousness: float | None
    mean_goal_distance_m: float | None
    planned: int = 0
    maps: tuple[int, ...] = field(default_factory=tuple)  # the generated maps with runs
    refused: Refused = field(default_factory=Refused)

    @property
    def key(self) -> tuple[str, str]:
        return self.experiment, self.config_key

    @property
    def recorded(self) -> int:
        """Every recorded run: ``runs`` and those on refused maps."""
        return self.runs + self.refused.runs

    @property
    def success_rate(self) -> float | None:
        """successes / runs, None without runs."""
        return self.successes / self.runs if self.runs else None

    def to_json(self) -> dict[str, Any]:
        return {"experiment": self.experiment, "config": self.config_key, "params": self.params,
                "navigator": self.navigator, "fault": self.fault, "runs": self.runs, "planned": self.planned,
                "successes": self.successes, "success_rate": self.success_rate, "ci": [self.ci_low, self.ci_high],
                "outcomes": self.outcomes, "median_duration_s": self.median_duration_s,
                "median_tortuousness": self.median_tortuousness, "mean_goal_distance_m": self.mean_goal_distance_m,
                "maps": list(self.maps), "refused": self.refused.to_json()}


def _finite(xs: Iterable[float | None]) -> list[float]:
    return [float(x) for x in xs if x is not None and math.isfinite(float(x))]


def summarise(experiment: str, key: str, params: dict[str, Any], navigator: str, fault: str,
              records: list[RunRecord], *, planned: int = 0, confidence: float = 0.95,
              interval: str = "wilson") -> ConfigStats:
    """The :class:`ConfigStats` of ``records`` (all of one configuration, navigator and fault; those
    of refused maps counted apart)."""
    if interval not in ("wilson", "clopper-pearson"):
        raise SpecError("interval", interval, "wilson or clopper-pearson")
    records, refused = split_refused(records)
    n = len(records)
    ok = [r for r in records if r.outcome == Outcome.SUCCESS.value]
    counts = {o: 0 for o in OUTCOMES}
    for r in records:
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    ci = (wilson if interval == "wilson" else clopper_pearson)(len(ok), n, confidence)
    dur = _finite(r.duration_s for r in ok)
    tort = _finite(r.tortuousness for r in ok)
    dist = _finite(r.goal_distance_m for r in records)
    return ConfigStats(
        experiment=experiment, config_key=key, params=dict(params), navigator=navigator, fault=fault, runs=n,
        successes=len(ok), ci_low=ci[0], ci_high=ci[1], outcomes=counts,
        median_duration_s=statistics.median(dur) if dur else None,
        median_tortuousness=statistics.median(tort) if tort else None,
        mean_goal_distance_m=statistics.fmean(dist) if dist else None,
        planned=planned, maps=tuple(sorted({r.map_index for r in records})), refused=refused)


@dataclass(frozen=True)
class PlannedConfig:
    """A configuration the campaign plans (so that one without any run still shows up)."""

    experiment: str
    config_key: str
    params: dict[str, Any]
    navigator: str
    fault: str
    planned: int


def config_stats(records: list[RunRecord], planned: list[PlannedConfig] | None = None, *,
                 confidence: float = 0.95, interval: str = "wilson") -> list[ConfigStats]:
    """One :class:`ConfigStats` per (experiment, configuration, navigator, fault).

    Order: the ``planned`` order first (configurations without any run included, with
    ``runs == 0``), then any group only seen in ``records``, in first-seen order."""
    groups: dict[tuple[str, str, str, str], list[RunRecord]] = {}
    params: dict[tuple[str, str, str, str], dict[str, Any]] = {}
    for r in records:
        g = (r.experiment, config_key(r), r.navigator, fault_name(r.fault))
        groups.setdefault(g, []).append(r)
        params.setdefault(g, dict(r.config))
    order: list[tuple[str, str, str, str]] = []
    n_planned: dict[tuple[str, str, str, str], int] = {}
    for p in planned or []:
        g = (p.experiment, p.config_key, p.navigator, p.fault)
        if g not in n_planned:
            order.append(g)
        n_planned[g] = p.planned
        params.setdefault(g, dict(p.params))
    order += [g for g in groups if g not in n_planned]
    return [summarise(g[0], g[1], params[g], g[2], g[3], groups.get(g, []), planned=n_planned.get(g, 0),
                      confidence=confidence, interval=interval) for g in order]


def planned_configs(spec: Any, runs: dict[tuple[str, str, str, str], int] | None = None) -> list[PlannedConfig]:
    """Every configuration x navigator x fault a :class:`~navstress.campaign.spec.CampaignSpec` plans;
    ``runs``: the planned runs of each (``Store.planned_by_config``: at most, where adaptive),
    default the maps per configuration (1 for an explicit world) x the most runs per map."""
    out: list[PlannedConfig] = []
    for exp in spec.experiments:
        per = spec.maps_of(exp) * spec.max_runs_of(exp)
        for cfg in exp.configurations(spec.world):
            for name in variants(spec, exp):
                for f in spec.faults_of(exp):
                    n = per if runs is None else runs.get((exp.name, cfg.key, name, fault_name(f)), per)
                    out.append(PlannedConfig(exp.name, cfg.key, dict(cfg.values), name, fault_name(f), n))
    return out


# ---- robots: a campaign of several robots is analysed per (navigator, robot) -----------------
#
# Every analysis groups runs by navigator (and fault): in a campaign of several robots the
# "navigator" of a run is its variant ``navigator@robot`` (the run id's navigator part,
# :func:`navstress.campaign.plan.variant`), so no statistic, table row or figure ever pools two
# robots. A campaign of one robot is analysed as before (its robot named beside the results).


def variants(spec: Any, exp: Any = None) -> list[str]:
    """The navigators of ``spec`` as analysed (of experiment ``exp``, default every experiment):
    their names, or ``navigator@robot`` for each robot in a campaign of several robots."""
    if not spec.several_robots:
        return [n.name for n in spec.navigators]
    robots = spec.robots_of(exp) if exp is not None else spec.all_robots()
    return [variant(n.name, r.name) for n in spec.navigators for r in robots]


def with_variants(spec: Any, records: list[RunRecord]) -> list[RunRecord]:
    """``records`` as analysed: unchanged in a campaign of one robot; in a campaign of several,
    each with its ``navigator`` the variant ``navigator@robot``."""
    if not spec.several_robots:
        return records
    return [dataclasses.replace(r, navigator=variant(r.navigator, r.robot)) for r in records]


def robots_text(spec: Any) -> str:
    """The campaign's robots in words: ``robot rmp400 (digest ...)`` or ``robots rmp400, jackal``."""
    rs = spec.all_robots()
    if len(rs) == 1:
        return f"robot {rs[0].name} (digest {rs[0].digest})"
    return "robots " + ", ".join(f"{r.name} ({r.digest})" for r in rs)


def params_text(params: dict[str, Any]) -> str:
    """``tree=4, deformation=1.5`` (last path component of each swept parameter)."""
    return ", ".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, v in params.items()) or "(base)"


def dumps(obj: Any) -> str:
    """Indented strict JSON (NaN/inf written as null; keys as text): :func:`navstress._json.pretty`."""
    return _json.pretty(obj)
