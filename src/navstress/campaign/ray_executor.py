"""The Ray executor: the same maps and runs as Ray tasks on a Ray cluster (pip extra ``ray``).

The driver keeps at most ``workers`` tasks in flight (so a task's age approximates its run
time, for the wall-clock watchdog), generates each map's world once before its runs, and
writes every record itself. Ray never retries a task (``max_retries=0``): the driver does, by
the campaign's rule (a task that kills its worker comes back as ``WorkerCrashedError`` and is
retried like a crashed local worker; see :class:`~navstress.campaign.executors.Recorder`).
Paths in the tasks must be visible to every node (a shared filesystem; always true on one
machine). Without an address a Ray instance of its own is started (never one already running).

    navstress campaign run spec.yaml -o out --executor ray --ray-address auto
"""

from __future__ import annotations

import contextlib
import logging
import os
import secrets
import socket
import sys
import tempfile
import time
from collections.abc import Iterator
from typing import IO, Any

from navstress.campaign.executors import (
    WORLD_LIMIT_S,
    Infra,
    Recorder,
    WorkQueue,
    attempt_run,
    attempt_world,
    register_targets,
)
from navstress.campaign.plan import MapJob, Plan
from navstress.errors import SpecError
from navstress.run.batch import drop_partial_trace, failure_record
from navstress.run.record import RunRecord, RunTask


def _import_ray() -> Any:
    try:
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


def _world_task(job: MapJob, targets: dict[str, str]) -> str | Infra | None:
    return attempt_world(job)


def _run_task(task: RunTask, targets: dict[str, str]) -> RunRecord | Infra:
    register_targets(targets)
    return attempt_run(task)


class RayExecutor:
    """Runs a plan on Ray: ``address`` None starts a local Ray instance (or uses the one initialised)."""

    def __init__(self, workers: int | None, wall_limit_s: float, targets: dict[str, str] | None = None, *,
                 address: str | None = None) -> None:
        self._restore_env: dict[str, str | None] = {}
        if address is None and "ray" not in sys.modules and not os.environ.get("RAY_AUTH_MODE"):
            # Ray reads its authentication mode when it is imported: our own cluster gets a
            # random token, so that nobody else on the network can use it
            for k, v in (("RAY_AUTH_MODE", "token"), ("RAY_AUTH_TOKEN", secrets.token_hex(16))):
                self._restore_env[k] = os.environ.get(k)
                os.environ[k] = v
        ray = _import_ray()
        self.ray = ray
        self._started = False
        if not ray.is_initialized():
            # workers import navstress and spec-given navigator modules like the driver does
            path = os.pathsep.join(p for p in sys.path if p)
            env = {"env_vars": {"PYTHONPATH": path}}
            captured = tempfile.TemporaryFile(mode="w+b")
            try:
                if address is None:
                    self._init(ray, address, env)
                else:  # Ray's C++ and Python logs of a failed connect: kept for the error line
                    with _stderr_to(captured):
                        self._init(ray, address, env)
            except Exception as err:
                captured.seek(0)
                raise _init_error(address, err, captured.read().decode("utf-8", "replace")) from None
            finally:
                captured.close()
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        if workers is not None and workers < 1:
            raise SpecError("--workers", workers, "an integer >= 1")
        self.workers = workers or max(1, cpus)
        self.wall_limit_s = wall_limit_s
        self.targets = dict(targets or {})
        self._world = ray.remote(num_cpus=1, max_retries=0)(_world_task)
        self._run = ray.remote(num_cpus=1, max_retries=0)(_run_task)

    @staticmethod
    def _init(ray: Any, address: str | None, env: dict[str, Any]) -> None:
        quiet = {"include_dashboard": False, "log_to_driver": False, "logging_level": logging.WARNING,
                 "runtime_env": env}
        if address is None:
            # our own cluster: "local" never joins one already running (ray.init() with no
            # address follows RAY_ADDRESS or the last cluster started on this machine). Ray
            # (2.60, Linux) resolves 127.0.0.1 to the node's address and listens on every
            # interface, so the cluster is protected by a token of its own instead (set before
            # ray is imported, see RayExecutor; unless the user chose an authentication mode).
            ray.init(address="local", **quiet)
        else:
            _reachable(address)
            ray.init(address=address, **quiet)

    def run(self, plan: Plan, pending: list[RunTask], rec: Recorder) -> None:
        """Run ``pending`` on the cluster, passing every end of a task to ``rec``."""
        ray = self.ray
        q = WorkQueue(plan, pending)
        inflight: dict[Any, tuple[str, Any, float]] = {}
        try:
            while q or inflight:
                while len(inflight) < self.workers and q:
                    kind, payload = q.next()
                    fn = self._run if kind == "run" else self._world
                    inflight[fn.remote(payload, self.targets)] = (kind, payload, time.monotonic())
                done, _ = ray.wait(list(inflight), num_returns=1, timeout=1.0)
                now = time.monotonic()
                for ref in done:
                    kind, payload, t0 = inflight.pop(ref)
                    try:
                        value = ray.get(ref)
                        status, why = "ok", ""
                    except Exception as err:  # RayTaskError, WorkerCrashedError, ...
                        value, status = None, "error"
                        text = " ".join(str(err).split())
                        why = f"{type(err).__name__}: {text[:300]}"
                    self._finish(kind, payload, status, value, why, now - t0, q, rec)
                for ref, (kind, payload, t0) in list(inflight.items()):
                    limit = self.wall_limit_s if kind == "run" else WORLD_LIMIT_S
                    if now - t0 > limit:
                        ray.cancel(ref, force=True)
                        inflight.pop(ref)
                        self._finish(kind, payload, "limit", None, f"exceeded wall-clock limit ({limit:g} s)",
                                     now - t0, q, rec)
        finally:
            for ref in inflight:
                ray.cancel(ref, force=True)
            self.close()

    def close(self) -> None:
        """Stop the Ray instance this executor started (idempotent; a cluster joined is left alone)."""
        if self._started:
            self._started = False
            self.ray.shutdown()
            for k, v in self._restore_env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v

    @staticmethod
    def _finish(kind: str, payload: Any, status: str, value: Any, why: str, wall: float, q: WorkQueue,
                rec: Recorder) -> None:
        if kind == "world":
            q.world_ended(payload, value if status == "ok" else Infra("error", f"world generation failed: {why}"),
                          rec)
            return
        if status == "ok":
            q.run_ended(payload, value, rec, wall)
        elif status == "limit":
            drop_partial_trace(payload)
            rec.record(failure_record(payload, f"run {why}; Ray task cancelled", wall))
        elif "WorkerCrashed" in why or "died" in why.lower():
            q.run_died(payload, f"run killed its Ray worker ({why})", rec, wall)
        else:
            q.run_ended(payload, Infra("error", f"run failed on Ray: {why}"), rec, wall)
