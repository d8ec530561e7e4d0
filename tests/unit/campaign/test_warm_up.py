"""A worker's warm-up leaves nothing behind, even when the worker is killed while it warms up."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from navstress.campaign.work import WARM_UP_PREFIX, sweep_warm_ups


def _dead_pid() -> int:
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def test_sweep_removes_only_directories_of_processes_that_are_gone(tmp_path: Path) -> None:
    dead = tmp_path / f"{WARM_UP_PREFIX}{_dead_pid()}-abc"
    live = tmp_path / f"{WARM_UP_PREFIX}{os.getpid()}-abc"
    parent = tmp_path / f"{WARM_UP_PREFIX}{os.getppid()}-x"
    no_pid = tmp_path / f"{WARM_UP_PREFIX}abc-def"   # not ours: no pid in the name
    old_style = tmp_path / f"{WARM_UP_PREFIX}q1w2e3"
    for d in (dead, live, parent, no_pid, old_style):
        (d / "w").mkdir(parents=True)
        (d / "w" / "f").write_text("x")
    a_file = tmp_path / f"{WARM_UP_PREFIX}{_dead_pid()}-file"
    a_file.write_text("not a directory")
    other = tmp_path / f"other-{_dead_pid()}-abc"
    other.mkdir()

    assert sweep_warm_ups(tmp_path) == [dead]
    assert not dead.exists()
    for kept in (live, parent, no_pid, old_style, a_file, other):
        assert kept.exists(), kept
    assert sweep_warm_ups(tmp_path) == []


def test_a_worker_killed_while_it_warms_up_leaves_a_directory_the_next_warm_up_removes(tmp_path: Path) -> None:
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    child = subprocess.Popen([sys.executable, "-c", "from navstress.campaign.work import warm_up; warm_up()"],
                             env=env)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(f"{WARM_UP_PREFIX}{child.pid}-*")):
            assert child.poll() is None, "the warm-up ended before its directory was seen"
            assert time.monotonic() < deadline, "no warm-up directory appeared"
            time.sleep(0.01)
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    left = list(tmp_path.glob(f"{WARM_UP_PREFIX}*"))
    assert [d.name.split("-")[2] for d in left] == [str(child.pid)]   # the kill left it

    # the next warm-up (another process, here the test's own) removes it, and leaves nothing itself
    done = subprocess.run([sys.executable, "-c", "from navstress.campaign.work import warm_up; print(warm_up())"],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) > 0
    assert list(tmp_path.glob(f"{WARM_UP_PREFIX}*")) == []
