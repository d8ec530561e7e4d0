"""Build an expensive fixture once per test session, also under ``pytest -n`` (pytest-xdist):
every worker process of a session shares the parent of its base temporary directory, and the
first worker that asks builds the value there under a file lock while the others wait and read
it. (A module-scoped fixture alone is built by each worker that runs one of its tests: under -n,
tests of one module are dealt out to both workers.)

The traces the build writes are checked here (``trace_check``), once: under -n its directory lies
outside every worker's own base temporary directory, which the session's own check covers."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.support.trace_check import TraceChecker


def built_once(factory: pytest.TempPathFactory, name: str, build: Callable[[Path], Any]) -> Any:
    """``build(directory)`` run once in the session; returns what it returned (through JSON)."""
    base = factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    d = shared / f"once-{name}"
    with open(shared / f"once-{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = shared / f"once-{name}.json"
        if done.is_file():
            return json.loads(done.read_text(encoding="utf-8"))
        shutil.rmtree(d, ignore_errors=True)  # an earlier attempt that failed
        d.mkdir()
        value = build(d)
        bad = TraceChecker().check_under(d)
        assert not bad, f"traces written by the {name!r} build are invalid:\n" + "\n".join(bad)
        done.write_text(json.dumps(value), encoding="utf-8")
        return json.loads(done.read_text(encoding="utf-8"))
