"""The scheduling core of a campaign, written once for every executor.

An *executor* only runs jobs somewhere (:class:`Executor`: start, submit, wait, kill,
shutdown); everything else is decided here, the same way for all of them:

- **worlds before runs**: each map's world is generated once, by one job, before the runs on
  it are handed out (:class:`WorkQueue`); runs on a broken world wait for its regeneration;
- **the watchdog**: a job still going after its wall-clock limit is killed (a run:
  ``wall_limit_s``, counted from when its worker began it; a world: ``world_limit_s``; a job
  whose worker has not begun it yet, e.g. still importing: ``start_limit_s``);
- **what an end means** (:func:`schedule`): a run that exceeded its limit is a Fail-Other
  record; a worker that died is retried with the same seeds, and recorded as the navigator's
  own crash when it dies on every attempt; failures of the machinery are retried and never
  recorded (:class:`Recorder`, the driver's single writer);
- **resume and progress** (:func:`resume`): the runs already in the store are skipped, partial
  files are removed, ``on_start`` / ``on_record`` are called.

A new executor (a batch scheduler) implements :class:`Executor` only; a policy of what to
run adds tasks to the :class:`WorkQueue` (:meth:`WorkQueue.add`) and decides from the records
it sees: :class:`Repetition` (adaptive repetition) queues run ``n`` of a stream once runs
``0 .. n-1`` are recorded and the stream's rule says continue (:meth:`~navstress.campaign.plan.Stream.due`),
so the final set of runs is the same whatever the executor, the number of workers, or the
interruptions: on resume, what is due is recomputed from the store's records.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol

from navstress import _files
from navstress.campaign.plan import MapJob, Plan, Stream
from navstress.campaign.store import Store, disk_full
from navstress.campaign.work import Infra
from navstress.run.batch import drop_partial_trace, failure_record
from navstress.run.record import GENERATION_FAILED, RunRecord, RunTask
from navstress.world.world import is_world_dir

RecordCallback = Callable[[RunRecord], None]
StartCallback = Callable[[int, int, dict[str, int]], None]
#: Told the campaign's new upper bound of runs when an adaptive stream stops before its max.
PlannedCallback = Callable[[int], None]
#: Wall-clock limit of generating one world, and of a worker's start before it begins a job.
WORLD_LIMIT_S = 900.0
#: Attempts of one run (or world) in one ``campaign run`` before it is given up for this session.
MAX_ATTEMPTS = 3
#: Longest wait for an executor's events before the watchdog looks again (seconds).
TICK_S = 1.0

JobKind = Literal["world", "run"]
EventStatus = Literal["started", "ok", "error", "died"]


@dataclass(eq=False)
class Job:
    """One unit of work handed to an executor: generate a map's world or run a task.

    The executor runs :func:`navstress.campaign.work.attempt_world` (``kind`` "world",
    ``payload`` a MapJob) or :func:`~navstress.campaign.work.attempt_run` ("run", a RunTask).
    ``started`` and ``running`` are the scheduler's (the watchdog's clock)."""

    kind: JobKind
    payload: Any
    started: float = 0.0
    running: bool = False


@dataclass(frozen=True)
class Event:
    """What an executor reports about a job.

    ``started``: a worker began it (the watchdog's clock starts; report it at once for a job
    that begins when submitted). ``ok``: ``value`` is what the work function returned. ``error``:
    ``value`` is one line, the work function or its transport raised (retried as a machinery
    failure). ``died``: ``value`` says how the worker ended ("exit code 7", "signal SIGSEGV",
    "WorkerCrashedError: ..."); the job is over and the executor replaced the worker."""

    job: Job
    status: EventStatus
    value: Any = None


class Executor(Protocol):
    """Where jobs run: the local process pool, Ray, a batch scheduler.

    ``worker`` names the thing a job runs in, for reasons ("worker process", "Ray worker"):
    "run killed its worker process (signal SIGSEGV)". ``workers``: the most jobs it runs at once.
    An executor is made by its factory (:mod:`navstress.campaign.registry`) and lives for one
    command: :meth:`shutdown` ends a session, :meth:`close` the executor."""

    worker: str
    workers: int

    def start(self, jobs: int) -> int:
        """Get ready for at most ``jobs`` jobs; returns how many may run at once (>= 1)."""
        ...

    def submit(self, job: Job) -> None:
        """Start ``job`` (the scheduler never submits more than :meth:`start` allowed)."""
        ...

    def wait(self, timeout_s: float) -> list[Event]:
        """The events since the last call, waiting at most ``timeout_s`` for one."""
        ...

    def kill(self, job: Job) -> None:
        """Stop ``job`` now (its worker is killed and replaced); no event follows for it."""
        ...

    def shutdown(self, *, now: bool) -> None:
        """End a session: end every worker (``now``: kill them, the campaign was interrupted),
        or, when it keeps them for the next session, only when ``now``. Idempotent."""
        ...

    def close(self) -> None:
        """End whatever the executor still holds (kept workers, a cluster it started). Idempotent."""
        ...


class Recorder:
    """Takes every end of a task from the scheduler (the driver's single writer): records results,
    keeps failed attempts in the store's ``attempts`` table, and decides what is retried.

    The rule (docs/design.md): a worker that dies (signal, exit) is retried with the same seeds;
    when it dies on each of ``max_attempts`` attempts the crash is the navigator's own and the
    run is recorded (Fail-Other, with the reason and the count). Failures of the machinery
    (:class:`Infra`) are retried too and never recorded: after ``max_attempts`` the run stays
    pending (``unfinished``) for the next ``campaign run``. A full disk stops the campaign."""

    def __init__(self, store: Store, on_record: RecordCallback | None = None,
                 max_attempts: int = MAX_ATTEMPTS) -> None:
        self.store = store
        self.on_record = on_record
        self.max_attempts = max_attempts
        self.recorded = 0
        self.kinds: dict[str, list[str]] = {}
        self.unfinished: dict[str, str] = {}
        self.fresh: list[RunRecord] = []  # recorded since the scheduler last looked (:meth:`take`)

    def record(self, rec: RunRecord) -> None:
        self.unfinished.pop(rec.run_id, None)
        if self.store.add(rec):
            self.recorded += 1
            self.fresh.append(rec)
            if self.on_record is not None:
                self.on_record(rec)

    def take(self) -> list[RunRecord]:
        """The records made since the last call."""
        out, self.fresh = self.fresh, []
        return out

    def failed(self, task: RunTask, kind: str, reason: str, wall_s: float = 0.0) -> bool:
        """A failed attempt of ``task`` (``kind``: died, world, error, disk-full); True: run it again."""
        if kind == "disk-full":
            raise disk_full(self.store.root, reason)
        drop_partial_trace(task)
        self.store.add_attempt(task.run_id, kind, reason)
        kinds = self.kinds.setdefault(task.run_id, [])
        kinds.append(kind)
        if len(kinds) < self.max_attempts:
            return True
        if all(k == "died" for k in kinds):
            n = len(kinds)
            self.record(failure_record(task, f"{reason}, in {n} of {n} attempts with the same seeds", wall_s))
        else:
            self.unfinished[task.run_id] = reason
        return False

    def world_failed(self, tasks: list[RunTask], result: str | Infra) -> list[RunTask]:
        """The world of ``tasks`` could not be made; returns the tasks to try again (with a new
        generation). A spec that cannot be generated (``result`` a string) is recorded for each
        run; a machinery failure counts as a failed attempt of each run."""
        if isinstance(result, str):
            for t in tasks:
                self.record(failure_record(t, f"{GENERATION_FAILED}: {result}"))
            return []
        kind = "disk-full" if result.kind == "disk-full" else "world"
        return [t for t in tasks if self.failed(t, kind, result.reason)]


class Repetition:
    """Adaptive repetition: after each record of a stream, the stream's runs that became due
    (:meth:`navstress.campaign.plan.Stream.due`), each handed out once; keeps the campaign's
    upper bound of runs (:meth:`navstress.campaign.plan.Plan.at_most`) up to date."""

    def __init__(self, plan: Plan, outcomes: dict[str, str]) -> None:
        self.outcomes = dict(outcomes)
        self.tasks = {t.run_id: t for t in plan.tasks}
        self.stream_of: dict[str, Stream] = {r: s for s in plan.streams if s.rule is not None for r in s.run_ids}
        self.handed: set[str] = plan.due(self.outcomes)
        self.most = {id(s): s.at_most(self.outcomes) for s in plan.streams}
        self.at_most = sum(self.most.values())

    def recorded(self, rec: RunRecord) -> list[RunTask]:
        """The tasks that ``rec`` made due (in run order)."""
        self.outcomes[rec.run_id] = rec.outcome
        s = self.stream_of.get(rec.run_id)
        if s is None:
            return []
        most = s.at_most(self.outcomes)
        self.at_most += most - self.most[id(s)]
        self.most[id(s)] = most
        new = [r for r in s.due(self.outcomes) if r not in self.handed]
        self.handed.update(new)
        return [self.tasks[r] for r in new]


class WorkQueue:
    """What is handed out next: each map's world first (once), then the map's runs; failed
    tasks come back to the front, runs on a broken world wait for its regeneration.
    ``repetition``: the adaptive policy that adds runs as records arrive (:meth:`recorded`)."""

    def __init__(self, plan: Plan, pending: Iterable[RunTask] = (), repetition: Repetition | None = None,
                 on_planned: PlannedCallback | None = None) -> None:
        self.jobs: dict[str, MapJob] = {m.world_dir: m for m in plan.maps}
        self.root = plan.root
        self.by_map: dict[str, deque[RunTask]] = {}
        self.to_generate: deque[MapJob] = deque()
        self.ready: deque[RunTask] = deque()
        self.generating: set[str] = set()
        self.repetition = repetition
        self.on_planned = on_planned
        self.add(pending)

    def recorded(self, records: list[RunRecord]) -> None:
        """Queue the runs that ``records`` made due (adaptive repetition; nothing otherwise)."""
        rep = self.repetition
        if rep is None or not records:
            return
        before = rep.at_most
        for r in records:
            self.add(rep.recorded(r))
        if rep.at_most != before and self.on_planned is not None:
            self.on_planned(rep.at_most)

    def add(self, tasks: Iterable[RunTask]) -> None:
        """Queue ``tasks`` (of maps in the plan), in plan order of their maps: behind their
        world's generation when it is not on disk yet."""
        new: dict[str, list[RunTask]] = {}
        for t in tasks:
            new.setdefault(t.world_dir, []).append(t)
        for world_dir, job in self.jobs.items():
            if world_dir not in new:
                continue
            waiting = self.by_map.get(world_dir)
            if waiting is not None:  # its world is being generated: the tasks wait with the others
                waiting.extend(new[world_dir])
            elif world_dir not in self.generating and is_world_dir(world_dir):
                self.ready.extend(new[world_dir])
            else:
                self.by_map[world_dir] = deque(new[world_dir])
                if world_dir not in self.generating:
                    self.generating.add(world_dir)
                    self.to_generate.append(job)

    def __bool__(self) -> bool:
        return bool(self.ready or self.to_generate)

    def next(self) -> Job:
        """The next job; call only when the queue is not empty. OutputPathError when a symbolic
        link was planted on the way to what the job writes (the output-directory rule)."""
        if self.ready:
            task = self.ready.popleft()
            self._inside(str(Path(task.trace_path).parent))
            return Job("run", task)
        job = self.to_generate.popleft()
        self._inside(job.world_dir)
        return Job("world", job)

    def _inside(self, path: str) -> None:
        if self.root:
            _files.check_below(self.root, path)

    def world_ended(self, job: MapJob, result: str | Infra | None, rec: Recorder) -> None:
        self.generating.discard(job.world_dir)
        tasks = list(self.by_map.pop(job.world_dir, deque()))
        if result is None:
            self.ready.extend(tasks)
            return
        again = rec.world_failed(tasks, result)
        if again:
            self.regenerate(job.world_dir, again, remove=False)

    def run_ended(self, task: RunTask, result: RunRecord | Infra, rec: Recorder, wall_s: float) -> None:
        if isinstance(result, RunRecord):
            rec.record(result)
        elif result.kind == "world":
            if rec.failed(task, "world", result.reason, wall_s):
                self.regenerate(task.world_dir, [task], remove=True)
        elif rec.failed(task, result.kind, result.reason, wall_s):
            self.ready.appendleft(task)

    def run_died(self, task: RunTask, reason: str, rec: Recorder, wall_s: float) -> None:
        if rec.failed(task, "died", reason, wall_s):
            self.ready.appendleft(task)

    def regenerate(self, world_dir: str, tasks: list[RunTask], *, remove: bool) -> None:
        """Queue ``tasks`` behind a new generation of ``world_dir`` (removing the broken one)."""
        self.by_map.setdefault(world_dir, deque()).extend(tasks)
        if world_dir in self.generating:
            return
        if remove:
            self._inside(world_dir)
            _files.remove_tree(world_dir)
        self.generating.add(world_dir)
        self.to_generate.append(self.jobs[world_dir])


def _first_line(value: Any) -> str:
    lines = str(value).splitlines()
    return lines[0] if lines else ""


def job_ended(job: Job, status: str, value: Any, wall_s: float, q: WorkQueue, rec: Recorder, worker: str) -> None:
    """Turn the end of ``job`` (``status``: ok, error, died, or ``limit`` with the limit in
    seconds as ``value``) into a result, a retry or a record: the same words for every executor."""
    payload = job.payload
    if job.kind == "world":
        if status == "ok":
            q.world_ended(payload, value, rec)
        elif status == "error":
            q.world_ended(payload, Infra("error", f"{GENERATION_FAILED}: {_first_line(value)}"), rec)
        elif status == "died":
            q.world_ended(payload, Infra("error", f"world generation killed its {worker} ({value})"), rec)
        else:
            q.world_ended(payload, Infra("error", f"world generation exceeded wall-clock limit ({value:g} s)"), rec)
    elif status == "ok":
        q.run_ended(payload, value, rec, wall_s)
    elif status == "error":
        q.run_ended(payload, Infra("error", f"worker error: {_first_line(value)}"), rec, wall_s)
    elif status == "died":
        q.run_died(payload, f"run killed its {worker} ({value})", rec, wall_s)
    else:
        drop_partial_trace(payload)
        rec.record(failure_record(payload, f"run exceeded wall-clock limit ({value:g} s); worker killed", wall_s))


def schedule(executor: Executor, q: WorkQueue, rec: Recorder, *, wall_limit_s: float,
             world_limit_s: float = WORLD_LIMIT_S, start_limit_s: float = WORLD_LIMIT_S,
             expected: int | None = None) -> None:
    """Run everything in ``q`` on ``executor``, passing every end of a job to ``rec`` (and each
    new record to ``q.recorded``, which may queue more: ``expected`` is how many runs may come in
    all, for the executor's size).

    The executor is shut down on the way out (killing its workers when something, e.g. Ctrl-C
    or a full disk, interrupted the loop)."""
    if not q:
        return

    def limit(job: Job) -> float:
        return (wall_limit_s if job.kind == "run" else world_limit_s) if job.running else start_limit_s

    queued = len(q.ready) + sum(len(t) for t in q.by_map.values())
    slots = executor.start(max(queued, expected or 0))
    inflight: list[Job] = []
    clean = False
    try:
        while q or inflight:
            while len(inflight) < slots and q:
                job = q.next()
                job.started, job.running = time.monotonic(), False
                executor.submit(job)
                inflight.append(job)
            now = time.monotonic()
            first_deadline = min(j.started + limit(j) for j in inflight)
            events = executor.wait(min(TICK_S, max(0.0, first_deadline - now)))
            now = time.monotonic()
            for ev in events:
                job = ev.job
                if ev.status == "started":  # the clock starts when the worker (warm) begins
                    job.started, job.running = now, True
                    continue
                inflight.remove(job)
                job_ended(job, ev.status, ev.value, now - job.started, q, rec, executor.worker)
            for job in list(inflight):
                if now - job.started > limit(job):
                    executor.kill(job)
                    inflight.remove(job)
                    job_ended(job, "limit", limit(job), now - job.started, q, rec, executor.worker)
            q.recorded(rec.take())
        clean = True
    finally:
        executor.shutdown(now=not clean)


@dataclass
class Session:
    """What one :func:`resume` did: planned runs, runs recorded before it, runs it recorded,
    and the runs left pending after repeated machinery failures (run_id -> last reason)."""

    planned: int
    already_done: int
    recorded: int
    unfinished: dict[str, str]


def resume(store: Store, executor: Executor, *, wall_limit_s: float, on_record: RecordCallback | None = None,
           on_start: StartCallback | None = None, max_attempts: int = MAX_ATTEMPTS,
           world_limit_s: float = WORLD_LIMIT_S, on_planned: PlannedCallback | None = None) -> Session:
    """Run the planned runs of ``store`` that are not recorded yet on ``executor``; with adaptive
    repetition, the runs due given the store's records, and those that become due.

    ``on_start(done, planned, counts)``: planned is an upper bound when adaptive, lowered through
    ``on_planned(planned)`` as streams stop. Partial files are removed before and after (whatever
    stopped the executor: Ctrl-C, SIGTERM, a full disk), so none is ever left behind."""
    store.cleanup_partials()
    try:
        p = store.plan()
        outcomes = store.outcomes()
        due = p.due(outcomes)
        pending = [t for t in p.tasks if t.run_id in due and t.run_id not in outcomes]
        rep = Repetition(p, outcomes) if p.adaptive else None
        at_most = rep.at_most if rep is not None else len(p.tasks)
        if on_start is not None:
            on_start(len(outcomes), at_most, store.outcome_counts())
        rec = Recorder(store, on_record, max_attempts)
        q = WorkQueue(p, pending, rep, on_planned)
        schedule(executor, q, rec, wall_limit_s=wall_limit_s, world_limit_s=world_limit_s,
                 expected=at_most - len(outcomes))
        planned = rep.at_most if rep is not None else len(p.tasks)
        return Session(planned, len(outcomes), rec.recorded, dict(rec.unfinished))
    finally:
        store.cleanup_partials()
