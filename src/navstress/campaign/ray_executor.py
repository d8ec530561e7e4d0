"""The Ray executor: the same maps and runs as Ray tasks on a Ray cluster (pip extra ``ray``).

The driver keeps at most ``workers`` tasks in flight (so a task's age approximates its run
time, for the wall-clock watchdog), generates each map's world once before its runs, and
writes every record itself. Tasks are never retried by Ray (``max_retries=0``): a task that
kills its worker comes back as ``WorkerCrashedError`` and is recorded as Fail-Other. Paths in
the tasks must be visible to every node (a shared filesystem; always true on one machine).

    navstress campaign run spec.yaml -o out --executor ray --ray-address auto
"""

from __future__ import annotations

import os
import sys
import time
from collections import deque
from typing import Any

from navstress.campaign.executors import (
    WORLD_LIMIT_S,
    Infra,
    Recorder,
    WorkQueue,
    attempt_run,
    attempt_world,
    drop_partial_trace,
    failure_record,
    register_targets,
)
from navstress.campaign.plan import MapJob, Plan
from navstress.errors import SpecError
from navstress.run.record import RunRecord, RunTask


def _import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise SpecError("--executor", "ray", "an installed Ray (pip extra)",
                        "install it with `pip install 'navstress[ray]'` or use --executor local") from None
    return ray


def _init_error(address: str | None, err: Exception) -> SpecError:
    """One line for a Ray cluster that cannot be joined or started, with the fix."""
    text = " ".join(str(err).split())
    where = "--ray-address" if address is not None else "--executor"
    value = address if address is not None else "ray"
    if type(err).__name__ == "AuthenticationError" or "token" in text.lower() or "authenticat" in text.lower():
        return SpecError(where, value, "a Ray cluster that accepts this process (it uses token authentication)",
                         "give this process the cluster's token: export RAY_AUTH_TOKEN=... (from `ray "
                         "get-auth-token` on the head node) or RAY_AUTH_TOKEN_PATH=FILE, then run again")
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
        ray = _import_ray()
        self.ray = ray
        self._started = False
        if not ray.is_initialized():
            # workers import navstress and spec-given navigator modules like the driver does
            path = os.pathsep.join(p for p in sys.path if p)
            env = {"env_vars": {"PYTHONPATH": path}}
            try:
                if address is None:
                    # our own cluster, on this machine only: "local" never joins one already
                    # running (ray.init() with no address would follow RAY_ADDRESS or the last
                    # cluster started here)
                    ray.init(address="local", _node_ip_address="127.0.0.1", include_dashboard=False,
                             log_to_driver=False, runtime_env=env)
                else:
                    ray.init(address=address, include_dashboard=False, log_to_driver=False, runtime_env=env)
            except Exception as err:
                raise _init_error(address, err) from None
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        if workers is not None and workers < 1:
            raise SpecError("--workers", workers, "an integer >= 1")
        self.workers = workers or max(1, cpus)
        self.wall_limit_s = wall_limit_s
        self.targets = dict(targets or {})
        self._world = ray.remote(num_cpus=1, max_retries=0)(_world_task)
        self._run = ray.remote(num_cpus=1, max_retries=0)(_run_task)

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
            if self._started:
                ray.shutdown()

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
