"""Every command protects itself from the navigator, on real processes (``campaign_navs:Escapes``):

- ``replay``: a navigator that behaved when the campaign ran and, replayed, hangs, exits with
  several codes, kills itself or raises (and one that starts a daemon first): one line saying what
  happened, exit 1; one that only starts processes replays identical, exit 0; no scratch folder
  left in a private TMPDIR, whatever happened to the worker; SIGTERM: 143, nothing left;
- ``replay``, ``run``, ``campaign run`` and ``nav check`` through pipes with navigators
  that start sleepers (a plain fork, a double-forked daemon, a child in a session of its own,
  ``sleep`` through subprocess), in their constructor or in a step, and then drive on, exit, or
  hang: every sleeper is gone when the command returns, and its pipes close when it exits
  (``search`` runs its runs through the campaign's executor and checks: tests/unit/test_isolate_tree.py
  covers every way of starting a process at the level of the worker).

Each sleeper writes its pid to a file; what a failing test leaves running is killed by those pids.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from typer.testing import CliRunner

from tests.support.leftovers import kill_left, pids, run_piped, scratch_left, still_running
from navstress.campaign.executors import run_campaign
from navstress.campaign.store import Store
from navstress.cli import app

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
HANG_LIMIT = "2"  # the wall-clock limit where a navigator hangs (any limit classifies it the same)
#: a user's script that registers the navigator, then is navstress (for `run` and `nav check`)
CLI = ("import sys; from navstress.nav import registry; registry.register('escapes-v1', 'tests.support.navigators.campaign_navs:Escapes'); "
       "from navstress.cli import main; sys.argv[0] = 'navstress'; main()")


def _env(tmpdir: Path) -> dict[str, str]:
    tmpdir.mkdir(exist_ok=True)
    return {**os.environ, "TMPDIR": str(tmpdir),
            "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")])}


def _spec(navigators: list[dict[str, Any]], **over: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "escapes", "seed": 3, "world": {"size_m": [20.0, 20.0], "cell_m": 0.5},
        "experiments": [{"name": "flat", "sweep": {"obstacles.obstruction.tree": {"values": [0]}}}],
        "maps_per_config": 1, "runs_per_map": 1, "navigators": navigators, "timeout_s": 3.0}
    d.update(over)
    return d


def _nav(name: str, pidfile: Path, **cfg: Any) -> dict[str, Any]:
    return {"name": name, "target": "tests.support.navigators.campaign_navs:Escapes",
            "config": {"after_s": 0.3, "pidfile": str(pidfile), **cfg}}


@pytest.fixture
def pidfile(tmp_path: Path) -> Iterator[Path]:
    p = tmp_path / "pids"
    yield p
    kill_left(p)


# ---- replay ----------------------------------------------------------------------------------

#: mode -> (navigator config, exit code, what the one line says)
REPLAYS: dict[str, tuple[dict[str, Any], int, str]] = {
    "hang": ({"then": "hang"}, 1, f"run exceeded wall-clock limit ({HANG_LIMIT} s)"),
    "exit0": ({"then": "exit", "code": 0}, 1, "the navigator killed its run's process (exit code 0)"),
    "exit3": ({"then": "exit", "code": 3}, 1, "the navigator killed its run's process (exit code 3)"),
    "exit7": ({"then": "exit", "code": 7}, 1, "the navigator killed its run's process (exit code 7)"),
    "sigkill": ({"then": "sigkill"}, 1, "the navigator killed its run's process (signal SIGKILL)"),
    "daemon-exit": ({"spawn": "double", "then": "exit", "code": 7}, 1, "(exit code 7)"),
    "setsid-drive": ({"spawn": "setsid", "then": "drive"}, 0, "identical"),
    "raise": ({"then": "raise"}, 1, "navigator raised RuntimeError: planner exploded"),
}


@pytest.fixture(scope="module")
def replayable(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path, Path]]:
    """A campaign of one run per misbehaving navigator, recorded while they behaved (no trigger
    file); then the trigger is created: replayed, each misbehaves. (campaign dir, trigger, pid dir)"""
    base = tmp_path_factory.mktemp("replayable")
    trigger, piddir = base / "trigger", base / "pids"
    piddir.mkdir()
    navs = [_nav(f"{m}-v1", piddir / m, trigger=str(trigger), **cfg) for m, (cfg, _c, _w) in REPLAYS.items()]
    spec = base / "spec.yaml"
    spec.write_text(yaml.safe_dump(_spec(navs)))
    res = run_campaign(spec, base / "c", workers=1)
    assert res.recorded == len(REPLAYS) and not res.counts.get("fail-other"), res.counts
    trigger.write_text("misbehave\n")
    yield base / "c", trigger, piddir
    for m in REPLAYS:
        kill_left(piddir / m)


def _run_id(directory: Path, navigator: str) -> str:
    with Store.open(directory) as store:
        return next(r.run_id for r in store.records() if r.navigator == navigator)


@pytest.mark.parametrize("mode", list(REPLAYS))
def test_replay_says_in_one_line_what_the_navigator_did(mode: str, replayable: tuple[Path, Path, Path],
                                                        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    directory, _trigger, piddir = replayable
    cfg, code, words = REPLAYS[mode]
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmpdir))
    monkeypatch.setattr("tempfile.tempdir", str(tmpdir))
    run_id = _run_id(directory, f"{mode}-v1")
    args = ["replay", str(directory), run_id] + (["--wall-limit", HANG_LIMIT] if mode == "hang" else [])
    t0 = time.monotonic()
    r = CliRunner().invoke(app, args)
    took = time.monotonic() - t0
    assert r.exit_code == code, (r.exit_code, r.stdout, r.stderr, r.exception)
    lines = r.stdout.strip().splitlines()
    if code == 1 and mode != "raise":  # the replay did not finish: one line says why
        assert len(lines) == 1 and lines[0].startswith(f"DIFFERENT: {run_id}: stored "), r.stdout
        assert "did not finish" in lines[0]
    assert words in r.stdout, r.stdout
    assert still_running(piddir / mode) == []
    assert len(pids(piddir / mode)) == (1 if "spawn" in cfg else 0)
    assert scratch_left(tmpdir) == []
    assert took < 120, took


def test_replay_through_a_pipe_returns_when_it_ends(replayable: tuple[Path, Path, Path], tmp_path: Path) -> None:
    """A daemon the replayed navigator started before it exited holds nothing: the command's pipes
    close with it, and its one line is on stdout."""
    directory, _trigger, piddir = replayable
    run_id = _run_id(directory, "daemon-exit-v1")
    code, out, err, lag = run_piped([sys.executable, "-m", "navstress.cli", "replay", str(directory), run_id],
                                    _env(tmp_path / "tmp"))
    assert code == 1 and len(out.strip().splitlines()) == 1 and "(exit code 7)" in out, (code, out, err)
    assert still_running(piddir / "daemon-exit") == []
    assert scratch_left(tmp_path / "tmp") == []


def test_replay_stopped_by_sigterm_leaves_nothing(replayable: tuple[Path, Path, Path], tmp_path: Path) -> None:
    directory, _trigger, piddir = replayable
    run_id = _run_id(directory, "hang-v1")
    env = _env(tmp_path / "tmp")
    proc = subprocess.Popen([sys.executable, "-m", "navstress.cli", "replay", str(directory), run_id],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not scratch_left(tmp_path / "tmp") and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)  # the worker runs the hanging navigator
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, (out, err)
    assert err.strip().splitlines()[-1] == "replay stopped by SIGTERM; nothing was written", err
    assert scratch_left(tmp_path / "tmp") == []


# ---- every command through a pipe: what the navigator started is gone when it returns -----------


@pytest.mark.parametrize(("spawn", "then", "where"), [("double", "exit", "step")])
def test_run_leaves_no_process(spawn: str, then: str, where: str, tmp_path: Path, pidfile: Path,
                               world_dir: Path) -> None:
    cfg = {"spawn": spawn, "then": then, "where": where, "after_s": 0.3, "pidfile": str(pidfile)}
    code, out, err, _lag = run_piped(
        [sys.executable, "-c", CLI, "run", str(world_dir), "-o", str(tmp_path / "out"), "--navigator", "escapes-v1",
         "--navigator-config", json.dumps(cfg), "--timeout", "3", "--wall-limit", HANG_LIMIT if then == "hang" else "120",
         "--json"], _env(tmp_path / "tmp"))
    assert code == 0, err
    rec = json.loads(out)["records"][0]
    if then != "drive":
        assert rec["outcome"] == "fail-other", rec
    assert pids(pidfile) and still_running(pidfile) == [], f"{spawn}/{then}/{where}: processes outlived the command"
    assert scratch_left(tmp_path / "tmp") == []


def test_campaign_leaves_no_process(tmp_path: Path, pidfile: Path) -> None:
    """Built to validate its config (no hook: in a worker), then run: a navigator that starts a
    daemon in its constructor; one that starts a child in a session of its own and exits in a step
    (three attempts). (search runs its generations through the same executor and check.)"""
    navs = [_nav("init-v1", pidfile, spawn="double", then="drive", where="init"),
            _nav("exits-v1", pidfile, spawn="setsid", then="exit", code=7)]
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(_spec(navs)))
    code, out, err, _lag = run_piped([sys.executable, "-m", "navstress.cli", "campaign", "run", str(spec), "-o",
                                      str(tmp_path / "c"), "-q", "-j", "1", "--wall-limit", "4"],
                                     _env(tmp_path / "tmp"))
    assert code == 0, err
    with Store.open(tmp_path / "c") as store:
        got = {r.navigator: r.reason for r in store.records()}
    assert "(exit code 7), in 3 of 3 attempts" in got["exits-v1"], got
    assert len(pids(pidfile)) >= 5 and still_running(pidfile) == [], "processes outlived the campaign"
    assert scratch_left(tmp_path / "tmp") == []


@pytest.mark.parametrize(("spawn", "then", "where"), [("double", "drive", "init"), ("setsid", "exit", "step")])
def test_nav_check_leaves_no_process(spawn: str, then: str, where: str, tmp_path: Path, pidfile: Path) -> None:
    cfg = {"spawn": spawn, "then": then, "where": where, "after_s": 0.0, "pidfile": str(pidfile)}
    code, out, err, _lag = run_piped([sys.executable, "-c", CLI, "nav", "check", "escapes-v1", "--navigator-config",
                                      json.dumps(cfg), "--wall-limit", HANG_LIMIT if then == "hang" else "120"],
                                     _env(tmp_path / "tmp"))
    assert code == (0 if then == "drive" else 1), (out, err)
    if then == "exit":
        assert "the navigator killed the checking process (exit code 7)" in out.replace("\n", " "), out
    assert pids(pidfile) and still_running(pidfile) == [], "processes outlived nav check"


@pytest.fixture(scope="module")
def world_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.support.world_fixtures import small_world

    d = tmp_path_factory.mktemp("escapes-world") / "w"
    small_world(5, bumpy=False).save(d)
    return d
