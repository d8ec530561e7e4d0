"""What the search maximises, from a candidate's repeated runs; the rule that confirms an elite on
fresh runs; the descriptors that place a world on the illumination map.

Every function here is pure: it reads run records (:class:`~navstress.run.record.RunRecord`) and
world files, and never runs anything. A candidate is one world (one ``worlds:`` entry of a
campaign spec); its records are the runs of that world.

**Objectives** (:data:`OBJECTIVES`), each giving an :class:`Evaluation` (fitness in [0, 1], higher
is better, with the counts it came from and an interval):

- ``failure``: the estimated failure probability of the stack under test (the nominal stack, or
  ``fault``), failures counted of one class (:data:`FAILURE_CLASSES`: any, collision, error,
  timeout, other);
- ``fault-revealing``: the share of *revealing pairs* among the paired runs of the nominal stack
  and one faulty stack. Run ``r`` of both shares its run seed (the campaign plans it so), and the
  pair reveals when the faulty run fails and the nominal run succeeds. A run whose partner is
  missing (not run yet, or a different seed) is not counted: :attr:`Evaluation.unpaired` says how
  many were left out;
- ``boundary``: the closeness of the success probability ``p`` to a target ``t`` (default 0.5):
  ``1 - |p - t| / max(t, 1 - t)``;
- ``illumination``: the failure probability, placed on the map by two descriptors.

The fitness is the proportion observed (events / trials; 0 without a trial); ``interval`` is the
anytime-valid confidence sequence of the underlying probability (:mod:`navstress.sequential`), valid
however the number of runs was chosen (fixed or adaptive).

    >>> from navstress.run.record import RunRecord
    >>> def rec(i, outcome, fault=None):
    ...     return RunRecord(f"g0/w0/m0/r{i}/nav/{fault or 'nominal'}", "g0", {}, 0, i, 7, 100 + i, "nav", fault,
    ...                      outcome, "", 1.0, 0.1, 0.0, 1.0, 0.0, 0, None, [], None)
    >>> failure([rec(0, "success"), rec(1, "fail-collision"), rec(2, "fail-timeout")]).fitness
    0.6666666666666666
    >>> e = fault_revealing([rec(0, "success"), rec(0, "fail-collision", "small-footprint"),
    ...                      rec(1, "success", "small-footprint")], "small-footprint")
    >>> (e.events, e.trials, e.unpaired)
    (1, 1, 1)

**Confirmation** (:func:`confirm`): an elite is re-run with fresh run seeds before it is reported;
it is *confirmed* failing, revealing or near the boundary when the confidence sequence of those runs
proves it at ``confidence``, so a confirmation is wrong with probability at most
``1 - confidence`` however many confirmation runs were looked at.

**Descriptors** (:data:`DESCRIPTORS`): named axes of the illumination map (obstruction, roughness,
BARN dispersion, path ratio, ...), each with its unit and natural range, read from a world's
a-priori descriptors (:mod:`navstress.world.descriptors`) or from its spec.
"""

from __future__ import annotations

import difflib
from navstress import _json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from navstress.errors import SpecError
from navstress.nav.faults import list_faults
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord
from navstress.run.record import ungenerated as ungenerated  # (here too: the search's name for it)
from navstress.sequential import FLAKY_BAND, confidence_sequence
from navstress.world.descriptors import describe_world
from navstress.world.spec import WorldSpec
from navstress.world.world import World

NOMINAL = "nominal"
OBJECTIVES: tuple[str, ...] = ("failure", "fault-revealing", "boundary", "illumination")
_FAILS = frozenset(o.value for o in Outcome if o is not Outcome.SUCCESS)
#: Which outcomes count as a failure, per class.
FAILURE_CLASSES: dict[str, frozenset[str]] = {
    "any": _FAILS,
    "collision": frozenset({Outcome.FAIL_COLLISION.value}),
    "error": frozenset({Outcome.FAIL_ERROR.value}),
    "timeout": frozenset({Outcome.FAIL_TIMEOUT.value}),
    "other": frozenset({Outcome.FAIL_OTHER.value}),
}
DEFAULT_CONFIDENCE = 0.95
#: A confirmed failing or revealing world fails (reveals) at least this often: the lower end of the
#: flaky band, so that a confirmed failing world is one whose pass probability is proven below 0.9.
DEFAULT_MIN_RATE = FLAKY_BAND[0]
DEFAULT_TARGET = 0.5
#: A world confirmed near the boundary has its success probability proven within target +- band
#: (0.5 +- 0.4: the flaky band).
DEFAULT_BAND = 0.4


def fault_names() -> tuple[str, ...]:
    """Every fault of the catalogue (:mod:`navstress.nav.faults`), in its order: the mutants a
    suite's mutation score counts."""
    return tuple(f.name for f in list_faults())


def is_nominal(fault: str | None) -> bool:
    """Whether a record's (or a spec's) fault names the nominal stack (None or ``"nominal"``)."""
    return fault is None or fault == NOMINAL


def fault_label(fault: str | None) -> str:
    return NOMINAL if is_nominal(fault) else str(fault)


def _check_class(failure: str) -> frozenset[str]:
    try:
        return FAILURE_CLASSES[failure]
    except (KeyError, TypeError):
        raise SpecError("objective.failure_class", failure, f"one of {', '.join(FAILURE_CLASSES)}",
                        "e.g. failure: collision") from None


def _check_confidence(confidence: float, name: str = "confidence") -> None:
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0.0 < confidence < 1.0:
        raise SpecError(name, confidence, "a number strictly between 0 and 1", "e.g. 0.95")


def _check_unit(value: float, name: str, *, closed: bool = True) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or not (0.0 <= value <= 1.0 if closed else 0.0 < value < 1.0):
        raise SpecError(name, value, f"a number in {'[0, 1]' if closed else '(0, 1)'}")


def failed(outcome: str, failure_class: str = "any") -> bool:
    """Whether ``outcome`` is a failure of class ``failure_class`` (:data:`FAILURE_CLASSES`)."""
    return outcome in _check_class(failure_class)


@dataclass(frozen=True)
class Evaluation:
    """One candidate's fitness under one objective, and where it came from.

    ``events`` of ``trials`` (failures of runs, revealing pairs of pairs, successes of runs for
    ``boundary``) give ``estimate`` (None without a trial) and ``interval``, the anytime-valid
    interval of that probability at ``confidence``; ``fitness`` is what the search maximises, in
    [0, 1]. ``ignored``: records of another navigator or fault than the objective reads;
    ``unpaired``: runs left out for want of a partner with the same run seed (fault-revealing)."""

    objective: str
    fitness: float
    estimate: float | None
    events: int
    trials: int
    interval: tuple[float, float]
    confidence: float
    ignored: int = 0
    unpaired: int = 0
    descriptors: tuple[float, ...] = ()

    def to_json(self) -> dict[str, Any]:
        d: dict[str, Any] = {"objective": self.objective, "fitness": self.fitness, "estimate": self.estimate,
                             "events": self.events, "trials": self.trials, "interval": list(self.interval),
                             "confidence": self.confidence, "ignored": self.ignored, "unpaired": self.unpaired}
        if self.descriptors:
            d["descriptors"] = list(self.descriptors)
        return d


def _select(records: Iterable[RunRecord], navigator: str | None,
            keep: Callable[[RunRecord], bool]) -> tuple[list[RunRecord], int]:
    """The records of ``navigator`` (the only one there is when None) that ``keep`` accepts, and
    how many others there were (:func:`ungenerated` ones among them). Two records of the same run
    id are refused."""
    recs = list(records)
    seen: set[str] = set()
    for r in recs:
        if r.run_id in seen:
            raise SpecError("records", r.run_id, "one record per run", "read the records from one store")
        seen.add(r.run_id)
    if navigator is None:
        navs = sorted({r.navigator for r in recs})
        if len(navs) > 1:
            raise SpecError("navigator", None, f"one of {navs}: the records hold several navigators",
                            "name the navigator under test")
    chosen = [r for r in recs if (navigator is None or r.navigator == navigator) and keep(r) and not ungenerated(r)]
    return chosen, len(recs) - len(chosen)


def _interval(events: int, trials: int, confidence: float) -> tuple[float, float]:
    return confidence_sequence(events, trials, confidence)


def _counted(objective: str, events: int, trials: int, confidence: float, *, ignored: int = 0,
             unpaired: int = 0) -> Evaluation:
    est = events / trials if trials else None
    return Evaluation(objective, est if est is not None else 0.0, est, events, trials,
                      _interval(events, trials, confidence), confidence, ignored, unpaired)


def failure(records: Iterable[RunRecord], *, fault: str | None = None, navigator: str | None = None,
            failure_class: str = "any", confidence: float = DEFAULT_CONFIDENCE,
            feasible: bool | None = None) -> Evaluation:
    """The ``failure`` objective: the failure probability (of class ``failure_class``) of ``navigator``
    under ``fault`` (None: the nominal stack) over its runs among ``records``. ``feasible=False``
    (the world has no traversable path from start to goal, :func:`world_feasible`) makes the fitness
    0: an impossible world fails every stack and teaches nothing (the counts are kept)."""
    cls = _check_class(failure_class)
    _check_confidence(confidence)
    want = fault_label(fault)
    runs, ignored = _select(records, navigator, lambda r: fault_label(r.fault) == want)
    e = _counted("failure", sum(r.outcome in cls for r in runs), len(runs), confidence, ignored=ignored)
    return replace(e, fitness=0.0) if feasible is False else e


def illumination(records: Iterable[RunRecord], descriptors: Sequence[float], *, fault: str | None = None,
                 navigator: str | None = None, failure_class: str = "any",
                 confidence: float = DEFAULT_CONFIDENCE, feasible: bool | None = None) -> Evaluation:
    """The ``illumination`` objective: the failure probability (as :func:`failure`, ``feasible``
    included), placed on the map at ``descriptors`` (the values of the map's axes, e.g. from
    :func:`descriptor_values`)."""
    e = failure(records, fault=fault, navigator=navigator, failure_class=failure_class, confidence=confidence,
                feasible=feasible)
    vals = tuple(float(v) for v in descriptors)
    if not all(math.isfinite(v) for v in vals):
        raise SpecError("descriptors", list(vals), "finite numbers")
    return Evaluation("illumination", e.fitness, e.estimate, e.events, e.trials, e.interval, e.confidence,
                      e.ignored, e.unpaired, vals)


def boundary(records: Iterable[RunRecord], *, target: float = DEFAULT_TARGET, fault: str | None = None,
             navigator: str | None = None, confidence: float = DEFAULT_CONFIDENCE) -> Evaluation:
    """The ``boundary`` objective: ``1 - |p - target| / max(target, 1 - target)`` where ``p`` is the
    success probability (1 at the target, 0 at the far end; 0 without a run). ``events`` are the
    successes and ``interval`` is the success probability's."""
    _check_unit(target, "objective.target", closed=False)
    _check_confidence(confidence)
    want = fault_label(fault)
    runs, ignored = _select(records, navigator, lambda r: fault_label(r.fault) == want)
    s, n = sum(r.outcome == Outcome.SUCCESS.value for r in runs), len(runs)
    p = s / n if n else None
    fit = 0.0 if p is None else max(0.0, 1.0 - abs(p - target) / max(target, 1.0 - target))
    return Evaluation("boundary", fit, p, s, n, _interval(s, n, confidence), confidence, ignored)


def world_key(r: RunRecord) -> str:
    """The world (configuration) key of a record: the second part of its run id
    (``experiment/key/m<k>/r<j>/navigator/fault``; for a search, the ``worlds:`` entry's key), else a
    stable text of its ``config``."""
    parts = r.run_id.split("/")
    if len(parts) >= 6 and parts[0] == r.experiment:
        return "/".join(parts[1:-4])
    return _json.dumps(r.config, sort_keys=True)


def by_world(records: Iterable[RunRecord]) -> dict[tuple[str, str, int], list[RunRecord]]:
    """The records of each world, keyed (experiment, world key, map index), in run order: what one
    candidate's objective reads (a generation's runs of one ``worlds:`` entry)."""
    out: dict[tuple[str, str, int], list[RunRecord]] = {}
    for r in records:
        out.setdefault((r.experiment, world_key(r), r.map_index), []).append(r)
    for v in out.values():
        v.sort(key=lambda r: (r.run_index, r.navigator, fault_label(r.fault), r.run_id))
    return dict(sorted(out.items()))


# ---------------------------------------------------------------- pairs of runs


def pair_key(r: RunRecord) -> tuple[Any, ...]:
    """What a nominal run and a faulty run share when they are a pair: the run id without its fault
    (``experiment/config/m<k>/r<j>/navigator``, the campaign's format), else (navigator, experiment,
    config, map index, map seed, run index) for records of another origin."""
    parts = r.run_id.split("/")
    if len(parts) >= 6 and parts[0] == r.experiment:
        return ("id", "/".join(parts[:-1]))
    return ("fields", r.navigator, r.experiment, _json.dumps(r.config, sort_keys=True), r.map_index, r.map_seed,
            r.run_index)


@dataclass(frozen=True)
class Pairs:
    """The (nominal, faulty) pairs of runs that share a run seed, and the runs left out."""

    pairs: tuple[tuple[RunRecord, RunRecord], ...]
    unpaired: int
    ignored: int


def pairs(records: Iterable[RunRecord], fault: str, *, navigator: str | None = None) -> Pairs:
    """Pair each nominal run with the run of ``fault`` that has the same :func:`pair_key` and the
    same run seed. A run whose partner is missing, or whose partner ran with another seed (not a
    paired comparison), is counted in ``unpaired`` and left out; records of other faults in
    ``ignored``. Pairs come in key order (whatever the order of ``records``)."""
    if is_nominal(fault):
        raise SpecError("fault", fault, "a fault name (the faulty stack compared with the nominal one)",
                        f"one of {', '.join(fault_names())}")
    runs, ignored = _select(records, navigator, lambda r: fault_label(r.fault) in (NOMINAL, fault))
    sides: tuple[dict[tuple[Any, ...], RunRecord], dict[tuple[Any, ...], RunRecord]] = ({}, {})
    for r in runs:
        side = sides[0 if is_nominal(r.fault) else 1]
        k = pair_key(r)
        if k in side:
            raise SpecError("records", r.run_id, "one record per run and fault",
                            f"{side[k].run_id} is the same run")
        side[k] = r
    nom, bad = sides
    out = []
    for k in sorted(set(nom) & set(bad), key=repr):
        if nom[k].run_seed == bad[k].run_seed:
            out.append((nom[k], bad[k]))
    return Pairs(tuple(out), len(runs) - 2 * len(out), ignored)


def reveals(nominal: RunRecord, faulty: RunRecord, failure_class: str = "any") -> bool:
    """A pair reveals the fault when the faulty run fails (of class ``failure_class``) and the nominal one
    succeeds."""
    return nominal.outcome == Outcome.SUCCESS.value and failed(faulty.outcome, failure_class)


def _discordant(p: Pairs, failure_class: str) -> tuple[int, int]:
    """(revealing pairs, counter pairs: the nominal run fails of the class, the faulty one succeeds)."""
    b = sum(reveals(n, f, failure_class) for n, f in p.pairs)
    c = sum(reveals(f, n, failure_class) for n, f in p.pairs)
    return b, c


def fault_revealing(records: Iterable[RunRecord], fault: str, *, navigator: str | None = None,
                    failure_class: str = "any", confidence: float = DEFAULT_CONFIDENCE) -> Evaluation:
    """The ``fault-revealing`` objective: the share of revealing pairs (:func:`reveals`) among the
    paired runs (:func:`pairs`) of the nominal stack and ``fault``."""
    _check_class(failure_class)
    _check_confidence(confidence)
    p = pairs(records, fault, navigator=navigator)
    b, _ = _discordant(p, failure_class)
    return _counted("fault-revealing", b, len(p.pairs), confidence, ignored=p.ignored, unpaired=p.unpaired)


def evaluate(objective: str, records: Iterable[RunRecord], *, fault: str | None = None,
             navigator: str | None = None, failure_class: str = "any", target: float = DEFAULT_TARGET,
             descriptors: Sequence[float] = (), confidence: float = DEFAULT_CONFIDENCE,
             feasible: bool | None = None) -> Evaluation:
    """The :class:`Evaluation` of ``objective`` (:data:`OBJECTIVES`); ``fault`` is the stack under
    test for ``failure``, ``boundary`` and ``illumination`` (None: nominal) and the faulty stack for
    ``fault-revealing`` (required); ``feasible`` as in :func:`failure` (the other objectives need no
    gate: an impossible world has no revealing pair and a success probability of 0)."""
    if objective == "failure":
        return failure(records, fault=fault, navigator=navigator, failure_class=failure_class, confidence=confidence,
                       feasible=feasible)
    if objective == "fault-revealing":
        if fault is None:
            raise SpecError("objective.fault", None, "a fault name for the fault-revealing objective",
                            f"one of {', '.join(fault_names())}")
        return fault_revealing(records, fault, navigator=navigator, failure_class=failure_class, confidence=confidence)
    if objective == "boundary":
        return boundary(records, target=target, fault=fault, navigator=navigator, confidence=confidence)
    if objective == "illumination":
        return illumination(records, descriptors, fault=fault, navigator=navigator, failure_class=failure_class,
                            confidence=confidence, feasible=feasible)
    close = difflib.get_close_matches(str(objective), OBJECTIVES, n=1, cutoff=0.5)
    raise SpecError("objective", objective, f"one of {', '.join(OBJECTIVES)}",
                    f"did you mean {close[0]}?" if close else None)


# ---------------------------------------------------------------- confirmation

ConfirmKind = Literal["failing", "revealing", "boundary"]
CONFIRM_KINDS: tuple[str, ...] = ("failing", "revealing", "boundary")


@dataclass(frozen=True)
class Confirmation:
    """Whether a world's confirmation runs prove it ``kind`` at ``confidence``, and why.

    ``events`` of ``trials``: failures of runs (failing), revealing pairs of pairs (revealing),
    successes of runs (boundary); ``interval``: that probability's confidence sequence. For
    ``revealing``, ``counter`` pairs (the nominal run fails, the faulty one succeeds) and
    ``direction``, the interval of the share of revealing pairs among the discordant ones."""

    kind: str
    confirmed: bool
    confidence: float
    events: int
    trials: int
    interval: tuple[float, float]
    reason: str
    counter: int = 0
    direction: tuple[float, float] | None = None
    unpaired: int = 0

    def to_json(self) -> dict[str, Any]:
        d: dict[str, Any] = {"kind": self.kind, "confirmed": self.confirmed, "confidence": self.confidence,
                             "events": self.events, "trials": self.trials, "interval": list(self.interval),
                             "reason": self.reason}
        if self.kind == "revealing":
            d.update(counter=self.counter, direction=list(self.direction or (0.0, 1.0)), unpaired=self.unpaired)
        return d


def confirm_counts(kind: str, events: int, trials: int, *, counter: int = 0,
                   confidence: float = DEFAULT_CONFIDENCE, min_rate: float = DEFAULT_MIN_RATE,
                   target: float = DEFAULT_TARGET, band: float = DEFAULT_BAND) -> Confirmation:
    """The confirmation rule on counts (see :func:`confirm`), with ``alpha = 1 - confidence``:

    - ``failing``: the failure probability's confidence sequence at ``confidence`` lies above
      ``min_rate``;
    - ``revealing``: two claims, each at ``1 - alpha / 2`` (so both hold with ``confidence``): the
      revealing probability lies above ``min_rate``, and among discordant pairs the revealing ones
      are the more likely (the share ``events / (events + counter)`` lies above 1/2: the fault
      makes this world fail, it does not just share a failure with the nominal stack, as in
      McNemar's test);
    - ``boundary``: the success probability (``events`` = successes) lies inside
      ``(target - band, target + band)``.

    A confidence sequence holds at every run count at once, so the rule may be checked after every
    confirmation run and stopped at the first ``confirmed``: it is wrong at most ``alpha`` of the time."""
    if kind not in CONFIRM_KINDS:
        raise SpecError("confirm", kind, f"one of {', '.join(CONFIRM_KINDS)}")
    _check_confidence(confidence)
    _check_unit(min_rate, "confirm.min_rate")
    _check_unit(target, "confirm.target", closed=False)
    _check_unit(band, "confirm.band", closed=False)
    for name, v in (("events", events), ("trials", trials), ("counter", counter)):
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise SpecError(name, v, "an integer >= 0")
    if events + (counter if kind == "revealing" else 0) > trials:
        raise SpecError("events", events, f"at most trials ({trials})")
    alpha = 1.0 - confidence
    if kind == "failing":
        lo, hi = confidence_sequence(events, trials, confidence)
        ok = lo > min_rate
        why = (f"failure probability in [{lo:.3f}, {hi:.3f}] from {events} of {trials} runs: "
               f"{'above' if ok else 'not proven above'} {min_rate:g}")
        return Confirmation("failing", ok, confidence, events, trials, (lo, hi), why)
    if kind == "boundary":
        lo, hi = confidence_sequence(events, trials, confidence)
        a, b = target - band, target + band
        ok = a < lo and hi < b
        why = (f"success probability in [{lo:.3f}, {hi:.3f}] from {events} of {trials} runs: "
               f"{'inside' if ok else 'not proven inside'} ({a:g}, {b:g})")
        return Confirmation("boundary", ok, confidence, events, trials, (lo, hi), why)
    half = 1.0 - alpha / 2.0
    lo, hi = confidence_sequence(events, trials, half)
    dlo, dhi = confidence_sequence(events, events + counter, half)
    rate_ok, dir_ok = lo > min_rate, dlo > 0.5
    ok = rate_ok and dir_ok
    why = (f"revealing probability in [{lo:.3f}, {hi:.3f}] from {events} of {trials} pairs "
           f"({'above' if rate_ok else 'not proven above'} {min_rate:g}); {events} revealing against {counter} "
           f"counter pairs ({'more likely' if dir_ok else 'not proven more likely'})")
    return Confirmation("revealing", ok, confidence, events, trials, (lo, hi), why, counter, (dlo, dhi))


def confirm(records: Iterable[RunRecord], kind: str, *, fault: str | None = None, navigator: str | None = None,
            failure_class: str = "any", confidence: float = DEFAULT_CONFIDENCE,
            min_rate: float = DEFAULT_MIN_RATE, target: float = DEFAULT_TARGET,
            band: float = DEFAULT_BAND) -> Confirmation:
    """Whether a world's confirmation runs (``records``: its runs with fresh run seeds) confirm it
    ``kind`` (``failing``, ``revealing``, ``boundary``; the rule: :func:`confirm_counts`).
    ``failing`` and ``boundary`` read the runs of ``fault`` (None: nominal); ``revealing`` pairs the
    nominal runs with those of ``fault`` (unpaired runs left out, as in :func:`fault_revealing`)."""
    if kind not in CONFIRM_KINDS:
        raise SpecError("confirm", kind, f"one of {', '.join(CONFIRM_KINDS)}")
    if kind == "revealing":
        if fault is None or is_nominal(fault):
            raise SpecError("fault", fault, "a fault name to confirm a revealing world",
                            f"one of {', '.join(fault_names())}")
        _check_class(failure_class)
        p = pairs(records, fault, navigator=navigator)
        b, c = _discordant(p, failure_class)
        got = confirm_counts("revealing", b, len(p.pairs), counter=c, confidence=confidence, min_rate=min_rate)
        return Confirmation(got.kind, got.confirmed, got.confidence, got.events, got.trials, got.interval,
                            got.reason, got.counter, got.direction, p.unpaired)
    if kind == "failing":
        e = failure(records, fault=fault, navigator=navigator, failure_class=failure_class, confidence=confidence)
        return confirm_counts("failing", e.events, e.trials, confidence=confidence, min_rate=min_rate)
    e = boundary(records, target=target, fault=fault, navigator=navigator, confidence=confidence)
    return confirm_counts("boundary", e.events, e.trials, confidence=confidence, target=target, band=band)


# ---------------------------------------------------------------- mutation score


@dataclass(frozen=True)
class Kill:
    """Whether one world kills one fault (mutant): its paired runs confirm it revealing."""

    fault: str
    killed: bool
    confirmation: Confirmation


def kills(records: Iterable[RunRecord], faults: Sequence[str] | None = None, *, navigator: str | None = None,
          failure_class: str = "any", confidence: float = DEFAULT_CONFIDENCE,
          min_rate: float = DEFAULT_MIN_RATE) -> dict[str, Kill]:
    """Per fault (default: every fault of the catalogue), whether this world's runs kill it: the
    nominal and faulty runs, paired, :func:`confirm` the world revealing. A fault without paired
    runs on the world is not killed."""
    recs = list(records)
    out: dict[str, Kill] = {}
    for f in (fault_names() if faults is None else faults):
        c = confirm(recs, "revealing", fault=f, navigator=navigator, failure_class=failure_class,
                    confidence=confidence, min_rate=min_rate)
        out[f] = Kill(f, c.confirmed, c)
    return out


@dataclass(frozen=True)
class MutationScore:
    """The faults a suite kills (by at least one of its worlds) of those it was run against."""

    faults: tuple[str, ...]
    killed: tuple[str, ...]
    by: dict[str, tuple[str, ...]] = field(default_factory=dict)

    @property
    def score(self) -> float:
        return len(self.killed) / len(self.faults) if self.faults else 0.0

    def to_json(self) -> dict[str, Any]:
        return {"faults": list(self.faults), "killed": list(self.killed), "score": self.score,
                "killed_by": {f: list(w) for f, w in self.by.items()}}


def mutation_score(world_kills: Mapping[str, Mapping[str, Kill]],
                   faults: Sequence[str] | None = None) -> MutationScore:
    """The mutation score of a suite from each world's :func:`kills` (``world_kills[world key]``):
    the share of ``faults`` (default: the catalogue's) that at least one world kills."""
    fs = tuple(fault_names() if faults is None else faults)
    by = {f: tuple(sorted(w for w, ks in world_kills.items() if f in ks and ks[f].killed)) for f in fs}
    return MutationScore(fs, tuple(f for f in fs if by[f]), {f: w for f, w in by.items() if w})


# ---------------------------------------------------------------- descriptors


@dataclass(frozen=True)
class Descriptor:
    """One axis of the illumination map: ``name`` (as a search spec writes it), a label and unit
    for a person, the natural range (``low``, ``high``), and where the value comes from
    (``source``: the world's spec, or its a-priori descriptors once generated)."""

    name: str
    label: str
    unit: str
    low: float
    high: float
    source: Literal["spec", "world"]
    description: str
    read: Callable[[Mapping[str, Any]], float | None] = field(repr=False, compare=False, default=lambda d: None)
    spec_value: Callable[[WorldSpec], float] | None = field(repr=False, compare=False, default=None)
    #: the value where the world has none (no obstacle for BARN metrics, no path for the path ratio)
    missing: float = 0.0

    @property
    def axis_label(self) -> str:
        return f"{self.label} [{self.unit}]" if self.unit else self.label

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, "unit": self.unit, "range": [self.low, self.high],
                "source": self.source, "description": self.description}


def _key(*path: str) -> Callable[[Mapping[str, Any]], float | None]:
    def read(d: Mapping[str, Any]) -> float | None:
        v: Any = d
        for p in path:
            if not isinstance(v, Mapping):
                return None
            v = v.get(p)
        return None if v is None or isinstance(v, bool) else float(v)
    return read


def _per_type(kind: str) -> Callable[[Mapping[str, Any]], float | None]:
    def read(d: Mapping[str, Any]) -> float | None:
        by = d.get("obstruction_pct")
        return None if not isinstance(by, Mapping) else float(by.get(kind, 0.0))
    return read


DESCRIPTORS: dict[str, Descriptor] = {d.name: d for d in (
    Descriptor("obstruction", "obstruction", "%", 0.0, 40.0, "world",
               "percent of the map covered by obstacle footprints, achieved", _key("obstruction_total_pct")),
    Descriptor("tree_obstruction", "tree obstruction", "%", 0.0, 30.0, "world",
               "percent of the map covered by trees, achieved", _per_type("tree")),
    Descriptor("building_obstruction", "building obstruction", "%", 0.0, 40.0, "world",
               "percent of the map covered by buildings, achieved", _per_type("building")),
    Descriptor("obstruction_target", "obstruction target", "%", 0.0, 40.0, "spec",
               "the spec's total obstruction target", spec_value=lambda s: float(sum(s.obstacles.targets().values()))),
    Descriptor("movers", "movers", "", 0.0, 50.0, "spec",
               "the number of movers (obstacles that move during a run) the spec asks for",
               spec_value=lambda s: float(sum(s.movers.counts(s.size_m).values()))),
    Descriptor("mover_density", "mover density", "/ha", 0.0, 50.0, "spec",
               "movers per hectare of the map",
               spec_value=lambda s: float(sum(s.movers.counts(s.size_m).values())) / (s.size_m[0] * s.size_m[1] / 1e4)),
    Descriptor("subdivisions", "subdivisions s", "", 0.0, 10.0, "spec",
               "the ground's subdivisions s (subdivide: 2**s + 1 control vertices per side; blender: s cuts)",
               spec_value=lambda s: float(s.ground.subdivisions)),
    Descriptor("deformation", "deformation d", "m", 0.0, 10.0, "spec",
               "the ground's deformation d (vertex displacement scale; blender: the Fractal value)",
               spec_value=lambda s: float(s.ground.deformation)),
    Descriptor("roughness", "roughness", "m", 0.0, 1.0, "world",
               "standard deviation of the height residual after a 1 m Gaussian smoothing", _key("roughness_m")),
    Descriptor("slope_p95", "95th-percentile slope", "deg", 0.0, 45.0, "world",
               "95th percentile of the ground slope", _key("slope_p95_deg")),
    Descriptor("height_std", "height spread", "m", 0.0, 10.0, "world",
               "standard deviation of the ground height", _key("height_std_m")),
    Descriptor("barn_dispersion", "BARN dispersion", "", 0.0, 8.0, "world",
               "mean alternations between open and blocked rays around a free cell (0 without obstacles)",
               _key("barn_dispersion"), missing=0.0),
    Descriptor("barn_visibility", "BARN visibility", "m", 0.0, 10.0, "world",
               "mean length of 16 rays from a free cell, capped at 10 m (the cap without obstacles)",
               _key("barn_visibility_m"), missing=10.0),
    Descriptor("barn_characteristic_dim", "BARN characteristic dimension", "m", 0.0, 20.0, "world",
               "mean width of the narrowest passage through a free cell (20 m without obstacles)",
               _key("barn_characteristic_dim_m"), missing=20.0),
    Descriptor("barn_dist_closest", "BARN distance to closest obstacle", "m", 0.0, 20.0, "world",
               "mean distance from a free cell to the nearest obstacle (20 m without obstacles)",
               _key("barn_dist_closest_m"), missing=20.0),
    Descriptor("path_ratio", "path ratio", "", 1.0, 3.0, "world",
               "shortest traversable path over straight distance, start to goal (3 when there is no path)",
               _key("path_ratio"), missing=3.0),
)}


def get_descriptor(name: str, field: str = "descriptors") -> Descriptor:
    """The descriptor called ``name``; a :class:`SpecError` naming ``field`` and the known ones otherwise."""
    try:
        return DESCRIPTORS[name]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(name), list(DESCRIPTORS), n=1, cutoff=0.5)
        raise SpecError(field, name, f"one of {', '.join(DESCRIPTORS)}",
                        f"did you mean {close[0]}?" if close else "see docs/search.md") from None


WorldSource = World | WorldSpec | str | Path


def descriptor_values(names: Sequence[str], source: WorldSource, *, field: str = "descriptors") -> tuple[float, ...]:
    """The values of the descriptors ``names`` for ``source``: a world directory, a loaded
    :class:`World`, or a :class:`WorldSpec` (then only descriptors of ``source == "spec"``: the
    others need the generated world). World descriptors are read from the world's stored a-priori
    descriptors (:mod:`navstress.world.descriptors`), recomputed by it when the world has none; a
    value the world does not have (no obstacle, no path) is the descriptor's ``missing``."""
    ds = [get_descriptor(n, field) for n in names]
    if isinstance(source, (str, Path)):
        source = World.load(source)
    spec = source if isinstance(source, WorldSpec) else source.spec
    stored: Mapping[str, Any] | None = None
    out: list[float] = []
    for d in ds:
        if d.source == "spec":
            assert d.spec_value is not None
            out.append(float(d.spec_value(spec)))
            continue
        if isinstance(source, WorldSpec):
            raise SpecError(field, d.name, "a descriptor of the spec when only a spec is given "
                            f"({', '.join(n for n, x in DESCRIPTORS.items() if x.source == 'spec')})",
                            "give the generated world (its directory)")
        if stored is None:
            stored = source.descriptors if "obstruction_total_pct" in source.descriptors else describe_world(source)
        v = d.read(stored)
        out.append(d.missing if v is None or not math.isfinite(v) else float(v))
    return tuple(out)


def world_feasible(source: World | str | Path) -> bool | None:
    """Whether a world has a traversable path from start to goal (its ``feasible`` descriptor,
    :mod:`navstress.world.descriptors`; recomputed when the world has none stored)."""
    w = World.load(source) if isinstance(source, (str, Path)) else source
    v = (w.descriptors if "feasible" in w.descriptors else describe_world(w)).get("feasible")
    return None if v is None else bool(v)
