"""Shared fixtures. Helpers that are not fixtures live in the ``tests.support`` package
(``from tests.support.world_fixtures import small_world``), never in a ``conftest`` module.

Every MCAP trace any test writes is checked (``trace_check``): messages in log-time order in
the file, a valid summary. Per test under its ``tmp_path``, and once at the end of the session
under the whole base temporary directory (traces written by module- or session-scoped
fixtures). A test that writes junk ``*.mcap`` files on purpose is marked ``not_traces``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

# Bytecode cached for the whole session, first thing (before the test modules are imported):
# with PYTHONDONTWRITEBYTECODE set (some shells and CI images set it) nothing was ever cached, so
# each pytest worker re-compiled and assertion-rewrote every test module (~half of collection's
# CPU), and every process the suite starts (the CLI's and campaigns' spawned workers, CLI
# subprocesses, navigators, nested pytest runs) compiled navstress's sources again (~0.25 s of
# CPU each). The *.pyc files land in __pycache__ folders that .gitignore lists; the numba cache's
# key hashes *.py and *.c only. Nothing a test checks depends on it (docs/performance.md).
if os.environ.pop("PYTHONDONTWRITEBYTECODE", None) is not None:  # the children inherit the environment
    sys.dont_write_bytecode = False

import pytest
from hypothesis import settings

from tests.support.search_dirs import SearchDirs, search_dirs
from tests.support.trace_check import TraceChecker
from tests.support.world_fixtures import small_world
from navstress.world import World

_CHECKER = TraceChecker()

# No per-example time limit for property tests: the suite runs on loaded 2-core machines, where
# hypothesis's default 200 ms deadline fails a correct test by wall-clock luck (speed is checked by
# benchmarks, never by timed tests). Every other setting stays hypothesis's default or the test's own.
settings.register_profile("navstress", deadline=None)
settings.load_profile("navstress")


def pytest_sessionstart(session: pytest.Session) -> None:
    """numba's kernels compiled once before the test workers start (``make test`` has done it
    beside mypy; then this finds the cache warm and returns at once)."""
    if not hasattr(session.config, "workerinput"):  # the controller (or a run without xdist)
        from tests.support.numba_warm import warm
        warm()


@pytest.fixture(autouse=True, scope="session")
def _charts_validated() -> None:
    """Every chart a test builds is validated against the Vega-Lite schema (a report skips it)."""
    from navstress.analysis import charts
    charts.VALIDATE = True


@pytest.fixture
def world() -> World:
    return small_world()


@pytest.fixture(autouse=True, scope="session")
def _every_trace_checked(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    yield
    bad = _CHECKER.check_under(tmp_path_factory.getbasetemp())
    assert not bad, "traces written by the tests are invalid:\n" + "\n".join(bad)


@pytest.fixture(autouse=True)
def _traces_checked(request: pytest.FixtureRequest) -> Iterator[None]:
    yield
    tmp = request.node.funcargs.get("tmp_path") if hasattr(request.node, "funcargs") else None
    if not isinstance(tmp, Path):
        return
    if request.node.get_closest_marker("not_traces") is not None:
        _CHECKER.ignore_under(tmp)
        return
    bad = _CHECKER.check_under(tmp)
    assert not bad, "traces written by this test are invalid:\n" + "\n".join(bad)


@pytest.fixture(scope="session")
def tiny_searches(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> SearchDirs:
    """Two tiny real search directories (``search_dirs``), run once per session."""
    return search_dirs(tmp_path_factory, worker_id)
