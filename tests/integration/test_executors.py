"""One executor contract: the local pool and Ray give the same results and the same words for
the same events (a world generation or a run over its wall-clock limit, a navigator that kills
its worker on every attempt), because the scheduling core is written once
(``navstress.campaign.scheduler``). And a Ray cluster that navstress starts listens on
127.0.0.1 only, outside any network namespace (the machine's own interfaces in view)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.support import executor_contract
from tests.support import loopback
from tests.support import ray_battery
from tests.support.built_once import built_once

pytestmark = pytest.mark.slow


def _local_contract(root: Path) -> dict[str, Any]:
    ex = executor_contract.LocalExecutor(2, {n["name"]: n["target"] for n in executor_contract.NAVS
                                             if "target" in n})
    out = executor_contract.scenarios(ex, root)
    out["worker"] = ex.worker
    return out


# each contract is built once in the session, also when pytest -n deals its tests to two workers
@pytest.fixture(scope="module")
def ray_contract(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The scenarios on the Ray cluster that navstress starts (in a fresh interpreter: the suite's
    one cluster, ``ray_battery``), with the sockets its processes held while it ran."""
    return ray_battery.battery(tmp_path_factory)


@pytest.fixture(scope="module")
def local_contract(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: dict[str, Any] = built_once(tmp_path_factory, "local-contract", _local_contract)
    return out


@pytest.fixture(params=["local", "ray"])
def contract(request: pytest.FixtureRequest) -> dict[str, Any]:
    got: dict[str, Any] = request.getfixturevalue(f"{request.param}_contract")
    return got


def test_ray_ignores_ray_address_and_starts_its_own_cluster(ray_contract: dict[str, Any]) -> None:
    """RAY_ADDRESS pointed at a dead address while the contract ran: RayExecutor with no address
    did not follow it (ray.init would have failed to connect) but started its own cluster (its
    GCS server and raylet among the contract's processes), on which the runs were recorded
    (their words: the tests around)."""
    assert {"gcs_server", "raylet"} <= {s[0] for s in ray_contract["sockets"]}, ray_contract["sockets"]
    assert ray_contract["runs"]["recorded"] == 2


def test_world_generation_over_its_limit_is_said_the_same_way(contract: dict[str, Any]) -> None:
    world = contract["world"]
    assert world["recorded"] == 0
    assert world["unfinished"] == ["world generation exceeded wall-clock limit (0.01 s)"]
    assert [(a[1], a[2], a[3]) for a in world["attempts"]] == [
        (i, "world", "world generation exceeded wall-clock limit (0.01 s)") for i in (1, 2, 3)]


def test_runs_end_the_same_way(contract: dict[str, Any]) -> None:
    runs, worker = contract["runs"], contract["worker"]
    assert runs["recorded"] == 2 and runs["unfinished"] == []
    recs = runs["records"]
    hang = f"run exceeded wall-clock limit ({executor_contract.HANG_LIMIT_S:g} s); worker killed"
    assert recs["hangs-v1"] == ["fail-other", hang]
    assert recs["exits-v1"][0] == "fail-other"
    assert executor_contract.normalised(recs["exits-v1"][1], worker) == \
        "run killed its WORKER (...), in 3 of 3 attempts with the same seeds"
    assert [(a[2], executor_contract.normalised(a[3], worker)) for a in runs["attempts"]] == \
        [("died", "run killed its WORKER (...)")] * 3


def test_both_executors_say_the_same(local_contract: dict[str, Any], ray_contract: dict[str, Any]) -> None:
    def words(c: dict[str, Any]) -> Any:
        return json.loads(executor_contract.normalised(json.dumps([c["world"], c["runs"]["attempts"],
                                                                    c["runs"]["records"]["hangs-v1"],
                                                                    c["runs"]["records"]["exits-v1"]]),
                                                       c["worker"]))
    assert words(local_contract) == words(ray_contract)


def test_ray_cluster_listens_on_loopback_only(ray_contract: dict[str, Any]) -> None:
    """Outside a network namespace: every socket of every process of the cluster (GCS, raylet,
    object manager, workers, runtime-env agent) is bound to 127.0.0.1 / ::ffff:127.0.0.1."""
    sockets = ray_contract["sockets"]
    names = {s[0] for s in sockets}
    assert {"gcs_server", "raylet"} <= names, sockets
    assert all(loopback.is_loopback(s[2]) for s in sockets), [s for s in sockets if not loopback.is_loopback(s[2])]
