"""Verdicts per world and per configuration: pass probability with an exact interval and a class.

A *world* is one map of a configuration run by one navigator with one fault; a *configuration*
pools every map of a configuration (same navigator and fault). For each:

- ``pass_probability``: successes / runs (None without runs);
- ``ci``: the exact (Clopper-Pearson) interval of the pass probability at ``confidence``, from
  :func:`scipy.stats.binomtest` (``proportion_ci(method="exact")``): the number to report;
- ``sequence``: the anytime-valid confidence sequence of :mod:`navstress.sequential` at the same
  ``confidence``, and ``verdict``, the class it proves against ``threshold``: ``passes``,
  ``fails``, ``flaky`` (proven inside :data:`~navstress.sequential.FLAKY_BAND`) or ``undecided``.
  The verdict stays valid however the number of runs was chosen (an adaptive campaign stops a
  world as soon as it is decided), which the fixed-sample exact interval does not.

Runs on maps the world generator refused (:func:`navstress.run.record.ungenerated`) are no
navigation result: such a map gets no world verdict and its runs count in no pass probability; a
configuration's verdict counts its refused maps apart (``refused_worlds``, with the first map's
reason), and a configuration whose every recorded map was refused has no verdict at all (there is
nothing to judge), only its count in :attr:`Verdicts.refused`.

The rule (threshold, confidence) is the adaptive rule of the world's experiment when the campaign
spec gives it one (the experiment's own, else the campaign's), else :data:`DEFAULT_THRESHOLD` and
:data:`DEFAULT_CONFIDENCE` (docs/statistics.md).

    >>> w = world_verdict("trees", "tree=4", 0, "dwa", "nominal", successes=10, runs=10)
    >>> w.verdict, round(w.ci[0], 3)  # 10 of 10 does not yet prove >= 0.8 with 95 % confidence
    ('undecided', 0.692)
    >>> world_verdict("trees", "tree=4", 0, "dwa", "nominal", successes=30, runs=30).verdict
    'passes'
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scipy.stats import binomtest

from navstress import __version__
from navstress._tables import Kind, read_table, write_table
from navstress.analysis.stats import config_key, fault_name, with_variants
from navstress.campaign.store import Store
from navstress.errors import SpecError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated
from navstress.sequential import FLAKY_BAND, VERDICTS, Verdict, check_rule, confidence_sequence, verdict

DEFAULT_THRESHOLD = 0.8
DEFAULT_CONFIDENCE = 0.95

#: Columns of ``campaign export --table verdicts``: one row per world, keyed as the runs table
#: (experiment, config, map_index, navigator, fault); ``scope`` is ``"world"`` and ``worlds`` 1.
VERDICT_COLUMNS: tuple[str, ...] = (
    "scope", "experiment", "config", "map_index", "navigator", "fault", "worlds", "runs", "successes",
    "pass_probability", "ci_low", "ci_high", "seq_low", "seq_high", "verdict", "threshold", "confidence",
    "indifference")
#: Columns of ``campaign export --table configurations``: one row per configuration (its worlds
#: pooled), the same without ``map_index`` (a configuration has none) and with ``refused_worlds``
#: (its maps the world generator refused, left out of the counts); ``scope`` is ``"configuration"``.
CONFIGURATION_COLUMNS: tuple[str, ...] = tuple(c for c in VERDICT_COLUMNS if c != "map_index") + ("refused_worlds",)
#: The tables of verdicts ``campaign export --table`` writes, and their columns.
TABLES: dict[str, tuple[str, ...]] = {"verdicts": VERDICT_COLUMNS, "configurations": CONFIGURATION_COLUMNS}
_INTS = {"map_index", "worlds", "runs", "successes", "refused_worlds"}
_FLOATS = {"pass_probability", "ci_low", "ci_high", "seq_low", "seq_high", "threshold", "confidence",
           "indifference"}
_KINDS: dict[str, Kind] = {c: "int" if c in _INTS else "float" if c in _FLOATS else "str"
                           for c in VERDICT_COLUMNS + CONFIGURATION_COLUMNS}


@dataclass(frozen=True)
class VerdictRule:
    """The threshold and confidence verdicts are given with, and where they come from."""

    threshold: float = DEFAULT_THRESHOLD
    confidence: float = DEFAULT_CONFIDENCE
    source: str = "default"
    indifference: float = 0.0

    def __post_init__(self) -> None:
        check_rule(1, 1, self.threshold, self.confidence, field="verdicts", indifference=self.indifference)


@functools.lru_cache(maxsize=4096)
def exact_interval(successes: int, runs: int, confidence: float) -> tuple[float, float]:
    """Clopper-Pearson interval of successes/runs at ``confidence``; (0, 1) without runs
    (memoised: a campaign's worlds share a few counts, and each interval is a root search)."""
    if runs == 0:
        return 0.0, 1.0
    ci = binomtest(successes, runs).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def _get(obj: Any, name: str) -> Any:
    return obj.get(name) if isinstance(obj, dict) else getattr(obj, name, None)


def _adaptive(owner: Any) -> tuple[float, float, float] | None:
    """(threshold, confidence, indifference) of an adaptive rule found on ``owner`` (a ``runs_per_map`` value
    with an ``adaptive`` mapping or object, or a rule object itself), None when there is none."""
    if owner is None or isinstance(owner, (bool, int, float, str)):
        return None
    ad = _get(owner, "adaptive")
    for cand in (ad, owner):
        if cand is None or isinstance(cand, (bool, int, float, str)):
            continue
        t, c, d = _get(cand, "threshold"), _get(cand, "confidence"), _get(cand, "indifference")
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (t, c)):
            ok = isinstance(d, (int, float)) and not isinstance(d, bool)
            return float(t), float(c), float(d) if ok else 0.0
    return None


def rule_of(spec: Any, experiment: str | None = None) -> VerdictRule:
    """The verdict rule of a campaign spec (of one of its experiments when ``experiment`` is
    given): the adaptive rule's threshold and confidence (``runs_per_map: {adaptive: {...}}``,
    an experiment's own before the campaign's; read defensively), else the defaults."""
    exps = [e for e in (getattr(spec, "experiments", None) or []) if getattr(e, "name", None) == experiment]
    owners: list[tuple[Any, str]] = []
    if exps:
        owners.append((getattr(exps[0], "runs_per_map", None), f"the adaptive rule of experiment {experiment}"))
    rpm = getattr(spec, "runs_per_map", None)
    owners += [(rpm, "the campaign's adaptive rule"), (getattr(spec, "adaptive", None), "the campaign's adaptive rule")]
    for owner, source in owners:
        tc = _adaptive(owner)
        if tc is not None:
            return VerdictRule(tc[0], tc[1], source, tc[2])
    return VerdictRule()


def rules_of(spec: Any) -> dict[str, VerdictRule]:
    """The verdict rule of each experiment of ``spec`` (by name)."""
    return {e.name: rule_of(spec, e.name) for e in (getattr(spec, "experiments", None) or [])
            if isinstance(getattr(e, "name", None), str)}


@dataclass(frozen=True)
class WorldVerdict:
    """The verdict of one world (``map_index`` set) or one configuration (``map_index`` None)."""

    experiment: str
    config_key: str
    map_index: int | None
    navigator: str
    fault: str
    runs: int
    successes: int
    ci: tuple[float, float]
    sequence: tuple[float, float]
    verdict: Verdict
    worlds: int = 1
    #: per configuration: how many of its worlds got each class
    world_verdicts: tuple[tuple[str, int], ...] = ()
    threshold: float = DEFAULT_THRESHOLD
    confidence: float = DEFAULT_CONFIDENCE
    indifference: float = 0.0
    #: per configuration: its maps the world generator refused (left out), and the first one's reason
    refused_worlds: int = 0
    refused_reason: str | None = None

    @property
    def pass_probability(self) -> float | None:
        return self.successes / self.runs if self.runs else None

    def to_json(self) -> dict[str, Any]:
        d: dict[str, Any] = {"experiment": self.experiment, "config": self.config_key}
        if self.map_index is not None:
            d["map_index"] = self.map_index
        d.update(navigator=self.navigator, fault=self.fault, runs=self.runs, successes=self.successes,
                 pass_probability=self.pass_probability, ci=list(self.ci), sequence=list(self.sequence),
                 verdict=self.verdict, threshold=self.threshold, confidence=self.confidence)
        if self.indifference:
            d["indifference"] = self.indifference
        if self.map_index is None:
            d["worlds"] = self.worlds
            d["world_verdicts"] = dict(self.world_verdicts)
            d["refused_worlds"] = self.refused_worlds
            d["refused_reason"] = self.refused_reason
        return d

    def row(self) -> dict[str, Any]:
        """One row of the verdicts export (:data:`VERDICT_COLUMNS`), or of the configurations
        export (:data:`CONFIGURATION_COLUMNS`) for a configuration's verdict."""
        d = {"scope": "world" if self.map_index is not None else "configuration", "experiment": self.experiment,
             "config": self.config_key, "map_index": self.map_index, "navigator": self.navigator,
             "fault": self.fault, "worlds": self.worlds, "runs": self.runs, "successes": self.successes,
             "pass_probability": self.pass_probability, "ci_low": self.ci[0], "ci_high": self.ci[1],
             "seq_low": self.sequence[0], "seq_high": self.sequence[1], "verdict": self.verdict,
             "threshold": self.threshold, "confidence": self.confidence, "indifference": self.indifference}
        if self.map_index is None:
            del d["map_index"]
            d["refused_worlds"] = self.refused_worlds
        return d


def world_verdict(experiment: str, key: str, map_index: int | None, navigator: str, fault: str, *,
                  successes: int, runs: int, threshold: float = DEFAULT_THRESHOLD,
                  confidence: float = DEFAULT_CONFIDENCE, worlds: int = 1,
                  world_verdicts: tuple[tuple[str, int], ...] = (), indifference: float = 0.0,
                  refused_worlds: int = 0, refused_reason: str | None = None) -> WorldVerdict:
    """The :class:`WorldVerdict` of ``successes`` of ``runs`` (see module doc)."""
    if runs < 0 or not 0 <= successes <= runs:
        raise SpecError("successes", f"{successes} of {runs}", "0 <= successes <= runs")
    seq = confidence_sequence(successes, runs, confidence)
    v: Verdict = verdict(*seq, threshold, indifference) if runs else "undecided"
    return WorldVerdict(experiment, key, map_index, navigator, fault, runs, successes,
                        exact_interval(successes, runs, confidence), seq, v, worlds, world_verdicts, threshold,
                        confidence, indifference, refused_worlds, refused_reason)


@dataclass(frozen=True)
class RefusedConfig:
    """A configuration (for one navigator and fault) whose every recorded map the world generator
    refused: no verdict, its maps counted here."""

    experiment: str
    config_key: str
    navigator: str
    fault: str
    worlds: int
    runs: int
    reason: str

    def to_json(self) -> dict[str, Any]:
        return {"experiment": self.experiment, "config": self.config_key, "navigator": self.navigator,
                "fault": self.fault, "refused_worlds": self.worlds, "runs": self.runs, "reason": self.reason}


@dataclass(frozen=True)
class Verdicts:
    """Every world's and every configuration's verdict; ``rule`` is the campaign's, ``rules`` an
    experiment's own where it has one (each verdict carries its threshold and confidence);
    ``refused``: the configurations whose every recorded map was refused (no verdict)."""

    rule: VerdictRule
    worlds: list[WorldVerdict]
    configurations: list[WorldVerdict]
    rules: dict[str, VerdictRule] = field(default_factory=dict)
    refused: list[RefusedConfig] = field(default_factory=list)

    def rule_for(self, experiment: str) -> VerdictRule:
        return self.rules.get(experiment, self.rule)

    def to_json(self) -> dict[str, Any]:
        return {"threshold": self.rule.threshold, "confidence": self.rule.confidence, "rule": self.rule.source,
                "indifference": self.rule.indifference,
                "experiments": {e: {"threshold": r.threshold, "confidence": r.confidence, "rule": r.source,
                                    "indifference": r.indifference} for e, r in self.rules.items()},
                "flaky_band": list(FLAKY_BAND), "interval": "clopper-pearson",
                "worlds": [w.to_json() for w in self.worlds],
                "configurations": [c.to_json() for c in self.configurations],
                "refused_configurations": [c.to_json() for c in self.refused]}

    def rows(self, table: str = "verdicts") -> list[dict[str, Any]]:
        """The rows of export ``table`` (:data:`TABLES`): the worlds' or the configurations'."""
        return [w.row() for w in (self.worlds if table == "verdicts" else self.configurations)]


def verdicts(records: Iterable[RunRecord], rule: VerdictRule | None = None,
             order: Iterable[tuple[str, str, str, str]] = (), rules: dict[str, VerdictRule] | None = None) -> Verdicts:
    """Verdicts of every world and configuration that has runs in ``records``, under ``rule``
    (an experiment's entry of ``rules`` where it has one).

    Configurations follow ``order`` ((experiment, config, navigator, fault), e.g. the plan's),
    then first-seen; worlds follow their configuration, by map index. Records of refused maps are
    counted apart (see module doc)."""
    rule = rule or VerdictRule()
    rules = dict(rules or {})
    counts: dict[tuple[str, str, str, str], dict[int, list[int]]] = {}
    refused: dict[tuple[str, str, str, str], dict[int, list[RunRecord]]] = {}
    for r in records:
        g = (r.experiment, config_key(r), r.navigator, fault_name(r.fault))
        if ungenerated(r):
            refused.setdefault(g, {}).setdefault(r.map_index, []).append(r)
            continue
        c = counts.setdefault(g, {}).setdefault(r.map_index, [0, 0])
        c[0] += r.outcome == Outcome.SUCCESS.value
        c[1] += 1

    def first_reason(g: tuple[str, str, str, str]) -> str | None:
        by_map = refused.get(g)
        if not by_map:
            return None
        return min(by_map[min(by_map)], key=lambda r: (r.run_index, r.run_id)).reason

    keys = list(dict.fromkeys([g for g in order if g in counts] + list(counts)))
    worlds: list[WorldVerdict] = []
    configs: list[WorldVerdict] = []
    for g in keys:
        gr = rules.get(g[0], rule)
        ws = [world_verdict(g[0], g[1], m, g[2], g[3], successes=s, runs=n, threshold=gr.threshold,
                            confidence=gr.confidence, indifference=gr.indifference) for m, (s, n) in sorted(counts[g].items())]
        worlds += ws
        tally = tuple((v, sum(w.verdict == v for w in ws)) for v in VERDICTS)
        configs.append(world_verdict(g[0], g[1], None, g[2], g[3], successes=sum(w.successes for w in ws),
                                     runs=sum(w.runs for w in ws), threshold=gr.threshold,
                                     confidence=gr.confidence, worlds=len(ws), world_verdicts=tally,
                                     indifference=gr.indifference, refused_worlds=len(refused.get(g, {})),
                                     refused_reason=first_reason(g)))
    gone = [g for g in dict.fromkeys([g for g in order if g in refused] + list(refused)) if g not in counts]
    out = [RefusedConfig(g[0], g[1], g[2], g[3], len(refused[g]), sum(map(len, refused[g].values())),
                         first_reason(g) or "") for g in gone]
    return Verdicts(rule, worlds, configs, rules, out)


def write_verdicts(v: Verdicts, fmt: str, dest: Path, metadata: dict[str, str] | None = None,
                   table: str = "verdicts") -> Path:
    """Write export ``table`` of :data:`TABLES` (the worlds' verdicts, or the configurations') as
    CSV or Parquet, atomically (``metadata``: a Parquet file's schema metadata)."""
    if table not in TABLES:
        raise SpecError("--table", table, " or ".join(TABLES))
    return write_table(v.rows(table), {c: _KINDS[c] for c in TABLES[table]}, fmt, dest, metadata=metadata)


def read_verdicts(path: str | Path, table: str = "verdicts") -> list[dict[str, Any]]:
    """Read back a verdicts (or configurations) export, CSV or Parquet, as typed rows."""
    return read_table(path, {c: _KINDS[c] for c in TABLES[table]})


def export_verdicts(directory: str | Path, table: str, fmt: str, dest: Path) -> tuple[Path, int]:
    """``campaign export --table verdicts|configurations``: write the table (the spec and the
    version in a Parquet file's metadata); returns the path and its number of rows."""
    with Store.open(directory) as store:
        v = verdicts(with_variants(store.spec, store.records()), rule_of(store.spec), rules=rules_of(store.spec))
        meta = {"navstress.version": __version__, "navstress.table": table, "navstress.spec": store.spec_text()}
    return write_verdicts(v, fmt, dest, meta, table), len(v.rows(table))
