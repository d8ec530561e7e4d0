"""Out-of-process navigators: any program that speaks the line protocol of :mod:`navstress.nav.wire`.

:class:`ExternalNavigator` implements :class:`~navstress.nav.api.Navigator` by spawning a
process and exchanging one JSON line per request over its stdin/stdout. It enforces a
wall-clock budget per request. That budget is a *safety net that ends the run*, never an input
to the simulation: a navigator answering within budget gets exactly the same observations and
produces the same trajectory whatever its speed (DESIGN invariant 3); one that overruns it, crashes
or answers garbage ends the run with ``Status("error", "navigator process ...",
infrastructure=True)`` and a precise reason (exit code and last stderr lines; ``no answer
within 2.0 s``; ``invalid message: ...``), which the run loop classifies (DESIGN invariant 4,
Fail-Other). :attr:`ExternalNavigator.failure` keeps the machine-readable kind.

The process runs in its own session (process group); ``close()`` (always called) asks it to exit,
then kills the whole group and reaps it, so no process is left behind.

    navigator = ExternalNavigator([sys.executable, "my_nav.py"], step_budget_s=2.0)

:func:`serve` does the opposite: it runs any in-process navigator behind the protocol
(``python -m navstress.nav.external NAME``), e.g. to isolate a stack that may crash.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Literal

from navstress import _json
from navstress.errors import MISSING, NavigatorError, SpecError
from navstress.nav import wire
from navstress.nav.api import Command, DebugDraw, NavMission, Navigator, Observation, Status, check_debug
from navstress.nav.registry import make_navigator
from navstress.robot import RobotSpec

__all__ = ["ExternalFailure", "ExternalNavigator", "external_from_config", "serve"]

MAX_LINE_BYTES = 64 * 1024 * 1024
"""A reply line longer than this (without a newline) is a protocol violation."""

STDERR_TAIL_BYTES = 64 * 1024
"""How much of the navigator's stderr is kept (the last bytes) for the error message."""
STDERR_LINE_CHARS = 500
"""A longer stderr line is cut to this many characters in the error message."""

FailureKind = Literal["exit", "timeout", "protocol", "navigator"]


@dataclass(frozen=True)
class ExternalFailure:
    """Why an external navigator ended the run.

    ``kind``: ``exit`` (the process ended), ``timeout`` (no answer within budget),
    ``protocol`` (garbage or an unexpected message), ``navigator`` (it refused a reset).
    """

    kind: FailureKind
    message: str


def _fmt_s(seconds: float) -> str:
    s = f"{seconds:.3f}".rstrip("0")
    return s + "0" if s.endswith(".") else s


def _describe_exit(rc: int) -> str:
    if rc < 0:
        try:
            name = signal.Signals(-rc).name
        except ValueError:
            name = f"signal {-rc}"
        return f"was killed by {name} (exit code {rc})"
    return f"exited with code {rc}"


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGKILL the process group of ``proc`` (its own session) and reap the leader."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        proc.kill()
    with contextlib.suppress(Exception):
        proc.wait(timeout=5.0)


class ExternalNavigator:
    """A navigator running in another process, spoken to over the line protocol.

    ``argv``: the command to start (no shell). The process is started on the first ``reset``
    (and started afresh on a ``reset`` after a failure). Budgets are wall-clock seconds:
    ``reset_budget_s`` covers start-up + hello and each reset, ``step_budget_s`` each step.
    A command that cannot be started raises :class:`NavigatorError` (a configuration error);
    everything that goes wrong later ends the run with a ``Status("error", ...)``.
    """

    def __init__(
        self,
        argv: Sequence[str],
        *,
        step_budget_s: float = 2.0,
        reset_budget_s: float = 30.0,
        close_budget_s: float = 2.0,
        cwd: str | Path | None = None,
        env: Mapping[str, str] | None = None,
        stderr_lines: int = 8,
    ) -> None:
        argv = [str(a) for a in argv]
        if not argv:
            raise SpecError("command", argv, "a non-empty list: program and arguments")
        for name, value in (("step_budget_s", step_budget_s), ("reset_budget_s", reset_budget_s),
                            ("close_budget_s", close_budget_s)):
            if not (isinstance(value, (int, float)) and value > 0):
                raise SpecError(name, value, "a positive number of seconds")
        prog = argv[0]
        if shutil.which(prog, path=(env or os.environ).get("PATH")) is None and not (
            os.sep in prog and os.access(prog, os.X_OK)
        ):
            raise NavigatorError(
                f"cannot start navigator process: {prog!r} is not an executable file or a "
                "program on PATH; fix the 'command' of the navigator config"
            )
        self.argv = argv
        self.step_budget_s = float(step_budget_s)
        self.reset_budget_s = float(reset_budget_s)
        self.close_budget_s = float(close_budget_s)
        self.cwd = None if cwd is None else str(cwd)
        self.env = None if env is None else {**os.environ, **env}
        self.failure: ExternalFailure | None = None
        self.remote_name: str | None = None
        self.step_times_s: list[float] = []
        self.stderr_lines = int(stderr_lines)
        self._stderr = bytearray()  # the last STDERR_TAIL_BYTES the process wrote on stderr
        self._stderr_lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self.last_pid: int | None = None  # kept after the process is gone (diagnostics)
        self._stderr_thread: threading.Thread | None = None
        self._buf = bytearray()
        self._finalizer: weakref.finalize | None = None  # type: ignore[type-arg]
        self._want_debug = False
        self._debug: object = None  # the last step reply's "debug" field, decoded when asked
        #: the protocol version the navigator answered hello with (wire.PROTOCOLS)
        self.protocol = wire.PROTOCOL_VERSION

    # ------------------------------------------------------------ Navigator

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        """Start the process if needed (hello), then send ``reset``. Failures are kept and
        reported by the next ``step``; only a command that cannot start raises."""
        if self._proc is None or self.failure is not None or _exited(self._proc):
            self._shutdown(graceful=False)
            self.failure = None
            self._spawn()
            reply = self._request(wire.hello_message(), self.reset_budget_s, "hello")
            if reply is None:
                return
            if reply.get("type") != "hello":
                self._fail("protocol", f"sent an invalid message in reply to hello: expected "
                           f"type 'hello', got {reply.get('type')!r}")
                return
            version = reply.get("protocol")
            if isinstance(version, bool) or version not in wire.PROTOCOLS:
                self._fail("protocol", f"speaks protocol {version!r}, navstress "
                           f"speaks {' or '.join(map(str, wire.PROTOCOLS))}")
                return
            self.protocol = int(version)
            name = reply.get("name")
            self.remote_name = name if isinstance(name, str) else None
        reply = self._request(wire.reset_message(mission, robot, seed, self.protocol), self.reset_budget_s, "reset")
        if reply is None:
            return
        if reply.get("type") == "ok":
            return
        if reply.get("type") == "status" and reply.get("kind") == "error":
            self._fail("navigator", f"refused the reset: {reply.get('message', '')}")
            return
        self._fail("protocol", "sent an invalid message in reply to reset: expected "
                   f"{{'type': 'ok'}}, got {_clip(reply)}")

    def step(self, obs: Observation) -> Command | Status:
        """One control cycle; ``Status('error', 'navigator process ...')`` on any failure."""
        if self.failure is not None:
            return self._error()
        if self._proc is None:
            self._fail("protocol", "was stepped before reset")
            return self._error()
        t0 = time.monotonic()
        self._debug = None
        reply = self._request(wire.step_message(obs, debug=self._want_debug, protocol=self.protocol),
                              self.step_budget_s, "step")
        self.step_times_s.append(time.monotonic() - t0)
        if reply is None:
            return self._error()
        self._debug = reply.get("debug")
        try:
            return wire.decode_command_or_status(reply)
        except wire.WireError as e:
            self._fail("protocol", f"sent an invalid message in reply to step: {e}")
            return self._error()

    def want_debug(self, on: bool) -> None:
        """Whether the host records the drawings: step requests then carry ``"debug": true``."""
        self._want_debug = bool(on)

    def debug(self) -> DebugDraw | None:
        """The drawing that came with the last step reply (its ``"debug"`` field), or None;
        :class:`~navstress.nav.api.InvalidAnswer` when it is malformed (the run records a warning
        and stops asking: a bad drawing never ends a run)."""
        return None if self._debug is None else wire.decode_debug(self._debug)

    def close(self) -> None:
        """Ask the process to exit, then kill its process group and reap it. Idempotent."""
        self._shutdown(graceful=self.failure is None)

    def __enter__(self) -> ExternalNavigator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def pid(self) -> int | None:
        """The process id while a process is held (for tests and diagnostics)."""
        return None if self._proc is None else self._proc.pid

    # ------------------------------------------------------------ internals

    def _spawn(self) -> None:
        try:
            proc = subprocess.Popen(
                self.argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                cwd=self.cwd, env=self.env, start_new_session=True, bufsize=0,
            )
        except OSError as e:
            raise NavigatorError(
                f"cannot start navigator process {shlex.join(self.argv)!r}: {e.strerror or e}; "
                "fix the 'command' of the navigator config"
            ) from e
        assert proc.stdin is not None and proc.stdout is not None and proc.stderr is not None
        os.set_blocking(proc.stdin.fileno(), False)
        os.set_blocking(proc.stdout.fileno(), False)
        self._proc = proc
        self.last_pid = proc.pid
        self._buf = bytearray()
        self._stderr = bytearray()  # a new one: a reader of a previous process may still append to the old
        self._finalizer = weakref.finalize(self, _kill_group, proc)
        stream = proc.stderr
        fd = stream.fileno()
        tail, lock = self._stderr, self._stderr_lock

        def drain() -> None:
            # blocks of up to 64 KiB per system call (a chatty navigator must not slow the run),
            # of which only a bounded tail is kept for the error message
            try:
                while True:
                    try:
                        chunk = os.read(fd, 1 << 16)
                    except OSError:
                        return
                    if not chunk:
                        return
                    with lock:
                        tail.extend(chunk)
                        if len(tail) > STDERR_TAIL_BYTES:
                            del tail[: len(tail) - STDERR_TAIL_BYTES]
            finally:
                with contextlib.suppress(OSError):
                    stream.close()

        self._stderr_thread = threading.Thread(target=drain, name="navstress-ext-stderr",
                                               daemon=True)
        self._stderr_thread.start()

    def _error(self) -> Status:
        assert self.failure is not None
        return Status("error", self.failure.message, infrastructure=True)

    def _fail(self, kind: FailureKind, detail: str) -> None:
        """Record the failure, kill the process now (reaped again in close)."""
        self.failure = ExternalFailure(kind, f"navigator process {detail}")
        self._shutdown(graceful=False)

    def _stderr_tail(self) -> str:
        if self._stderr_thread is not None:
            self._stderr_thread.join(timeout=0.5)  # let it read what the process left
        with self._stderr_lock:
            text = bytes(self._stderr).decode("utf-8", "replace")
        lines = [ln.rstrip() for ln in text.splitlines() if ln.strip()][-self.stderr_lines:]
        if not lines:
            return "no stderr output"
        return "last stderr lines: " + " | ".join(
            ln if len(ln) <= STDERR_LINE_CHARS else ln[:STDERR_LINE_CHARS] + f"... ({len(ln)} characters)"
            for ln in lines)

    def _exit_failure(self, what: str) -> None:
        proc = self._proc
        assert proc is not None
        deadline = time.monotonic() + 1.0
        rc = _peek_exit(proc)
        while rc is None and time.monotonic() < deadline:
            time.sleep(0.002)
            rc = _peek_exit(proc)
        if rc is None:
            self._fail("exit", f"closed its stdout during {what} (still running); "
                       + self._stderr_tail())
            return
        tail = self._stderr_tail()
        self._fail("exit", f"{_describe_exit(rc)} during {what}; {tail}")

    def _request(self, msg: dict[str, Any], budget_s: float, what: str) -> dict[str, Any] | None:
        """Write one message and read one reply line within ``budget_s`` (wall clock).

        Reading and writing are multiplexed, so a process that writes before it has read the
        whole request cannot deadlock us. Returns the parsed reply, or None after a failure.
        """
        proc = self._proc
        assert proc is not None and proc.stdin is not None and proc.stdout is not None
        data = memoryview(wire.dumps(msg))
        win, rout = proc.stdin.fileno(), proc.stdout.fileno()
        deadline = time.monotonic() + budget_s
        while True:
            nl = self._buf.find(b"\n")
            if nl >= 0:
                line = bytes(self._buf[:nl])
                del self._buf[: nl + 1]
                if not line.strip():
                    continue  # tolerate blank lines
                if len(data):
                    self._fail("protocol", f"answered {what} before reading all of it")
                    return None
                try:
                    return wire.loads(line)
                except wire.WireError as e:
                    self._fail("protocol", f"sent an invalid message in reply to {what}: {e}")
                    return None
            if len(self._buf) > MAX_LINE_BYTES:
                self._fail("protocol", f"sent an invalid message in reply to {what}: a line "
                           f"longer than {MAX_LINE_BYTES} bytes")
                return None
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self._fail("timeout", f"gave no answer within {_fmt_s(budget_s)} s to {what} "
                           f"(budget exceeded; the run ends, the process is killed)")
                return None
            wlist = [win] if len(data) else []
            try:
                # at most an hour per select (a huge budget must not overflow it); the loop goes on
                readable, writable, _ = select.select([rout], wlist, [], min(remaining, 3600.0))
            except InterruptedError:
                continue
            if writable:
                try:
                    n = os.write(win, data[: 1 << 16])
                    data = data[n:]
                except BlockingIOError:
                    pass
                except (BrokenPipeError, ConnectionResetError):
                    self._exit_failure(what)
                    return None
            if readable:
                try:
                    chunk = os.read(rout, 1 << 16)
                except BlockingIOError:
                    continue
                if not chunk:
                    self._exit_failure(what)
                    return None
                self._buf += chunk

    def _shutdown(self, *, graceful: bool) -> None:
        proc = self._proc
        if proc is None:
            return
        self._proc = None
        if graceful and not _exited(proc) and proc.stdin is not None:
            with contextlib.suppress(OSError):
                os.write(proc.stdin.fileno(), wire.dumps(wire.close_message()))
            with contextlib.suppress(OSError):
                proc.stdin.close()
            deadline = time.monotonic() + self.close_budget_s
            while time.monotonic() < deadline and not _exited(proc):
                time.sleep(0.005)
        _kill_group(proc)  # the leader and anything it started
        for stream in (proc.stdin, proc.stdout):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
        if self._stderr_thread is not None:
            self._stderr_thread.join(timeout=1.0)
        # the reader closes stderr when it ends; while it still reads (a process outside the group
        # holds the pipe open), closing the descriptor here could let it read a reused one
        if proc.stderr is not None and not (self._stderr_thread is not None and self._stderr_thread.is_alive()):
            with contextlib.suppress(OSError):
                proc.stderr.close()
        if self._finalizer is not None:
            self._finalizer.detach()
            self._finalizer = None


def _peek_exit(proc: subprocess.Popen[bytes]) -> int | None:
    """The leader's exit code (negative: killed by that signal) or None while it runs,
    *without reaping it*, so its pid (also the process-group id) cannot be reused before
    the group is killed. Falls back to ``poll()`` where ``waitid`` is missing."""
    if proc.returncode is not None:
        return proc.returncode
    if hasattr(os, "waitid"):
        try:
            info = os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return proc.poll()
        if info is None:
            return None
        if info.si_code == os.CLD_EXITED:
            return int(info.si_status)
        return -int(info.si_status)
    return proc.poll()


def _exited(proc: subprocess.Popen[bytes]) -> bool:
    return _peek_exit(proc) is not None


def _clip(obj: object, n: int = 120) -> str:
    text = _json.dumps(obj) if isinstance(obj, dict) else repr(obj)
    return text if len(text) <= n else text[:n] + "..."


_CONFIG_KEYS = ("command", "step_budget_s", "reset_budget_s", "close_budget_s", "cwd", "env")


def external_config(config: Mapping[str, Any]) -> tuple[list[str], dict[str, Any]]:
    """Validate an ``external-v1`` config without starting anything: ``(argv, keyword arguments)``.

    Checks the keys, that ``command`` is a non-empty list of strings (or one command line) whose
    program is an executable file or a program on PATH (of ``env`` when given), the budgets
    (finite seconds > 0), ``cwd`` (an existing directory) and ``env`` (strings to strings).
    SpecError fields are ``navigator-config.<key>``."""
    if not isinstance(config, Mapping):
        raise SpecError("navigator-config", config, "a mapping of option names to values")
    unknown = sorted(set(config) - set(_CONFIG_KEYS))
    if unknown:
        raise SpecError(f"navigator-config.{unknown[0]}", config[unknown[0]],
                        f"one of the keys {', '.join(_CONFIG_KEYS)}")
    if "command" not in config:
        raise SpecError("navigator-config.command", MISSING,
                        'the command that starts the navigator, e.g. ["python3", "my_nav.py"]')
    command = config["command"]
    if isinstance(command, str):
        try:
            command = shlex.split(command)
        except ValueError as err:
            raise SpecError("navigator-config.command", config["command"], "a valid command line",
                            str(err)) from None
    if not (isinstance(command, (list, tuple)) and command
            and all(isinstance(c, str) for c in command)):
        raise SpecError("navigator-config.command", command, "a non-empty list of strings")
    for key in ("step_budget_s", "reset_budget_s", "close_budget_s"):
        if key in config:
            v = config[key]
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                raise SpecError(f"navigator-config.{key}", v, "a finite number of seconds > 0")
    cwd = config.get("cwd")
    if cwd is not None and not (isinstance(cwd, (str, os.PathLike)) and Path(cwd).is_dir()):
        raise SpecError("navigator-config.cwd", cwd, "an existing directory")
    env = config.get("env")
    if env is not None and not (isinstance(env, Mapping)
                                and all(isinstance(k, str) and isinstance(v, str) for k, v in env.items())):
        raise SpecError("navigator-config.env", env, "a mapping of variable names to string values")
    prog = command[0]
    search = (env or {}).get("PATH", os.environ.get("PATH"))
    if os.sep in prog:
        where = Path(cwd) / prog if cwd is not None and not os.path.isabs(prog) else Path(prog)
        ok = where.is_file() and os.access(where, os.X_OK)
    else:
        ok = shutil.which(prog, path=search) is not None
    if not ok:
        raise SpecError("navigator-config.command", list(command),
                        "a command whose program is an executable file or a program on PATH",
                        f"{prog!r} is not; fix the path or its permissions (chmod +x)")
    kwargs: dict[str, Any] = {k: config[k] for k in ("step_budget_s", "reset_budget_s",
                                                      "close_budget_s", "cwd", "env")
                              if k in config}
    return list(command), kwargs


def external_from_config(*, config: Mapping[str, Any]) -> ExternalNavigator:
    """Registry factory (``external-v1``): config ``{"command": [...] | "cmd line", ...}``.

    Optional keys: ``step_budget_s``, ``reset_budget_s``, ``close_budget_s``, ``cwd``, ``env``.
    Validated by :func:`external_config` (also its ``validate_config`` hook: nothing starts).
    """
    argv, kwargs = external_config(config)
    return ExternalNavigator(argv, **kwargs)


def _validate_external(config: Mapping[str, Any]) -> None:
    external_config(config)


external_from_config.validate_config = _validate_external  # type: ignore[attr-defined]


# ---------------------------------------------------------------- the other side


def serve(navigator: Navigator, inp: IO[bytes], out: IO[bytes], *, name: str = "") -> int:
    """Serve an in-process navigator over the line protocol until ``close`` or end of input.

    Anything the navigator prints on stdout is moved to stderr (stdout carries the protocol).
    An exception in ``reset`` is answered as a refused reset (``status`` error with its message).
    An exception in ``step`` is not turned into the navigator's own ``status`` error (that would
    be Fail-Error, while the same navigator raising in-process is Fail-Other): it ends the
    process, its traceback on stderr, and the host classifies the run as a crashed navigator.
    """

    def send(msg: dict[str, Any]) -> None:
        out.write(wire.dumps(msg))
        out.flush()

    try:
        for raw in inp:
            msg = wire.loads(raw)
            kind = msg["type"]
            if kind == "hello":
                send({"type": "hello", "protocol": wire.LATEST, "name": name})  # every sensor's readings
            elif kind == "reset":
                try:
                    with contextlib.redirect_stdout(sys.stderr):
                        navigator.reset(wire.decode_mission(msg["mission"]),
                                        RobotSpec.model_validate(msg["robot"]),
                                        seed=int(msg["seed"]))
                    send({"type": "ok"})
                except Exception as e:  # the run loop classifies it
                    send({"type": "status", "kind": "error",
                          "message": f"reset raised {type(e).__name__}: {e}"})
            elif kind == "step":
                obs = wire.decode_observation(msg["obs"])
                with contextlib.redirect_stdout(sys.stderr):
                    answer = navigator.step(obs)  # an exception ends the process (docstring)
                    reply = wire.encode_command_or_status(answer)
                    draw = _drawing(navigator) if msg.get("debug") is True else None
                if draw is not None:
                    reply["debug"] = draw
                send(reply)
            elif kind == "close":
                break
            else:
                raise wire.WireError(f"unknown message type {kind!r}")
    finally:
        with contextlib.redirect_stdout(sys.stderr):
            navigator.close()
    return 0


def _drawing(navigator: Navigator) -> dict[str, Any] | None:
    """The served navigator's ``debug()`` (if it has one) for a step reply; a drawing that raises
    or is malformed is left out, with a line on stderr (a drawing never ends a run)."""
    hook = getattr(navigator, "debug", None)
    if not callable(hook):
        return None
    try:
        draw = hook()
        return None if draw is None else wire.encode_debug(check_debug(draw))
    except Exception as e:
        print(f"navstress.nav.external: debug() left out: {type(e).__name__}: {e}", file=sys.stderr)
        return None


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m navstress.nav.external NAME [CONFIG]``: serve a registered navigator."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help") or len(args) > 2:
        print("usage: python -m navstress.nav.external NAVIGATOR [CONFIG_JSON_OR_PATH]",
              file=sys.stderr)
        return 2
    with contextlib.redirect_stdout(sys.stderr):
        nav = make_navigator(args[0], args[1] if len(args) > 1 else None)
    return serve(nav, sys.stdin.buffer, sys.stdout.buffer, name=args[0])


if __name__ == "__main__":
    raise SystemExit(main())
