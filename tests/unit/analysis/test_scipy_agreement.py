"""navstress's intervals and correlation against ``scipy.stats`` and against small independent
references, over families of (successes, runs, confidence) with the edges (no run, no success,
every run a success) and of samples with ties.

Which routine gives each number (docs/statistics.md, "Intervals and scipy"): the Wilson interval
is ``binomtest(k, n).proportion_ci(method="wilson")`` and Spearman's rho is ``spearmanr``, bit for
bit; the Clopper-Pearson limits (two-sided and the gate's one-sided bound) are read off
``scipy.stats.beta``'s exact quantiles, which ``proportion_ci(method="exact")`` approaches by a root
search (brentq, to 2e-12: up to 5e-13 apart)."""

from __future__ import annotations

import math
import warnings
from decimal import Decimal, localcontext
from fractions import Fraction
from statistics import NormalDist

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as sst

from navstress.analysis.descriptors_corr import spearman
from navstress.analysis.gate import lower_bound
from navstress.analysis.stats import clopper_pearson, wilson
from navstress.analysis.verdicts import exact_interval

#: Common confidences, and the open interval's ends a user may ask for.
CONFIDENCES = st.one_of(st.sampled_from([0.5, 0.8, 0.9, 0.95, 0.975, 0.99, 0.999]),
                        st.floats(0.5, 0.9999, allow_nan=False))
#: (successes, runs) with the edges drawn often: no success, every run a success, one run.
COUNTS = st.integers(1, 2000).flatmap(
    lambda n: st.tuples(st.one_of(st.just(0), st.just(n), st.integers(0, n)), st.just(n)))
SMALL_COUNTS = st.integers(1, 60).flatmap(
    lambda n: st.tuples(st.one_of(st.just(0), st.just(n), st.integers(0, n)), st.just(n)))

EXACT_TOL = 2e-12  # scipy's brentq tolerance (measured: at most 5e-13)


def _scipy_ci(k: int, n: int, c: float, method: str, alternative: str = "two-sided") -> tuple[float, float]:
    ci = sst.binomtest(k, n, alternative=alternative).proportion_ci(confidence_level=c, method=method)
    return float(ci.low), float(ci.high)


def _wilson_reference(k: int, n: int, c: float) -> tuple[float, float]:
    """The score interval solved in 40-digit decimals, z from the standard library's normal."""
    z = Decimal(NormalDist().inv_cdf(0.5 + c / 2))
    with localcontext() as ctx:
        ctx.prec = 40
        p, nn = Decimal(k) / Decimal(n), Decimal(n)
        den = 1 + z * z / nn
        centre = (p + z * z / (2 * nn)) / den
        half = z * (p * (1 - p) / nn + z * z / (4 * nn * nn)).sqrt() / den
        return float(max(Decimal(0), centre - half)), float(min(Decimal(1), centre + half))


# ---- Wilson ---------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(kn=COUNTS, c=CONFIDENCES)
def test_wilson_is_scipys_wilson_interval(kn: tuple[int, int], c: float) -> None:
    k, n = kn
    lo, hi = wilson(k, n, c)
    slo, shi = _scipy_ci(k, n, c, "wilson")
    assert (lo, hi) == (slo, shi)  # scipy's own interval (ends clamped to [0, 1], never moved)
    assert (lo == 0.0) == (k == 0) and (hi == 1.0) == (k == n)  # exact ends, as scipy's
    assert (slo == 0.0) == (k == 0) and (shi == 1.0) == (k == n)


@settings(max_examples=200, deadline=None)
@given(kn=COUNTS, c=CONFIDENCES)
def test_wilson_matches_the_decimal_reference(kn: tuple[int, int], c: float) -> None:
    k, n = kn
    got, want = wilson(k, n, c), _wilson_reference(k, n, c)
    assert got == pytest.approx(want, abs=1e-12)


# ---- Clopper-Pearson: two-sided, one-sided (the gate), the verdicts' ---------------------------


@settings(max_examples=200, deadline=None)
@given(kn=COUNTS, c=CONFIDENCES)
def test_clopper_pearson_is_scipys_exact_interval(kn: tuple[int, int], c: float) -> None:
    k, n = kn
    lo, hi = clopper_pearson(k, n, c)
    slo, shi = _scipy_ci(k, n, c, "exact")
    assert abs(lo - slo) <= EXACT_TOL and abs(hi - shi) <= EXACT_TOL
    assert (lo == 0.0) == (k == 0) == (slo == 0.0) and (hi == 1.0) == (k == n) == (shi == 1.0)
    assert exact_interval(k, n, c) == (slo, shi)  # the verdicts' interval is scipy's own


@settings(max_examples=200, deadline=None)
@given(kn=COUNTS, c=CONFIDENCES)
def test_the_gates_one_sided_bound_is_the_two_sided_lower_limit_at_2c_minus_1(kn: tuple[int, int], c: float) -> None:
    """One-sided at confidence c is two-sided at 1 - 2 (1 - c): bit for bit (for c in [0.5, 1) both
    tails are computed exactly: 1 - c and (1 - (2c - 1)) / 2 are the same double), and scipy's
    one-sided root within its tolerance."""
    k, n = kn
    lo = lower_bound(k, n, c)
    if c > 0.5:
        assert lo == clopper_pearson(k, n, 2 * c - 1)[0]
    slo, shi = _scipy_ci(k, n, c, "exact", alternative="greater")
    assert abs(lo - slo) <= EXACT_TOL and shi == 1.0
    assert (lo == 0.0) == (k == 0)


def _tail_at_least(k: int, n: int, p: float) -> float:
    """P(X >= k) for X ~ Binomial(n, p), exactly in rationals, then rounded."""
    q = Fraction(p)
    return float(sum(math.comb(n, i) * q**i * (1 - q) ** (n - i) for i in range(k, n + 1)))


def _root(f: object, target: float) -> float:
    """Bisection on [0, 1] for an increasing ``f(p) = target``."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if f(mid) < target else (lo, mid)  # type: ignore[operator]
    return (lo + hi) / 2


@settings(max_examples=60, deadline=None)
@given(kn=SMALL_COUNTS, c=st.sampled_from([0.8, 0.9, 0.95, 0.99]))
def test_clopper_pearson_matches_the_exact_tail_reference(kn: tuple[int, int], c: float) -> None:
    """Limits where an exact binomial tail (rational arithmetic) equals alpha/2, found by bisection."""
    k, n = kn
    a = (1 - c) / 2
    lo, hi = clopper_pearson(k, n, c)
    want_lo = 0.0 if k == 0 else _root(lambda p: _tail_at_least(k, n, p), a)
    want_hi = 1.0 if k == n else _root(lambda p: _tail_at_least(k + 1, n, p), 1 - a)  # P(X <= k) = a
    assert lo == pytest.approx(want_lo, abs=1e-12) and hi == pytest.approx(want_hi, abs=1e-12)


@pytest.mark.parametrize("c", [0.5, 0.9, 0.95, 0.999])
def test_no_run_is_the_whole_interval(c: float) -> None:
    assert wilson(0, 0, c) == clopper_pearson(0, 0, c) == exact_interval(0, 0, c) == (0.0, 1.0)
    assert lower_bound(0, 0, c) == 0.0
    with pytest.raises(ValueError):  # scipy has no interval without a trial: navstress answers (0, 1)
        _scipy_ci(0, 0, c, "wilson")


# ---- Spearman -------------------------------------------------------------------------------


def _average_ranks(xs: list[float]) -> list[Fraction]:
    order = sorted(range(len(xs)), key=lambda i: xs[i])
    ranks = [Fraction(0)] * len(xs)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and xs[order[j + 1]] == xs[order[i]]:
            j += 1
        for t in range(i, j + 1):
            ranks[order[t]] = Fraction(i + j + 2, 2)  # the mean of ranks i+1 .. j+1
        i = j + 1
    return ranks


def _spearman_reference(x: list[float], y: list[float]) -> float | None:
    """Pearson's r of the average ranks, in rationals up to the last square root."""
    if len(x) < 3:
        return None
    rx, ry = _average_ranks(x), _average_ranks(y)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    cov = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    vx, vy = sum((a - mx) ** 2 for a in rx), sum((b - my) ** 2 for b in ry)
    if vx == 0 or vy == 0:
        return None
    return float(cov) / math.sqrt(float(vx * vy))


#: Samples with ties: few distinct values (difficulty levels are 0, 1, 2), and some constant.
SAMPLES = st.integers(0, 25).flatmap(lambda n: st.tuples(
    st.lists(st.one_of(st.integers(0, 2).map(float), st.floats(-1e3, 1e3, allow_nan=False)), min_size=n, max_size=n),
    st.lists(st.one_of(st.integers(0, 3).map(float), st.floats(-1.0, 1.0, allow_nan=False)), min_size=n, max_size=n)))


@settings(max_examples=300, deadline=None)
@given(xy=SAMPLES)
def test_spearman_is_scipys_spearmanr(xy: tuple[list[float], list[float]]) -> None:
    x, y = xy
    got = spearman(x, y)
    if len(x) < 3:
        assert got is None
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a constant side: scipy warns and answers nan
        want = float(sst.spearmanr(x, y).statistic)
    if math.isnan(want):
        assert got is None
    else:
        assert got == want  # scipy's own rho


@settings(max_examples=300, deadline=None)
@given(xy=SAMPLES)
def test_spearman_matches_the_rational_reference(xy: tuple[list[float], list[float]]) -> None:
    x, y = xy
    got, want = spearman(x, y), _spearman_reference(x, y)
    assert (got is None) == (want is None)
    if got is not None and want is not None:
        assert got == pytest.approx(want, abs=1e-14)


def test_spearman_edges() -> None:
    assert spearman([1.0, 2.0], [2.0, 1.0]) is None  # fewer than 3 pairs
    assert spearman([1.0, 1.0, 1.0], [1.0, 2.0, 3.0]) is None  # a constant side
    assert spearman([1.0, 2.0, 3.0], [1.0, 2.0]) is None  # unequal lengths
    assert spearman([1.0, 2.0, 3.0], [30.0, 20.0, 10.0]) == -1.0


# ---- the numbers the outputs hold ------------------------------------------------------------


def test_the_gate_bounds_keep_their_bits() -> None:
    """``gate``'s lower bounds are the beta quantiles at ``1 - confidence`` (the double
    0.050000000000000044 for 0.95, not 0.05: the last bits show), bit for bit."""
    for k, n in [(6, 6), (5, 6), (12, 20), (1, 40), (39, 40)]:
        assert lower_bound(k, n, 0.95) == float(sst.beta.ppf(1.0 - 0.95, k, n - k + 1))
    assert lower_bound(6, 6, 0.95) == 0.6069622310029174  # gate.json of the demo
    assert lower_bound(20, 20, 0.95) == pytest.approx(0.05 ** (1 / 20), rel=1e-15)
    assert np.isfinite(lower_bound(1999, 2000, 0.9999))
