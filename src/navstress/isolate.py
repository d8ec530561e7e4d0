"""A child process for code that may crash, hang or exit: the navigator under test.

(A module of its own, below ``navstress.nav.check``, ``navstress.run`` and
``navstress.campaign``, so that all three use it; it needs only ``navstress.nav.registry``.)

``navstress run``, ``navstress nav check``, ``navstress replay`` and the campaign's local executor
(campaigns, searches) run the navigator in worker processes (spawn context) with a wall-clock
limit, so that a navigator that calls
``sys.exit``, ``os._exit``, segfaults, kills itself or loops forever costs its own run (or
check), never the command:

- the worker dies with its parent (Linux ``PR_SET_PDEATHSIG`` plus a watch thread) and ignores
  SIGINT (Ctrl-C is the parent's: it stops the command and kills the worker);
- what the navigator starts ends with its call: the process the parent starts is a *keeper*
  (a session and process group of its own, a child subreaper) that forks the worker and
  never runs the code under test. The worker is a subreaper too and, after each call, kills
  every process below it (children, grandchildren, ``setsid``/double-forked daemons: with a
  subreaper, an orphan is reparented to it, never to init). When the worker ends, however it
  ends (``os._exit``, a signal, killed at the wall-clock limit, the parent gone), the keeper
  kills what is left below it, then ends with the worker's own exit status, so the parent
  sees "exit code 7" or "signal SIGSEGV" as before; the parent finally kills the process
  group. Nothing the navigator started outlives its run, holding the command's stdout or
  stderr open (:func:`end_descendants`). What escapes: a process that another service starts
  for it (a container runtime, ``systemd-run``), and anything after the keeper itself is
  SIGKILLed from outside (its group is still killed; a ``setsid`` daemon is not);
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
import resource
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from navstress.nav import registry

__all__ = ["Child", "Worker", "describe_exit", "die_with_parent", "end_descendants", "registered_targets",
           "report", "stdout_to_stderr"]

_conn: mpc.Connection | None = None  # the worker's end of its pipe (set in the worker only)
_worker_pid = 0  # in a keeper: its worker's process id


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
    for name, spec in registry.registered().items():
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


_PR_SET_PDEATHSIG = 1
_PR_SET_CHILD_SUBREAPER = 36


def _prctl(option: int, value: int) -> bool:
    """Linux ``prctl(option, value)``; False where it is not there or fails."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        return int(libc.prctl(option, value, 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def die_with_parent(parent_pid: int, sig: int = signal.SIGKILL, *, watch: bool = True) -> None:
    """In a worker process: die when ``parent_pid`` does (PR_SET_PDEATHSIG on Linux, plus a
    watch thread), so a killed parent leaves no orphan writing files behind it. ``sig``: the
    signal this process gets then (the keeper's is SIGTERM: it ends its worker first);
    ``watch``: start the watch thread now (else call :func:`_watch_parent` later)."""
    _prctl(_PR_SET_PDEATHSIG, int(sig))
    if os.getppid() != parent_pid:
        os._exit(1)
    if watch:
        _watch_parent(parent_pid, sig)


def _watch_parent(parent_pid: int, sig: int) -> None:
    """A thread that sends ``sig`` to this process once ``parent_pid`` is no longer its parent
    (where PR_SET_PDEATHSIG is not there, or was set too late)."""

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                if sig == signal.SIGKILL:
                    os._exit(1)
                os.kill(os.getpid(), sig)
                return

    threading.Thread(target=watch, daemon=True).start()


def _has_children() -> bool:
    """Whether this process has any child, running or a zombie (no /proc read: one system call)."""
    try:
        os.waitid(os.P_ALL, 0, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:
        return False
    except (AttributeError, OSError):  # no waitid here: assume there may be some
        return True
    return True


def _process_table() -> dict[int, tuple[str, int]]:
    """Every process's (state, parent pid), from /proc (empty where there is no /proc)."""
    table: dict[int, tuple[str, int]] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return table
    for name in entries:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                text = f.read()
        except OSError:  # gone meanwhile
            continue
        fields = text[text.rindex(b")") + 2:].split(b" ", 2)  # after "pid (comm) "
        table[int(name)] = (fields[0].decode("ascii", "replace"), int(fields[1]))
    return table


def _below(root: int, table: dict[int, tuple[str, int]]) -> list[int]:
    """The processes below ``root`` in ``table`` (children first, then theirs)."""
    kids: dict[int, list[int]] = {}
    for pid, (_state, ppid) in table.items():
        kids.setdefault(ppid, []).append(pid)
    out: list[int] = []
    todo = list(kids.get(root, ()))
    while todo:
        pid = todo.pop()
        out.append(pid)
        todo += kids.get(pid, ())
    return out


def end_descendants(bound_s: float = 5.0) -> list[int]:
    """In this process: SIGKILL every process below it and reap its children; return those
    still there after ``bound_s`` seconds (a process stuck in the kernel), normally none.

    Complete in a child subreaper (the worker and its keeper are: an orphan below it is
    reparented to it, so every process it started, ``setsid`` or double-forked ones included,
    stays below it); it costs one system call when there is nothing to end."""
    me = os.getpid()
    deadline = time.monotonic() + bound_s
    left: list[int] = []
    while _has_children():
        table = _process_table()
        if not table:  # no /proc: the children are unknown; reap what has ended
            _reap_ended()
            return []
        left = [pid for pid in _below(me, table) if table[pid][0] not in ("Z", "X")]
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:  # gone, or not ours to kill
                pass
        _reap_ended()
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.002)
    return left


def _reap_ended() -> None:
    """Reap every child of this process that has ended."""
    while True:
        try:
            pid, _status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


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
    """The process the parent started: the keeper of one worker (module doc). It takes a session
    of its own and becomes a child subreaper, forks the worker (which runs :func:`_serve`), then
    waits for it and ends what it left (:func:`_keep`)."""
    try:
        os.setsid()  # its own session and process group: the parent kills the group at the end
    except OSError:
        pass
    _prctl(_PR_SET_CHILD_SUBREAPER, 1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
    signal.signal(signal.SIGTERM, _keeper_stop)  # from the parent (kill) or when it dies (PDEATHSIG)
    stdout_to_stderr()  # the keeper holds none of the command's stdout either
    die_with_parent(parent_pid, signal.SIGTERM, watch=False)  # no thread before the fork
    keeper = os.getpid()
    worker = os.fork()
    if worker == 0:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        _serve(conn, keeper, targets, preload, warm)  # then back to multiprocessing: a normal exit
        return
    global _worker_pid
    _worker_pid = worker
    conn.close()
    _watch_parent(parent_pid, signal.SIGTERM)
    _keep(worker)


def _keeper_stop(signum: int, frame: Any) -> None:
    """The keeper's SIGTERM: kill the worker (:func:`_keep` then ends what is below it, and
    the keeper); before the worker is forked, end at once."""
    if _worker_pid == 0:
        os._exit(1)
    try:
        os.kill(_worker_pid, signal.SIGKILL)
    except OSError:  # ended already: its status stands
        pass


def _keep(worker: int) -> None:
    """The keeper's loop: reap whatever ends below it until ``worker`` has, end what is left,
    exit as the worker did. Never returns."""
    while True:
        try:
            pid, status = os.waitpid(-1, 0)
        except ChildProcessError:
            status = 0
            break
        if pid == worker:
            break
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})  # the worker has ended: finish the cleanup
    end_descendants()
    code = os.waitstatus_to_exitcode(status)
    if code < 0:  # the same signal, so that the parent says "signal SIGSEGV"
        try:
            resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
            if -code not in (signal.SIGKILL, signal.SIGSTOP):
                signal.signal(-code, signal.SIG_DFL)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {-code})
            os.kill(os.getpid(), -code)
        except (OSError, ValueError):
            pass
        os._exit(128 - code)
    os._exit(code)


def _serve(conn: mpc.Connection, keeper: int, targets: dict[str, Any], preload: tuple[str, ...],
           warm: Callable[[], object] | None) -> None:
    """The worker loop: get ready (imports, registrations, ``warm``), answer ``("ready", None)``;
    then per ``(fn, args)`` received, ``("started", None)`` and ``("ok", value)`` or
    ``("raised", exception)``, each once every process the call started has been ended;
    None (or a closed pipe) ends it."""
    global _conn
    die_with_parent(keeper)
    _prctl(_PR_SET_CHILD_SUBREAPER, 1)
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
        end_descendants()
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
        end_descendants()  # what the call started ends with it
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
        pipe is closed, and everything it started is gone."""
        if broken and self._running():
            self._exited(0.5)
        if self._running() and not broken:
            return None
        self._end()
        return describe_exit(self.proc.exitcode)

    def kill(self) -> None:
        """Kill the worker now, and everything it started; close its pipe."""
        self._end()

    def stop(self, *, kill: bool = False) -> None:
        """Ask the worker to end (``kill``: kill it first); :meth:`reap` then waits for it."""
        if kill:
            self._terminate()
        try:
            self.conn.send(None)
        except (OSError, ValueError):
            pass

    def reap(self) -> None:
        """Wait up to 2 s for an ended worker, then kill it; close its pipe. Idempotent."""
        self._exited(2.0)
        self._end()

    # -- the end of the keeper's process tree (module doc) ------------------------------------------
    def _unreaped(self) -> bool:
        """The keeper's pid is still this process's child (running, or ended and not reaped):
        its process group id cannot be anyone else's."""
        if not hasattr(os, "waitid"):  # (not on macOS): as multiprocessing knows it
            return self.proc._popen is not None and self.proc._popen.returncode is None
        try:
            os.waitid(os.P_PID, self.proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except (ChildProcessError, OSError):
            return False
        return True

    def _running(self) -> bool:
        """The keeper has not ended (it is not reaped here: see :meth:`_unreaped`)."""
        if not hasattr(os, "waitid"):
            return bool(self.proc.is_alive())
        try:
            got = os.waitid(os.P_PID, self.proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except (ChildProcessError, OSError):
            return False
        return got is None

    def _exited(self, timeout_s: float) -> bool:
        """Wait at most ``timeout_s`` for the keeper to end (not reaping it)."""
        deadline = time.monotonic() + timeout_s
        while self._running():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            # the sentinel is ready once every holder of its pipe has ended; poll the keeper too
            mpc.wait([self.proc.sentinel], timeout=min(remaining, 0.05))
        return True

    def _terminate(self) -> None:
        """Ask the keeper to kill the worker and everything below it (SIGTERM), and end."""
        if self._running():
            try:
                os.kill(self.proc.pid, signal.SIGTERM)
            except OSError:
                pass

    def _end(self) -> None:
        """End the worker's whole tree: the keeper's own clean-up first (3 s at most), then
        SIGKILL to its process group (what is left if the keeper itself was killed); reap the
        keeper and close the pipe. Idempotent."""
        self._terminate()
        self._exited(3.0)
        if self._unreaped():
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except OSError:  # the group is empty
                pass
            if self._running():  # not the group's leader (no session of its own)
                self.proc.kill()
        self.proc.join()
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

    def close(self, *, now: bool = False) -> None:
        """Ask the worker to end, kill it if it does not (``now``: kill it at once, as when
        Ctrl-C stops the command). Idempotent."""
        if self._child is not None:
            if now:
                self._child.kill()
            else:
                self._child.stop()
                self._child.reap()
        self._child = None

    def __enter__(self) -> Worker:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(now=exc_type is not None)
