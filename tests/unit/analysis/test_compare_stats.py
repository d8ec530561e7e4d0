"""The paired statistics of ``navstress compare``: properties over every table (hypothesis), exact
error rates by enumeration of every outcome of paired Bernoulli streams of known probabilities,
and the Holm family-wise error rate by simulation."""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as sst

from navstress.analysis.compare import (holm, mcnemar_exact, mean_diff, newcombe_paired, newcombe_unpaired,
                                        parse_arm, Arm)
from navstress.errors import SpecError

counts = st.integers(0, 60)
tables = st.tuples(counts, counts, counts, counts).filter(lambda t: sum(t) > 0)
levels = st.sampled_from([0.8, 0.9, 0.95, 0.99])


@given(counts, counts)
def test_mcnemar_is_a_probability_symmetric_in_a_and_b(a_only: int, b_only: int) -> None:
    p = mcnemar_exact(a_only, b_only)
    assert 0.0 <= p <= 1.0
    assert p == pytest.approx(mcnemar_exact(b_only, a_only), abs=1e-12)
    if a_only == b_only:
        assert p == 1.0


def test_mcnemar_without_discordant_pairs_is_1_and_known_values() -> None:
    assert mcnemar_exact(0, 0) == 1.0
    assert mcnemar_exact(1, 9) == pytest.approx(2 * 11 / 1024)  # 2 P(X <= 1), X ~ Bin(10, 1/2)
    assert mcnemar_exact(0, 5) == pytest.approx(2 / 32)
    with pytest.raises(SpecError):
        mcnemar_exact(-1, 2)


@given(tables, levels)
def test_paired_interval_holds_the_observed_difference_and_swaps_sign(t: tuple[int, int, int, int],
                                                                       conf: float) -> None:
    both, a_only, b_only, neither = t
    n = sum(t)
    d = (b_only - a_only) / n
    lo, hi = newcombe_paired(both, a_only, b_only, neither, conf)
    assert -1.0 <= lo <= d <= hi <= 1.0
    assert hi - lo > 0
    lo2, hi2 = newcombe_paired(both, b_only, a_only, neither, conf)  # A and B swapped
    assert (lo2, hi2) == pytest.approx((-hi, -lo), abs=1e-12)
    ulo, uhi = newcombe_unpaired(both + a_only, n, both + b_only, n, conf)
    assert -1.0 <= ulo <= d <= uhi <= 1.0
    if both * neither - a_only * b_only >= 0:  # positively correlated pairs: pairing never widens
        assert hi - lo <= uhi - ulo + 1e-12


@given(tables)
def test_higher_confidence_gives_a_wider_interval(t: tuple[int, int, int, int]) -> None:
    lo90, hi90 = newcombe_paired(*t, confidence=0.9)
    lo99, hi99 = newcombe_paired(*t, confidence=0.99)
    assert lo99 <= lo90 + 1e-12 and hi90 <= hi99 + 1e-12


def test_no_pairs_gives_the_whole_range_and_bad_input_is_refused() -> None:
    assert newcombe_paired(0, 0, 0, 0) == (-1.0, 1.0)
    assert newcombe_unpaired(0, 0, 3, 4) == (-1.0, 1.0)
    with pytest.raises(SpecError, match="confidence"):
        newcombe_paired(1, 2, 3, 4, 1.5)
    with pytest.raises(SpecError):
        newcombe_paired(-1, 2, 3, 4)


@given(st.lists(st.floats(0.0, 1.0), min_size=0, max_size=30))
def test_holm_never_lowers_a_p_value_and_keeps_their_order(ps: list[float]) -> None:
    adj = holm(ps)
    assert len(adj) == len(ps)
    m = len(ps)
    for i, (p, q) in enumerate(zip(ps, adj)):
        assert p <= q <= 1.0
        assert q <= min(1.0, m * p) + 1e-12  # never more than Bonferroni
        for j in range(m):
            if ps[i] <= ps[j]:
                assert adj[i] <= adj[j]
    # the definition: the k-th smallest is max over j <= k of min(1, (m - j) p_(j))
    s = sorted(ps)
    want = [max(min(1.0, (m - j) * s[j]) for j in range(k + 1)) for k in range(m)]
    assert sorted(adj) == pytest.approx(want)
    if m == 1:
        assert adj == ps


@given(st.lists(st.tuples(st.floats(0, 500), st.floats(-50, 50)), min_size=0, max_size=20))
def test_mean_diff_is_the_mean_of_the_paired_differences(rows: list[tuple[float, float]]) -> None:
    a = [x for x, _ in rows]
    b = [x + d for x, d in rows]
    m = mean_diff(a, b)
    assert m.n == len(rows)
    if rows:
        assert m.diff == pytest.approx(float(np.mean([y - x for x, y in zip(a, b)])), abs=1e-9)
        if m.ci is not None:
            assert m.ci[0] <= m.diff + 1e-9 and m.diff <= m.ci[1] + 1e-9
    else:
        assert m.diff is None and m.ci is None
    nan = mean_diff([1.0, math.nan], [2.0, 3.0])
    assert nan.n == 1 and nan.diff == 1.0 and nan.ci is None


@pytest.mark.parametrize("text,arm", [("reference-v1", Arm("reference-v1")),
                                      ("reference-v1:small-footprint", Arm("reference-v1", "small-footprint")),
                                      ("nav:nominal", Arm("nav"))])
def test_arms_parse(text: str, arm: Arm) -> None:
    assert parse_arm(text) == arm


@pytest.mark.parametrize("text", ["", ":", "a:", ":b", "a:b:c", " a", "a :b", "a:b "])
def test_bad_arms_name_the_flag(text: str) -> None:
    with pytest.raises(SpecError, match="--b="):
        parse_arm(text, "--b")


# ---- known probabilities ---------------------------------------------------------------


def _cells(pa: float, pb: float, rho: float) -> tuple[float, float, float, float]:
    """Probabilities of (both succeed, only A, only B, neither) for success rates pa, pb with
    correlation rho between the two outcomes of a pair."""
    both = pa * pb + rho * math.sqrt(pa * (1 - pa) * pb * (1 - pb))
    return both, pa - both, pb - both, 1 - pa - pb + both


def _tables(n: int) -> Iterator[tuple[int, int, int, int]]:
    for a in range(n + 1):
        for b in range(n + 1 - a):
            for c in range(n + 1 - a - b):
                yield a, b, c, n - a - b - c


SCENARIOS = [(0.5, 0.5, 0.0), (0.8, 0.8, 0.5), (0.9, 0.9, 0.3), (0.3, 0.3, 0.8), (0.7, 0.5, 0.4),
             (0.95, 0.6, 0.2), (0.6, 0.9, 0.3)]


@functools.cache
def _all_tables(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every table of n pairs, with its 95 % interval and its McNemar p-value."""
    t = np.array(list(_tables(n)))
    ci = np.array([newcombe_paired(*map(int, row)) for row in t])
    p = np.array([mcnemar_exact(int(row[1]), int(row[2])) for row in t])
    return t, ci[:, 0], ci[:, 1], p


@pytest.mark.parametrize("n", [10, 20])
@pytest.mark.parametrize("pa,pb,rho", SCENARIOS)
def test_exact_error_rates_under_known_probabilities(n: int, pa: float, pb: float, rho: float) -> None:
    """Every possible outcome of n pairs, weighted by its multinomial probability: the McNemar
    test rejects a true null at most alpha of the time, and the 95 % interval covers the true
    difference at least 92 % of the time (Newcombe's method stays near nominal; 93.2 % is its
    worst case on this grid)."""
    probs = _cells(pa, pb, rho)
    assert min(probs) >= 0
    t, lo, hi, p = _all_tables(n)
    w = sst.multinomial.pmf(t, n, probs)
    assert float(w.sum()) == pytest.approx(1.0)
    cover = float(np.sum(w * ((lo <= pb - pa) & (pb - pa <= hi))))
    reject = float(np.sum(w * (p <= 0.05)))
    assert cover >= 0.92
    if pa == pb:
        assert reject <= 0.05
    elif abs(pb - pa) >= 0.3 and n == 20:
        assert reject >= 0.5  # and it does find a real difference


def _streams(rng: np.random.Generator, n: int, pa: float, pb: float, shared: float) -> tuple[np.ndarray, np.ndarray]:
    """Paired Bernoulli streams: with probability ``shared`` a pair uses one uniform for both
    sides (common random numbers), else two independent ones."""
    u = rng.random(n)
    v = np.where(rng.random(n) < shared, u, rng.random(n))
    return u < pa, v < pb


def test_holm_keeps_the_family_wise_error_rate_under_the_null() -> None:
    """Four configurations with no difference, 2,000 simulated comparisons of 30 pairs each:
    claims of a difference after Holm in at most alpha of them (plus Monte Carlo slack); with a
    real difference of 40 points on one configuration, it is found most of the time."""
    rng = np.random.default_rng(20261124)
    alpha, reps = 0.05, 2000
    rates = [0.9, 0.7, 0.5, 0.3]
    mcnemar = functools.cache(mcnemar_exact)  # the same few (a_only, b_only) come back often
    false = found = 0
    for _ in range(reps):
        ps, ps_alt = [], []
        for i, p in enumerate(rates):
            a, b = _streams(rng, 30, p, p, 0.6)
            ps.append(mcnemar(int(np.sum(a & ~b)), int(np.sum(b & ~a))))
            a2, b2 = _streams(rng, 30, p, p - 0.4 if i == 1 else p, 0.6)
            ps_alt.append(mcnemar(int(np.sum(a2 & ~b2)), int(np.sum(b2 & ~a2))))
        false += min(holm(ps)) <= alpha
        found += holm(ps_alt)[1] <= alpha
    assert false / reps <= alpha + 3 * math.sqrt(alpha * (1 - alpha) / reps)
    assert found / reps >= 0.7
