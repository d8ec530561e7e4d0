"""Per-configuration statistics and confidence intervals, against hand-computed values."""

from __future__ import annotations

import math

import pytest
from tests.support.analysis_synth import NAN, record
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats as sst

from navstress.analysis.stats import (PlannedConfig, clopper_pearson, config_key, config_stats, params_text, summarise,
                                      wilson)
from navstress.errors import SpecError

Z95 = 1.959963984540054


@given(st.integers(0, 200).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))).filter(lambda t: t[1] > 0))
def test_wilson_bounds_solve_the_score_equation(kn: tuple[int, int]) -> None:
    k, n = kn
    lo, hi = wilson(k, n)
    p = k / n
    assert 0 <= lo <= p <= hi <= 1
    # each interior bound satisfies |p - b| = z sqrt(b (1 - b) / n)
    for b in (lo, hi):
        if 1e-12 < b < 1 - 1e-12:
            assert abs(abs(p - b) - Z95 * math.sqrt(b * (1 - b) / n)) < 1e-9


@given(st.integers(1, 100).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_clopper_pearson_tails_are_alpha_over_two(kn: tuple[int, int]) -> None:
    k, n = kn
    lo, hi = clopper_pearson(k, n)
    assert 0 <= lo <= k / n <= hi <= 1
    if k < n:
        assert sst.binom.cdf(k, n, hi) == pytest.approx(0.025, abs=1e-7)
    else:
        assert hi == 1.0
    if k > 0:
        assert sst.binom.sf(k - 1, n, lo) == pytest.approx(0.025, abs=1e-7)
    else:
        assert lo == 0.0


def test_hand_values_and_empty() -> None:
    lo, hi = wilson(8, 10)  # by hand: centre (0.8 + 1.9208/10)/1.38415 = 0.71673, half 0.22657
    assert (round(lo, 4), round(hi, 4)) == (0.4902, 0.9433)
    assert wilson(0, 0) == (0.0, 1.0) and clopper_pearson(0, 0) == (0.0, 1.0)
    assert clopper_pearson(0, 5)[1] == pytest.approx(1 - 0.025 ** (1 / 5))


@pytest.mark.parametrize("k,n,conf,msg", [(3, 2, 0.95, "successes"), (-1, 2, 0.95, "successes"),
                                          (1, 2, 1.5, "confidence")])
def test_bad_inputs_name_the_field(k: int, n: int, conf: float, msg: str) -> None:
    with pytest.raises(SpecError, match=msg):
        wilson(k, n, conf)


def test_summary_ties_nan_and_failures() -> None:
    recs = [record("trees", "tree=4", 0, 0, duration=30.0, tort=0.2, goal=1.0),
            record("trees", "tree=4", 0, 1, duration=10.0, tort=0.2, goal=NAN),
            record("trees", "tree=4", 1, 0, duration=30.0, tort=0.4, goal=2.0),
            record("trees", "tree=4", 1, 1, duration=20.0, tort=0.1, goal=3.0),
            record("trees", "tree=4", 1, 2, "fail-error", duration=5.0, tort=9.0, goal=12.0)]
    s = summarise("trees", "tree=4", {"obstacles.obstruction.tree": 4}, "reference-v1", "nominal", recs)
    assert (s.runs, s.successes, s.success_rate) == (5, 4, 0.8)
    assert s.median_duration_s == 25.0  # successes 10, 20, 30, 30 -> (20 + 30) / 2; the failure's 5 s ignored
    assert s.median_tortuousness == pytest.approx(0.2)  # 0.1, 0.2, 0.2, 0.4
    assert s.mean_goal_distance_m == pytest.approx((1 + 2 + 3 + 12) / 4)  # NaN left out
    assert s.outcomes == {"success": 4, "fail-collision": 0, "fail-error": 1, "fail-timeout": 0, "fail-other": 0}
    assert (s.ci_low, s.ci_high) == wilson(4, 5)
    assert s.maps == (0, 1)


def test_all_failures_single_run_and_empty_configuration() -> None:
    fail = [record("trees", "tree=8", 0, r, "fail-timeout", goal=20.0 + r) for r in range(3)]
    one = [record("trees", "tree=0", 0, 0, duration=12.5, tort=0.05)]
    planned = [PlannedConfig("trees", k, {"obstacles.obstruction.tree": v}, "reference-v1", "nominal", 4)
               for k, v in (("tree=0", 0), ("tree=4", 4), ("tree=8", 8))]
    out = config_stats(fail + one, planned)
    assert [s.config_key for s in out] == ["tree=0", "tree=4", "tree=8"]  # planned order, empty included
    s0, s4, s8 = out
    assert (s0.runs, s0.median_duration_s, s0.median_tortuousness, s0.planned) == (1, 12.5, 0.05, 4)
    assert (s4.runs, s4.success_rate, s4.median_duration_s, s4.mean_goal_distance_m) == (0, None, None, None)
    assert (s4.ci_low, s4.ci_high) == (0.0, 1.0)
    assert (s8.successes, s8.median_duration_s, s8.median_tortuousness) == (0, None, None)
    assert s8.mean_goal_distance_m == pytest.approx(21.0)


def test_groups_split_by_fault_and_keys() -> None:
    recs = [record("trees", "tree=4", 0, 0), record("trees", "tree=4", 0, 0, "fail-collision", fault="small-footprint",
                                                      collisions=2)]
    out = config_stats(recs)
    assert [(s.fault, s.runs, s.successes) for s in out] == [("nominal", 1, 1), ("small-footprint", 1, 0)]
    assert config_key(recs[1]) == "tree=4"
    assert params_text({"obstacles.obstruction.tree": 4}) == "tree=4"
    with pytest.raises(SpecError, match="interval"):
        config_stats(recs, interval="bayes")
