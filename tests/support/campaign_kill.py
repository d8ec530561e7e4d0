"""SIGKILL a campaign's driver process once its store holds a given number of run records, and
wait until its worker processes are gone too (the state a resume must start from).

Every wait is on the condition itself, polled, with a generous bound for a loaded machine (a
cold first run compiles the simulator's kernels; two cores may be shared by several suites):
the test goes on as soon as the condition holds, and fails with a clear message if the bound
passes first."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path

#: Longest wait for the records (the first ones include the workers' start and compilation).
RECORD_BOUND_S = 420.0
#: Longest wait for the killed driver's workers to end (they die with it: PR_SET_PDEATHSIG).
ORPHAN_BOUND_S = 60.0


def recorded(db: Path) -> int | None:
    """Run records in the store ``db`` now (None: not readable yet)."""
    if not db.exists():
        return None
    try:
        con = sqlite3.connect(db, timeout=1)
        try:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return None


def _stat(pid: int) -> tuple[str, int] | None:
    """(state, parent pid) of a live process, None when it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()  # after "pid (comm) "
    return fields[0], int(fields[1])


def descendants(pid: int) -> list[int]:
    """Every live process under ``pid`` (children, their children, ...), from /proc."""
    parent: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            st = _stat(int(entry))
            if st is not None:
                parent[int(entry)] = st[1]
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


def _alive(pid: int) -> bool:
    st = _stat(pid)
    return st is not None and st[0] not in ("Z", "X")  # a zombie has ended (nobody may reap it here)


def wait_gone(pids: list[int], bound_s: float = ORPHAN_BOUND_S, poll_s: float = 0.05) -> None:
    """Return once none of ``pids`` runs any more; AssertionError naming them after ``bound_s``."""
    deadline = time.monotonic() + bound_s
    while any(_alive(p) for p in pids):
        if time.monotonic() > deadline:
            raise AssertionError(f"processes {[p for p in pids if _alive(p)]} still run {bound_s:g} s after "
                                 "their campaign driver was killed")
        time.sleep(poll_s)


def kill_when_recorded(proc: subprocess.Popen[bytes], db: Path, count: int, timeout_s: float = RECORD_BOUND_S,
                       poll_s: float = 0.05) -> int:
    """Wait until ``db`` holds ``count`` records, then SIGKILL ``proc``, reap it, and wait until
    the worker processes it had started are gone; returns the records there at the kill.

    AssertionError when ``proc`` ends by itself first (the campaign finished before it could be
    killed) or ``timeout_s`` passes without ``count`` records (after killing ``proc`` all the same)."""
    deadline = time.monotonic() + timeout_s
    n = None
    while proc.poll() is None and time.monotonic() < deadline:
        n = recorded(db)
        if n is not None and n >= count:
            break
        time.sleep(poll_s)
    ended_first = proc.poll() is not None
    workers = descendants(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    wait_gone(workers)
    if ended_first:
        raise AssertionError(f"the driver ended (exit {proc.returncode}) before it could be killed "
                             f"at {count} records")
    if n is None or n < count:
        raise AssertionError(f"{count} records were not in {db} within {timeout_s:g} s (there were {n})")
    return n
