"""Navigators that attack their host (sys.exit, os._exit, signals, infinite loops, BaseException
subclasses, garbage) in each of their methods, in process and out of process: `navstress run`
records one classified run for each and goes on; `navstress nav check` fails naming the attack.
Real worker processes, real signals, real external processes."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from tests.support.navigators.hostile_nav import MODES
from navstress.nav import registry
from navstress.isolate import Worker
from navstress.nav.check import CHECK_NAMES, check_in_worker
from navstress.run.batch import plan_batch, run_batch
from navstress.run.record import RunRecord, RunTask
from tests.support.strict_json import strict_lines
from tests.support.world_fixtures import small_world

pytestmark = pytest.mark.slow

HOSTILE = Path(__file__).resolve().parents[2] / "support" / "navigators" / "hostile_nav.py"
WHERE = ("init", "reset", "step")
#: attacks that end the worker process (one fresh worker each: the costly part of the family)
FATAL = ("os_exit0", "segv", "sigkill", "loop")
IN_PROCESS = ([(m, w) for w in WHERE for m in MODES if m not in FATAL] + [("garbage", "step")]
              + [(m, "step") for m in FATAL] + [("os_exit0", "init"), ("segv", "reset"), ("loop", "init"),
                                                ("loop", "reset")])
OUT_OF_PROCESS = [(m, w) for w in WHERE for m in MODES]
WALL_LIMIT_S = 60.0  # for runs that end by themselves (generous: a cold worker on a loaded machine)
HANG_LIMIT_S = 2.0  # for runs that hang (any limit classifies them the same)

#: what the reason of an in-process attack says
IN_REASON = {"exit0": "SystemExit", "exit3": "SystemExit", "os_exit0": "exit code 0", "segv": "SIGSEGV",
             "sigkill": "SIGKILL", "loop": "wall-clock limit", "keyboardinterrupt": "KeyboardInterrupt",
             "systemexit": "SystemExit", "generatorexit": "GeneratorExit", "garbage": "str"}
#: ... and of the same attack in the navigator's own process
OUT_REASON = {"exit0": "exited with code 0", "exit3": "exited with code 3", "os_exit0": "exited with code 0",
              "segv": "SIGSEGV", "sigkill": "SIGKILL", "loop": "no answer within",
              "keyboardinterrupt": "navigator process", "systemexit": "exited with code 1",
              "generatorexit": "navigator process"}


@pytest.fixture(scope="module")
def world_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The world, after one short mission in this process: the compiled kernels are then in the
    on-disk cache, so that the workers' wall-clock limits measure runs, not a cold compilation."""
    from navstress.nav.registry import make_navigator
    from navstress.run.mission import run_mission

    d = tmp_path_factory.mktemp("hostile") / "w"
    w = small_world(5, bumpy=False)
    w.save(d)
    run_mission(w, make_navigator("reference-v1"), run_seed=0, timeout_s=0.5)
    return d


@pytest.fixture
def hostile_registered() -> object:
    registry.register("hostile-v1", "tests.support.navigators.hostile_nav:Hostile", override=True)
    yield None
    registry.unregister("hostile-v1")


def external_config(mode: str, where: str) -> dict[str, object]:
    """Short budgets where the navigator hangs (any budget classifies it the same), generous ones
    elsewhere (a loaded machine may take seconds to start a Python process)."""
    hang = mode == "loop"
    return {"command": [sys.executable, str(HOSTILE), mode, where], "step_budget_s": 1.0 if hang else 30.0,
            "reset_budget_s": 2.0 if hang else 60.0,
            "env": {"NUMBA_CACHE_DIR": str(Path(tempfile.gettempdir()) / "navstress-test-numba")}}


def batch(world_dir: Path, out: Path, navigator: str, cases: list[tuple[str, str]], configure: object,
          wall_limit_s: float) -> list[RunRecord]:
    base = plan_batch(world_dir, out, navigator=navigator, navigator_config={}, fault=None, runs=1,
                      seed=0, timeout_s=5.0, goal_tolerance_m=1.0)[0]
    tasks = [RunTask(**{**base.__dict__, "run_id": f"{m}-{w}", "trace_path": str(out / f"{m}-{w}.mcap"),
                        "navigator_config": configure(m, w)})  # type: ignore[operator]
             for m, w in cases]
    records = run_batch(tasks, out, wall_limit_s=wall_limit_s)
    lines = strict_lines((out / "runs.jsonl").read_text())
    assert [r["run_id"] for r in lines] == [t.run_id for t in tasks]
    assert not list(out.glob(".*.partial"))
    return records


def test_every_in_process_attack_is_one_classified_run(world_dir: Path, tmp_path: Path,
                                                       hostile_registered: object) -> None:
    hangs = [c for c in IN_PROCESS if c[0] == "loop"]
    others = [c for c in IN_PROCESS if c[0] != "loop"]
    records = batch(world_dir, tmp_path / "a", "hostile-v1", others, in_config, 120.0)
    records += batch(world_dir, tmp_path / "b", "hostile-v1", hangs, in_config, HANG_LIMIT_S)
    for (mode, where), rec in zip(others + hangs, records):
        assert rec.outcome == "fail-other", (mode, where, rec.reason)
        assert IN_REASON[mode] in rec.reason, (mode, where, rec.reason)
        assert rec.map_seed == 5
        if rec.trace is not None:
            assert Path(rec.trace).is_file()


def test_every_out_of_process_attack_is_one_classified_run(world_dir: Path, tmp_path: Path) -> None:
    records = batch(world_dir, tmp_path / "out", "external-v1", OUT_OF_PROCESS, external_config, 60.0)
    for (mode, where), rec in zip(OUT_OF_PROCESS, records):
        assert rec.outcome == "fail-other", (mode, where, rec.reason)
        assert "navigator process" in rec.reason and OUT_REASON[mode] in rec.reason, (mode, where, rec.reason)
        assert rec.trace is not None and Path(rec.trace).is_file()  # the run loop itself survived


def in_config(mode: str, where: str) -> dict[str, str]:
    return {"mode": mode, "where": where}


def test_nav_check_fails_naming_every_in_process_attack(hostile_registered: object) -> None:
    cases = [(m, w) for m, w in IN_PROCESS if w != "reset"]
    with Worker(120.0) as worker, Worker(HANG_LIMIT_S) as hang_worker:
        for mode, where in cases:
            report = check_in_worker("hostile-v1", in_config(mode, where), n_steps=3,
                                     worker=hang_worker if mode == "loop" else worker)
            assert not report.passed
            failed = [r for r in report.results if not r.passed]
            assert failed[0].name == ("builds" if where == "init" else "valid-types"), (mode, where, report)
            assert IN_REASON[mode] in failed[0].detail, (mode, where, report)
            assert len(report.results) == len(CHECK_NAMES)


def test_nav_check_fails_naming_every_out_of_process_attack() -> None:
    with Worker(60.0) as worker:  # (a subset: each check starts the navigator's process five times)
        for mode in ("exit0", "os_exit0", "segv", "loop", "keyboardinterrupt"):
            report = check_in_worker("external-v1", external_config(mode, "step"), n_steps=3, worker=worker)
            assert not report.passed
            failed = [r for r in report.results if not r.passed]
            assert failed[0].name == "valid-types", (mode, report)
            assert OUT_REASON[mode] in failed[0].detail, (mode, report)


# ---- through the real CLI: a user's script registers the navigator, then calls navstress

CLI = ("import sys; from navstress.nav import registry; registry.register('hostile-v1', 'tests.support.navigators.hostile_nav:Hostile'); "
       "from navstress.cli import main; sys.argv[0] = 'navstress'; main()")


def navstress(*args: str) -> subprocess.CompletedProcess[str]:
    env_path = str(HOSTILE.parents[3])  # the repository root: tests.support.navigators.hostile_nav
    import os

    env = {**os.environ, "PYTHONPATH": os.pathsep.join([env_path, *sys.path])}
    return subprocess.run([sys.executable, "-c", CLI, *args], capture_output=True, text=True, timeout=300, env=env)


@pytest.mark.parametrize(("mode", "where"), [("exit0", "step"), ("segv", "step"), ("loop", "step")])
def test_cli_run_survives_and_records(mode: str, where: str, world_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    limit = HANG_LIMIT_S if mode == "loop" else WALL_LIMIT_S
    runs = 1 if mode == "loop" else 2
    r = navstress("run", str(world_dir), "-o", str(out), "--navigator", "hostile-v1", "--runs", str(runs),
                  "--timeout", "5", "--wall-limit", str(limit), "--navigator-config",
                  str(_config_file(tmp_path, {"mode": mode, "where": where})))
    assert r.returncode == 0, r.stderr
    recs = strict_lines((out / "runs.jsonl").read_text())
    assert [x["run_id"] for x in recs] == ["run-000", "run-001"][:runs]
    assert all(x["outcome"] == "fail-other" and IN_REASON[mode] in x["reason"] for x in recs), recs
    assert not list(out.glob(".*.partial"))


@pytest.mark.parametrize(("mode", "where"), [("exit0", "step"), ("loop", "step")])
def test_cli_nav_check_exits_1_naming_the_failure(mode: str, where: str, tmp_path: Path) -> None:
    limit = HANG_LIMIT_S if mode == "loop" else WALL_LIMIT_S
    r = navstress("nav", "check", "hostile-v1", "--wall-limit", str(limit), "--navigator-config",
                  str(_config_file(tmp_path, {"mode": mode, "where": where})))
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "FAIL" in r.stdout and IN_REASON[mode] in r.stdout.replace("\n", " "), r.stdout


def _config_file(tmp_path: Path, cfg: dict[str, str]) -> Path:
    p = tmp_path / "nav.json"
    p.write_text(json.dumps(cfg))
    return p


@pytest.mark.parametrize("mode", ["raise", "garbage"])
def test_served_navigator_raising_in_step_is_classified_as_in_process(mode: str, world_dir: Path) -> None:
    """`serve` (python -m navstress.nav.external) does not turn an exception into the stack's own
    Fail-Error: the same navigator gives the same class in process and out of process."""
    from tests.support.navigators.hostile_nav import Hostile
    from navstress.nav.external import ExternalNavigator
    from navstress.run.mission import run_mission
    from navstress.world.world import World

    w = World.load(world_dir)
    local = run_mission(w, Hostile({"mode": mode, "where": "step"}), run_seed=1, timeout_s=2.0).classification
    with ExternalNavigator([sys.executable, str(HOSTILE), mode, "step"], step_budget_s=30.0,
                           reset_budget_s=60.0) as nav:
        remote = run_mission(w, nav, run_seed=1, timeout_s=2.0).classification
    assert local.outcome == remote.outcome
    assert local.outcome.value == "fail-other"
    if mode == "raise":
        assert "ZeroDivisionError: planner bug" in local.reason and "ZeroDivisionError: planner bug" in remote.reason
