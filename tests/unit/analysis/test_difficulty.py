"""Difficulty levels: threshold, weighted k-means, the reference rule, ties, ranges and overlaps."""

from __future__ import annotations

import math

import pytest
from tests.support.analysis_synth import spec_dict

from navstress.analysis.difficulty import (CHALLENGING, EASY, NO_DATA, VERY_DIFFICULT, DifficultyParams,
                                           assign_levels, is_flat_empty, level_ranges, reference_keys)
from navstress.analysis.stats import ConfigStats
from navstress.campaign.spec import parse_campaign
from navstress.errors import SpecError

P = "obstacles.obstruction.tree"


def cs(key: str, runs: int, succ: int, dur: float | None, tort: float | None, exp: str = "trees",
       value: float | None = None) -> ConfigStats:
    v = value if value is not None else float(key.split("=")[1])
    return ConfigStats(exp, key, {P: v}, "nav", "nominal", runs, succ, 0.0, 1.0, {}, dur, tort, None)


def table() -> list[ConfigStats]:
    return [cs("tree=0", 10, 10, 50.0, 0.01), cs("tree=2", 10, 9, 52.0, 0.012), cs("tree=4", 10, 5, 90.0, 0.2),
            cs("tree=6", 10, 4, 95.0, 0.25), cs("tree=8", 10, 2, 99.0, 0.3), cs("tree=10", 0, 0, None, None)]


def ref0(s: ConfigStats) -> bool:
    return s.config_key == "tree=0"


def test_paper_rule_on_a_hand_table() -> None:
    d = assign_levels(table(), ref0)
    assert {k[1]: v for k, v in d.levels.items()} == {
        "tree=0": EASY, "tree=2": EASY, "tree=4": CHALLENGING, "tree=6": CHALLENGING,
        "tree=8": VERY_DIFFICULT, "tree=10": NO_DATA}
    # features: min-max over the 4 clustered configs, times sqrt(weight)
    f = d.features[("trees", "tree=4")]
    assert f[0] == pytest.approx((0.5 - 0.4) / (1.0 - 0.4) * math.sqrt(0.5))
    assert f[1] == pytest.approx((90 - 50) / (95 - 50) * math.sqrt(0.25))
    assert f[2] == pytest.approx((0.2 - 0.01) / (0.25 - 0.01) * math.sqrt(0.25))
    assert d.level("trees", "nope") == NO_DATA


def test_threshold_is_a_parameter_and_inclusive_at_the_boundary() -> None:
    d = assign_levels(table(), ref0, DifficultyParams(threshold=0.45))
    assert d.level("trees", "tree=6") == VERY_DIFFICULT  # 0.4 < 0.45
    d = assign_levels(table(), ref0, DifficultyParams(threshold=0.2))
    assert d.level("trees", "tree=8") != VERY_DIFFICULT  # 0.2 is not below 0.2


def test_the_reference_cluster_is_easy_whatever_its_scores() -> None:
    t = [cs("tree=0", 10, 5, 90.0, 0.2), cs("tree=2", 10, 10, 50.0, 0.01), cs("tree=4", 10, 10, 51.0, 0.01),
         cs("tree=6", 10, 5, 92.0, 0.21)]
    d = assign_levels(t, ref0)
    assert [d.level("trees", k) for k in ("tree=0", "tree=2", "tree=4", "tree=6")] == [
        EASY, CHALLENGING, CHALLENGING, EASY]
    d2 = assign_levels(t, lambda s: False)  # no reference: the higher mean success rate is easy
    assert d2.level("trees", "tree=2") == EASY and d2.level("trees", "tree=0") == CHALLENGING
    assert any("no flat" in n for n in d2.notes)


def test_weights_change_the_split() -> None:
    # success separates {0, 2} from {4, 6}; duration separates {0, 4} from {2, 6}
    t = [cs("tree=0", 10, 10, 50.0, 0.1), cs("tree=2", 10, 10, 100.0, 0.1), cs("tree=4", 10, 5, 50.0, 0.1),
         cs("tree=6", 10, 5, 100.0, 0.1)]
    by_success = assign_levels(t, ref0, DifficultyParams(weights=(1.0, 0.0, 0.0)))
    by_duration = assign_levels(t, ref0, DifficultyParams(weights=(0.0, 1.0, 0.0)))
    assert by_success.level("trees", "tree=2") == EASY and by_success.level("trees", "tree=4") == CHALLENGING
    assert by_duration.level("trees", "tree=4") == EASY and by_duration.level("trees", "tree=2") == CHALLENGING


def test_ties_and_degenerate_inputs() -> None:
    same = [cs(f"tree={i}", 4, 4, 60.0, 0.1) for i in range(4)]
    d = assign_levels(same, ref0)
    assert set(d.levels.values()) == {EASY} and any("distinct" in n for n in d.notes)
    # duplicated points (ties) with two distinct groups: the duplicates stay together
    tied = [cs("tree=0", 4, 4, 60.0, 0.1), cs("tree=1", 4, 4, 60.0, 0.1), cs("tree=2", 4, 2, 90.0, 0.3),
            cs("tree=3", 4, 2, 90.0, 0.3)]
    d = assign_levels(tied, ref0)
    assert [d.level("trees", f"tree={i}") for i in range(4)] == [EASY, EASY, CHALLENGING, CHALLENGING]
    assert assign_levels([], ref0).levels == {}
    single = assign_levels([cs("tree=0", 1, 1, 10.0, 0.0)], ref0)
    assert single.level("trees", "tree=0") == EASY
    all_fail = assign_levels([cs("tree=0", 3, 0, None, None), cs("tree=2", 3, 0, None, None)], ref0)
    assert set(all_fail.levels.values()) == {VERY_DIFFICULT}


def test_same_input_same_levels_with_k3() -> None:
    a = assign_levels(table(), ref0, DifficultyParams(k=3, seed=5))
    b = assign_levels(table(), ref0, DifficultyParams(k=3, seed=5))
    assert a.levels == b.levels and a.level("trees", "tree=0") == EASY


@pytest.mark.parametrize("kw,field", [({"threshold": 1.5}, "threshold"), ({"k": 1}, "k"),
                                      ({"weights": (0.0, 0.0, 0.0)}, "weights"),
                                      ({"weights": (1.0, -1.0, 0.5)}, "weights")])
def test_bad_params_name_the_field(kw: dict[str, object], field: str) -> None:
    with pytest.raises(SpecError, match=field):
        DifficultyParams(**kw)  # type: ignore[arg-type]


def test_duplicate_configuration_is_refused() -> None:
    with pytest.raises(SpecError, match="one entry per configuration"):
        assign_levels([cs("tree=0", 1, 1, 1.0, 0.0)] * 2, ref0)


def test_ranges_and_fuzzy_overlaps() -> None:
    t = [cs("tree=0", 10, 10, 50.0, 0.01), cs("tree=2", 10, 5, 90.0, 0.2), cs("tree=4", 10, 9, 52.0, 0.02),
         cs("tree=6", 10, 4, 95.0, 0.25), cs("tree=8", 10, 1, 99.0, 0.3)]
    d = assign_levels(t, ref0)
    ranges, overlaps = level_ranges(t, d)
    got = {r.level: (r.values, r.lo, r.hi) for r in ranges}
    assert got[EASY] == ((0.0, 4.0), 0.0, 4.0)
    assert got[CHALLENGING] == ((2.0, 6.0), 2.0, 6.0)
    assert got[VERY_DIFFICULT] == ((8.0,), 8.0, 8.0)
    assert [(o.a, o.b, o.lo, o.hi) for o in overlaps] == [(EASY, CHALLENGING, 2.0, 4.0)]


def test_reference_keys_from_a_spec() -> None:
    spec = parse_campaign(spec_dict(defs=[0.0, 0.5]))
    assert reference_keys(spec) == {("trees", "tree=0"), ("smooth", "deformation=0")}
    assert is_flat_empty({"ground": {"subdivisions": 3, "deformation": 0.0}})
    assert not is_flat_empty({"obstacles": {"obstruction": {"building": 2}}})
