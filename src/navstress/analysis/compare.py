"""Paired A/B comparison of two navigators, two faults, or two versions of a stack.

Runs are paired by (experiment, configuration, map index, run index): the same world (map
seed) and the same run seed, so both sides meet the same sensor noise, timing jitter and
navigator seed (common random numbers). A pair whose seeds differ is an error, not a pair.
Two campaign directories may be compared (version 1 of a stack against version 2) when they
were made from the same spec and seed: the worlds, seeds, timeout, goal tolerance and
simulation settings of every paired configuration must match.

A pair where either side's map was refused by the world generator
(:func:`navstress.run.record.ungenerated`: nothing ran there) is no comparison of the stacks: it
is left out and counted (``refused_pairs``, with the first reason, in the notes and the JSON).

Per configuration and overall, for the success (outcome ``success``) of each run:

- the success rates of A and B and the difference ``B - A`` with **Newcombe's hybrid score
  interval for paired proportions** (Newcombe 1998, Statistics in Medicine 17:2635, method
  10: the two Wilson intervals combined with the pairs' phi correlation);
- the **exact McNemar test**: under "A and B succeed equally often", each discordant pair
  (one side succeeds, the other fails) is B's win with probability 1/2, so the number of B's
  wins is Binomial(discordant, 1/2) (``scipy.stats.binomtest``, two-sided);
- p-values of the configurations adjusted with **Holm's step-down** method (family-wise error
  rate under any dependence between configurations); the overall test is one more, unadjusted;
- the change in duration: mean paired difference of simulated duration over the pairs where
  both runs succeeded (a failed run's duration is its time to failure), with a t interval;
- the change in collisions: runs with a collision on each side, collision counts, and the
  mean paired difference of collisions per run;
- how much pairing gains: the width of the unpaired interval (Newcombe's hybrid score
  interval for independent proportions, the same Wilson ingredients with the correlation left
  out) beside the paired one.

    >>> round(mcnemar_exact(0, 0), 3), round(mcnemar_exact(1, 9), 4)
    (1.0, 0.0215)
    >>> holm([0.01, 0.04, 0.03])
    [0.03, 0.06, 0.06]
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scipy import stats as _st

from navstress._percent import percent, setting
from navstress.analysis.fault_power import collided
from navstress.analysis.stats import (NOMINAL, _check, config_key, fault_name, params_text, reason_line, variants,
                                      wilson, with_variants)
from navstress.campaign.spec import CampaignSpec
from navstress.campaign.store import Store
from navstress.errors import SpecError, StoreError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated

#: (experiment, configuration key, map index, run index): what makes two runs a pair.
PairKey = tuple[str, str, int, int]


@dataclass(frozen=True)
class Arm:
    """One side of a comparison: a navigator and a fault (``"nominal"`` for none)."""

    navigator: str
    fault: str = NOMINAL

    @property
    def label(self) -> str:
        return self.navigator if self.fault == NOMINAL else f"{self.navigator}:{self.fault}"


def parse_arm(text: str, flag: str = "--a") -> Arm:
    """``NAV`` or ``NAV:FAULT`` (``NAV:nominal`` is ``NAV``); in a campaign of several robots NAV
    is ``navigator@robot``; SpecError naming ``flag`` otherwise."""
    expected = "NAV or NAV:FAULT, e.g. reference-v1 or reference-v1:small-footprint (or reference-v1@jackal)"
    parts = text.split(":")
    if len(parts) > 2 or not all(p.strip() == p and p for p in parts):
        raise SpecError(flag, text, expected, "list navigators and faults with `navstress campaign status DIR`")
    return Arm(parts[0], parts[1] if len(parts) == 2 else NOMINAL)


# ---- paired statistics ----------------------------------------------------------------


def mcnemar_exact(a_only: int, b_only: int) -> float:
    """Two-sided exact McNemar p-value from the discordant pairs: ``a_only`` pairs where only A
    succeeded, ``b_only`` where only B did (1.0 without discordant pairs)."""
    if a_only < 0 or b_only < 0:
        raise SpecError("discordant pairs", (a_only, b_only), "two counts >= 0")
    m = a_only + b_only
    if m == 0:
        return 1.0
    return min(1.0, float(_st.binomtest(b_only, m, 0.5).pvalue))


def _phi(both: int, a_only: int, b_only: int, neither: int) -> float:
    """Newcombe's continuity-corrected phi of the 2x2 table of pairs (0 with an empty margin)."""
    den = (both + a_only) * (b_only + neither) * (both + b_only) * (a_only + neither)
    if den == 0:
        return 0.0
    n = both + a_only + b_only + neither
    num = float(both * neither - a_only * b_only)
    if num > n / 2:
        num -= n / 2
    elif num > 0:
        num = 0.0
    return float(num / math.sqrt(den))


def _square_and_add(pa: float, la: float, ua: float, pb: float, lb: float, ub: float,
                    phi: float) -> tuple[float, float]:
    """Newcombe's square-and-add limits of ``pb - pa`` from the Wilson limits of each."""
    d = pb - pa
    lo = d - math.sqrt(max(0.0, (pb - lb) ** 2 - 2 * phi * (pb - lb) * (ua - pa) + (ua - pa) ** 2))
    hi = d + math.sqrt(max(0.0, (ub - pb) ** 2 - 2 * phi * (ub - pb) * (pa - la) + (pa - la) ** 2))
    return max(-1.0, lo), min(1.0, hi)


def newcombe_paired(both: int, a_only: int, b_only: int, neither: int,
                    confidence: float = 0.95) -> tuple[float, float]:
    """Interval of ``p_B - p_A`` from paired outcomes (Newcombe 1998, method 10); (-1, 1) without pairs.

    ``both``: pairs where both succeeded, ``a_only``/``b_only``: only A/only B succeeded,
    ``neither``: both failed."""
    n = both + a_only + b_only + neither
    _check(both + a_only, n, confidence)
    _check(both + b_only, n, confidence)
    if min(both, a_only, b_only, neither) < 0:
        raise SpecError("pairs", (both, a_only, b_only, neither), "four counts >= 0")
    if n == 0:
        return -1.0, 1.0
    sa, sb = both + a_only, both + b_only
    la, ua = wilson(sa, n, confidence)
    lb, ub = wilson(sb, n, confidence)
    return _square_and_add(sa / n, la, ua, sb / n, lb, ub, _phi(both, a_only, b_only, neither))


def newcombe_unpaired(sa: int, na: int, sb: int, nb: int, confidence: float = 0.95) -> tuple[float, float]:
    """Interval of ``p_B - p_A`` as if A's and B's runs were independent samples (Newcombe
    1998, Statistics in Medicine 17:873, method 10); (-1, 1) when a side has no run."""
    _check(sa, na, confidence)
    _check(sb, nb, confidence)
    if na == 0 or nb == 0:
        return -1.0, 1.0
    la, ua = wilson(sa, na, confidence)
    lb, ub = wilson(sb, nb, confidence)
    return _square_and_add(sa / na, la, ua, sb / nb, lb, ub, 0.0)


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (same order as given): the i-th smallest times
    ``m - i`` (i from 0), made non-decreasing along that order, capped at 1."""
    m = len(pvalues)
    order = sorted(range(m), key=lambda i: pvalues[i])
    out = [1.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * float(pvalues[i])))
        out[i] = running
    return out


@dataclass(frozen=True)
class MeanDiff:
    """A mean of paired differences ``B - A`` with its t interval (None with fewer than 2 pairs)."""

    n: int
    mean_a: float | None
    mean_b: float | None
    diff: float | None
    ci: tuple[float, float] | None

    def to_json(self) -> dict[str, Any]:
        return {"n": self.n, "mean_a": self.mean_a, "mean_b": self.mean_b, "diff": self.diff,
                "ci": list(self.ci) if self.ci else None}


def mean_diff(a: Sequence[float], b: Sequence[float], confidence: float = 0.95) -> MeanDiff:
    """The :class:`MeanDiff` of paired values (non-finite pairs left out)."""
    pairs = [(x, y) for x, y in zip(a, b) if math.isfinite(x) and math.isfinite(y)]
    if not pairs:
        return MeanDiff(0, None, None, None, None)
    d = [y - x for x, y in pairs]
    mean = statistics.fmean(d)
    ci: tuple[float, float] | None = None
    if len(d) >= 2:
        half = float(_st.t.ppf(0.5 + confidence / 2, len(d) - 1)) * statistics.stdev(d) / math.sqrt(len(d))
        ci = (mean - half, mean + half)
    return MeanDiff(len(d), statistics.fmean(x for x, _ in pairs), statistics.fmean(y for _, y in pairs), mean, ci)


# ---- the comparison -------------------------------------------------------------------


@dataclass(frozen=True)
class PairedStats:
    """A and B on a set of pairs (one configuration, or all of them)."""

    experiment: str  # "" for the overall figures
    config_key: str  # "all" for the overall figures
    params: dict[str, Any]
    pairs: int
    both: int  # pairs where both succeeded
    a_only: int
    b_only: int
    neither: int
    ci: tuple[float, float]
    ci_unpaired: tuple[float, float]
    p_value: float
    duration_s: MeanDiff
    collided_a: int
    collided_b: int
    collisions_a: int
    collisions_b: int
    collisions_diff: float | None  # mean paired difference of collisions per run (B - A)
    p_collision: float  # exact McNemar on "the run had a collision"
    maps: tuple[int, ...] = ()
    p_adjusted: float | None = None  # Holm; None for the overall figures

    @property
    def label(self) -> str:
        return "all configurations" if not self.experiment else f"{self.experiment} {params_text(self.params)}"

    @property
    def rate_a(self) -> float:
        return (self.both + self.a_only) / self.pairs

    @property
    def rate_b(self) -> float:
        return (self.both + self.b_only) / self.pairs

    @property
    def diff(self) -> float:
        """Success rate of B minus A."""
        return (self.b_only - self.a_only) / self.pairs

    @property
    def width(self) -> float:
        return self.ci[1] - self.ci[0]

    @property
    def width_unpaired(self) -> float:
        return self.ci_unpaired[1] - self.ci_unpaired[0]

    @property
    def width_ratio(self) -> float:
        """Paired interval width over the unpaired one (below 1: pairing made it tighter)."""
        return self.width / self.width_unpaired

    @property
    def var_paired(self) -> float:
        """Plug-in variance of one pair's difference of successes, B - A."""
        return (self.a_only + self.b_only) / self.pairs - self.diff ** 2

    @property
    def var_unpaired(self) -> float:
        """Plug-in variance of the same difference with A and B run independently."""
        return self.rate_a * (1 - self.rate_a) + self.rate_b * (1 - self.rate_b)

    def to_json(self) -> dict[str, Any]:
        # the overall figures name no configuration (keys are never empty: docs/campaigns.md)
        keys = {"experiment": self.experiment, "config": self.config_key} if self.experiment else {}
        return {**keys, "params": self.params, "label": self.label, "pairs": self.pairs, "maps": list(self.maps),
                "table": {"both_succeed": self.both, "only_a_succeeds": self.a_only,
                          "only_b_succeeds": self.b_only, "both_fail": self.neither},
                "success_rate_a": self.rate_a, "success_rate_b": self.rate_b, "diff": self.diff,
                "ci": list(self.ci), "ci_unpaired": list(self.ci_unpaired), "width": self.width,
                "width_unpaired": self.width_unpaired, "width_ratio": self.width_ratio,
                "p_value": self.p_value, "p_holm": self.p_adjusted,
                "duration_s": self.duration_s.to_json(),
                "collisions": {"runs_with_collision_a": self.collided_a, "runs_with_collision_b": self.collided_b,
                               "total_a": self.collisions_a, "total_b": self.collisions_b,
                               "mean_diff_per_run": self.collisions_diff, "p_value": self.p_collision},
                "variance_per_pair": {"paired": self.var_paired, "unpaired": self.var_unpaired}}


def paired_stats(experiment: str, key: str, params: dict[str, Any], pairs: list[tuple[RunRecord, RunRecord]],
                 confidence: float = 0.95) -> PairedStats:
    """The :class:`PairedStats` of ``pairs`` of (A's record, B's record); at least one pair."""
    ok = Outcome.SUCCESS.value
    sa = [r.outcome == ok for r, _ in pairs]
    sb = [r.outcome == ok for _, r in pairs]
    both = sum(x and y for x, y in zip(sa, sb))
    a_only = sum(x and not y for x, y in zip(sa, sb))
    b_only = sum(y and not x for x, y in zip(sa, sb))
    neither = len(pairs) - both - a_only - b_only
    n = len(pairs)
    dur = [(ra.duration_s, rb.duration_s) for (ra, rb), x, y in zip(pairs, sa, sb) if x and y]
    return PairedStats(
        experiment=experiment, config_key=key, params=dict(params), pairs=n, both=both, a_only=a_only,
        b_only=b_only, neither=neither, ci=newcombe_paired(both, a_only, b_only, neither, confidence),
        ci_unpaired=newcombe_unpaired(both + a_only, n, both + b_only, n, confidence),
        p_value=mcnemar_exact(a_only, b_only),
        duration_s=mean_diff([x for x, _ in dur], [y for _, y in dur], confidence),
        collided_a=sum(collided(ra) for ra, _ in pairs), collided_b=sum(collided(rb) for _, rb in pairs),
        collisions_a=sum(ra.collisions for ra, _ in pairs), collisions_b=sum(rb.collisions for _, rb in pairs),
        collisions_diff=statistics.fmean(rb.collisions - ra.collisions for ra, rb in pairs),
        p_collision=mcnemar_exact(sum(collided(ra) and not collided(rb) for ra, rb in pairs),
                                  sum(collided(rb) and not collided(ra) for ra, rb in pairs)),
        maps=tuple(sorted({ra.map_index for ra, _ in pairs})))


@dataclass
class Comparison:
    """Everything ``navstress compare`` prints (see module doc)."""

    a: Arm
    b: Arm
    dir_a: Path
    dir_b: Path
    confidence: float
    alpha: float
    configs: list[PairedStats]
    overall: PairedStats
    unpaired_a: int  # A's runs without a B partner (left out)
    unpaired_b: int
    notes: list[str] = field(default_factory=list)
    #: pairs left out because either side's map was refused by the world generator, and the first reason
    refused_pairs: int = 0
    refused_reason: str | None = None
    #: the robot of each side's runs (name and description digest; several: joined by ", ")
    robot_a: str = ""
    robot_b: str = ""

    @property
    def significant(self) -> list[PairedStats]:
        """Configurations whose Holm-adjusted p-value is at most ``alpha``, most significant first."""
        sig = [c for c in self.configs if c.p_adjusted is not None and c.p_adjusted <= self.alpha]
        return sorted(sig, key=lambda c: (c.p_adjusted or 0.0, -abs(c.diff)))

    @property
    def width_ratio(self) -> float:
        """Paired interval widths over unpaired ones, summed over the configurations."""
        return sum(c.width for c in self.configs) / sum(c.width_unpaired for c in self.configs)

    @property
    def runs_factor(self) -> float | None:
        """How many times the runs an unpaired design (independent seeds, the configurations as
        strata) would need for the overall difference's variance: the ratio of the plug-in
        variances; None when both are 0 (no run differs), inf when only the paired one is."""
        w = [(c.pairs, c.var_paired, c.var_unpaired) for c in self.configs]
        n = sum(k for k, _, _ in w)
        paired = sum(k * v for k, v, _ in w) / n ** 2
        unpaired = sum(k * u for k, _, u in w) / n ** 2
        if paired <= 1e-15:
            return None if unpaired <= 1e-15 else math.inf
        return unpaired / paired

    def headline(self) -> str:
        """The one line a person reads first."""
        sig = self.significant
        pct = setting(self.alpha)
        m = len(self.configs)
        if not sig:
            o = self.overall
            return (f"no configuration differs at the {pct} level after Holm correction ({m} compared); "
                    f"overall success {percent(o.rate_a)} -> {percent(o.rate_b)}, exact McNemar p = {_p(o.p_value)}")
        top = sig[0]
        word = "worse" if top.diff < 0 else "better"
        line = (f"B is {word} than A on {top.label}: success {percent(top.rate_a)} -> {percent(top.rate_b)}, "
                f"p = {_p(top.p_adjusted or 0.0)} (exact McNemar, Holm over {m})")
        worse = sum(c.diff < 0 for c in sig[1:])
        better = sum(c.diff > 0 for c in sig[1:])
        if worse or better:
            line += f"; also worse on {worse} and better on {better} more"
        return line

    def collision_line(self) -> str:
        """The runs with a collision on each side, overall, with their exact McNemar p-value."""
        o = self.overall
        return (f"runs with a collision: A {o.collided_a}, B {o.collided_b} of {o.pairs} pairs, "
                f"exact McNemar p = {_p(o.p_collision)}")

    def to_json(self) -> dict[str, Any]:
        return {"a": {"navigator": self.a.navigator, "fault": self.a.fault, "campaign": str(self.dir_a),
                      "robot": self.robot_a},
                "b": {"navigator": self.b.navigator, "fault": self.b.fault, "campaign": str(self.dir_b),
                      "robot": self.robot_b},
                "confidence": self.confidence, "alpha": self.alpha,
                "interval": "Newcombe hybrid score, paired (1998, method 10)",
                "interval_unpaired": "Newcombe hybrid score, independent (1998, method 10)",
                "test": "exact McNemar (two-sided binomial test on the discordant pairs)",
                "correction": "Holm", "headline": self.headline(),
                "collision_line": self.collision_line(),
                "significant": [c.label for c in self.significant],
                "width_ratio": self.width_ratio, "runs_factor": self.runs_factor, "unpaired_runs": {"a": self.unpaired_a, "b": self.unpaired_b},
                "refused_pairs": self.refused_pairs, "refused_reason": self.refused_reason,
                "configurations": [c.to_json() for c in self.configs], "overall": self.overall.to_json(),
                "notes": list(self.notes)}


def _p(p: float) -> str:
    return f"{p:.2g}" if p < 0.001 else f"{p:.3f}"


# ---- reading the stores ---------------------------------------------------------------


def _arms(spec: CampaignSpec) -> tuple[list[str], list[str]]:
    navs = variants(spec)  # a campaign of several robots: navigator@robot
    faults: list[str] = []
    for exp in spec.experiments:
        for f in spec.faults_of(exp):
            if fault_name(f) not in faults:
                faults.append(fault_name(f))
    return navs, faults


def _check_arm(spec: CampaignSpec, arm: Arm, flag: str, where: Path) -> None:
    navs, faults = _arms(spec)
    if arm.navigator not in navs:
        raise SpecError(flag, arm.label, f"a navigator of campaign {str(where)!r}: one of {navs}",
                        "list them with `navstress campaign status DIR`")
    if arm.fault not in faults:
        raise SpecError(flag, arm.label, f"a fault of campaign {str(where)!r}: one of {faults} after the ':'",
                        "write NAV for nominal runs")


def _check_same_design(sa: CampaignSpec, sb: CampaignSpec, da: Path, db: Path,
                       keys: set[tuple[str, str]]) -> None:
    """StoreError unless the two specs give the paired configurations the same worlds and settings."""
    fix = "compare campaigns made from the same spec and seed (only the navigators may differ)"
    for name in ("seed", "timeout_s", "goal_tolerance_m", "sim"):
        va, vb = getattr(sa, name), getattr(sb, name)
        if va != vb:
            raise StoreError(f"{name}={vb!r} is invalid: expected the same {name} as campaign {str(da)!r} "
                             f"({va!r}) in campaign {str(db)!r}; {fix}")
    worlds_a = {(e.name, c.key): c.world for e in sa.experiments for c in e.configurations(sa.world)}
    worlds_b = {(e.name, c.key): c.world for e in sb.experiments for c in e.configurations(sb.world)}
    for k in sorted(keys):
        if k in worlds_a and k in worlds_b and worlds_a[k] != worlds_b[k]:
            raise StoreError(f"configuration={'/'.join(k)!r} is invalid: expected the same world spec in "
                             f"campaigns {str(da)!r} and {str(db)!r}; {fix}")


def first_navigator(directory: str | Path) -> Arm:
    """The nominal runs of the first navigator of the campaign in ``directory`` (on its first
    robot, in a campaign of several)."""
    with Store.open(directory) as store:
        return Arm(variants(store.spec)[0])


def _index(records: list[RunRecord], arm: Arm) -> dict[PairKey, RunRecord]:
    return {(r.experiment, config_key(r), r.map_index, r.run_index): r for r in records
            if r.navigator == arm.navigator and fault_name(r.fault) == arm.fault}


def compare(dir_a: str | Path, a: Arm, b: Arm, dir_b: str | Path | None = None, *,
            confidence: float = 0.95, alpha: float = 0.05) -> Comparison:
    """Compare arm ``a`` of campaign ``dir_a`` with arm ``b`` of ``dir_b`` (default: the same
    campaign), run by run (see module doc). Read only; errors are one-line NavstressErrors."""
    if not 0.0 < confidence < 1.0:
        raise SpecError("--confidence", confidence, "a probability in (0, 1), e.g. 0.95")
    if not 0.0 < alpha < 1.0:
        raise SpecError("--alpha", alpha, "a significance level in (0, 1), e.g. 0.05")
    pa = Path(dir_a)
    pb = Path(dir_b) if dir_b is not None else pa
    same = dir_b is None or pa.resolve() == pb.resolve()
    if same and a == b:
        raise SpecError("--b", b.label, f"another navigator or fault than --a ({a.label}) in one campaign",
                        "or give two campaign directories")
    with Store.open(pa) as store:
        spec_a, rec_a = store.spec, with_variants(store.spec, store.records())
    if same:
        spec_b, rec_b = spec_a, rec_a
    else:
        with Store.open(pb) as store:
            spec_b, rec_b = store.spec, with_variants(store.spec, store.records())
    _check_arm(spec_a, a, "--a", pa)
    _check_arm(spec_b, b, "--b", pb)
    for d, recs in ((pa, rec_a), (pb, rec_b)):
        if not recs:
            raise StoreError(f"campaign={str(d)!r} is invalid: expected recorded runs, it has none yet; "
                             "run it with `navstress campaign run SPEC -o DIR`")
    ia, ib = _index(rec_a, a), _index(rec_b, b)
    common = [k for k in ia if k in ib]
    if not common:
        raise StoreError(f"pairs=0 is invalid: expected runs of {a.label} ({len(ia)} recorded) and {b.label} "
                         f"({len(ib)} recorded) on the same maps and run indices; run both on the same "
                         "configurations (same spec), or wait for the campaign to record them")
    if not same:
        _check_same_design(spec_a, spec_b, pa, pb, {(k[0], k[1]) for k in common})
    for k in common:
        ra, rb = ia[k], ib[k]
        for name in ("map_seed", "run_seed"):
            if getattr(ra, name) != getattr(rb, name):
                raise StoreError(f"{name}={getattr(rb, name)} is invalid: expected the same {name} for B as for A "
                                 f"({getattr(ra, name)}) on {k[0]}/{k[1]}/m{k[2]}/r{k[3]}; compare runs of "
                                 "campaigns made from the same spec and seed")
    refused = [k for k in common if ungenerated(ia[k]) or ungenerated(ib[k])]
    why = None
    if refused:
        k0 = min(refused)
        why = reason_line((ia[k0] if ungenerated(ia[k0]) else ib[k0]).reason)
    keys = [k for k in common if not (ungenerated(ia[k]) or ungenerated(ib[k]))]
    if not keys:
        raise StoreError(f"pairs=0 is invalid: expected runs of {a.label} and {b.label} on maps the world generator "
                         f"made; every one of the {len(common)} pairs is on a map it refused (first: {why}); "
                         "fix the world spec or compare other configurations")
    groups: dict[tuple[str, str], list[tuple[RunRecord, RunRecord]]] = {}
    for k in keys:
        groups.setdefault((k[0], k[1]), []).append((ia[k], ib[k]))
    configs = [paired_stats(e, key, ps[0][0].config, ps, confidence) for (e, key), ps in groups.items()]
    adjusted = holm([c.p_value for c in configs])
    configs = [dataclasses.replace(c, p_adjusted=p) for c, p in zip(configs, adjusted)]
    overall = paired_stats("", "all", {}, [p for ps in groups.values() for p in ps], confidence)
    notes = []
    lone_a, lone_b = len(ia) - len(common), len(ib) - len(common)
    if lone_a or lone_b:
        notes.append(f"left out, without a partner: {lone_a} runs of A, {lone_b} of B")
    if refused:
        notes.append(f"left out, on maps the world generator refused: {len(refused)} pair{'s' if len(refused) != 1 else ''}"
                     f" (first: {why})")
    return Comparison(a=a, b=b, dir_a=pa, dir_b=pb, confidence=confidence, alpha=alpha, configs=configs,
                      overall=overall, unpaired_a=lone_a, unpaired_b=lone_b, notes=notes,
                      refused_pairs=len(refused), refused_reason=why, robot_a=_robot(ia.values()),
                      robot_b=_robot(ib.values()))


def _robot(records: Iterable[RunRecord]) -> str:
    """The robot of an arm's runs: ``name (digest)``; several (a navigator named without its robot
    across two campaigns of one robot each cannot mix them: an arm is one campaign's) joined."""
    return ", ".join(dict.fromkeys(f"{r.robot} ({r.robot_digest})" for r in records))
