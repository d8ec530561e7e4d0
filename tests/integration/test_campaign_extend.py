"""A campaign grown by ``Store.extend`` generation after generation, end to end: real missions in
worker processes, a real SQLite store, SIGKILL of the driver around an extension and during the
next generation's runs, then resumed:
no run lost, doubled or extra, and every run's seeds those of the grown spec's plan.

The navigator is ``campaign_navs:Coin`` (one control cycle per run, a success drawn from the
run seed) on small explicit worlds, so a generation takes seconds.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support.campaign_kill import kill_when_recorded
from navstress.campaign.local import LocalExecutor
from navstress.campaign.plan import plan
from navstress.campaign.scheduler import resume
from navstress.campaign.spec import load_campaign
from navstress.campaign.store import Store

ROOT = str(Path(__file__).resolve().parents[2])
SRC = str(Path(__file__).resolve().parents[2] / "src")
TARGETS = {"coin-v1": "tests.support.navigators.campaign_navs:Coin"}

pytestmark = pytest.mark.slow


def _gen(g: int) -> dict[str, Any]:
    return {"name": f"g{g:04d}", "worlds": [{"key": f"c{i}", "map_seed": 10 * g + i,
                                             "world": {"obstacles": {"obstruction": {"tree": i}}}} for i in range(2)]}


def _spec(generations: int) -> dict[str, Any]:
    return {
        "name": "grown", "seed": 5,
        "world": {"size_m": [12.0, 12.0], "cell_m": 0.5,
                  "mission": {"start": [5.0, 5.0, 0.0], "goal": [6.0, 5.0], "free_radius_m": 1.0}},
        "experiments": [_gen(g) for g in range(generations)], "runs_per_map": 2,
        "navigators": [{"name": "coin-v1", "target": "tests.support.navigators.campaign_navs:Coin", "config": {"p": 0.5}}],
        "faults": [None], "timeout_s": 5.0, "goal_tolerance_m": 2.0}


#: Runs per generation (2 worlds x 2 runs), and generations.
PER_GEN, GENS = 4, 2

_DRIVER = """
import sys
from navstress.campaign.local import LocalExecutor
from navstress.campaign.scheduler import resume
from navstress.campaign.spec import load_campaign
from navstress.campaign.store import Store

if __name__ == "__main__":
    out, paths = sys.argv[1], sys.argv[2:]
    ex = LocalExecutor(1, {"coin-v1": "tests.support.navigators.campaign_navs:Coin"}, warm=False)
    with Store.create(out, *load_campaign(paths[0])) as store:
        resume(store, ex, wall_limit_s=60)
        for p in paths[1:]:
            store.extend(*load_campaign(p))
            resume(store, ex, wall_limit_s=60)
"""


def _specs(root: Path) -> list[Path]:
    out = []
    for g in range(1, GENS + 1):
        p = root / f"gen{g}.yaml"
        p.write_text(yaml.safe_dump(_spec(g), sort_keys=False))
        out.append(p)
    return out


def _drive(root: Path, out: Path) -> subprocess.Popen[bytes]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([SRC, ROOT, os.environ.get("PYTHONPATH", "")])}
    driver = root / "driver.py"
    driver.write_text(_DRIVER)
    return subprocess.Popen([sys.executable, str(driver), str(out), *map(str, _specs(root))], env=env)


def _runs(out: Path) -> dict[str, str]:
    with Store.open(out) as s:
        return s.outcomes()


@pytest.mark.parametrize("kill_after", [PER_GEN, PER_GEN + 1])
def test_sigkill_during_extend_and_runs_then_resume_loses_and_doubles_nothing(tmp_path: Path, kill_after: int) -> None:
    """``kill_after`` records: generation 1's last (the driver then stops its workers and
    extends the store), or one run into generation 2. The resumed driver extends the store to the last spec
    (``Store.create(..., extend=True)``) and runs what is missing."""
    out = tmp_path / "out"
    proc = _drive(tmp_path, out)
    kill_when_recorded(proc, out / "campaign.sqlite", kill_after, timeout_s=240, poll_s=0.02)
    assert proc.returncode == -signal.SIGKILL, "the driver finished before it could be killed"
    before = _runs(out)
    assert kill_after <= len(before) < PER_GEN * GENS
    time.sleep(0.6)  # orphaned workers notice the dead parent and exit
    spec, text = load_campaign(tmp_path / f"gen{GENS}.yaml")
    tasks = {t.run_id: t for t in plan(spec, out).tasks}
    with Store.create(out, spec, text, extend=True) as store:
        assert store.planned_ids() == list(tasks)
        s = resume(store, LocalExecutor(2, TARGETS, warm=False), wall_limit_s=60)
        assert s.already_done == len(before) and s.already_done + s.recorded == s.planned == len(tasks)
        rows = [r[0] for r in store.con.execute("SELECT run_id FROM runs")]
        records = store.records()
    assert sorted(rows) == sorted(tasks) and len(rows) == len(set(rows))  # none lost, doubled or extra
    assert all(_runs(out)[r] == o for r, o in before.items())
    for r in records:
        t = tasks[r.run_id]
        assert (r.map_seed, r.run_seed, r.config) == (t.map_seed, t.run_seed, t.config)
        assert r.outcome in ("success", "fail-error") and r.trace and (out / r.trace).is_file()
    assert {r.map_seed for r in records if r.experiment == "g0001"} == {10, 11}
    assert (out / "spec.yaml").read_text() == text
    assert [p for p in out.rglob(".*") if p.name != ".lock"] == []
