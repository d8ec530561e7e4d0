"""The driver's pure parts: what NSGA-II is told (two objectives), when a candidate counts as
found, and the found-vs-runs curve (property-tested over random evaluation histories)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.search.driver import Evaluated, SearchResult, _found, _objectives
from navstress.search.space import Candidate
from navstress.search.spec import parse_search

BASE: dict[str, Any] = {
    "name": "s", "seed": 1, "world": {"size_m": [40.0, 40.0], "cell_m": 0.5},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 20}]},
    "objective": {"name": "failure"}, "budget": {"runs": 400},
}


def _spec(algorithm: str, objective: str = "failure") -> Any:
    obj: dict[str, Any] = {"name": objective}
    if objective == "fault-revealing":
        obj["fault"] = "small-footprint"
    return parse_search({**BASE, "objective": obj, "algorithm": {"name": algorithm, "batch": 4}})


def test_nsga2_is_told_the_fitness_and_the_closeness_of_the_first_descriptor_to_its_low_end() -> None:
    spec = _spec("nsga2")  # default descriptors: obstruction [0, 40], path_ratio [1, 2]
    F = _objectives(spec, [0.5, 1.0, 0.0, 0.25], [(0.0, 1.0), (40.0, 1.5), (10.0, 2.0), (80.0, 1.0)])
    assert F.shape == (4, 2)
    np.testing.assert_allclose(F[:, 0], [0.5, 1.0, 0.0, 0.25])
    np.testing.assert_allclose(F[:, 1], [1.0, 0.0, 0.75, 0.0])  # clipped outside the range


def test_the_other_algorithms_are_told_the_fitness_alone() -> None:
    for name in ("random", "map-elites", "cma-me", "ga"):
        F = _objectives(_spec(name), [0.5, 0.0], [(1.0, 1.0), (2.0, 1.0)])
        assert F.shape == (2,) and list(F) == [0.5, 0.0]


def test_found_means_the_event_was_seen() -> None:
    for obj in ("failure", "fault-revealing", "illumination"):
        spec = _spec("random", obj) if obj != "illumination" else parse_search({**BASE, "objective": {
            "name": "illumination", "descriptors": [{"name": "obstruction", "low": 0, "high": 40},
                                                    {"name": "path_ratio", "low": 1, "high": 3}]}})
        assert _found(spec, 1, 3, 1 / 3) and not _found(spec, 0, 3, 0.0)
        assert not _found(spec, 3, 3, 0.0)  # an infeasible world: failures, no fitness
    b = _spec("random", "boundary")
    assert _found(b, 1, 3, 0.6) and not _found(b, 0, 3, 0.0) and not _found(b, 3, 3, 0.0)


def _cand(key: str) -> Candidate:
    return Candidate(key, 1, {}, {})


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.tuples(st.sampled_from("abcdef"), st.booleans()), min_size=1, max_size=5),
                min_size=1, max_size=6), st.integers(1, 8))
def test_found_curve_counts_distinct_worlds_per_generation_monotone(gens: list[list[tuple[str, bool]]],
                                                                   per: int) -> None:
    res = SearchResult(Path("."), _spec("random"))
    runs = 0
    for g, cands in enumerate(gens):
        runs += per * len(cands)
        for key, found in cands:
            res.evaluated.append(Evaluated(g, _cand(key), float(found), None, int(found), 1, (0.0, 0.0), per, runs,
                                           found))
    res.generations = len(gens)
    curve = res.found_curve()
    assert curve[0] == (0, 0) and len(curve) == len(gens) + 1
    assert all(a[0] < b[0] and a[1] <= b[1] for a, b in zip(curve, curve[1:]))
    assert curve[-1] == (runs, len({k for cands in gens for k, f in cands if f}))
