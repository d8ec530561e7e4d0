"""navstress.sequential against streams of known probability: the stated error rates hold under
optional stopping (the rule's own stopping, by ``should_continue``), a Wilson interval recomputed
after each run does not; the interval's properties; bad rules are one SpecError naming the field.

Streams are drawn with numpy Generators of fixed seeds. The rule's decision depends on (successes,
runs) only, so it is cached per count: the streams are many, the distinct calls few."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import binom

from navstress.analysis.stats import wilson
from navstress.errors import SpecError
from navstress.sequential import (FLAKY_BAND, VERDICTS, AdaptiveRule, check_rule, confidence_sequence, decide,
                                  should_continue, verdict)

STREAMS = 4000
#: the test fails only when the wrong-verdict count is above 1 - confidence with this significance
#: (binomial upper tail): a real excess is caught, chance alone fails one run in 10^4
SLACK = 1e-4


def wrong(v: str, p: float, threshold: float, indifference: float = 0.0) -> bool:
    """Whether verdict ``v`` is false for a stream of success probability ``p`` (with an
    indifference zone, what ``passes`` and ``fails`` claim: ``p >= threshold - indifference``,
    ``p < threshold + indifference``)."""
    return ((v == "passes" and p < threshold - indifference) or (v == "fails" and p >= threshold + indifference)
            or (v == "flaky" and not FLAKY_BAND[0] < p < FLAKY_BAND[1]))


def run_streams(p: float, rule: AdaptiveRule, cont: object, final: object, seed: int) -> tuple[int, list[int]]:
    """Feed ``STREAMS`` Bernoulli(p) streams to a stopping rule; (wrong verdicts, runs per stream)."""
    rng = np.random.default_rng(seed)
    draws = rng.random((STREAMS, rule.max_runs)) < p
    bad = 0
    used = []
    for row in draws:
        s = n = 0
        while cont(s, n):  # type: ignore[operator]
            s += int(row[n])
            n += 1
        bad += wrong(final(s, n), p, rule.threshold, rule.indifference)  # type: ignore[operator]
        used.append(n)
    return bad, used


def cached_rule(rule: AdaptiveRule) -> tuple[object, object]:
    return (functools.lru_cache(None)(lambda s, n: should_continue(s, n, rule)),
            functools.lru_cache(None)(lambda s, n: decide(s, n, rule)))


def wilson_rule(rule: AdaptiveRule) -> tuple[object, object]:
    """The tempting rule: recompute a 95 % Wilson interval after each run, stop at the first verdict."""
    @functools.lru_cache(None)
    def final(s: int, n: int) -> str:
        return "undecided" if n < rule.min_runs else verdict(*wilson(s, n, rule.confidence), rule.threshold)
    return (lambda s, n: n < rule.max_runs and final(s, n) == "undecided"), final


def at_most_alpha(bad: int, alpha: float) -> bool:
    """``bad`` of STREAMS is not significantly above ``alpha`` (binomial tail >= SLACK)."""
    return float(binom.sf(bad - 1, STREAMS, alpha)) >= SLACK


DEFAULT = AdaptiveRule()  # min 3, max 25, threshold 0.8, confidence 0.95


@pytest.mark.parametrize("p", [0.0, 0.05, 0.1, 0.3, 0.5, 0.7, 0.75, 0.79, 0.8, 0.81, 0.85, 0.9, 0.95, 1.0])
def test_wrong_verdicts_at_most_one_minus_confidence(p: float) -> None:
    """Near, at and far from the threshold, inside and outside the flaky band."""
    bad, used = run_streams(p, DEFAULT, *cached_rule(DEFAULT), seed=int(1000 * p) + 1)
    assert at_most_alpha(bad, 1 - DEFAULT.confidence), (p, bad / STREAMS)
    assert all(DEFAULT.min_runs <= n <= DEFAULT.max_runs for n in used)


@pytest.mark.parametrize("rule,p", [(AdaptiveRule(2, 60, 0.5, 0.8), 0.5), (AdaptiveRule(2, 60, 0.5, 0.8), 0.45),
                                    (AdaptiveRule(5, 40, 0.9, 0.9), 0.9), (AdaptiveRule(5, 40, 0.9, 0.9), 0.87),
                                    (AdaptiveRule(1, 80, 0.3, 0.8), 0.25)])
def test_wrong_verdicts_other_rules(rule: AdaptiveRule, p: float) -> None:
    """Other thresholds and confidences (a larger 1 - confidence: the bound is tested where it bites)."""
    bad, _ = run_streams(p, rule, *cached_rule(rule), seed=7)
    assert at_most_alpha(bad, 1 - rule.confidence), (rule, p, bad / STREAMS)


ZONE = AdaptiveRule(1, 25, 0.5, 0.8, indifference=0.25)  # the benchmark's rule, with a larger budget


@pytest.mark.parametrize("p", [0.0, 0.05, 0.1, 0.2, 0.24, 0.25, 0.5, 0.75, 0.76, 0.8, 0.9, 0.95, 1.0])
def test_indifference_zone_wrong_verdicts_at_most_one_minus_confidence(p: float) -> None:
    """With an indifference zone (0.25, 0.75): passes for a world below 0.25, fails for one at or
    above 0.75, or flaky outside the band, at most 20 % of the time; inside the zone either answer
    is right by definition, and the edges of the zone are where the bound bites."""
    bad, used = run_streams(p, ZONE, *cached_rule(ZONE), seed=int(1000 * p) + 5)
    assert at_most_alpha(bad, 1 - ZONE.confidence), (p, bad / STREAMS)
    assert all(1 <= n <= ZONE.max_runs for n in used)


@pytest.mark.parametrize("p", [0.0, 1.0])
def test_indifference_zone_decides_agreeing_streams_in_two_runs(p: float) -> None:
    """What the zone buys: a world that always passes (or always fails) is decided after 2 runs
    (24 without a zone at threshold 0.8, confidence 0.95; 5 at threshold 0.5, confidence 0.8)."""
    _, used = run_streams(p, ZONE, *cached_rule(ZONE), seed=3)
    assert set(used) == {2}
    assert decide(2, 2, ZONE) == "passes" and decide(0, 2, ZONE) == "fails"
    plain = AdaptiveRule(1, 25, 0.5, 0.8)
    assert decide(4, 4, plain) == "undecided" and decide(5, 5, plain) == "passes"


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 60).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))), st.floats(0.3, 0.7),
       st.floats(0.0, 0.2), st.floats(0.5, 0.99))
def test_indifference_verdicts_are_claims_the_interval_proves(sn: tuple[int, int], t: float, d: float,
                                                               c: float) -> None:
    s, n = sn
    rule = AdaptiveRule(1, 100, t, c, indifference=d)
    v = decide(s, n, rule)
    lo, hi = confidence_sequence(s, n, c) if n else (0.0, 1.0)
    assert {"passes": lo >= t - d, "fails": hi < t + d,
            "flaky": FLAKY_BAND[0] < lo and hi < FLAKY_BAND[1]}.get(v, True)
    # a zone only widens what is decided: a verdict without it stands with it
    if decide(s, n, AdaptiveRule(1, 100, t, c)) != "undecided":
        assert v != "undecided"


@pytest.mark.parametrize("p", [0.8, 0.9])
def test_wilson_recomputed_after_each_run_breaks_the_error_rate(p: float) -> None:
    """The same streams, stopped at the first verdict of a recomputed 95 % Wilson interval: wrong
    far more often than 5 % (about 10 % at p = 0.8, 16 % at p = 0.9), the sequence well under."""
    bad_w, _ = run_streams(p, DEFAULT, *wilson_rule(DEFAULT), seed=99)
    bad_cs, _ = run_streams(p, DEFAULT, *cached_rule(DEFAULT), seed=99)
    assert float(binom.sf(bad_w - 1, STREAMS, 0.05)) < 1e-6, bad_w / STREAMS  # significantly above 5 %
    assert bad_w > 4 * max(bad_cs, 1)


def test_confidence_sequence_covers_at_every_run_count_at_once() -> None:
    """P(p outside the interval at some n <= 100) <= 1 - confidence; a recomputed Wilson interval
    misses at some n far more often."""
    p, conf, horizon = 0.7, 0.9, 100
    rng = np.random.default_rng(5)
    cum = np.cumsum(rng.random((STREAMS, horizon)) < p, axis=1)
    cs = functools.lru_cache(None)(lambda s, n: confidence_sequence(s, n, conf))
    wi = functools.lru_cache(None)(lambda s, n: wilson(s, n, conf))
    miss_cs = miss_w = 0
    for row in cum:
        ns = range(1, horizon + 1)
        miss_cs += any(not cs(int(row[n - 1]), n)[0] <= p <= cs(int(row[n - 1]), n)[1] for n in ns)
        miss_w += any(not wi(int(row[n - 1]), n)[0] <= p <= wi(int(row[n - 1]), n)[1] for n in ns)
    assert at_most_alpha(miss_cs, 1 - conf), miss_cs / STREAMS
    assert miss_w > 3 * miss_cs and miss_w / STREAMS > 0.3, (miss_w, miss_cs)


# ---- properties of the interval and the verdict ------------------------------------------------

counts = st.integers(1, 400).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n)))
confidences = st.floats(0.5, 0.999)


@settings(max_examples=150, deadline=None)
@given(counts, confidences)
def test_interval_contains_mle_within_unit(sn: tuple[int, int], conf: float) -> None:
    s, n = sn
    lo, hi = confidence_sequence(s, n, conf)
    assert 0.0 <= lo <= s / n <= hi <= 1.0
    assert lo < hi


@settings(max_examples=100, deadline=None)
@given(counts, st.integers(2, 8), confidences)
def test_interval_shrinks_as_n_grows_at_a_fixed_ratio(sn: tuple[int, int], k: int, conf: float) -> None:
    s, n = sn
    lo, hi = confidence_sequence(s, n, conf)
    lo2, hi2 = confidence_sequence(k * s, k * n, conf)
    assert hi2 - lo2 < hi - lo


@settings(max_examples=100, deadline=None)
@given(counts, confidences)
def test_interval_monotone_in_successes(sn: tuple[int, int], conf: float) -> None:
    s, n = sn
    if s == n:
        s -= 1
    lo, hi = confidence_sequence(s, n, conf)
    lo2, hi2 = confidence_sequence(s + 1, n, conf)
    assert lo2 >= lo and hi2 >= hi and (lo2, hi2) != (lo, hi)


@settings(max_examples=100, deadline=None)
@given(counts, confidences)
def test_interval_wider_with_more_confidence(sn: tuple[int, int], conf: float) -> None:
    s, n = sn
    lo, hi = confidence_sequence(s, n, conf)
    lo2, hi2 = confidence_sequence(s, n, min(conf + 0.0005, 0.9995))
    assert lo2 <= lo and hi2 >= hi


rules = st.builds(lambda lo, extra, t, c: AdaptiveRule(lo, lo + extra, t, c), st.integers(1, 10),
                  st.integers(0, 60), st.floats(0.05, 0.95), st.floats(0.5, 0.99))


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 80).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))), rules)
def test_decide_verdict_should_continue_agree(sn: tuple[int, int], rule: AdaptiveRule) -> None:
    s, n = sn
    d = decide(s, n, rule)
    assert d in VERDICTS
    if n < rule.min_runs:
        assert d == "undecided"
    else:
        lo, hi = confidence_sequence(s, n, rule.confidence)
        assert d == verdict(lo, hi, rule.threshold)
        # each class is a claim the interval proves
        assert {"passes": lo >= rule.threshold, "fails": hi < rule.threshold,
                "flaky": FLAKY_BAND[0] < lo and hi < FLAKY_BAND[1]}.get(d, True)
    assert should_continue(s, n, rule) == (n < rule.max_runs and d == "undecided")


@given(st.floats(0, 1), st.floats(0, 1), st.floats(0.01, 0.99))
def test_verdict_of_any_interval(a: float, b: float, t: float) -> None:
    lo, hi = min(a, b), max(a, b)
    v = verdict(lo, hi, t)
    if v == "undecided":
        assert lo < t <= hi and not (FLAKY_BAND[0] < lo and hi < FLAKY_BAND[1])


def test_certain_streams_decide_and_empty_is_undecided() -> None:
    assert confidence_sequence(0, 0, 0.95) == (0.0, 1.0)
    assert decide(25, 25, DEFAULT) == "passes" and decide(0, 3, DEFAULT) == "fails"
    assert not should_continue(0, 3, DEFAULT) and should_continue(3, 3, DEFAULT)
    assert not should_continue(12, 25, DEFAULT)  # budget spent: stop, undecided
    assert decide(12, 25, DEFAULT) in ("flaky", "undecided")


# ---- bad rules ---------------------------------------------------------------------------------

BAD = [
    (dict(min_runs=5, max_runs=3), "adaptive.max"),
    (dict(min_runs=0), "adaptive.min"),
    (dict(min_runs=True), "adaptive.min"),
    (dict(min_runs=2.5), "adaptive.min"),
    (dict(min_runs=math.nan), "adaptive.min"),
    (dict(max_runs=True), "adaptive.max"),
    (dict(max_runs=10**6), "adaptive.max"),
    (dict(confidence=1.5), "adaptive.confidence"),
    (dict(confidence=1.0), "adaptive.confidence"),
    (dict(confidence=math.nan), "adaptive.confidence"),
    (dict(confidence=True), "adaptive.confidence"),
    (dict(confidence="0.9"), "adaptive.confidence"),
    (dict(threshold=0), "adaptive.threshold"),
    (dict(threshold=-0.2), "adaptive.threshold"),
    (dict(threshold=math.inf), "adaptive.threshold"),
    (dict(threshold=math.nan), "adaptive.threshold"),
    (dict(threshold=False), "adaptive.threshold"),
    (dict(indifference=-0.1), "adaptive.indifference"),
    (dict(indifference=math.nan), "adaptive.indifference"),
    (dict(indifference=True), "adaptive.indifference"),
    (dict(indifference="0.2"), "adaptive.indifference"),
    (dict(threshold=0.8, indifference=0.2), "adaptive.indifference"),  # the zone (0.6, 1.0) leaves the band
    (dict(threshold=0.5, indifference=0.45), "adaptive.indifference"),
]


@pytest.mark.parametrize("kw,field", BAD, ids=[f"{f}-{v!r}" for kw, f in BAD for v in kw.values()][: len(BAD)])
def test_bad_rule_is_one_spec_error_naming_the_field(kw: dict[str, object], field: str) -> None:
    with pytest.raises(SpecError) as e:
        AdaptiveRule(**kw)  # type: ignore[arg-type]
    assert e.value.field == field
    assert str(e.value).startswith(f"{field}=")


def test_check_rule_names_its_field_prefix() -> None:
    with pytest.raises(SpecError) as e:
        check_rule(3, 25, 0.8, 1.5, field="runs_per_map.adaptive")
    assert e.value.field == "runs_per_map.adaptive.confidence"
