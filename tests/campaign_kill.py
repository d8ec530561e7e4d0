"""SIGKILL a campaign's driver process once its store holds a given number of run records."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import time
from pathlib import Path


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


def kill_when_recorded(proc: subprocess.Popen[bytes], db: Path, count: int, timeout_s: float,
                       poll_s: float = 0.05) -> None:
    """Wait until ``db`` holds ``count`` records (or ``proc`` ends, or ``timeout_s`` passes), then
    SIGKILL ``proc`` and reap it; the caller checks ``proc.returncode``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        time.sleep(poll_s)
        n = recorded(db)
        if n is not None and n >= count:
            break
    proc.send_signal(signal.SIGKILL)
    proc.wait()
