"""The local executor: a pool of worker processes on this machine (:class:`~navstress.campaign.scheduler.Executor`).

Each worker is a :class:`navstress.isolate.Child` (spawn context; it dies with the driver:
Linux ``PR_SET_PDEATHSIG`` plus a parent watch, so a killed campaign leaves no orphan writing
traces behind the resumed one; it ignores Ctrl-C, the driver's business). A worker first runs
a 0.5 s warm-up mission (JIT, imports) so that the watchdog measures the work only (the folder of
a warm-up cut short by the pool's end is removed then). The pool knows which job each worker
holds: a worker that dies or is killed costs exactly its own job, and is replaced. What a run
starts (a navigator's helper processes) ends with the run (:mod:`navstress.isolate`).

With ``keep`` the pool outlives a session: the scheduler ends its executor's workers when a
session ends, and a search runs one session per generation (and one for its confirmation), each
of which would start fresh workers (an interpreter, the imports, the warm-up mission: seconds
each, more than a small generation's runs). A kept pool keeps them between sessions (a session
that wants more workers than it holds starts a new pool); an interrupted session
(``shutdown(now=True)``) still kills them, and :meth:`LocalExecutor.close` ends them.
"""

from __future__ import annotations

import multiprocessing.connection as mpc
import os
from dataclasses import dataclass

from navstress.campaign.registry import ExecutorOptions
from navstress.campaign.scheduler import Event, Job
from navstress.campaign.work import attempt_run, attempt_world, sweep_warm_ups, warm_up
from navstress.isolate import Child


@dataclass
class _Slot:
    child: Child
    job: Job | None = None


def open_local(options: ExecutorOptions) -> "LocalExecutor":
    """The ``local`` executor (:mod:`navstress.campaign.registry`): ``options.workers`` processes
    (default: all cores), kept between sessions with ``options.keep``."""
    workers = options.workers if options.workers is not None else (os.cpu_count() or 1)
    return LocalExecutor(workers, options.targets, keep=options.keep)


class LocalExecutor:
    """``workers`` processes; ``targets``: spec-given navigators registered in each;
    ``warm``: run the warm-up mission in each new worker; ``keep``: keep the workers from one
    session to the next (module doc), until :meth:`close`."""

    worker = "worker process"

    def __init__(self, workers: int, targets: dict[str, str] | None = None, *, warm: bool = True,
                 keep: bool = False) -> None:
        self.workers = workers
        self.targets = dict(targets or {})
        self.warm = warm
        self.keep = keep
        self._slots: list[_Slot] = []

    def _spawn(self) -> _Slot:
        return _Slot(Child(self.targets, warm=warm_up if self.warm else None))

    def start(self, jobs: int) -> int:
        want = max(1, min(self.workers, jobs))
        if self.keep and len(self._slots) >= want:  # the workers kept from the last session do
            return len(self._slots)
        if self._slots:  # kept, but fewer than this session can use
            self._end(now=False)
        self._slots = [self._spawn() for _ in range(want)]
        return len(self._slots)

    def submit(self, job: Job) -> None:
        slot = next(s for s in self._slots if s.job is None)
        slot.job = job
        # a worker gone already is seen by wait() as died: the job is retried like any crash
        slot.child.send(attempt_run if job.kind == "run" else attempt_world, (job.payload,))

    def wait(self, timeout_s: float) -> list[Event]:
        busy = [s for s in self._slots if s.job is not None]
        mpc.wait([w for s in busy for w in s.child.waitables], timeout=timeout_s)
        events: list[Event] = []
        for i, s in enumerate(self._slots):
            job = s.job
            if job is None:
                continue
            end: Event | None = None
            broken = False
            while end is None and not broken:
                got = s.child.receive()
                if got is None:
                    break
                kind, value = got
                if kind == "started":
                    events.append(Event(job, "started"))
                elif kind == "ok":
                    end = Event(job, "ok", value)
                elif kind == "raised":
                    end = Event(job, "error", f"{type(value).__name__}: {value}")
                elif kind == "":
                    broken = True
            if end is None:
                why = s.child.ended(broken=broken)
                if why is None:
                    continue
                end = Event(job, "died", why)
                self._slots[i] = self._spawn()
            s.job = None
            events.append(end)
        return events

    def kill(self, job: Job) -> None:
        for i, s in enumerate(self._slots):
            if s.job is job:
                s.child.kill()
                self._slots[i] = self._spawn()
                return

    def shutdown(self, *, now: bool) -> None:
        if now or not self.keep:
            self._end(now=now)

    def close(self) -> None:
        if self._slots:
            self._end(now=False)

    def _end(self, *, now: bool) -> None:
        for s in self._slots:
            s.child.stop(kill=now)
        for s in self._slots:
            s.child.reap()
        self._slots = []
        if self.warm:  # a worker ended while it warmed up cannot remove its folder: do it here
            sweep_warm_ups()

    def __repr__(self) -> str:
        return f"LocalExecutor(workers={self.workers})"
