"""One local Ray cluster for every Ray test of the suite.

Starting a Ray cluster and its fresh worker processes costs tens of seconds on a 2-core machine,
and two clusters started at once by two pytest workers slow each other down further. So the
suite starts one: a fresh interpreter runs the executor contract on a :class:`RayExecutor` that
starts navstress's own cluster (127.0.0.1 only, ``RAY_ADDRESS`` pointing at a dead address), then
every job that a test module registered here (:func:`register`): campaigns and searches run
through the public entry points (``run_campaign`` / ``run_search`` with ``executor="ray"``), which
join the cluster that process initialised, as a user's script that calls ``ray.init`` itself
does. Each job's result, or the traceback of its failure, is kept apart: a failing job fails its
own test only. The whole is built once per session (``built_once``), also under ``pytest -n``.

A test module registers at import, so the battery holds the jobs of the modules collected in the
session (under ``pytest -n`` every worker collects the same modules).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.support.built_once import built_once

ROOT = Path(__file__).resolve().parents[2]  # tests.support (executor_contract, navigators.campaign_navs) importable
#: What RAY_ADDRESS holds while the battery runs: nothing listens there.
DEAD_RAY_ADDRESS = "127.0.0.1:1"

#: name -> make(job directory, the session's TempPathFactory) -> the job (JSON: kind "campaign"
#: with spec, out, workers; or kind "search" with spec, out, budget, workers)
JOBS: dict[str, Callable[[Path, pytest.TempPathFactory], dict[str, Any]]] = {}


def register(name: str, make: Callable[[Path, pytest.TempPathFactory], dict[str, Any]]) -> None:
    """Add a job to the battery (call at the test module's import)."""
    JOBS[name] = make


def _build(root: Path, factory: pytest.TempPathFactory) -> dict[str, Any]:
    jobs = {}
    for name, make in sorted(JOBS.items()):
        (root / "jobs" / name).mkdir(parents=True)
        jobs[name] = make(root / "jobs" / name, factory)
    (root / "contract").mkdir()
    (root / "contract" / "jobs.json").write_text(json.dumps(jobs), encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    # with no address given navstress must not follow RAY_ADDRESS but start its own local cluster
    # (test_executors.test_ray_ignores_ray_address_and_starts_its_own_cluster)
    env["RAY_ADDRESS"] = DEAD_RAY_ADDRESS
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")])
    code = "import sys; from tests.support import executor_contract; executor_contract.main('ray', sys.argv[1])"
    p = subprocess.run([sys.executable, "-c", code, str(root / "contract")], env=env, capture_output=True,
                       text=True, timeout=580)
    assert p.returncode == 0, p.stderr[-3000:]
    out: dict[str, Any] = json.loads(p.stdout.strip().splitlines()[-1])
    assert sorted(out.get("jobs", {})) == sorted(jobs), (sorted(out.get("jobs", {})), sorted(jobs))
    return out


def battery(factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The contract's results on Ray (``world``, ``runs``, ``worker``, ``sockets``: the sockets the
    cluster's processes held) and ``jobs``: each registered job's result."""
    pytest.importorskip("ray", reason="ray is not installed (pip extra 'ray'; the 'test' extra installs it)")
    out: dict[str, Any] = built_once(factory, "ray-battery", lambda root: _build(root, factory))
    return out


def job(factory: pytest.TempPathFactory, name: str) -> dict[str, Any]:
    """The registered job ``name``'s result; fails with its traceback if it raised."""
    got: dict[str, Any] = battery(factory)["jobs"][name]
    assert "error" not in got, got.get("error")
    return got
