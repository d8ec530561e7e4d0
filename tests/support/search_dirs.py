"""Two tiny real searches for the report's tests (unit and browser): a MAP-Elites search whose
archive's second axis is a space path (``ground.deformation``), with confirmed elites and a suite,
and a random-sampling baseline too small to confirm anything. Run once per test session, however
many xdist workers (a file lock over the workers' shared temporary directory, the pattern of
pytest-xdist's docs), in about ten seconds of runs."""

from __future__ import annotations

import fcntl
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml

from navstress.search.driver import run_search

BASE: dict[str, Any] = {
    "seed": 3,
    "world": {"size_m": [14.0, 14.0], "cell_m": 0.5,
              "mission": {"start": [3, 3, 0.785], "goal": [11, 11], "free_radius_m": 1.2}},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 5, "high": 30},
                             {"path": "ground.deformation", "low": 0, "high": 1.5}]},
    "navigator": {"name": "reference-v1", "config": {}},
    "faults": [None],
    "objective": {"name": "failure"},
    "timeout_s": 15.0,
}
#: MAP-Elites: one generation of 4 candidates x 2 runs, 2 elites confirmed with 2 fresh runs each.
SEARCH: dict[str, Any] = {**BASE, "name": "tiny", "budget": {"runs": 8}, "runs_per_candidate": 2,
                          "algorithm": {"name": "map-elites", "batch": 4, "descriptors": [
                              {"name": "obstruction", "low": 0, "high": 40, "cells": 4},
                              {"name": "ground.deformation", "low": 0, "high": 1.5, "cells": 3}]},
                          "confirm_runs": 2, "elites": 2}
#: Random sampling: 2 candidates x 1 run; 1 confirmation run proves nothing (no suite).
BASELINE: dict[str, Any] = {**BASE, "name": "tiny-random", "budget": {"runs": 2}, "runs_per_candidate": 1,
                            "algorithm": {"name": "random", "batch": 2}, "confirm_runs": 1, "elites": 1}


@dataclass(frozen=True)
class SearchDirs:
    search: Path
    baseline: Path


def search_dirs(factory: pytest.TempPathFactory, worker: str) -> SearchDirs:
    """The two searches, run on first use into a directory every worker of the session shares."""
    base = factory.getbasetemp()
    shared = (base.parent if worker != "master" else base) / "search-report"
    shared.mkdir(parents=True, exist_ok=True)
    out = SearchDirs(shared / "search", shared / "baseline")
    with open(shared / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (shared / "done").exists():
            for spec, d in ((SEARCH, out.search), (BASELINE, out.baseline)):
                path = shared / f"{d.name}.yaml"
                path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
                run_search(path, d, workers=1)
            (shared / "done").write_text("ok\n", encoding="utf-8")
    return out
