"""The confirmation rule against streams of known probability: checked after every confirmation run
and stopped at the first confirmation (the most optional stopping there is), it confirms a world
wrongly at most ``1 - confidence`` of the time, for failing, revealing and boundary worlds; a
fixed-sample interval recomputed after each run does not. Streams come from numpy Generators of
fixed seeds; the rule depends on the counts only, so it is cached per count."""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import binom

from navstress.analysis.stats import wilson
from navstress.errors import SpecError
from navstress.run.record import RunRecord
from navstress.search.objectives import DEFAULT_MIN_RATE, confirm, confirm_counts

STREAMS = 2000
HORIZON = 60
#: a test fails only when the wrong count is above alpha with this significance (binomial tail)
SLACK = 1e-4
ALPHA = 0.05


def at_most_alpha(bad: int, alpha: float = ALPHA, streams: int = STREAMS) -> bool:
    return float(binom.sf(bad - 1, streams, alpha)) >= SLACK


def first_confirmation(draws: np.ndarray, confirmed: Callable[[int, int], bool]) -> tuple[int, list[int]]:
    """Bernoulli rows (event or not per run): how many rows confirm at some run count, and when."""
    cum = np.cumsum(draws, axis=1)
    hits, when = 0, []
    for row in cum:
        for n in range(1, draws.shape[1] + 1):
            if confirmed(int(row[n - 1]), n):
                hits += 1
                when.append(n)
                break
    return hits, when


@functools.lru_cache(None)
def failing(e: int, n: int, min_rate: float = DEFAULT_MIN_RATE) -> bool:
    return confirm_counts("failing", e, n, min_rate=min_rate).confirmed


@functools.lru_cache(None)
def near(e: int, n: int) -> bool:
    return confirm_counts("boundary", e, n).confirmed


@pytest.mark.parametrize("p_fail", [0.0, 0.03, 0.06, 0.08, 0.1])
def test_failing_is_wrongly_confirmed_at_most_alpha(p_fail: float) -> None:
    """A world failing at most ``min_rate`` of the time is not a confirmed failing world."""
    draws = np.random.default_rng(int(1000 * p_fail) + 3).random((STREAMS, HORIZON)) < p_fail
    bad, _ = first_confirmation(draws, failing)
    assert at_most_alpha(bad), (bad, STREAMS)


@pytest.mark.parametrize("p_fail, min_rate", [(0.3, 0.3), (0.5, 0.5), (0.2, 0.3)])
def test_failing_other_rates(p_fail: float, min_rate: float) -> None:
    draws = np.random.default_rng(17).random((STREAMS, HORIZON)) < p_fail
    bad, _ = first_confirmation(draws, lambda e, n: failing(e, n, min_rate))
    assert at_most_alpha(bad), (bad, STREAMS)


def test_failing_worlds_are_confirmed_in_a_few_runs() -> None:
    """The rule has power: a world failing 60 % of the time is confirmed within 60 runs almost
    always, and a world that always fails within a handful."""
    draws = np.random.default_rng(4).random((STREAMS, HORIZON)) < 0.6
    hits, when = first_confirmation(draws, failing)
    assert hits >= 0.99 * STREAMS and float(np.median(when)) <= 12
    always = np.ones((1, HORIZON), bool)
    _, (n,) = first_confirmation(always, failing)
    assert n <= 5


def test_a_recomputed_fixed_sample_interval_confirms_too_often() -> None:
    """The same streams under the tempting rule (a 95 % Wilson interval recomputed after each run):
    far more wrong confirmations than 5 %. This is what the confidence sequence buys."""
    draws = np.random.default_rng(9).random((STREAMS, HORIZON)) < 0.1
    bad_w, _ = first_confirmation(draws, functools.lru_cache(None)(lambda e, n: wilson(e, n, 0.95)[0] > 0.1))
    bad_cs, _ = first_confirmation(draws, failing)
    assert not at_most_alpha(bad_w) and bad_w > 3 * max(bad_cs, 1)


@pytest.mark.parametrize("p_success", [0.02, 0.1, 0.9, 0.97])
def test_boundary_is_wrongly_confirmed_at_most_alpha(p_success: float) -> None:
    """A world outside (0.1, 0.9) is not confirmed near the boundary."""
    draws = np.random.default_rng(int(100 * p_success)).random((STREAMS, HORIZON)) < p_success
    bad, _ = first_confirmation(draws, near)
    assert at_most_alpha(bad), (bad, STREAMS)


def test_boundary_worlds_are_confirmed() -> None:
    draws = np.random.default_rng(5).random((STREAMS, HORIZON)) < 0.5
    hits, _ = first_confirmation(draws, near)
    assert hits >= 0.95 * STREAMS


# ---------------------------------------------------------------- revealing: pairs of runs

REVEAL_STREAMS = 1500
REVEAL_HORIZON = 40


@functools.lru_cache(None)
def revealing(b: int, c: int, n: int) -> bool:
    return confirm_counts("revealing", b, n, counter=c).confirmed


def reveal_streams(p_b: float, p_c: float, seed: int) -> tuple[int, list[int]]:
    """Streams of pairs, each revealing (nominal succeeds, faulty fails) with probability ``p_b``,
    counter (nominal fails, faulty succeeds) with ``p_c``, concordant otherwise: how many confirm
    revealing at some pair count, and when."""
    u = np.random.default_rng(seed).random((REVEAL_STREAMS, REVEAL_HORIZON))
    b = np.cumsum(u < p_b, axis=1)
    c = np.cumsum((u >= p_b) & (u < p_b + p_c), axis=1)
    hits, when = 0, []
    for rb, rc in zip(b, c):
        for n in range(1, REVEAL_HORIZON + 1):
            if revealing(int(rb[n - 1]), int(rc[n - 1]), n):
                hits += 1
                when.append(n)
                break
    return hits, when


@pytest.mark.parametrize("p_b, p_c", [
    (0.1, 0.0),    # reveals, but not more often than min_rate
    (0.06, 0.0),
    (0.3, 0.3),    # the fault fails as often where the nominal fails: no fault effect
    (0.25, 0.25),  # both stacks fail half of the time, independently
    (0.35, 0.45),  # the faulty stack does better
])
def test_revealing_is_wrongly_confirmed_at_most_alpha(p_b: float, p_c: float) -> None:
    bad, _ = reveal_streams(p_b, p_c, seed=int(1000 * p_b + 100 * p_c))
    assert at_most_alpha(bad, streams=REVEAL_STREAMS), (bad, REVEAL_STREAMS)


def test_revealing_worlds_are_confirmed() -> None:
    hits, when = reveal_streams(0.6, 0.0, seed=2)
    assert hits >= 0.99 * REVEAL_STREAMS and float(np.median(when)) <= 15
    hits, _ = reveal_streams(0.5, 0.05, seed=3)
    assert hits >= 0.9 * REVEAL_STREAMS


# ---------------------------------------------------------------- the rule on counts and on records


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 60).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_more_failures_never_unconfirm(en: tuple[int, int]) -> None:
    e, n = en
    c = confirm_counts("failing", e, n)
    if e < n:
        assert confirm_counts("failing", e + 1, n).confirmed >= c.confirmed
    assert confirm_counts("failing", e, n, confidence=0.8).confirmed >= c.confirmed  # less confidence, less proof
    lo, hi = c.interval
    assert 0.0 <= lo <= hi <= 1.0 and c.confirmed == (lo > DEFAULT_MIN_RATE)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 40).flatmap(lambda n: st.tuples(st.integers(0, n), st.integers(0, n), st.just(n)))
       .filter(lambda t: t[0] + t[1] <= t[2]))
def test_revealing_needs_both_claims(bcn: tuple[int, int, int]) -> None:
    b, c, n = bcn
    r = confirm_counts("revealing", b, n, counter=c)
    assert r.direction is not None
    assert r.confirmed == (r.interval[0] > DEFAULT_MIN_RATE and r.direction[0] > 0.5)
    if c > 0:  # one counter pair fewer never hurts
        assert confirm_counts("revealing", b, n, counter=c - 1).confirmed >= r.confirmed


def test_bad_counts_and_kinds_are_one_spec_error() -> None:
    for kwargs, field in [({"kind": "flaky"}, "confirm"), ({"events": 5, "trials": 3}, "events"),
                          ({"events": -1}, "events"), ({"confidence": 1.0}, "confidence"),
                          ({"min_rate": 1.5}, "confirm.min_rate"), ({"band": 0.0}, "confirm.band"),
                          ({"kind": "revealing", "events": 2, "counter": 2, "trials": 3}, "events")]:
        args = {"kind": "failing", "events": 1, "trials": 3, **kwargs}
        with pytest.raises(SpecError) as ei:
            confirm_counts(str(args.pop("kind")), int(args.pop("events")), int(args.pop("trials")),  # type: ignore[arg-type]
                           **args)  # type: ignore[arg-type]
        assert ei.value.field == field


def _rec(run: int, outcome: str, fault: str | None = None, seed: int | None = None) -> RunRecord:
    return RunRecord(f"confirm/w3/m0/r{run}/nav/{fault or 'nominal'}", "confirm", {}, 0, run, 3,
                     500 + run if seed is None else seed, "nav", fault, outcome, "", 1.0, 0.1, 0.0, 1.0, 0.0, 0,
                     None, [], None)


def test_confirm_on_records_agrees_with_the_counts() -> None:
    fault = "small-footprint"
    recs = [_rec(i, "success") for i in range(20)] + [_rec(i, "fail-collision", fault) for i in range(16)]
    recs += [_rec(i, "success", fault) for i in range(16, 20)] + [_rec(20, "fail-timeout", fault)]
    c = confirm(recs, "revealing", fault=fault)
    assert (c.events, c.trials, c.counter, c.unpaired) == (16, 20, 0, 1) and c.confirmed
    assert c == confirm(list(reversed(recs)), "revealing", fault=fault)
    assert confirm(recs, "revealing", fault=fault, failure_class="timeout").events == 0
    f = confirm(recs, "failing", fault=fault)
    assert (f.events, f.trials, f.confirmed) == (17, 21, True)
    assert not confirm(recs, "failing").confirmed  # the nominal stack never failed
    assert not confirm(recs, "boundary").confirmed
    assert set(c.to_json()) >= {"confirmed", "interval", "counter", "direction", "unpaired", "reason"}
    assert "revealing probability in" in c.reason
    with pytest.raises(SpecError, match="fault=None"):
        confirm(recs, "revealing")
