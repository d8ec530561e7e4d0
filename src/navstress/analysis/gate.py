"""The CI gate: does every gated configuration of a campaign meet a success bar *with confidence*?

A *gated configuration* is one (experiment, configuration, navigator, fault) of the campaign;
by default every navigator's nominal runs are gated (a fault is injected to be caught, so a
faulty stack is gated only when asked for by name). A configuration passes when

- the one-sided exact (Clopper-Pearson) lower confidence bound of its success rate, over its
  recorded runs, is at least ``min_success`` (:func:`lower_bound`); a configuration without a
  recorded run has the bound 0;
- and, when ``max_collisions`` is set, it has at most that many Fail-Collision runs.

The gate passes when every gated configuration passes. Each configuration's worlds
(experiment/configuration/map, for its navigator and fault) are the JUnit test cases
(:func:`junit_xml`); a world *fails* when its configuration fails and the world holds evidence
of it: a run that is not a success (when the success bar is missed) or a Fail-Collision run
(when the collision bar is exceeded). A configuration that misses the success bar with no such
run in any world (too few runs to prove the bar, or none recorded) fails all its worlds, with
"not enough runs" as the reason. So the JUnit file has a failure exactly when the gate fails.

Maps the world generator refused (:func:`navstress.run.record.ungenerated`: nothing ran there)
are no evidence either way: their runs count in no figure above, the configuration's evidence
line and JSON count them apart, and they are no test case (their runs are listed in the suite's
``system-out``). A gated configuration with no run on a generated map but with refused maps
**fails** ("no generated map"), whatever the bar: it measured nothing, and a gate must not pass
what it could not test; then each refused map is a failed test case naming the generator's reason.

    >>> round(lower_bound(12, 20, 0.95), 4)
    0.3936
    >>> round(lower_bound(20, 20, 0.95), 4)  # 0.05 ** (1 / 20)
    0.8609
"""

from __future__ import annotations

import math
import socket
import time
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

from scipy import stats as _st

from navstress import _files
from navstress._percent import percent, percent_vs, setting
from navstress.analysis.stats import (MAX_REASON_CHARS, NOMINAL, config_key, fault_name, reason_line, variants,
                                      with_variants)
from navstress.campaign.store import Store
from navstress.errors import SpecError, StoreError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated

SUCCESS = Outcome.SUCCESS.value
COLLISION = Outcome.FAIL_COLLISION.value


def lower_bound(successes: int, n: int, confidence: float = 0.95) -> float:
    """The one-sided exact (Clopper-Pearson) lower confidence bound of a success probability
    after ``successes`` of ``n`` runs: ``P(p >= bound) >= confidence`` for a fixed ``n``. It is
    the ``1 - confidence`` quantile of Beta(successes, n - successes + 1); 0 without a success
    (and without runs)."""
    if n < 0 or not 0 <= successes <= n:
        raise SpecError("successes", f"{successes} of {n}", "0 <= successes <= n")
    check_confidence(confidence)
    if successes == 0:
        return 0.0
    return float(_st.beta.ppf(1.0 - confidence, successes, n - successes + 1))


def check_confidence(confidence: float, field: str = "confidence") -> None:
    """SpecError unless ``confidence`` is a finite number strictly between 0 and 1."""
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not math.isfinite(confidence) \
            or not 0.0 < confidence < 1.0:
        raise SpecError(field, confidence, "a probability strictly between 0 and 1", "e.g. 0.95")


@dataclass(frozen=True)
class GateRule:
    """The bar: success rate >= ``min_success`` with ``confidence``; at most ``max_collisions``
    Fail-Collision runs per configuration (None: not checked)."""

    min_success: float
    confidence: float = 0.95
    max_collisions: int | None = None

    def __post_init__(self) -> None:
        v = self.min_success
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0.0 <= v <= 1.0:
            raise SpecError("min_success", v, "a success rate in [0, 1]", "e.g. 0.8")
        check_confidence(self.confidence)
        m = self.max_collisions
        if m is not None and (isinstance(m, bool) or not isinstance(m, int) or m < 0):
            raise SpecError("max_collisions", m, "an integer >= 0")

    def text(self) -> str:
        """``success >= 80% with 95% confidence, at most 0 collision runs``."""
        s = f"success >= {setting(self.min_success)} with {setting(self.confidence)} confidence"
        if self.max_collisions is not None:
            s += f", at most {self.max_collisions} collision run{'s' if self.max_collisions != 1 else ''}"
        return s


@dataclass(frozen=True)
class RunEvidence:
    """One recorded run of a world, as the JUnit file shows it: ``wall_s`` and ``sim_s`` its wall
    and simulated seconds (0 when the store holds no usable number), ``started`` when it started
    (seconds since the epoch: its record's time less its wall time; None when unknown)."""

    run_id: str
    outcome: str
    reason: str
    map_seed: int
    run_seed: int
    trace: str | None  # path under the campaign directory as given, None without a trace
    wall_s: float = 0.0
    sim_s: float = 0.0
    started: float | None = None
    refused: bool = False  # the world generator refused its map: it never ran


@dataclass(frozen=True)
class WorldCase:
    """One world (experiment/configuration/map) for one navigator and fault: a JUnit test case."""

    experiment: str
    config_key: str
    map_index: int
    navigator: str
    fault: str
    runs: tuple[RunEvidence, ...]
    failed: bool = False
    reason: str = ""

    @property
    def classname(self) -> str:
        """``experiment/config``: CI views group a configuration's worlds under it."""
        return f"{self.experiment}/{self.config_key}"

    @property
    def name(self) -> str:
        """``m<k>/navigator/fault`` (with the classname: a run id without its ``r<j>``)."""
        return f"m{self.map_index}/{self.navigator}/{self.fault}"

    @property
    def successes(self) -> int:
        return sum(r.outcome == SUCCESS for r in self.runs)

    @property
    def wall_ms(self) -> int:
        """The wall time of the world's recorded runs, summed, in whole milliseconds (its JUnit
        ``time``)."""
        return sum(round(_seconds(r.wall_s) * 1000) for r in self.runs)

    def failed_runs(self) -> list[RunEvidence]:
        return [r for r in self.runs if r.outcome != SUCCESS]


@dataclass(frozen=True)
class ConfigResult:
    """The gate's verdict on one configuration for one navigator and fault."""

    experiment: str
    config_key: str
    navigator: str
    fault: str
    runs: int
    successes: int
    collisions: int
    lower: float
    success_ok: bool
    collisions_ok: bool
    worlds: tuple[WorldCase, ...] = field(default_factory=tuple)
    #: the maps the world generator refused (left out of every figure), their runs, the first one's reason
    refused_maps: tuple[int, ...] = ()
    refused_runs: int = 0
    refused_reason: str | None = None
    #: the refused maps that are no test case (all of them unless the configuration has no generated map)
    refused_worlds: tuple[WorldCase, ...] = ()

    @property
    def passed(self) -> bool:
        return self.success_ok and self.collisions_ok

    @property
    def no_generated_map(self) -> bool:
        """No run on a generated map, and some on refused ones: the configuration fails."""
        return self.runs == 0 and self.refused_runs > 0

    def refused_text(self) -> str:
        """``2 maps refused by the world generator (first: ...)`` ('' without a refused map)."""
        if not self.refused_runs:
            return ""
        n = len(self.refused_maps)
        why = reason_line(self.refused_reason)
        return f"{n} map{'s' if n != 1 else ''} refused by the world generator (first: {why})"

    @property
    def label(self) -> str:
        """``trees/tree=10 reference-v1`` (``+ fault`` for a faulty stack)."""
        who = self.navigator if self.fault == NOMINAL else f"{self.navigator} + {self.fault}"
        return f"{self.experiment}/{self.config_key} {who}"

    def evidence(self, rule: GateRule) -> str:
        """``success 12/20 = 60%, lower 95% bound 39% < 80%`` (and the collisions when checked; the
        maps the world generator refused, left out)."""
        if self.no_generated_map:
            return f"no generated map: {self.refused_text()}, so nothing was measured"
        if self.runs:
            cmp = ">=" if self.success_ok else "<"
            s = (f"success {self.successes}/{self.runs} = {percent(self.successes / self.runs)}, "
                 f"lower {setting(rule.confidence)} bound {percent_vs(self.lower, rule.min_success)} {cmp} "
                 f"{setting(rule.min_success)}")
        else:
            s = f"no run recorded, lower {setting(rule.confidence)} bound 0% {'>=' if self.success_ok else '<'} " \
                f"{setting(rule.min_success)}"
        if rule.max_collisions is not None:
            s += f", collision runs {self.collisions} {'<=' if self.collisions_ok else '>'} {rule.max_collisions}"
        if self.refused_runs:
            s += f"; left out: {self.refused_text()}"
        return s

    def line(self, rule: GateRule) -> str:
        return f"{self.label}: {self.evidence(rule)}"

    def to_json(self, rule: GateRule) -> dict[str, Any]:
        return {"experiment": self.experiment, "config": self.config_key, "navigator": self.navigator,
                "fault": self.fault, "runs": self.runs, "successes": self.successes,
                "success_rate": self.successes / self.runs if self.runs else None, "lower_bound": self.lower,
                "collisions": self.collisions, "passed": self.passed, "evidence": self.evidence(rule),
                "refused_maps": len(self.refused_maps), "refused_map_indices": list(self.refused_maps),
                "refused_runs": self.refused_runs, "refused_reason": self.refused_reason,
                "worlds": [{"world": f"{w.classname}/m{w.map_index}", "map_index": w.map_index, "runs": len(w.runs),
                            "successes": w.successes, "failed": w.failed} for w in self.worlds]}


@dataclass(frozen=True)
class GateResult:
    """The gate over a campaign: one :class:`ConfigResult` per gated configuration."""

    campaign: str
    directory: str
    rule: GateRule
    recorded: int
    planned: int
    configs: tuple[ConfigResult, ...]
    #: the campaign's robots, (name, digest); several: each configuration's navigator is navigator@robot
    robots: tuple[tuple[str, str], ...] = ()

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.configs)

    @property
    def failing(self) -> list[ConfigResult]:
        return [c for c in self.configs if not c.passed]

    def summary(self) -> str:
        """One line: passed or failed, how many configurations, the bar, the runs recorded."""
        n, bad = len(self.configs), len(self.failing)
        if not bad:
            head = "gate passed: the 1 configuration meets" if n == 1 else f"gate passed: all {n} configurations meet"
        else:
            head = f"gate FAILED: {bad} of {n} configuration{'s' if n != 1 else ''} below"
        tail = f"{self.recorded}/{self.planned} runs recorded"
        if self.recorded < self.planned:
            tail += f", {self.planned - self.recorded} pending"
        refused = sum(len(c.refused_maps) for c in self.configs)
        if refused:
            tail += (f"; {refused} map{'s' if refused != 1 else ''} refused by the world generator, left out"
                     f" ({sum(c.no_generated_map for c in self.configs)} configuration(s) without a generated map)")
        return f"{head} the bar ({self.rule.text()}); campaign {self.campaign}: {tail}"

    def to_json(self) -> dict[str, Any]:
        return {"campaign": self.campaign, "passed": self.passed, "min_success": self.rule.min_success,
                "confidence": self.rule.confidence, "max_collisions": self.rule.max_collisions,
                "recorded": self.recorded, "planned": self.planned,
                "robots": [{"name": n, "digest": d} for n, d in self.robots],
                "configurations": [c.to_json(self.rule) for c in self.configs]}


def _parse_run_id(rid: str) -> tuple[str, str, int, str, str] | None:
    """``experiment/config/m<k>/r<j>/navigator/fault`` -> (experiment, config, k, navigator, fault)."""
    parts = rid.split("/")
    if len(parts) < 6 or not parts[-4].startswith("m") or not parts[-4][1:].isdigit():
        return None
    return parts[0], "/".join(parts[1:-4]), int(parts[-4][1:]), parts[-2], parts[-1]


def _check_names(kind: str, asked: tuple[str, ...] | None, known: list[str]) -> None:
    for name in asked or ():
        if name not in known:
            raise SpecError(kind, name, f"one of the campaign's {kind}s {known}")


def gate(directory: str | Path, rule: GateRule, *, navigators: tuple[str, ...] | None = None,
         faults: tuple[str, ...] | None = None) -> GateResult:
    """Gate the campaign in ``directory`` (read only). ``navigators``: those gated (default
    all); ``faults``: those gated, ``"nominal"`` for the nominal stack (default nominal only).

    StoreError for a directory that holds no campaign or no recorded run; SpecError for a
    navigator or fault the campaign does not have."""
    root = Path(directory)
    with Store.open(root) as store:
        spec = store.spec
        recorded, planned = store.progress()
        planned_ids = store.planned_ids()
        records = with_variants(spec, store.records()) if recorded else []
        recorded_at = _recorded_at(store) if recorded else {}
    if not recorded:
        raise StoreError(f"campaign={str(root)!r} is invalid: expected a campaign with recorded runs (it has "
                         f"none of its {planned} planned runs); run it first with `navstress campaign run`")
    nav_names = variants(spec)  # several robots: navigator@robot (a navigator's name: each of its robots)
    plain = [n.name for n in spec.navigators if n.name not in nav_names]
    fault_names = list(dict.fromkeys(fault_name(f) for e in spec.experiments for f in spec.faults_of(e)))
    _check_names("navigator", navigators, nav_names + plain)
    _check_names("fault", faults, fault_names)
    navs = {v for v in nav_names if not navigators or any(v == n or v.startswith(n + "@") for n in navigators)}
    fset = set(faults or (NOMINAL,))

    Key = tuple[str, str, str, str]  # experiment, config, navigator, fault
    worlds: dict[Key, dict[int, list[RunEvidence]]] = {}
    for rid in planned_ids:
        p = _parse_run_id(rid)
        if p is not None and p[3] in navs and p[4] in fset:
            worlds.setdefault((p[0], p[1], p[3], p[4]), {}).setdefault(p[2], [])
    for r in records:
        k = (r.experiment, config_key(r), r.navigator, fault_name(r.fault))
        if k[2] in navs and k[3] in fset:
            worlds.setdefault(k, {}).setdefault(r.map_index, []).append(_evidence(r, root, recorded_at.get(r.run_id)))
    if not worlds:  # a gate over nothing would pass: say what there is to gate instead
        ran = ", ".join(fault_names)
        raise SpecError("--fault", ",".join(sorted(fset)), f"a stack the campaign ran (its faults: {ran})",
                        f"gate them by name, e.g. --fault {fault_names[0]}" if fault_names else None)
    configs = tuple(_judge(k, by_map, rule) for k, by_map in worlds.items())
    return GateResult(spec.name, str(root), rule, recorded, planned, configs,
                      tuple((r.name, r.digest) for r in spec.all_robots()))


def _recorded_at(store: Store) -> dict[str, float]:
    """When each run was recorded (seconds since the epoch, the store's ``runs.recorded_at``); a
    run whose time is not a usable number is left out."""
    out: dict[str, float] = {}
    for rid, at in store.con.execute("SELECT run_id, recorded_at FROM runs"):
        t = _seconds(at)
        if t > 0.0:
            out[str(rid)] = t
    return out


#: Seconds past this (about 31,700 years) are no run's time nor date: a damaged value.
MAX_SECONDS = 1e12


def _seconds(v: Any) -> float:
    """``v`` as a duration or time in seconds: a number in [0, :data:`MAX_SECONDS`], else 0 (a
    damaged or missing value never makes a NaN, negative or overflowing time in the JUnit file)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return 0.0
    try:
        f = float(v)
    except OverflowError:  # an integer too large for a float
        return 0.0
    return f if 0.0 <= f <= MAX_SECONDS else 0.0


def _evidence(r: RunRecord, root: Path, recorded_at: float | None = None) -> RunEvidence:
    trace = None
    if r.trace:
        t = Path(r.trace)
        trace = str(t if t.is_absolute() else root / t)
    wall = _seconds(r.wall_s)
    started = recorded_at - wall if recorded_at is not None and recorded_at - wall > 0.0 else None
    return RunEvidence(r.run_id, r.outcome, r.reason, r.map_seed, r.run_seed, trace, wall, _seconds(r.duration_s),
                       started, ungenerated(r))


def _judge(k: tuple[str, str, str, str], by_map_all: dict[int, list[RunEvidence]], rule: GateRule) -> ConfigResult:
    refused = {m: rs for m, rs in by_map_all.items() if any(r.refused for r in rs)}
    by_map = {m: rs for m, rs in by_map_all.items() if m not in refused}
    runs = [r for m in sorted(by_map) for r in by_map[m]]
    gone = [r for m in sorted(refused) for r in refused[m] if r.refused]
    first = min((r for r in refused[min(refused)] if r.refused), key=lambda r: r.run_id).reason if refused else None
    n, s = len(runs), sum(r.outcome == SUCCESS for r in runs)
    col = sum(r.outcome == COLLISION for r in runs)
    lo = lower_bound(s, n, rule.confidence)
    blind = n == 0 and bool(gone)  # nothing ran on a generated map: nothing proves the bar
    success_ok = lo >= rule.min_success and not blind
    collisions_ok = rule.max_collisions is None or col <= rule.max_collisions
    apart = () if blind else tuple(WorldCase(k[0], k[1], m, k[2], k[3], tuple(refused[m])) for m in sorted(refused))
    more: dict[str, Any] = dict(refused_maps=tuple(sorted(refused)), refused_runs=len(gone), refused_reason=first,
                                refused_worlds=apart)
    cfg = ConfigResult(k[0], k[1], k[2], k[3], n, s, col, lo, success_ok, collisions_ok, **more)
    evidence = cfg.line(rule)
    no_failed_run = all(r.outcome == SUCCESS for r in runs)
    cases = []
    if blind:  # each refused map a failed case: the generator's reason is why nothing ran
        by_map = {**by_map, **refused}
    for m in sorted(by_map):
        if m in refused:
            told = reason_line(next(r.reason for r in refused[m] if r.refused), MAX_REASON_CHARS * 2)
            cases.append(WorldCase(k[0], k[1], m, k[2], k[3], tuple(refused[m]), True,
                                   f"the world generator refused this map: {told}; configuration {evidence}"))
            continue
        w = WorldCase(k[0], k[1], m, k[2], k[3], tuple(by_map[m]))
        why = []
        if not success_ok and (no_failed_run or w.failed_runs()):
            why.append(f"success {w.successes}/{len(w.runs)} on this world" if w.runs else "no run recorded on "
                       "this world")
            if no_failed_run:
                why.append("not enough runs to prove the bar")
        if not collisions_ok and any(r.outcome == COLLISION for r in w.runs):
            why.append(f"{sum(r.outcome == COLLISION for r in w.runs)} collision run(s) on this world")
        if why:
            w = replace(w, failed=True, reason=f"{'; '.join(why)}; configuration {evidence}")
        cases.append(w)
    return ConfigResult(k[0], k[1], k[2], k[3], n, s, col, lo, success_ok, collisions_ok, tuple(cases), **more)


# ---- JUnit XML -------------------------------------------------------------------------------


#: The JUnit file's timestamps: ISO 8601, UTC, to the second, no zone (Ant's schema allows none).
TIMESTAMP_FORMAT = "%Y-%m-%dT%H:%M:%S"


def junit_xml(result: GateResult, *, hostname: str | None = None, now: float | None = None) -> str:
    """The JUnit XML of ``result``, valid against both schemas CI readers hold JUnit files to
    (Ant's JUnit.xsd and Jenkins' junit-10.xsd): one ``testsuite`` per gated configuration, one
    ``testcase`` per world (classname ``experiment/config``, name ``m<k>/navigator/fault``).

    - a case's ``time`` is the wall time of the world's recorded runs, summed (seconds, to the
      millisecond); a suite's is the sum of its cases'; its ``timestamp`` is when its first run
      started (UTC; ``now``, default the gate's time, for a configuration without a recorded run);
      ``hostname`` the host the gate ran on (default this one); ``id`` its index, ``package``
      ``navstress.<campaign>``; its properties the campaign, directory, bar, evidence, verdict and
      the simulated seconds of its runs;
    - a failed case's ``failure`` carries the reason (message) and, in its text, each failed run:
      run id, outcome, reason, seeds, simulated and wall seconds, trace path and the command that
      replays it; the failed runs a passing world's bar tolerated are in its suite's ``system-out``.

    The root ``testsuites`` element has no attributes: Ant's schema allows none (readers sum the
    suites)."""
    rule = result.rule
    host = _token(hostname if hostname is not None else socket.gethostname(), "localhost")
    gate_time = time.time() if now is None else now
    package = _token(f"navstress.{result.campaign}", "navstress")
    top = ET.Element("testsuites")
    for i, c in enumerate(result.configs):
        starts = [t for w in c.worlds for r in w.runs if r.started is not None and (t := _seconds(r.started)) > 0.0]
        sim = sum(_seconds(r.sim_s) for w in c.worlds for r in w.runs)
        suite = ET.SubElement(top, "testsuite", {
            "name": _token(c.label, "configuration"), "tests": str(len(c.worlds)),
            "failures": str(sum(w.failed for w in c.worlds)), "errors": "0",
            "time": _ms(sum(w.wall_ms for w in c.worlds)), "timestamp": _timestamp(min(starts, default=gate_time),
                                                                                  gate_time),
            "hostname": host, "id": str(i), "package": package})
        props = ET.SubElement(suite, "properties")
        for name, value in (("campaign", result.campaign), ("directory", result.directory), ("bar", rule.text()),
                            ("evidence", c.evidence(rule)), ("passed", str(c.passed).lower()),
                            ("simulated_s", f"{sim:.3f}"), ("refused_maps", str(len(c.refused_maps)))):
            ET.SubElement(props, "property", name=name, value=value)
        tolerated = []
        for w in c.worlds:
            case = ET.SubElement(suite, "testcase", classname=_token(w.classname, "-"), name=_token(w.name, "-"),
                                 time=_ms(w.wall_ms))
            if w.failed:
                f = ET.SubElement(case, "failure", message=w.reason, type="GateFailure")
                f.text = _runs_text(w, result.directory, only_failed=True)
            elif w.failed_runs():
                tolerated.append(f"{w.classname}/{w.name}: tolerated by the bar:\n"
                                 + _runs_text(w, result.directory, only_failed=True))
        for w in c.refused_worlds:
            tolerated.append(f"{w.classname}/{w.name}: refused by the world generator, left out of the gate:\n"
                             + _runs_text(w, result.directory, only_failed=True))
        ET.SubElement(suite, "system-out").text = "\n".join(tolerated)
        ET.SubElement(suite, "system-err").text = ""
    ET.indent(top)
    return _xml_safe(ET.tostring(top, encoding="unicode", xml_declaration=True)) + "\n"


def _token(text: str, empty: str) -> str:
    """``text`` as an XML Schema token (no leading, trailing or repeated white space, no line
    breaks or tabs: what the schemas' name attributes hold); ``empty`` when nothing is left."""
    return " ".join(_xml_safe(str(text)).split()) or empty


def _ms(ms: int) -> str:
    """Whole milliseconds as the schemas' decimal seconds: ``12.345``."""
    return f"{ms // 1000}.{ms % 1000:03d}"


def _timestamp(t: float, fallback: float) -> str:
    """``t`` (seconds since the epoch) in UTC as :data:`TIMESTAMP_FORMAT` (``fallback`` when it
    is no date with a four-digit year)."""
    for v in (t, fallback, 0.0):
        try:
            d = datetime.fromtimestamp(v, timezone.utc)
        except (OverflowError, OSError, ValueError):
            continue
        if 1970 <= d.year <= 9999:
            return d.strftime(TIMESTAMP_FORMAT)
    return "1970-01-01T00:00:00"


def _runs_text(w: WorldCase, directory: str, *, only_failed: bool) -> str:
    runs = w.failed_runs() if only_failed else list(w.runs)
    if not runs:
        return f"{len(w.runs)} run(s), all successes"
    lines = []
    for r in runs:
        lines.append(f"{r.run_id}: {r.outcome} ({r.reason}); map_seed={r.map_seed} run_seed={r.run_seed}; "
                     f"simulated {r.sim_s:.1f} s, wall {r.wall_s:.1f} s; "
                     f"trace: {r.trace or '(none)'}; replay: navstress replay {directory} {r.run_id}")
    return "\n".join(lines)


def _xml_safe(text: str) -> str:
    """``text`` without the characters XML 1.0 cannot hold (control characters become escapes)."""
    return "".join(c if c in "\t\n\r" or (" " <= c <= "\ud7ff") or ("\ue000" <= c <= "\ufffd")
                   or c >= "\U00010000" else c.encode("unicode_escape").decode("ascii") for c in text)


def write_junit(result: GateResult, path: str | Path) -> Path:
    """Write :func:`junit_xml` of ``result`` to ``path`` atomically; returns the path."""
    _files.write_atomic(path, junit_xml(result))
    return Path(path)


__all__ = ["GateResult", "GateRule", "ConfigResult", "RunEvidence", "TIMESTAMP_FORMAT", "WorldCase",
           "check_confidence", "gate", "junit_xml", "lower_bound", "write_junit"]
