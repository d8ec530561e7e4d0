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

    navstress campaign run spec.yaml -o out --executor ray --ray-address auto
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
import os
import secrets
import socket
import sys
import tempfile
from collections.abc import Iterator
from typing import IO, Any

from navstress.campaign.plan import MapJob
from navstress.campaign.scheduler import Event, Job
from navstress.campaign.work import Infra, attempt_run, attempt_world, register_targets
from navstress.errors import SpecError
from navstress.run.record import RunRecord, RunTask

#: Ray (2.60, Linux) resolves a node address of 127.0.0.1 to the machine's outside address, and
#: its servers then listen on every interface, unless this is 0 when ray is imported (the
#: setting Ray reads for single-machine instances on Windows and macOS).
LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _import_ray() -> Any:
    try:  # here, not at the top: Ray is an optional extra, and reads its environment when imported
        import ray
    except ImportError:
        raise SpecError("--executor", "ray", "an installed Ray (pip extra)",
                        "install it with `pip install 'navstress[ray]'` or use --executor local") from None
    return ray


def _reachable(address: str, timeout_s: float = 10.0) -> None:
    """Fail fast (ConnectionError) when a HOST:PORT address does not accept TCP connections: Ray
    itself keeps retrying a dead address for minutes."""
    if "://" in address or address in ("auto", "local"):
        return
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit():
        raise ConnectionError(f"{address!r} is not HOST:PORT")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as err:
        raise ConnectionError(f"nothing answers at {address} ({err.strerror or err})") from None


@contextlib.contextmanager
def _stderr_to(f: IO[bytes]) -> Iterator[None]:
    """Send file descriptor 2 (where Ray's C++ core logs) to ``f`` for the duration."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        os.dup2(f.fileno(), 2)
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)


def _init_error(address: str | None, err: Exception, logs: str = "") -> SpecError:
    """One line for a Ray cluster that cannot be joined or started, with the fix."""
    text = " ".join(str(err).split())
    if "InvalidAuthToken" in logs or "Unauthenticated" in logs:
        text += " (the cluster refused this process's authentication token)"
    where = "--ray-address" if address is not None else "--executor"
    value = address if address is not None else "ray"
    if type(err).__name__ == "AuthenticationError" or "token" in text.lower() or "authenticat" in text.lower():
        return SpecError(where, value, "a Ray cluster that accepts this process (it uses token authentication)",
                         "give this process the cluster's token: export RAY_AUTH_MODE=token RAY_AUTH_TOKEN=... "
                         "(from `ray get-auth-token` on the head node; or RAY_AUTH_TOKEN_PATH=FILE), then run again")
    if address is not None:
        return SpecError(where, value, "the address of a running Ray cluster (HOST:PORT, or auto)",
                         f"{type(err).__name__}: {text[:200]}; start one with `ray start --head` or leave "
                         "out --ray-address to start a local one")
    return SpecError(where, value, "a local Ray instance that can start",
                     f"{type(err).__name__}: {text[:200]}")


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return host == "localhost"


def _world_task(job: MapJob, targets: dict[str, str]) -> str | Infra | None:
    return attempt_world(job)


def _run_task(task: RunTask, targets: dict[str, str]) -> RunRecord | Infra:
    register_targets(targets)
    return attempt_run(task)


class RayExecutor:
    """Runs jobs on Ray: ``address`` None starts a local Ray instance bound to 127.0.0.1 (or
    uses the one initialised in this process). Call :meth:`close` (or use ``with``) at the end."""

    worker = "Ray worker"

    def __init__(self, workers: int | None, targets: dict[str, str] | None = None, *,
                 address: str | None = None) -> None:
        if workers is not None and workers < 1:
            raise SpecError("--workers", workers, "an integer >= 1")
        self._restore_env: dict[str, str | None] = {}
        if address is None and "ray" not in sys.modules:
            # Ray reads these when it is imported: our own cluster listens on loopback only and,
            # unless the user chose an authentication mode, gets a random token, so that no
            # other user of this machine can use it either
            env = {LOOPBACK_ENV: "0"}
            if not os.environ.get("RAY_AUTH_MODE"):
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
            captured = tempfile.TemporaryFile(mode="w+b")
            try:
                if address is None:
                    self._init(ray, address, runtime_env)
                else:  # Ray's C++ and Python logs of a failed connect: kept for the error line
                    with _stderr_to(captured):
                        self._init(ray, address, runtime_env)
            except Exception as err:
                captured.seek(0)
                self._restore()
                raise _init_error(address, err, captured.read().decode("utf-8", "replace")) from None
            finally:
                captured.close()
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
            _reachable(address)
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
