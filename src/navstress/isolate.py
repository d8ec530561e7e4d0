"""A child process for code that may crash, hang or exit: the navigator under test.

(A module of its own, below ``navstress.nav`` and ``navstress.run``, so that both can use it.)

``navstress run`` and ``navstress nav check`` run the navigator in a worker process (spawn
context) with a wall-clock limit, as the campaign executors do, so that a navigator that calls
``sys.exit``, ``os._exit``, segfaults, kills itself or loops forever costs its own run (or
check), never the command:

- the worker dies with its parent (Linux ``PR_SET_PDEATHSIG`` plus a watch thread) and ignores
  SIGINT (Ctrl-C is the parent's: it stops the command and kills the worker);
- the parent waits for each answer at most the wall-clock limit, then kills the worker;
- names registered with :func:`navstress.nav.registry.register` in the parent (``module:attr``
  targets, or factories that pickle) are registered in the worker too.

:class:`Worker` runs one call at a time; :meth:`Worker.call` answers ``("ok", value)``,
``("raised", exception)`` (any ``BaseException`` the call raised, pickled back),
``("died", "exit code 3" | "signal SIGSEGV")`` or ``("limit", seconds)``; after ``died`` or
``limit`` the worker is gone and the next call starts a fresh one. Messages that the call sends
with :func:`report` (e.g. the check being run) are passed to ``on_message`` as they come.
"""

from __future__ import annotations

import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

__all__ = ["Worker", "describe_exit", "die_with_parent", "registered_targets", "report"]

_conn: mpc.Connection | None = None  # the worker's end of its pipe (set in the worker only)


def describe_exit(code: int | None) -> str:
    """'exit code 3' / 'signal SIGSEGV' for a process exit status."""
    if code is None:
        return "unknown status"
    if code < 0:
        try:
            return f"signal {signal.Signals(-code).name}"
        except ValueError:
            return f"signal {-code}"
    return f"exit code {code}"


def registered_targets() -> dict[str, Any]:
    """The names registered in this process (``register()``), to register in a worker:
    ``module:attr`` strings, and factories that can be pickled (others are left out: the
    worker then reports the name as unknown)."""
    import pickle

    from navstress.nav import registry

    out: dict[str, Any] = {}
    for name, spec in registry._registered.items():
        if isinstance(spec.target, str):
            out[name] = spec.target
            continue
        try:
            pickle.dumps(spec.target)
        except Exception:
            continue
        out[name] = spec.target
    return out


def report(message: Any) -> None:
    """From inside a worker call: send ``message`` to the parent's ``on_message`` (no-op elsewhere)."""
    if _conn is not None:
        _conn.send(("message", message))


def die_with_parent(parent_pid: int) -> None:
    """In a worker process: die when ``parent_pid`` does (PR_SET_PDEATHSIG on Linux, plus a
    watch thread), so a killed parent leaves no orphan writing files behind it."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:
            pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _worker_main(conn: mpc.Connection, parent_pid: int, targets: dict[str, Any], preload: tuple[str, ...]) -> None:
    """Receive ``(fn, args)``, answer ``("ok", value)`` or ``("raised", exception)``; None ends."""
    global _conn
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
    import importlib

    from navstress.nav import registry

    for module in preload:  # imports before "ready": the wall-clock limit measures the work
        try:
            importlib.import_module(module)
        except Exception:
            pass

    for name, target in targets.items():
        try:
            registry.register(name, target, override=True)
        except Exception:
            pass
    _conn = conn
    conn.send(("ready", None))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        fn, args = msg
        try:
            answer: tuple[str, Any] = ("ok", fn(*args))
        except BaseException as err:  # sys.exit, KeyboardInterrupt... from the code under test
            answer = ("raised", _picklable(err))
        sys.stdout.flush()
        sys.stderr.flush()
        conn.send(answer)


def _picklable(err: BaseException) -> BaseException:
    import pickle

    try:
        pickle.loads(pickle.dumps(err))
        return err
    except Exception:
        return RuntimeError(f"{type(err).__name__}: {err}")


#: How long a fresh worker may take to start (imports) before it is given up.
START_LIMIT_S = 300.0


class Worker:
    """One worker process, started on the first call and again after one died or was killed.

    ``preload``: modules the worker imports before it takes calls (outside the limit)."""

    def __init__(self, wall_limit_s: float, *, preload: tuple[str, ...] = ()) -> None:
        self.wall_limit_s = float(wall_limit_s)
        self.preload = tuple(preload)
        self._ctx = mp.get_context("spawn")
        self._proc: Any = None
        self._conn: mpc.Connection | None = None
        self._targets = registered_targets()

    def _start(self) -> str | None:
        """Start the worker and wait for it to be ready; a reason when it could not."""
        parent, child = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=_worker_main, args=(child, os.getpid(), self._targets, self.preload),
                                 daemon=True)
        proc.start()
        child.close()
        self._proc, self._conn = proc, parent
        status, value = self._wait(START_LIMIT_S, None)
        if status != "ok":
            self.close()
            return f"the worker process could not start ({value})"
        return None

    def _wait(self, limit_s: float, on_message: Callable[[Any], None] | None,
              restart: bool = False) -> tuple[str, Any]:
        assert self._conn is not None and self._proc is not None
        deadline = time.monotonic() + limit_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self._kill()
                return "limit", limit_s
            # at most an hour per wait: poll() refuses timeouts past ~24 days; the loop goes on
            mpc.wait([self._conn, self._proc.sentinel], timeout=min(remaining, 3600.0))
            kind = "none"
            if self._conn.poll():
                try:
                    kind, value = self._conn.recv()
                except (EOFError, OSError):
                    kind, value = "", None
                except Exception as err:  # an answer that cannot be unpickled here
                    return "raised", RuntimeError(f"the worker's answer could not be read: {err}")
                else:
                    if kind == "message":
                        if on_message is not None:
                            on_message(value)
                        if restart:
                            deadline = time.monotonic() + limit_s
                        continue
                    if kind == "ready":
                        return "ok", None
                    return kind, value
            if kind == "" and self._proc.is_alive():  # the pipe broke under a live worker
                self._proc.join(0.5)
            if not self._proc.is_alive() or kind == "":
                if self._proc.is_alive():
                    self._proc.kill()
                self._proc.join(1.0)
                code = self._proc.exitcode
                self._conn.close()
                self._proc = self._conn = None
                return "died", describe_exit(code)

    def call(self, fn: Callable[..., Any], *args: Any, on_message: Callable[[Any], None] | None = None,
             limit_per_message: bool = False) -> tuple[str, Any]:
        """``fn(*args)`` in the worker (``fn`` must pickle by reference: a module-level function).

        The wall-clock limit counts from when the call is sent to a started worker (with
        ``limit_per_message``: from the last message the call sent)."""
        if self._proc is None:
            why = self._start()
            if why is not None:
                return "died", why
        assert self._conn is not None
        try:
            self._conn.send((fn, args))
        except (OSError, ValueError):
            self.close()
            return "died", "the worker process is gone"
        return self._wait(self.wall_limit_s, on_message, limit_per_message)

    def _kill(self) -> None:
        if self._proc is not None:
            self._proc.kill()
            self._proc.join(5.0)
        if self._conn is not None:
            self._conn.close()
        self._proc = self._conn = None

    def close(self) -> None:
        """Ask the worker to end, kill it if it does not. Idempotent."""
        if self._proc is not None and self._conn is not None:
            try:
                self._conn.send(None)
            except (OSError, ValueError):
                pass
            self._proc.join(2.0)
        self._kill()

    def __enter__(self) -> Worker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
