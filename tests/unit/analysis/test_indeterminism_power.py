"""Indeterminism curves and fault-revealing power against hand-computed values."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from tests.support.analysis_synth import record
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navstress.analysis.fault_power import by_level, fault_power
from navstress.analysis.indeterminism import config_curves, max_spread, mean_curve, positions_at
from navstress.errors import SpecError


def tr(*rows: tuple[float, float, float]) -> np.ndarray:
    return np.array(rows, dtype=float)


def test_max_spread_by_hand_with_an_ended_run_holding_its_position() -> None:
    a = tr((0, 0, 0), (4, 4, 0))  # moves 1 m/s along x for 4 s
    b = tr((0, 0, 0), (2, 0, 2))  # moves 1 m/s along y, ends at t = 2 and stays at (0, 2)
    c = tr((0, 0, 0), (4, 0, 0))  # never moves
    t, d = max_spread([a, b, c], dt=1.0)
    assert list(t) == [0, 1, 2, 3, 4]
    # t=3: a (3,0), b (0,2), c (0,0): max(|ab| = sqrt 13, |ac| = 3, |bc| = 2)
    np.testing.assert_allclose(d, [0, np.sqrt(2), np.sqrt(8), np.sqrt(13), np.sqrt(20)])
    t1, d1 = max_spread([a], dt=1.0)
    assert d1.max() == 0.0 and t1[-1] == 4.0
    t2, _ = max_spread([tr((0, 0, 0), (2.5, 1, 0))], dt=1.0)
    assert list(t2) == [0, 1, 2, 2.5]  # the end is included


@settings(max_examples=40, deadline=None)
@given(st.lists(arrays(np.float64, (4, 2), elements=st.floats(-50, 50)), min_size=2, max_size=5))
def test_spread_is_brute_force_max_pairwise_at_samples(xys: list[np.ndarray]) -> None:
    trajs = [np.column_stack([np.arange(4.0), xy]) for xy in xys]
    t, d = max_spread(trajs, dt=1.0)
    for i, ti in enumerate(t):
        pts = [xy[int(ti)] for xy in xys]
        want = max(float(np.hypot(*(p - q))) for p, q in itertools.combinations(pts, 2))
        assert d[i] == pytest.approx(want, abs=1e-9)
    _, d_rev = max_spread(trajs[::-1], dt=1.0)
    np.testing.assert_allclose(d, d_rev)  # order of runs does not matter


def test_bad_inputs() -> None:
    with pytest.raises(SpecError, match="dt"):
        max_spread([tr((0, 0, 0))], dt=0)
    with pytest.raises(SpecError, match="trajectories"):
        max_spread([], dt=1)
    with pytest.raises(SpecError, match="trajectory"):
        positions_at(np.zeros((0, 3)), np.zeros(2))


def test_config_curves_average_maps_and_split_groups() -> None:
    ok1, ok2 = tr((0, 0, 0), (2, 2, 0)), tr((0, 0, 0), (2, 0, 0))  # map 0: spread 0, 1, 2
    bad = tr((0, 0, 0), (1, 0, 3))  # map 0: a lone failure (no failure curve from map 0)
    m1a, m1b = tr((0, 0, 0), (4, 0, 4)), tr((0, 0, 0), (4, 0, 0))  # map 1: spread 0, 1, 2, 3, 4
    f1, f2 = tr((0, 0, 0), (1, 1, 0)), tr((0, 0, 0), (1, 0, 0))  # map 2: two failures, spread 0, 1
    curves = config_curves({0: [(True, ok1), (True, ok2), (False, bad)], 1: [(True, m1a), (True, m1b)],
                            2: [(False, f1), (False, f2)], 3: [(True, ok1)]}, dt=1.0)
    s = curves["success"]
    assert (s.n_maps, s.n_runs) == (2, 4)
    np.testing.assert_allclose(s.d, [0, 1, 2, 2.5, 3])  # map 0 held at 2 past t = 2
    assert (s.peak_m, s.final_m) == (3.0, 3.0)
    assert s.mean_m == pytest.approx(np.trapezoid([0, 1, 2, 2.5, 3], [0, 1, 2, 3, 4]) / 4)
    f = curves["failure"]
    assert (f.n_maps, f.n_runs) == (1, 2) and list(f.d) == [0, 1]
    a = curves["all"]
    assert a.n_maps == 3  # maps 0, 1, 2 (map 3 has one run)
    assert config_curves({0: [(True, ok1)]}) == {}


def test_mean_curve_holds_short_maps() -> None:
    t, d = mean_curve([(np.array([0.0, 1.0]), np.array([0.0, 4.0])), (np.array([0.0, 1, 2]), np.array([0.0, 0, 2]))],
                      dt=1.0)
    np.testing.assert_allclose(d, [0, 2, 3])


def test_fault_power_by_hand() -> None:
    k = "tree=4"
    recs = [
        record("trees", k, 0, 0), record("trees", k, 0, 1),  # nominal map 0: two successes
        record("trees", k, 0, 0, "fail-collision", fault="small", collisions=1),  # collision, new
        record("trees", k, 0, 1, "fail-timeout", fault="small"),  # new (nominal never timed out on m0)
        record("trees", k, 1, 0, "fail-timeout"), record("trees", k, 1, 1, "fail-collision", collisions=2),
        record("trees", k, 1, 0, "fail-timeout", fault="small"),  # not new: nominal timed out on m1
        record("trees", k, 1, 1, "fail-collision", fault="small", collisions=1),  # collision, not new (nominal too)
        record("trees", k, 2, 0),  # nominal on a map without faulty runs: not compared
        record("trees", "tree=8", 0, 0, "fail-error"), record("trees", "tree=8", 0, 0, "success", fault="small"),
    ]
    p = {(x.config_key, x.fault): x for x in fault_power(recs, {("trees", k): "challenging",
                                                                ("trees", "tree=8"): "easy"})}
    a = p[(k, "small")]
    assert (a.runs, a.collisions, a.new_failures, a.nominal_runs, a.nominal_collisions) == (4, 2, 2, 4, 1)
    assert (a.collision_share, a.nominal_collision_share, a.level) == (0.5, 0.25, "challenging")
    b = p[("tree=8", "small")]
    assert (b.runs, b.collisions, b.new_failures, b.nominal_runs) == (1, 0, 0, 1)
    lv = by_level(list(p.values()), ("easy", "challenging", "very difficult"))
    assert [(x.level, x.runs, x.collisions, x.nominal_collisions) for x in lv] == [
        ("easy", 1, 0, 0), ("challenging", 4, 2, 1)]
    assert fault_power([record("trees", k, 0, 0)]) == []  # no faulty run: nothing
