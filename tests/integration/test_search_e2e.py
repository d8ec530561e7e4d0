"""``navstress search`` end to end with REAL missions on small 20 m worlds (timeout 30 s, where
reference-v1 sometimes reaches the goal and sometimes does not).

One finished search (``reference``: MAP-Elites, two generations of three worlds, two runs each,
run through the CLI in this process with two workers) is shared by the tests that read it:
search.json against the store, a finished search run again (nothing recorded, the same bytes),
its suite re-run with ``campaign run`` and ``gate`` against a faulty stack. The same command
SIGKILLed and SIGTERMed at random moments (one worker) and the same search on a local Ray
cluster end with byte-identical search.json and traces. The other algorithms run through the
driver on one-generation searches.
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support import ray_battery
from tests.support.built_once import built_once
from tests.support.campaign_kill import descendants, recorded, wait_gone
from tests.support.cli_run import cli
from tests.support.search_checks import check_search, result, traces
from navstress.campaign.store import Store
from navstress.search.driver import run_search

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ENV = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
ENV["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")])

#: One generation: 3 worlds x 2 runs. The spec's budget holds one generation; the commands
#: below give --budget 12 (two): the search goes on past its spec's budget.
SPEC: dict[str, Any] = {
    "name": "tiny", "seed": 3,
    "world": {"size_m": [20.0, 20.0], "cell_m": 0.5,
              "mission": {"start": [4.0, 4.0, 0.785], "goal": [13.0, 13.0], "free_radius_m": 1.5}},
    "space": {"parameters": [{"path": "obstacles.obstruction.tree", "low": 0, "high": 25},
                             {"path": "ground.deformation", "low": 0, "high": 2}],
              "map_seed": True, "map_seeds": 1000},
    "objective": {"name": "failure"}, "budget": {"runs": 6}, "runs_per_candidate": 2,
    "algorithm": {"name": "map-elites", "batch": 3}, "confirm_runs": 2, "elites": 2, "timeout_s": 30.0}
BUDGET = 12
GEN_RUNS = 6


def _write(path: Path, data: dict[str, Any]) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def _reference(root: Path) -> list[str]:
    spec = _write(root / "tiny.yaml", SPEC)
    out = root / "ref"
    code, stdout, stderr = cli("search", str(spec), "-o", str(out), "--budget", str(BUDGET), "-j", "2", "-q")
    assert code == 0, stderr
    return [str(spec), str(out), stdout]


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    """(spec, search directory, stdout) of the uninterrupted search, two workers: built once in
    the session (the tests only read it)."""
    spec, out, stdout = built_once(tmp_path_factory, "search-reference", _reference)
    return Path(spec), Path(out), stdout


def test_search_json_is_the_store_and_the_elites_are_confirmed(reference: tuple[Path, Path, str]) -> None:
    spec, out, stdout = reference
    data = check_search(out)
    assert data["generations"] == 2 and data["runs"] == BUDGET and data["stopped"] == "budget.runs"
    assert data["budget"]["runs"] == BUDGET  # the --budget given, past the spec's 6
    outcomes = {r.outcome for r in Store.open(out).records()}
    assert "success" in outcomes and outcomes - {"success"}, f"the space should give mixed outcomes: {outcomes}"
    assert data["found"] >= 1 and data["elites"] and data["confirmed"] >= 1, data["elites"]
    assert f"{out}: 2 generations, 6 candidates, 12/12 runs (stopped at budget.runs)" in stdout
    assert f"suite: {out / 'suite' / 'suite.yaml'}" in stdout


def test_a_finished_search_run_again_records_nothing_and_writes_the_same(reference: tuple[Path, Path, str],
                                                                         tmp_path: Path) -> None:
    spec, out, _ = reference
    copy = tmp_path / "again"
    shutil.copytree(out, copy)
    before = (copy / "search.json").read_bytes(), (copy / "search.yaml").read_bytes()
    res = run_search(spec, copy, budget=BUDGET, workers=1)
    assert res.recorded == 0 and res.ended_before and res.budget_unused is None
    assert ((copy / "search.json").read_bytes(), (copy / "search.yaml").read_bytes()) == before
    # another budget cannot reopen the generations (the confirmation follows them): the CLI
    # says so, and the result keeps the budget they ended with
    for argv, given in ((["--budget", "30"], "--budget 30"), ([], "budget.runs=6")):
        code, stdout, stderr = cli("search", str(spec), "-o", str(copy), *argv, "-q")
        assert code == 0, stderr
        assert f"note: this search had already ended: {given} changes nothing" in stdout, stdout
        assert ((copy / "search.json").read_bytes(), (copy / "search.yaml").read_bytes()) == before
    with Store.open(copy) as s:
        assert s.progress() == (len(traces(out)), len(traces(out)))


def test_the_suite_reruns_with_campaign_run_and_gates_a_faulty_stack(reference: tuple[Path, Path, str],
                                                                     tmp_path: Path) -> None:
    """suite/suite.yaml is a campaign spec: run as written it rebuilds the very worlds the search
    confirmed; with `faults: [small-footprint]` it is the regression suite of a faulty stack."""
    _, out, _ = reference
    data = result(out)
    confirmed = [e for e in data["elites"] if e["confirmed"]]
    suite = yaml.safe_load((out / "suite" / "suite.yaml").read_text(encoding="utf-8"))
    suite["faults"] = ["small-footprint"]
    spec = _write(tmp_path / "suite.yaml", suite)
    code, stdout, stderr = cli("campaign", "run", str(spec), "-o", str(tmp_path / "run"), "-q", "-j", "2")
    assert code == 0, stderr
    with Store.open(tmp_path / "run") as s:
        recs = s.records()
    assert sorted({r.run_id.split("/")[1] for r in recs}) == sorted(e["key"] for e in confirmed)
    assert {r.fault for r in recs} == {"small-footprint"} and len(recs) == len(confirmed) * suite["runs_per_map"]
    for e in confirmed:  # the same world, regenerated from its map seed and overrides
        assert (tmp_path / "run" / "worlds" / "suite" / e["key"] / "m0" / "world.json").read_bytes() == \
            (out / "suite" / "worlds" / e["key"] / "world.json").read_bytes()
    failed = sum(r.outcome != "success" for r in recs)
    code, stdout, stderr = cli("gate", str(tmp_path / "run"), "--min-success", "0.9", "--fault", "small-footprint")
    assert code == (1 if failed else 0), stdout + stderr
    assert f"{len(confirmed)} configuration" in stdout and "small-footprint" in stdout, stdout


# ---- kill and resume ---------------------------------------------------------------------------


def _search(spec: Path, out: Path) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "navstress.cli", "search", str(spec), "-o", str(out),
                             "--budget", str(BUDGET), "-j", "1", "-q"], env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _partials(out: Path) -> list[Path]:
    return [p for p in out.rglob(".*") if p.name != ".lock"]


def _files(out: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != ".lock"}


def _stop_at(proc: subprocess.Popen[str], out: Path, count: int, delay_s: float, sig: signal.Signals,
             bound_s: float = 300.0) -> tuple[int, str]:
    """Once ``out``'s store holds ``count`` records, wait ``delay_s`` more, send ``sig`` and
    wait for the process and its workers to end: (records then, stderr). On a resumed store the
    process must have recorded one run itself first: a store that already holds ``count`` records
    would have it signalled while Python still starts, before the command installs its handlers."""
    db = out / "campaign.sqlite"
    before = recorded(db)  # the process just started: nothing of it recorded yet
    if before:
        count = max(count, before + 1)
    deadline = time.monotonic() + bound_s
    while proc.poll() is None and ((n := recorded(db)) is None or n < count):  # None: no store yet
        assert time.monotonic() < deadline, f"{count} records were not in {db} within {bound_s:g} s"
        time.sleep(0.02)
    time.sleep(delay_s)
    assert proc.poll() is None, f"the search ended (exit {proc.returncode}) before it could be stopped at {count}"
    workers = descendants(proc.pid)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    wait_gone(workers)
    return recorded(db) or 0, err


def test_killed_and_stopped_at_random_moments_it_resumes_to_the_same_bytes(reference: tuple[Path, Path, str],
                                                                           tmp_path: Path) -> None:
    """SIGKILL within a generation (world generation, runs, the store's extension, the tell: a
    random delay after a random record count), SIGTERM (exit 143, one line saying how to
    resume), SIGKILL during the confirmation; each time the same command resumes. The search
    ends as the uninterrupted one did (two workers there, one here), byte for byte, every run
    recorded once. A kill moment is drawn from a seed printed on failure."""
    spec, ref, _ = reference
    seed = int(os.environ.get("NAVSTRESS_KILL_SEED", time.time_ns() % 10**6))
    rng = random.Random(seed)
    out = tmp_path / "k"
    total = BUDGET + result(ref)["confirm_runs"]
    plan = [(rng.randrange(0, GEN_RUNS), rng.uniform(0.0, 1.5), signal.SIGKILL),
            (rng.randrange(GEN_RUNS + 1, BUDGET - 1), rng.uniform(0.0, 0.3), signal.SIGTERM),
            (BUDGET + 1, 0.0, signal.SIGKILL)]
    for count, delay, sig in plan:
        at, err = _stop_at(_search(spec, out), out, count, delay, sig)
        assert at < total, f"seed {seed}: stopped at {at} records, after the end"
        if sig == signal.SIGTERM:
            lines = err.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("stopped by SIGTERM"), (seed, err)
            assert f"resume with: navstress search {spec} -o {out} --budget {BUDGET}" in lines[0], (seed, err)
            assert _partials(out) == [], seed  # a SIGKILL leaves them: the next resume removes them
            # two generations stored: the spec's budget (one) does not hold them
            before = _files(out)
            code, stdout, stderr = cli("search", str(spec), "-o", str(out), "-q")
            lines = stderr.strip().splitlines()
            assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (seed, stderr)
            assert f"--budget {BUDGET} holds them" in lines[0], lines[0]
            assert _files(out) == before
    p = _search(spec, out)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, (seed, err)
    assert _partials(out) == [], seed
    check_search(out)
    assert (out / "search.json").read_bytes() == (ref / "search.json").read_bytes(), f"seed {seed}"
    assert traces(out) == traces(ref), f"seed {seed}"


# ---- Ray ---------------------------------------------------------------------------------------

def _ray_job(root: Path, factory: pytest.TempPathFactory) -> dict[str, Any]:
    spec, _, _ = built_once(factory, "search-reference", _reference)
    return {"kind": "search", "spec": spec, "out": str(root / "ray"), "budget": BUDGET, "workers": 2}


ray_battery.register("search", _ray_job)


def test_on_a_local_ray_cluster_the_search_is_the_same(reference: tuple[Path, Path, str],
                                                        tmp_path_factory: pytest.TempPathFactory) -> None:
    """On the cluster navstress starts (the suite's one, ``ray_battery``: 127.0.0.1 only, as the
    executor contract checks), in a fresh interpreter."""
    _, ref, _ = reference
    res = ray_battery.job(tmp_path_factory, "search")
    assert res["unfinished"] == [] and res["runs"] == BUDGET
    out = Path(res["out"])
    assert (out / "search.json").read_bytes() == (ref / "search.json").read_bytes()
    assert traces(out) == traces(ref)


# ---- the other algorithms, through the driver ------------------------------------------------------


@pytest.mark.parametrize("algorithm", [{"name": "cma-me", "batch": 2, "emitters": 1},
                                       {"name": "ga", "batch": 2}, {"name": "nsga2", "batch": 2}],
                         ids=lambda a: a["name"])
def test_every_algorithm_runs_a_generation_and_confirms(tmp_path: Path, algorithm: dict[str, Any]) -> None:
    """One generation of two worlds, one run each (the algorithm is asked twice, told once), and
    the elite's confirmation: search.json consistent with the store (MAP-Elites: ``reference``;
    random sampling: the next test)."""
    spec = _write(tmp_path / "s.yaml", {**SPEC, "algorithm": algorithm, "runs_per_candidate": 1,
                                        "budget": {"runs": 2}, "elites": 1})
    res = run_search(spec, tmp_path / "out", workers=2)
    assert not res.unfinished and res.generations == 1 and res.runs == 2
    data = check_search(tmp_path / "out")
    assert data["algorithm"] == algorithm["name"]


def test_when_no_elite_is_confirmed_no_suite_is_written_and_the_cli_says_so(tmp_path: Path) -> None:
    """Random sampling, whose one confirmation run cannot prove a world failing (two failures are
    the least): suite/ holds suite.json alone, each elite with its verdict."""
    spec = _write(tmp_path / "s.yaml", {**SPEC, "algorithm": {"name": "random", "batch": 2}, "runs_per_candidate": 1,
                                        "budget": {"runs": 2}, "confirm_runs": 1})
    out = tmp_path / "out"
    code, stdout, stderr = cli("search", str(spec), "-o", str(out), "-j", "2", "-q")
    assert code == 0, stderr
    data = check_search(out)
    assert data["elites"] and not data["confirmed"] and data["suite"] is None, data["elites"]
    assert f"no world confirmed: no suite written ({out / 'suite' / 'suite.json'} says why per elite)" in stdout
    assert "suite:" not in stdout
