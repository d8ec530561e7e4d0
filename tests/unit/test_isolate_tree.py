"""What a navigator starts ends with its call (``navstress.isolate``), on real processes: a family
of navigators that start a sleeper (a plain fork, a daemon by double fork + setsid, a child in a
session of its own, ``sleep`` through subprocess) and then go on, exit with several codes, kill
themselves, hang or raise. After each call every sleeper is gone, the answer says what happened,
and the worker's end costs no wait on a pipe a sleeper holds; when the command itself is SIGKILLed,
the keeper ends the whole tree."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.leftovers import kill_left, pids, running, still_running
from navstress.isolate import Worker
from tests.support.navigators.campaign_navs import escape  # a module the worker imports too

ROOT = str(Path(__file__).resolve().parents[2])  # tests.support importable in a child

SPAWNS = ("fork", "double", "setsid", "popen")
#: (then, code): what the navigator does after it started the sleeper, and the answer expected
THEN = {"exit7": ("died", "exit code 7"), "sigkill": ("died", "signal SIGKILL"),
        "hang": ("limit", 1.5), "raise": ("raised", "planner exploded")}
#: each way of starting a sleeper, with a worker that dies after it (one that lives on: below)
CASES = ([(s, "exit7") for s in SPAWNS] + [("fork", "sigkill"), ("double", "sigkill"), ("setsid", "hang"),
                                            ("popen", "hang"), ("setsid", "raise")])


@pytest.fixture
def pidfile(tmp_path: Path) -> Iterator[Path]:
    p = tmp_path / "pids"
    yield p
    kill_left(p)  # a failing test leaves nothing running either


@pytest.mark.parametrize(("spawn", "then"), CASES)
def test_what_the_call_started_ends_with_it(spawn: str, then: str, pidfile: Path) -> None:
    act = "exit" if then == "exit7" else then
    with Worker(1.5 if then == "hang" else 60.0) as worker:
        assert worker.call(os.getpid)[0] == "ok"  # started (imports) outside the measured call
        t0 = time.monotonic()
        status, value = worker.call(escape, spawn, act, 7, str(pidfile))
        took = time.monotonic() - t0
        if status == "raised":
            value = str(value)
        assert (status, value) == THEN[then]
        assert still_running(pidfile) == [], f"{spawn} + {then}: the navigator's processes outlived its call"
    assert len(pids(pidfile)) == 1
    # the answer did not wait for a sleeper holding the worker's pipes (the sleepers sleep 120 s)
    assert took < (1.5 if then == "hang" else 0.0) + 20.0, took


def test_a_worker_that_lives_on_ends_each_calls_processes(pidfile: Path) -> None:
    """A campaign's worker runs many runs: what each started is gone when it answers, the worker stays."""
    with Worker(60.0) as worker:
        first = worker.call(os.getpid)
        for spawn in SPAWNS:
            assert worker.call(escape, spawn, "drive", 7, str(pidfile)) == ("ok", "drove on")
            assert still_running(pidfile) == [], spawn
            assert worker.call(os.getpid) == first  # the same worker
    assert len(pids(pidfile)) == len(SPAWNS)


SCRIPT = """
import os, sys
sys.path[:0] = [{helpers!r}]
from navstress.isolate import Worker
from tests.support.navigators.campaign_navs import escape
if __name__ == "__main__":
    w = Worker(600.0)
    with open({marker!r}, "w") as f:
        f.write(str(w.call(os.getpid)[1]))
    w.call(escape, {spawn!r}, "hang", 7, {pidfile!r})
"""


@pytest.mark.parametrize("spawn", ["double", "setsid"])
def test_a_command_killed_outright_leaves_no_process(spawn: str, tmp_path: Path, pidfile: Path) -> None:
    """SIGKILL to the command (the OOM killer, ``kill -9``): its worker, and what the navigator
    started, daemons included, end too (the keeper gets SIGTERM when its parent dies)."""
    marker = tmp_path / "worker.pid"
    src = SCRIPT.format(helpers=ROOT, marker=str(marker), spawn=spawn, pidfile=str(pidfile))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-c", src], env=env)
    try:
        deadline = time.monotonic() + 120.0
        while not pids(pidfile) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        assert pids(pidfile), "the navigator started nothing"
        worker = int(marker.read_text())
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        left = [*pids(pidfile), worker]
        deadline = time.monotonic() + 10.0
        while any(running(p) for p in left) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not [p for p in left if running(p)], "processes outlived the killed command"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
