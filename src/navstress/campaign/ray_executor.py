"""The Ray executor: the same jobs as Ray tasks on a Ray cluster (pip extra ``ray``).

A thin :class:`~navstress.campaign.scheduler.Executor`: the scheduler keeps at most
``workers`` tasks in flight (so a task's age approximates its run time, for the wall-clock
watchdog), generates each map's world once before its runs, and writes every record itself.
Ray never retries a task (``max_retries=0``): the scheduler does, by the campaign's rule (a
task that kills its worker comes back as ``WorkerCrashedError`` and is retried like a crashed
local worker). Paths in the tasks must be visible to every node (a shared filesystem; always
true on one machine).

Without an address a Ray instance of its own is started (never one already running), bound to
127.0.0.1 only (every server: GCS, raylet, object manager, workers, runtime-env agent; no
dashboard) and protected by a random token.

With an address, the cluster is joined (docs/campaigns.md, "A Ray cluster of your own"): a
loopback address stays one (Ray would dial the machine's outside address instead), and joining is
bounded: Ray alone retries an address that does not answer, or that refuses the token, for
minutes with nothing said. A TCP connection to the address Ray will really dial, then a join
from a short-lived process whose output (Ray's log) is read, fail within seconds with Ray's
reason in one line.

    navstress campaign run spec.yaml -o out --executor ray --ray-address 127.0.0.1:6379
"""

from __future__ import annotations

import ipaddress
import logging
import os
import re
import secrets
import selectors
import socket
import subprocess
import sys
import time
from typing import Any

from navstress.campaign.plan import MapJob
from navstress.campaign.registry import ExecutorOptions
from navstress.campaign.scheduler import Event, Job
from navstress.campaign.work import Infra, attempt_run, attempt_world, register_targets
from navstress.errors import SpecError
from navstress.run.record import RunRecord, RunTask

#: Ray (2.60, Linux) resolves a node address of 127.0.0.1 to the machine's outside address, and
#: its servers then listen on every interface, and a driver given a cluster at 127.0.0.1:PORT dials
#: OUTSIDE:PORT, unless this is 0 when ray is imported (the setting Ray reads for single-machine
#: instances on Windows and macOS).
LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _import_ray() -> Any:
    try:  # here, not at the top: Ray is an optional extra, and reads its environment when imported
        import ray
    except ImportError:
        raise SpecError("--executor", "ray", "an installed Ray (pip extra)",
                        "install it with `pip install 'navstress[ray]'` or use --executor local") from None
    return ray


def _split(address: str) -> tuple[str, str] | None:
    """(host, port) of a HOST:PORT address (IPv6 in brackets), else None (``auto``, ``ray://...``)."""
    if "://" in address or address in ("auto", "local"):
        return None
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConnectionError(f"{address!r} is not HOST:PORT")
    return host, port


def _reachable(address: str, timeout_s: float = 10.0) -> None:
    """Fail fast (ConnectionError) when a HOST:PORT address does not accept TCP connections: Ray
    itself keeps retrying a dead address for minutes."""
    parts = _split(address)
    if parts is None:
        return
    host, port = parts
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as err:
        raise ConnectionError(f"nothing answers at {address} ({err.strerror or err})") from None


def _dialled(ray: Any, address: str) -> str:
    """The address Ray's driver will really connect to for ``address``: Ray (2.60) replaces a
    host written localhost, 127.0.0.1 or ::1 with this machine's node address, which is its
    outside address unless ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` was set when ray was imported
    (``ray._private.services.canonicalize_bootstrap_address``)."""
    parts = _split(address)
    if parts is None or parts[0].strip("[]").lower() not in ("localhost", "127.0.0.1", "::1"):
        return address
    node = str(ray.util.get_node_ip_address())  # before ray.init: what Ray would put in its place
    return f"[{node}]:{parts[1]}" if ":" in node else f"{node}:{parts[1]}"


#: The most a connection to a cluster may take: Ray retries an address that does not answer, or
#: refuses this process's token, for minutes (20 attempts of up to 40 s each, in 2.60).
JOIN_TIMEOUT_S = 60.0
#: Ray's log lines (its C++ core writes them to stderr) that say an attempt failed: the probe stops
#: at the first one, where Ray would try again and again.
_FAILED = re.compile(r"Failed to connect to GCS|Failed to get cluster ID|InvalidAuthToken|Unauthenticated")
#: A Ray log line's head: ``[2026-11-27 12:32:43,483 W 15771 15771] gcs_client.cc:210: ``.
_LOG_HEAD = re.compile(r"^\[[^]]*\]\s*(\S+\.(cc|h|py):\d+:\s*)?")
_PROBE = """
import logging, signal, sys
getattr(signal, "alarm", int)(int(sys.argv[2]))  # a bound of its own (SIGALRM ends it), should navstress vanish
try:
    import ray
    ray.init(address=sys.argv[1], include_dashboard=False, log_to_driver=False, logging_level=logging.WARNING)
except BaseException as err:
    print("navstress-probe-error", type(err).__name__ + ":", " ".join(str(err).split()), file=sys.stderr, flush=True)
    sys.exit(3)
print("navstress-probe-ok", flush=True)
"""


def _ray_line(line: str) -> str:
    """One line of Ray's output, for a message: its time stamp and source file taken off,
    control characters replaced, bounded."""
    text = " ".join(_LOG_HEAD.sub("", line.strip()).removeprefix("navstress-probe-error ").split())
    text = "".join(c if c.isprintable() else "?" for c in text).rstrip(". ")
    return text if len(text) <= 300 else text[:297] + "..."


def _probe(address: str, timeout_s: float = JOIN_TIMEOUT_S) -> None:
    """Join the cluster at ``address`` from a fresh process, as ray.init in this one will, and
    leave it (ConnectionError with Ray's own reason, one line, when it cannot): at the first
    line of Ray's log that says an attempt failed, at Ray's error, or after ``timeout_s``. Ray's
    output is read from a pipe, never hidden: what it said is in the error."""
    parts = _split(address)
    env = dict(os.environ)
    if parts is not None and _is_loopback(parts[0]):  # no rewriting of the address Ray will be given
        env[LOOPBACK_ENV] = "0"
    p = subprocess.Popen([sys.executable, "-c", _PROBE, address, str(int(timeout_s) + 5)], env=env,
                         stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert p.stdout is not None
    said: list[str] = []
    why = None
    joined = False
    deadline = time.monotonic() + timeout_s
    buf = b""
    try:
        with selectors.DefaultSelector() as sel:
            sel.register(p.stdout, selectors.EVENT_READ)
            while why is None:
                left = deadline - time.monotonic()
                if left <= 0:
                    last = next((ln for ln in reversed(said) if _LOG_HEAD.match(ln)), None)
                    why = (f"Ray did not connect within {timeout_s:g} s"
                           + (f" (its last words: {_ray_line(last)})" if last else ""))
                    break
                if not sel.select(min(left, 1.0)):
                    continue
                chunk = os.read(p.stdout.fileno(), 65536)  # readable: some bytes, or b"" at the end
                if not chunk:  # the probe ended without saying it joined
                    p.wait()
                    last = next((ln for ln in reversed(said) if ln.strip()), "")
                    why = f"Ray: {_ray_line(last)}" if last else f"Ray's probe exited with code {p.returncode}"
                    break
                buf += chunk
                *lines, buf = buf.split(b"\n")
                for raw in lines:
                    line = raw.decode("utf-8", "replace")
                    if line.startswith("navstress-probe-ok"):
                        joined = True
                        return
                    said.append(line)
                    if line.startswith("navstress-probe-error") or _FAILED.search(line):
                        why = f"Ray: {_ray_line(line)}"
                        break
                del said[:-50]
    finally:
        try:
            p.wait(timeout=10 if joined else 0)  # joined: let it leave the cluster
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
        p.stdout.close()
    raise ConnectionError(why)


#: What a process needs to join a cluster that uses token authentication (Ray 2.60).
TOKEN_FIX = ("give this process the cluster's token: export RAY_AUTH_MODE=token, with the token in "
             "~/.ray/auth_token, RAY_AUTH_TOKEN_PATH=FILE or RAY_AUTH_TOKEN=... (`ray get-auth-token` prints it "
             "on the head node), then run again")


def _init_error(address: str | None, err: Exception, logs: str = "", dialled: str | None = None) -> SpecError:
    """One line for a Ray cluster that cannot be joined or started: Ray's reason and the fix.
    ``dialled``: the address Ray really tried, where it rewrote ``address``."""
    text = " ".join(f"{err} {logs}".split())
    where = "--ray-address" if address is not None else "--executor"
    value = address if address is not None else "ray"
    # ConnectionError: navstress's own words or the probe's, which quote Ray ("Ray: ...")
    said = _ray_line(str(err)) if isinstance(err, ConnectionError) and str(err) else \
        f"{type(err).__name__}: {_ray_line(str(err))}"
    if type(err).__name__ == "AuthenticationError" or any(
            w in text for w in ("InvalidAuthToken", "Unauthenticated", "authentication token", "Token authentication")):
        return SpecError(where, value, "a Ray cluster that accepts this process (it uses token authentication)",
                         f"{said}; {TOKEN_FIX}")
    if address is not None and dialled is not None and dialled != address:
        return SpecError(where, value, "the address of a running Ray cluster (HOST:PORT, or auto)",
                         f"Ray connects to {dialled} instead, this machine's outside address (ray was imported "
                         f"before navstress could set {LOOPBACK_ENV}=0, or it is set to 1), and there: "
                         f"{said}; set {LOOPBACK_ENV}=0 in the environment before ray is imported")
    if address is not None:
        return SpecError(where, value, "the address of a running Ray cluster (HOST:PORT, or auto)",
                         f"{said}; start one with `ray start --head` (docs/campaigns.md, Executors) or leave "
                         "out --ray-address to start a local one")
    return SpecError(where, value, "a local Ray instance that can start", said)


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


def _on_loopback(address: str) -> bool:
    """Whether ``address`` is HOST:PORT with a loopback host (127.x, ::1, localhost)."""
    try:
        parts = _split(address)
    except ConnectionError:
        return False
    return parts is not None and _is_loopback(parts[0])


def _world_task(job: MapJob, targets: dict[str, str]) -> str | Infra | None:
    return attempt_world(job)


def _run_task(task: RunTask, targets: dict[str, str]) -> RunRecord | Infra:
    register_targets(targets)
    return attempt_run(task)


def open_ray(options: ExecutorOptions) -> "RayExecutor":
    """The ``ray`` executor (:mod:`navstress.campaign.registry`): joins ``options.address``, or
    starts a Ray instance of its own; Ray keeps its workers between sessions itself."""
    return RayExecutor(options.workers, options.targets, address=options.address)


class RayExecutor:
    """Runs jobs on Ray: ``address`` None starts a local Ray instance bound to 127.0.0.1 (or
    uses the one initialised in this process). Call :meth:`close` (or use ``with``) at the end."""

    worker = "Ray worker"

    def __init__(self, workers: int | None, targets: dict[str, str] | None = None, *,
                 address: str | None = None) -> None:
        if workers is not None and workers < 1:
            raise SpecError("--workers", workers, "an integer >= 1")
        if address == "local":  # Ray's word for a new local instance: ours, bound to 127.0.0.1
            address = None
        self._restore_env: dict[str, str | None] = {}
        if "ray" not in sys.modules:
            # Ray reads these when it is imported. Our own cluster listens on loopback only and,
            # unless the user chose an authentication mode, gets a random token, so that no other
            # user of this machine can use it either; a cluster joined on this machine keeps the
            # loopback address it was given (Ray would put the machine's outside address in its place)
            env = {}
            if address is None or address == "auto" or _on_loopback(address):
                env[LOOPBACK_ENV] = "0"
            if address is None and not os.environ.get("RAY_AUTH_MODE"):
                env.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(16))
            for k, v in env.items():
                self._restore_env[k] = os.environ.get(k)
                os.environ[k] = v
        try:
            ray = _import_ray()
        except SpecError:
            self._restore()
            raise
        self.ray = ray
        self._started = False
        if not ray.is_initialized():
            # workers import navstress and spec-given navigator modules like the driver does
            path = os.pathsep.join(p for p in sys.path if p)
            runtime_env = {"env_vars": {"PYTHONPATH": path}}
            dialled = None
            try:
                if address is not None:
                    # Ray retries an address that does not answer for minutes: first the address
                    # it will really use (a TCP connection), then a join from a fresh process,
                    # bounded, that says Ray's reason when it fails
                    dialled = _dialled(ray, address)
                    _reachable(dialled)
                    _probe(dialled)
                    dialled = None  # it answers: an error from here on is not the address's
                self._init(ray, address, runtime_env)
            except Exception as err:
                self._restore()
                moved = dialled if dialled not in (None, address) and not _on_loopback(str(dialled)) else None
                raise _init_error(address, err, dialled=moved) from None
            except BaseException:  # Ctrl-C, SIGTERM: the environment as it was
                self._restore()
                raise
            self._started = True
            if address is None and not _is_loopback(ray.util.get_node_ip_address()):
                node = ray.util.get_node_ip_address()
                self.close()
                raise SpecError("--executor", "ray", "a local Ray instance bound to 127.0.0.1",
                                f"Ray chose the address {node} (ray was imported before navstress could set "
                                f"{LOOPBACK_ENV}=0): set it before importing ray, or start the cluster "
                                "yourself and pass --ray-address")
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.workers = workers or max(1, cpus)
        self.targets = dict(targets or {})
        self._world = ray.remote(num_cpus=1, max_retries=0)(_world_task)
        self._run = ray.remote(num_cpus=1, max_retries=0)(_run_task)
        self._refs: dict[Any, Job] = {}
        self._begun: list[Job] = []

    @staticmethod
    def _init(ray: Any, address: str | None, runtime_env: dict[str, Any]) -> None:
        quiet = {"include_dashboard": False, "log_to_driver": False, "logging_level": logging.WARNING,
                 "runtime_env": runtime_env}
        if address is None:
            # our own cluster: "local" never joins one already running (ray.init() with no
            # address follows RAY_ADDRESS or the last cluster started on this machine)
            ray.init(address="local", _node_ip_address="127.0.0.1", **quiet)
        else:
            ray.init(address=address, **quiet)

    # ---- the Executor interface ----

    def start(self, jobs: int) -> int:
        return self.workers

    def submit(self, job: Job) -> None:
        fn = self._run if job.kind == "run" else self._world
        self._refs[fn.remote(job.payload, self.targets)] = job
        self._begun.append(job)  # a Ray task's clock starts when it is submitted

    def wait(self, timeout_s: float) -> list[Event]:
        if self._begun:
            events = [Event(j, "started") for j in self._begun]
            self._begun = []
            return events
        done, _ = self.ray.wait(list(self._refs), num_returns=1, timeout=timeout_s)
        events = []
        for ref in done:
            job = self._refs.pop(ref)
            try:
                events.append(Event(job, "ok", self.ray.get(ref)))
            except Exception as err:  # RayTaskError, WorkerCrashedError, ...
                why = f"{type(err).__name__}: {' '.join(str(err).split())[:300]}"
                died = "WorkerCrashed" in why or "died" in why.lower()
                events.append(Event(job, "died" if died else "error", why))
        return events

    def kill(self, job: Job) -> None:
        for ref, j in list(self._refs.items()):
            if j is job:
                self.ray.cancel(ref, force=True)
                del self._refs[ref]

    def shutdown(self, *, now: bool) -> None:
        for ref in self._refs:
            self.ray.cancel(ref, force=True)
        self._refs.clear()
        self._begun = []

    # ---- the cluster ----

    def _restore(self) -> None:
        for k, v in self._restore_env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        self._restore_env = {}

    def close(self) -> None:
        """Stop the Ray instance this executor started (idempotent; a cluster joined is left alone)."""
        if self._started:
            self._started = False
            self.ray.shutdown()
            self._restore()

    def __enter__(self) -> RayExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
