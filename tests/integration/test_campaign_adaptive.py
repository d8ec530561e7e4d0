"""Adaptive repetition end to end: real missions in worker processes, a real SQLite store,
SIGKILL of the driver, the local pool with 1 and 2 workers, and Ray once.

The navigators are ``campaign_navs:Coin`` (tests/support/navigators): each run is a real mission on a
small generated world that ends after one control cycle, a success with probability ``p`` drawn
from the run's seed, so the streams stop at varied run counts within seconds.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support import ray_battery
from tests.support.built_once import built_once
from tests.support.campaign_kill import kill_when_recorded
from navstress.campaign.executors import run_campaign
from navstress.campaign.store import Store
from navstress.sequential import decide, should_continue

ROOT = str(Path(__file__).resolve().parents[2])
SRC = str(Path(__file__).resolve().parents[2] / "src")

pytestmark = pytest.mark.slow  # real campaigns (built once), Ray

RULE = {"min": 3, "max": 12, "threshold": 0.5, "confidence": 0.8}
SPEC: dict[str, Any] = {
    "name": "adaptive", "seed": 3,
    "world": {"size_m": [12.0, 12.0], "cell_m": 0.5,
              "mission": {"start": [5.0, 5.0, 0.0], "goal": [6.0, 5.0], "free_radius_m": 1.0}},
    "experiments": [
        {"name": "coins", "sweep": {"obstacles.obstruction.tree": {"values": [0]}},
         "runs_per_map": {"adaptive": RULE}},
        {"name": "fixed", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}},
    ],
    "maps_per_config": 2, "runs_per_map": 2,
    "navigators": [{"name": "coin-v1", "target": "tests.support.navigators.campaign_navs:Coin", "config": {"p": 0.5}},
                   {"name": "coin-v2", "target": "tests.support.navigators.campaign_navs:Coin", "config": {"p": 0.95}}],
    "faults": [None], "timeout_s": 5.0, "goal_tolerance_m": 2.0}


def _write(path: Path) -> Path:
    path.write_text(yaml.safe_dump(SPEC, sort_keys=False))
    return path


def _runs(out: Path) -> dict[str, str]:
    with Store.open(out) as s:
        return s.outcomes()


def _uninterrupted(root: Path) -> str:
    res = run_campaign(_write(root / "spec.yaml"), root / "out", workers=2)
    assert res.recorded == res.planned and res.already_done == 0 and not res.unfinished
    return str(root / "out")


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The campaign run without interruption, built once in the session (the tests only read it)."""
    return Path(built_once(tmp_path_factory, "adaptive-uninterrupted", _uninterrupted))


def test_each_stream_stops_where_the_rule_says(uninterrupted: Path) -> None:
    with Store.open(uninterrupted) as s:
        p = s.plan()
        outcomes = s.outcomes()
        tasks = {t.run_id: t for t in p.tasks}
        stops = []
        for st in p.streams:
            got = [r for r in st.run_ids if r in outcomes]
            assert got == list(st.run_ids[:len(got)]), f"runs of a stream recorded out of order: {got}"
            if st.rule is None:
                assert len(got) == len(st.run_ids) == 2
                continue
            wins = [outcomes[r] == "success" for r in got]
            n = len(got)
            for k in range(st.rule.min_runs, n):  # every run past min was due: the rule said continue
                assert should_continue(sum(wins[:k]), k, st.rule), (got, k)
            assert n >= st.rule.min_runs and not should_continue(sum(wins), n, st.rule), got  # and it stopped
            stops.append((tasks[got[0]].navigator, n, decide(sum(wins), n, st.rule)))
        # the streams stopped at varied counts: some decided early, some ran to max undecided
        assert len({n for _, n, _ in stops}) >= 2 and any(n < RULE["max"] for _, n, _ in stops), stops
        assert s.progress() == (len(outcomes), len(outcomes))
        assert all(d == p for _, d, p, _ in s.per_experiment())
        # paired: run r of both navigators on a map has the same run seed
        recs = {r.run_id: r for r in s.records()}
        for r in recs.values():
            twin = r.run_id.replace(f"/{r.navigator}/", "/coin-v1/" if r.navigator == "coin-v2" else "/coin-v2/")
            if twin in recs:
                assert recs[twin].run_seed == r.run_seed


def test_one_worker_gives_the_same_final_set(uninterrupted: Path, tmp_path: Path) -> None:
    res = run_campaign(_write(tmp_path / "spec.yaml"), tmp_path / "out", workers=1)
    assert _runs(tmp_path / "out") == _runs(uninterrupted) and res.planned == len(_runs(uninterrupted))
    again = run_campaign(tmp_path / "spec.yaml", tmp_path / "out", workers=2)  # finished: nothing more is due
    assert again.recorded == 0 and again.planned == again.already_done


_DRIVER = ("import sys; from navstress.campaign.executors import run_campaign\n"
           "if __name__ == '__main__':\n    run_campaign(sys.argv[1], sys.argv[2], workers=2)\n")


@pytest.mark.slow
@pytest.mark.parametrize("kill_after", [1, 9, 20])
def test_sigkill_then_resume_gives_the_same_final_set(uninterrupted: Path, tmp_path: Path, kill_after: int) -> None:
    spec, out = _write(tmp_path / "spec.yaml"), tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([SRC, ROOT, os.environ.get("PYTHONPATH", "")])}
    driver = tmp_path / "driver.py"
    driver.write_text(_DRIVER)
    proc = subprocess.Popen([sys.executable, str(driver), str(spec), str(out)], env=env)
    kill_when_recorded(proc, out / "campaign.sqlite", kill_after)  # and its workers are gone
    assert proc.returncode == -signal.SIGKILL, "the driver finished before it could be killed"
    before = _runs(out)
    full = _runs(uninterrupted)
    assert kill_after <= len(before) < len(full)
    assert all(full.get(r) == o for r, o in before.items())  # nothing recorded that the full campaign lacks
    res = run_campaign(spec, out, workers=2)
    assert _runs(out) == full  # none lost, none doubled (run_id is the key), none extra
    assert res.already_done == len(before) and res.already_done + res.recorded == res.planned == len(full)
    assert [p for p in out.rglob(".*") if p.name != ".lock"] == []


def _ray_job(root: Path, factory: pytest.TempPathFactory) -> dict[str, Any]:
    return {"kind": "campaign", "spec": str(_write(root / "spec.yaml")), "out": str(root / "out"), "workers": 2}


ray_battery.register("adaptive", _ray_job)


@pytest.mark.slow
def test_ray_executor_gives_the_same_final_set(uninterrupted: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    """On the suite's one local Ray cluster (``ray_battery``)."""
    res = ray_battery.job(tmp_path_factory, "adaptive")
    assert res["recorded"] == res["planned"] == len(_runs(uninterrupted))
    assert _runs(Path(res["out"])) == _runs(uninterrupted)


def test_analysis_counts_a_finished_adaptive_campaign_complete(uninterrupted: Path) -> None:
    from navstress.analysis.analyze import analyze

    a = analyze(uninterrupted)
    assert a.done == a.planned == len(_runs(uninterrupted)) and a.missing == []
    coins = [s for s in a.stats if s.experiment == "coins"]
    assert coins and all(s.runs == s.planned for s in coins) and any(s.planned < 2 * RULE["max"] for s in coins)
