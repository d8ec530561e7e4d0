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
    RecordCallback,
    drop_partial_trace,
    WORLD_LIMIT_S,
    failure_record,
    generate_world,
    maps_needed,
    register_targets,
    run_one,
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


def _world_task(job: MapJob, targets: dict[str, str]) -> None:
    generate_world(job)


def _run_task(task: RunTask, targets: dict[str, str]) -> RunRecord:
    register_targets(targets)
    return run_one(task)


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
            ray.init(address=address, include_dashboard=False, log_to_driver=False,
                     runtime_env={"env_vars": {"PYTHONPATH": path}})
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        if workers is not None and workers < 1:
            raise SpecError("--workers", workers, "an integer >= 1")
        self.workers = workers or max(1, cpus)
        self.wall_limit_s = wall_limit_s
        self.targets = dict(targets or {})
        self._world = ray.remote(num_cpus=1, max_retries=0)(_world_task)
        self._run = ray.remote(num_cpus=1, max_retries=0)(_run_task)

    def run(self, plan: Plan, pending: list[RunTask], sink: RecordCallback) -> None:
        """Run ``pending`` on the cluster, passing every record to ``sink``."""
        ray = self.ray
        maps, by_map = maps_needed(plan, pending)
        to_generate: deque[MapJob] = deque(maps)
        ready: deque[RunTask] = deque()
        inflight: dict[Any, tuple[str, Any, float]] = {}
        try:
            while ready or to_generate or inflight:
                while len(inflight) < self.workers and (ready or to_generate):
                    if ready:
                        t = ready.popleft()
                        inflight[self._run.remote(t, self.targets)] = ("run", t, time.monotonic())
                    else:
                        m = to_generate.popleft()
                        inflight[self._world.remote(m, self.targets)] = ("world", m, time.monotonic())
                done, _ = ray.wait(list(inflight), num_returns=1, timeout=1.0)
                now = time.monotonic()
                for ref in done:
                    kind, payload, t0 = inflight.pop(ref)
                    try:
                        value = ray.get(ref)
                        status, why = "ok", ""
                    except Exception as err:  # RayTaskError, WorkerCrashedError, ...
                        value, status = None, "error"
                        why = f"{type(err).__name__}: {str(err).strip().splitlines()[0] if str(err).strip() else ''}"
                    self._finish(kind, payload, status, value, why, now - t0, by_map, ready, sink)
                for ref, (kind, payload, t0) in list(inflight.items()):
                    limit = self.wall_limit_s if kind == "run" else WORLD_LIMIT_S
                    if now - t0 > limit:
                        ray.cancel(ref, force=True)
                        inflight.pop(ref)
                        self._finish(kind, payload, "limit", None, f"exceeded wall-clock limit ({limit:g} s)",
                                     now - t0, by_map, ready, sink)
        finally:
            for ref in inflight:
                ray.cancel(ref, force=True)
            if self._started:
                ray.shutdown()

    @staticmethod
    def _finish(kind: str, payload: Any, status: str, value: Any, why: str, wall: float,
                by_map: dict[str, deque[RunTask]], ready: deque[RunTask], sink: RecordCallback) -> None:
        if kind == "world":
            tasks = by_map.pop(payload.world_dir, deque())
            if status == "ok":
                ready.extend(tasks)
            else:
                for t in tasks:
                    sink(failure_record(t, f"world generation failed: {why}"))
            return
        if status == "ok":
            sink(value)
            return
        drop_partial_trace(payload)
        if "WorkerCrashed" in why or "died" in why.lower():
            sink(failure_record(payload, f"run killed its Ray worker ({why})", wall))
        else:
            sink(failure_record(payload, f"run failed on Ray: {why}", wall))
