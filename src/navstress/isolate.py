"""A child process for code that may crash, hang or exit: the navigator under test.

(A module of its own, below ``navstress.nav.check``, ``navstress.run`` and
``navstress.campaign``, so that all three use it; it needs only ``navstress.nav.registry``.)

``navstress run``, ``navstress nav check`` and the campaign's local executor run the navigator
in worker processes (spawn context) with a wall-clock limit, so that a navigator that calls
``sys.exit``, ``os._exit``, segfaults, kills itself or loops forever costs its own run (or
check), never the command:

- the worker dies with its parent (Linux ``PR_SET_PDEATHSIG`` plus a watch thread) and ignores
  SIGINT (Ctrl-C is the parent's: it stops the command and kills the worker);
- the worker's standard output is its standard error (:func:`stdout_to_stderr`): what the
  navigator prints never mixes into the command's standard output (a ``--json`` document);
- the parent waits for each answer at most the wall-clock limit, then kills the worker;
- names registered with :func:`navstress.nav.registry.register` in the parent (``module:attr``
  targets, or factories that pickle) are registered in the worker too.

:class:`Child` is one worker process and its pipe, never waited for (the campaign's pool holds
several and waits on all at once); every worker runs the same loop (``_worker_main``).
:class:`Worker` holds one and runs one call at a time; :meth:`Worker.call` answers ``("ok", value)``,
``("raised", exception)`` (any ``BaseException`` the call raised, pickled back),
``("died", "exit code 3" | "signal SIGSEGV")`` or ``("limit", seconds)``; after ``died`` or
``limit`` the worker is gone and the next call starts a fresh one. Messages that the call sends
with :func:`report` (e.g. the check being run) are passed to ``on_message`` as they come.
"""

from __future__ import annotations

import ctypes
import importlib
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import pickle
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from navstress.nav import registry

__all__ = ["Child", "Worker", "describe_exit", "die_with_parent", "registered_targets", "report",
           "stdout_to_stderr"]

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


def stdout_to_stderr() -> None:
    """In a worker process: make file descriptor 1 a copy of 2, so that what the code under
    test prints (``print``, a C library, a child process it starts) goes to the command's stderr
    and never into its stdout, which carries a ``--json`` document."""
    try:
        sys.stdout.flush()
        os.dup2(2, 1)
    except (OSError, ValueError, AttributeError):  # no stderr to share: leave stdout as it is
        pass


def _worker_main(conn: mpc.Connection, parent_pid: int, targets: dict[str, Any], preload: tuple[str, ...],
                 warm: Callable[[], object] | None) -> None:
    """The worker loop: get ready (imports, registrations, ``warm``), answer ``("ready", None)``;
    then per ``(fn, args)`` received, ``("started", None)`` and ``("ok", value)`` or
    ``("raised", exception)``; None (or a closed pipe) ends it."""
    global _conn
    die_with_parent(parent_pid)
    stdout_to_stderr()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
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
    if warm is not None:
        warm()
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
        conn.send(("started", None))
        try:
            answer: tuple[str, Any] = ("ok", fn(*args))
        except BaseException as err:  # sys.exit, KeyboardInterrupt... from the code under test
            answer = ("raised", _picklable(err))
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            conn.send(answer)
        except Exception as err:  # a value that does not pickle: nothing was written yet
            conn.send(("raised", RuntimeError(f"the answer could not be sent: {type(err).__name__}: {err}")))


def _picklable(err: BaseException) -> BaseException:
    try:
        pickle.loads(pickle.dumps(err))
        return err
    except Exception:
        return RuntimeError(f"{type(err).__name__}: {err}")


#: How long a fresh worker may take to start (imports) before it is given up.
START_LIMIT_S = 300.0


class Child:
    """One worker process and its pipe, started at once and never waited for here: the
    campaign's local pool holds several and waits on all of them (:class:`Worker` waits on one).

    ``targets``: names to register in the worker; ``preload``: modules it imports and ``warm``: a
    module-level function it calls before it answers "ready" and takes calls."""

    def __init__(self, targets: dict[str, Any], *, preload: tuple[str, ...] = (),
                 warm: Callable[[], object] | None = None) -> None:
        ctx = mp.get_context("spawn")
        parent, child = ctx.Pipe(duplex=True)
        self.proc: Any = ctx.Process(target=_worker_main, args=(child, os.getpid(), targets, preload, warm),
                                     daemon=True)
        self.proc.start()
        child.close()
        self.conn: mpc.Connection = parent

    @property
    def waitables(self) -> list[Any]:
        """What :func:`multiprocessing.connection.wait` waits on: an answer, or the process's end."""
        return [self.conn, self.proc.sentinel]

    def send(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> bool:
        """Ask the worker to call ``fn(*args)``; False when the worker is gone."""
        try:
            self.conn.send((fn, args))
            return True
        except (OSError, ValueError):
            return False

    def receive(self) -> tuple[str, Any] | None:
        """The next message when one is there: ``(kind, value)`` (ready, started, message, ok,
        raised), ``("", None)`` when the pipe broke; None when there is nothing to read.
        An answer that cannot be unpickled here is ``("raised", RuntimeError)``."""
        if not self.conn.poll():
            return None
        try:
            kind, value = self.conn.recv()
        except (EOFError, OSError):
            return "", None
        except Exception as err:
            return "raised", RuntimeError(f"the worker's answer could not be read: {err}")
        return kind, value

    def ended(self, *, broken: bool = False) -> str | None:
        """How the worker ended ("exit code 3", "signal SIGSEGV"), or None while it lives; with
        ``broken`` (its pipe broke) a live worker is given 0.5 s, then killed. An ended worker's
        pipe is closed."""
        if broken and self.proc.is_alive():
            self.proc.join(0.5)
        if self.proc.is_alive() and not broken:
            return None
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(1.0)
        self.conn.close()
        return describe_exit(self.proc.exitcode)

    def kill(self) -> None:
        """Kill the worker now and close its pipe."""
        self.proc.kill()
        self.proc.join(5.0)
        self.conn.close()

    def stop(self, *, kill: bool = False) -> None:
        """Ask the worker to end (``kill``: kill it first); :meth:`reap` then waits for it."""
        if kill:
            self.proc.kill()
        try:
            self.conn.send(None)
        except (OSError, ValueError):
            pass

    def reap(self) -> None:
        """Wait up to 2 s for an ended worker, then kill it; close its pipe. Idempotent."""
        self.proc.join(2.0)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join(2.0)
        self.conn.close()


class Worker:
    """One worker process, started on the first call and again after one died or was killed.

    ``preload``: modules the worker imports before it takes calls (outside the limit)."""

    def __init__(self, wall_limit_s: float, *, preload: tuple[str, ...] = ()) -> None:
        self.wall_limit_s = float(wall_limit_s)
        self.preload = tuple(preload)
        self._child: Child | None = None
        self._targets = registered_targets()

    def _start(self) -> str | None:
        """Start the worker and wait for it to be ready; a reason when it could not."""
        self._child = Child(self._targets, preload=self.preload)
        status, value = self._wait(START_LIMIT_S, None)
        if status != "ok":
            self.close()
            return f"the worker process could not start ({value})"
        return None

    def _wait(self, limit_s: float, on_message: Callable[[Any], None] | None,
              restart: bool = False) -> tuple[str, Any]:
        child = self._child
        assert child is not None
        deadline = time.monotonic() + limit_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self._kill()
                return "limit", limit_s
            # at most an hour per wait: poll() refuses timeouts past ~24 days; the loop goes on
            mpc.wait(child.waitables, timeout=min(remaining, 3600.0))
            got = child.receive()
            if got is not None and got[0] != "":
                kind, value = got
                if kind == "message":
                    if on_message is not None:
                        on_message(value)
                    if restart:
                        deadline = time.monotonic() + limit_s
                    continue
                if kind == "started":
                    continue
                if kind == "ready":
                    return "ok", None
                return kind, value
            why = child.ended(broken=got is not None)
            if why is not None:
                self._child = None
                return "died", why

    def call(self, fn: Callable[..., Any], *args: Any, on_message: Callable[[Any], None] | None = None,
             limit_per_message: bool = False) -> tuple[str, Any]:
        """``fn(*args)`` in the worker (``fn`` must pickle by reference: a module-level function).

        The wall-clock limit counts from when the call is sent to a started worker (with
        ``limit_per_message``: from the last message the call sent)."""
        if self._child is None:
            why = self._start()
            if why is not None:
                return "died", why
        assert self._child is not None
        if not self._child.send(fn, args):
            self.close()
            return "died", "the worker process is gone"
        return self._wait(self.wall_limit_s, on_message, limit_per_message)

    def _kill(self) -> None:
        if self._child is not None:
            self._child.kill()
        self._child = None

    def close(self) -> None:
        """Ask the worker to end, kill it if it does not. Idempotent."""
        if self._child is not None:
            self._child.stop()
            self._child.reap()
        self._child = None

    def __enter__(self) -> Worker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
