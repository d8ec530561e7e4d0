"""The kill-and-resume helper of the campaign tests (tests/support/campaign_kill.py), on real processes:
it waits on the records themselves (not a fixed time), kills the driver, returns only once the
driver's workers are gone, and says clearly when the driver ended first or the bound passed."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.support.campaign_kill import descendants, kill_when_recorded, wait_gone

#: A worker: runs until its parent is gone (as the campaign's workers do).
WORKER = "import os, time\np = os.getppid()\nwhile os.getppid() == p:\n    time.sleep(0.02)\n"
#: A driver: starts a worker, then writes one record every DELAY seconds, N of them, then ends.
DRIVER = (
    "import sqlite3, subprocess, sys, time\n"
    "db, n, delay, first = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])\n"
    f"w = subprocess.Popen([sys.executable, '-c', {WORKER!r}])\n"
    "con = sqlite3.connect(db, isolation_level=None)\n"
    "con.execute('CREATE TABLE runs (run_id TEXT)')\n"
    "time.sleep(first)\n"
    "for i in range(n):\n"
    "    con.execute('INSERT INTO runs VALUES (?)', (str(i),))\n"
    "    time.sleep(delay)\n"
    "w.kill()\n")


def _driver(tmp_path: Path, n: int, delay: float, first: float = 0.0) -> tuple[subprocess.Popen[bytes], Path]:
    db = tmp_path / "campaign.sqlite"
    return subprocess.Popen([sys.executable, "-c", DRIVER, str(db), str(n), str(delay), str(first)]), db


def _workers(proc: subprocess.Popen[bytes], bound_s: float = 30.0) -> list[int]:
    deadline = time.monotonic() + bound_s
    while not (kids := descendants(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.02)
    return kids


@pytest.mark.parametrize("first", [0.0, 1.5])  # the first record at once, or late (a cold start)
def test_kills_at_the_count_and_the_workers_are_gone(tmp_path: Path, first: float) -> None:
    proc, db = _driver(tmp_path, n=1000, delay=0.05, first=first)
    kids = _workers(proc)
    assert kids, "the driver started no worker"
    n = kill_when_recorded(proc, db, 3)
    assert proc.returncode == -9 and n >= 3
    assert all(not Path(f"/proc/{k}").exists() or Path(f"/proc/{k}/stat").read_text().split(") ")[1][0] in "ZX"
               for k in kids), "a worker outlived the helper"


def test_a_driver_that_ends_first_is_said_so(tmp_path: Path) -> None:
    proc, db = _driver(tmp_path, n=1, delay=0.0)
    with pytest.raises(AssertionError, match="ended .* before it could be killed at 5 records"):
        kill_when_recorded(proc, db, 5)


def test_a_bound_that_passes_is_said_so_and_the_driver_is_killed(tmp_path: Path) -> None:
    proc, db = _driver(tmp_path, n=0, delay=0.0, first=60.0)
    with pytest.raises(AssertionError, match="1 records were not in .* within 0.5 s"):
        kill_when_recorded(proc, db, 1, timeout_s=0.5)
    assert proc.returncode == -9


def test_wait_gone_fails_on_a_process_that_keeps_running() -> None:
    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        with pytest.raises(AssertionError, match=f"processes \\[{p.pid}\\] still run"):
            wait_gone([p.pid], bound_s=0.3)
    finally:
        p.kill()
        p.wait()
    wait_gone([p.pid], bound_s=5)  # reaped: gone
