"""What a command leaves behind: the processes a navigator started (their pids in a file they
wrote), navstress's scratch folders in a private temporary directory, and a pipe to the command
held open after it exited (a process that kept its stdout or stderr)."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from pathlib import Path


def pids(pidfile: Path) -> list[int]:
    """The pids written to ``pidfile``, one a line (none when it is not there)."""
    try:
        return [int(x) for x in pidfile.read_text().split()]
    except FileNotFoundError:
        return []


def running(pid: int) -> bool:
    """``pid`` is a live process (a zombie is not: it holds nothing open)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # no /proc: kill(0) said it exists
    return stat[stat.rindex(")") + 2] not in "ZX"


def still_running(pidfile: Path) -> list[int]:
    """The pids of ``pidfile`` that still run."""
    return [p for p in pids(pidfile) if running(p)]


def kill_left(pidfile: Path) -> None:
    """SIGKILL what a failed test left running (by the pids its processes wrote, nothing else)."""
    for p in still_running(pidfile):
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


def scratch_left(tmpdir: Path) -> list[str]:
    """navstress's temporary folders and files left in ``tmpdir``."""
    return sorted(p.name for p in tmpdir.iterdir() if p.name.startswith("navstress"))


def run_piped(argv: list[str], env: dict[str, str], timeout_s: float = 300.0,
              eof_bound_s: float = 5.0) -> tuple[int, str, str, float]:
    """Run ``argv`` with stdout and stderr to pipes, as a shell pipeline would; return its exit
    code, both texts, and how long the pipes stayed open after it exited (an assertion fails when
    they were still open ``eof_bound_s`` after: something it started holds them)."""
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    chunks: dict[str, list[bytes]] = {"out": [], "err": []}
    eof: dict[str, float] = {}

    def drain(name: str, stream: object) -> None:
        assert hasattr(stream, "read")
        while True:
            b = stream.read(65536)
            if not b:
                break
            chunks[name].append(b)
        eof[name] = time.monotonic()

    threads = [threading.Thread(target=drain, args=(n, s), daemon=True)
               for n, s in (("out", proc.stdout), ("err", proc.stderr))]
    for t in threads:
        t.start()
    try:
        code = proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise AssertionError(f"{argv[:6]} did not end within {timeout_s} s") from None
    exited = time.monotonic()
    for t in threads:
        t.join(eof_bound_s)
    out, err = (b"".join(chunks[n]).decode("utf-8", "replace") for n in ("out", "err"))
    assert len(eof) == 2, (f"the pipes of {argv[:6]} were still open {eof_bound_s} s after it exited "
                           f"(a process it started holds them); stderr so far: {err[-2000:]}")
    return code, out, err, max(eof.values()) - exited
