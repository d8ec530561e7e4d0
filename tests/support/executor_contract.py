"""The executor contract, run against any executor (local pool, Ray): what the scheduling core
makes of a world generation over its limit, a run over its limit, a navigator that kills its
worker on every attempt, and a good run. Importable by a subprocess (``python -c``), so a Ray
cluster never starts inside the test process.

    python -c "from tests.support import executor_contract; executor_contract.main('ray', DIR)"   # prints JSON

On Ray the suite starts one cluster for all its Ray tests (``tests/support/ray_battery.py``): after the
scenarios, :func:`main` runs the jobs listed in ``DIR/jobs.json`` (campaigns and searches other
test modules registered) on the same cluster, through the public entry points, which join the
cluster this process initialised.
"""

from __future__ import annotations

import json
import os
import re
import sys
import traceback
from pathlib import Path
from typing import Any

import yaml

from tests.support import loopback
from navstress.campaign.local import LocalExecutor
from navstress.campaign.ray_executor import RayExecutor
from navstress.campaign.scheduler import Executor, resume
from navstress.campaign.spec import load_campaign
from navstress.campaign.store import Store
from navstress.campaign.executors import run_campaign
from navstress.search.driver import run_search

#: The wall-clock limit of the crashing navigator's runs (a Ray task's clock starts when it is
#: submitted: the limit leaves a fresh Ray worker the time to start on a busy machine).
WALL_LIMIT_S = 40.0
#: The wall-clock limit of the hanging navigator's run (it lasts that long; started late on a
#: busy machine, it ends the same way).
HANG_LIMIT_S = 8.0
NAVS = [{"name": "reference-v1"},
        {"name": "hangs-v1", "target": "tests.support.navigators.campaign_navs:Hangs", "config": {"after_s": 0.2}},
        {"name": "exits-v1", "target": "tests.support.navigators.campaign_navs:Exits", "config": {"after_s": 0.2}}]


def _spec(root: Path, name: str, navigators: list[dict[str, Any]], size_m: float = 20.0) -> Path:
    d = {"name": name, "seed": 5, "world": {"size_m": [size_m, size_m], "cell_m": 0.5},
         "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0 if size_m < 50 else 10]}}}],
         "maps_per_config": 1, "runs_per_map": 1, "navigators": navigators, "timeout_s": 3.0}
    path = root / f"{name}.yaml"
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    return path


def _session(ex: Executor, spec: Path, out: Path, **limits: float) -> dict[str, Any]:
    with Store.create(out, *load_campaign(spec)) as store:
        s = resume(store, ex, **limits)  # type: ignore[arg-type]
        attempts = [list(a) for r in store.planned_ids() for a in store.attempts(r)]
        records = {r.navigator: [r.outcome, r.reason] for r in store.records()}
    return {"recorded": s.recorded, "unfinished": sorted(s.unfinished.values()), "attempts": attempts,
            "records": records}


def scenarios(ex: Executor, root: Path) -> dict[str, Any]:
    """Three campaigns on one executor: a world that never generates within its limit; then the
    hanging navigator (a short limit: its run lasts that long), and the crashing navigator (a long
    one, which its crashes never reach), on a world that does."""
    # a 200 m world takes about a second to generate: far over its limit, whatever the load
    world = _session(ex, _spec(root, "world", NAVS[:1], 200.0), root / "world", wall_limit_s=60.0,
                     world_limit_s=0.01)
    hang = _session(ex, _spec(root, "hang", NAVS[1:2]), root / "hang", wall_limit_s=HANG_LIMIT_S)
    crash = _session(ex, _spec(root, "crash", NAVS[2:]), root / "crash", wall_limit_s=WALL_LIMIT_S)
    runs = {"recorded": hang["recorded"] + crash["recorded"], "unfinished": hang["unfinished"] + crash["unfinished"],
            "attempts": hang["attempts"] + crash["attempts"], "records": {**hang["records"], **crash["records"]}}
    return {"world": world, "runs": runs}


def normalised(reason: str, worker: str) -> str:
    """``reason`` with the executor's own words (its worker's name, how it died) taken out."""
    return re.sub(r"\(([^()]|\([^()]*\))*\)", "(...)", reason.replace(worker, "WORKER"))


def job(spec: dict[str, Any]) -> dict[str, Any]:
    """One registered job (``ray_battery``) on the Ray cluster this process runs: its result, or
    the traceback of its failure (which fails its own test only)."""
    try:
        if spec["kind"] == "campaign":
            res = run_campaign(spec["spec"], spec["out"], workers=spec["workers"], executor="ray")
            return {"out": spec["out"], "recorded": res.recorded, "planned": res.planned, "workers": res.workers}
        got = run_search(spec["spec"], spec["out"], budget=spec["budget"], workers=spec["workers"], executor="ray")
        return {"out": spec["out"], "unfinished": sorted(got.unfinished.items()), "runs": got.runs}
    except Exception:
        return {"out": spec["out"], "error": traceback.format_exc()}


def main(kind: str, root: str) -> None:
    """Run :func:`scenarios` on a fresh executor of ``kind`` (Ray: then the jobs of
    ``root/jobs.json``, if any, on the same cluster); print the JSON (last line)."""
    ex: Any
    if kind == "ray":
        ex = RayExecutor(2, {n["name"]: n["target"] for n in NAVS if "target" in n})
    else:
        ex = LocalExecutor(2, {n["name"]: n["target"] for n in NAVS if "target" in n})
    try:
        out = scenarios(ex, Path(root))
        if kind == "ray":
            out["sockets"] = loopback.sockets_of_tree(os.getpid())
            jobs = Path(root) / "jobs.json"
            if jobs.is_file():
                out["jobs"] = {name: job(spec) for name, spec in json.loads(jobs.read_text()).items()}
    finally:
        if kind == "ray":
            ex.close()
    out["worker"] = ex.worker
    sys.stdout.write(json.dumps(out) + "\n")
