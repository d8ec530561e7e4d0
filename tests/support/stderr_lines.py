"""Run navstress command lines in one process with standard error on a real file or on a real
pseudo-terminal (file descriptor 2 itself is replaced, so rich and click see what a user's shell
gives them), and print, as JSON, each command's exit code and the exact bytes of its standard
error.

    python stderr_lines.py < cases.json > results.json

``cases.json``: a list of ``{"argv": [...], "mode": "file" | "pty"}``. Run as a script (a child
process of the test): what one command leaves behind in the process (signal handlers, rich's
consoles) cannot reach the test's own process.
"""

from __future__ import annotations

import json
import os
import pty
import select
import sys
import tempfile
import threading
from typing import Any


#: After the command, how long the reader waits for bytes still on their way through the
#: pseudo-terminal (the kernel hands them to the reading end asynchronously: under load they can
#: arrive after the writing end is closed) before it gives up; normally the closed writing end
#: ends the read at once (EIO).
DRAIN_GRACE_S = 3.0


def _drain(fd: int, out: bytearray, stop: threading.Event) -> None:
    idle = 0.0
    while True:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # EIO: the writing end is closed and everything was read
                return
            if not chunk:
                return
            out.extend(chunk)
            idle = 0.0
        elif stop.is_set():
            idle += 0.05
            if idle >= DRAIN_GRACE_S:
                return


def run(argv: list[str], mode: str) -> dict[str, Any]:
    """Exit code, standard error (bytes as latin-1 text) and standard output of ``navstress argv``."""
    from navstress.cli import app

    sys.stdout.flush()
    sys.stderr.flush()
    saved_err, saved_out = os.dup(2), os.dup(1)
    out_file = tempfile.TemporaryFile()
    err_file = tempfile.TemporaryFile() if mode == "file" else None
    captured = bytearray()
    stop = threading.Event()
    reader = None
    master = slave = -1
    if mode == "pty":
        master, slave = pty.openpty()
        os.dup2(slave, 2)
        reader = threading.Thread(target=_drain, args=(master, captured, stop), daemon=True)
        reader.start()
    else:
        assert err_file is not None
        os.dup2(err_file.fileno(), 2)
    os.dup2(out_file.fileno(), 1)
    code: Any = 0
    try:
        app(args=argv, prog_name="navstress")
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except BaseException as e:  # noqa: BLE001 - reported, not raised: the test says what went wrong
        code = f"raised {type(e).__name__}: {e}"
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved_err, 2)
        os.dup2(saved_out, 1)
        os.close(saved_err)
        os.close(saved_out)
    if mode == "pty":
        os.close(slave)
        stop.set()
        assert reader is not None
        reader.join(timeout=5)
        os.close(master)
        err = bytes(captured)
    else:
        assert err_file is not None
        err_file.seek(0)
        err = err_file.read()
    out_file.seek(0)
    return {"argv": argv, "mode": mode, "code": code, "stderr": err.decode("latin-1"),
            "stdout": out_file.read().decode("latin-1")[-2000:]}


def main() -> None:
    cases = json.load(sys.stdin)
    results = [run(c["argv"], c["mode"]) for c in cases]
    sys.stdout.write(json.dumps(results))


if __name__ == "__main__":
    main()
