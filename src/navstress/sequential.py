"""Decisions from repeated runs that stay valid however many runs are looked at: an anytime-valid
confidence sequence for a success probability, and the verdict it gives.

A world (with one navigator and fault) is a stream of Bernoulli outcomes, success or not, with an
unknown success probability ``p``. After each run, :func:`confidence_sequence` gives an interval
that contains ``p`` at *every* run count at once with probability at least ``confidence`` (a
confidence sequence: Robbins' beta-binomial mixture martingale with Ville's inequality), so a
rule that stops as soon as the interval settles a question (optional stopping) keeps the error
rate of its answer below ``1 - confidence``. A fixed-sample interval (Wilson, Clopper-Pearson)
recomputed after each run does not: looked at after every run, it is wrong far more often than
its nominal rate. docs/statistics.md says why this construction and what it costs.

:func:`verdict` maps an interval to a class: ``passes`` (``p >= threshold``), ``fails``
(``p < threshold``), ``flaky`` (both outcomes likely: ``FLAKY_BAND[0] < p < FLAKY_BAND[1]``),
or ``undecided``. Each class is a claim about ``p`` that the interval proves, so a wrong verdict
needs ``p`` outside the interval: at most ``1 - confidence`` of the streams, at any stopping time.

With an *indifference* ``delta > 0`` (Wald's indifference zone), ``passes`` proves only
``p >= threshold - delta`` and ``fails`` only ``p < threshold + delta``: the rule tells a world
that passes at least ``threshold + delta`` of the time from one that passes at most
``threshold - delta`` of the time, with error at most ``1 - confidence`` for each, and may
answer either way for a world inside the zone. It decides much sooner (docs/statistics.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from navstress.errors import SpecError

Verdict = Literal["passes", "fails", "flaky", "undecided"]
VERDICTS: tuple[Verdict, ...] = ("passes", "fails", "flaky", "undecided")
#: Both outcomes likely: the success probability is proven inside this open band.
FLAKY_BAND = (0.1, 0.9)
#: The mixture's prior Beta(a, a) (Jeffreys): the interval's width at the extremes and in the middle
#: balanced (docs/statistics.md).
PRIOR_A = 0.5


@dataclass(frozen=True)
class AdaptiveRule:
    """Run a world again while its verdict is undecided, at least ``min_runs`` and at most
    ``max_runs`` times; decide against ``threshold`` with ``confidence``."""

    min_runs: int = 3
    max_runs: int = 25
    threshold: float = 0.8
    confidence: float = 0.95
    #: the half-width of the indifference zone around ``threshold`` (0: none; see the module doc)
    indifference: float = 0.0

    def __post_init__(self) -> None:
        check_rule(self.min_runs, self.max_runs, self.threshold, self.confidence, indifference=self.indifference)


def check_rule(min_runs: int, max_runs: int, threshold: float, confidence: float, field: str = "adaptive",
               indifference: float = 0.0) -> None:
    """Raise :class:`SpecError` naming the first invalid parameter of an adaptive rule. The
    indifference zone ``(threshold - indifference, threshold + indifference)`` must lie inside
    :data:`FLAKY_BAND` (so a world proven inside it is flaky)."""
    if isinstance(min_runs, bool) or not isinstance(min_runs, int) or not 1 <= min_runs <= 10_000:
        raise SpecError(f"{field}.min", min_runs, "an integer in [1, 10000]")
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < min_runs or max_runs > 10_000:
        raise SpecError(f"{field}.max", max_runs, f"an integer from min ({min_runs}) to 10000",
                        "make max at least min")
    for name, v in (("threshold", threshold), ("confidence", confidence)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0.0 < v < 1.0:
            raise SpecError(f"{field}.{name}", v, "a number strictly between 0 and 1", "e.g. 0.95")
    d = indifference
    if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d) or d < 0.0:
        raise SpecError(f"{field}.indifference", d, "a number >= 0 (0: no indifference zone)", "e.g. 0.25")
    if d > 0.0 and not (threshold - d >= FLAKY_BAND[0] - 1e-12 and threshold + d <= FLAKY_BAND[1] + 1e-12):
        hi = max(0.0, min(threshold - FLAKY_BAND[0], FLAKY_BAND[1] - threshold))
        raise SpecError(f"{field}.indifference", d,
                        f"a zone threshold +/- indifference inside the flaky band {FLAKY_BAND}: at most {hi:.4g} "
                        f"for threshold {threshold:g}", "lower it, or move the threshold towards 0.5")


def _log_martingale_gap(p: float, successes: int, n: int, log_bound: float) -> float:
    """log M_n(p) - log(1/alpha): M_n is the Beta(a, a) mixture of likelihood ratios against p."""
    from scipy.special import betaln  # local, as brentq below

    a = PRIOR_A
    f = n - successes
    loglik = (successes * math.log(p) if successes else 0.0) + (f * math.log1p(-p) if f else 0.0)
    return float(betaln(a + successes, a + f) - betaln(a, a)) - loglik - log_bound


def confidence_sequence(successes: int, n: int, confidence: float) -> tuple[float, float]:
    """The (lo, hi) interval of the success probability after ``successes`` of ``n`` runs, valid
    at every ``n`` at once with probability >= ``confidence``. (0, 1) when ``n`` is 0."""
    if n < 0 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n, got {successes} of {n}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if n == 0:
        return 0.0, 1.0
    log_bound = math.log(1.0 / (1.0 - confidence))
    mle = successes / n
    eps = 1e-12
    # the set {p: M_n(p) < 1/alpha} is an interval around the MLE (the log-likelihood is concave)
    centre = min(max(mle, eps), 1.0 - eps)

    def g(p: float) -> float:
        return _log_martingale_gap(p, successes, n, log_bound)

    if g(centre) >= 0.0:  # (cannot happen for alpha < 1: M_n(mle) <= 1 < 1/alpha; kept as a guard)
        return centre, centre
    from scipy.optimize import brentq  # local: 0.8 s to import, and every worker imports this module

    lo = 0.0 if successes == 0 or g(eps) < 0.0 else float(brentq(g, eps, centre, xtol=1e-12))
    hi = 1.0 if successes == n or g(1.0 - eps) < 0.0 else float(brentq(g, centre, 1.0 - eps, xtol=1e-12))
    return lo, hi


def verdict(lo: float, hi: float, threshold: float, indifference: float = 0.0) -> Verdict:
    """The class an interval (lo, hi) of the success probability proves (see the module doc);
    flaky first: a stream proven to give both outcomes often is flaky whatever the threshold
    (and an interval inside the indifference zone, which lies inside the flaky band, is flaky)."""
    if FLAKY_BAND[0] < lo and hi < FLAKY_BAND[1]:
        return "flaky"
    if lo >= threshold - indifference:
        return "passes"
    if hi < threshold + indifference:
        return "fails"
    return "undecided"


def decide(successes: int, n: int, rule: AdaptiveRule) -> Verdict:
    """The verdict after ``successes`` of ``n`` runs under ``rule`` ("undecided" also before
    ``rule.min_runs`` runs)."""
    if n < rule.min_runs:
        return "undecided"
    lo, hi = confidence_sequence(successes, n, rule.confidence)
    return verdict(lo, hi, rule.threshold, rule.indifference)


def should_continue(successes: int, n: int, rule: AdaptiveRule) -> bool:
    """Whether another run of this stream is scheduled: undecided and fewer than ``max_runs``."""
    return n < rule.max_runs and decide(successes, n, rule) == "undecided"
