"""Running a campaign: the driver, the local process-pool executor, and the work functions.

:func:`run_campaign` opens (or resumes) the store, validates that every navigator and fault
exists, cleans partial files, and hands the pending work to an executor. Executors return
results to the driver, which alone writes records (single writer).

The local executor keeps ``workers`` processes of its own (spawn context) and knows which
job each one holds, so that:

- each map's world is generated once, by one worker, before the runs on it are dispatched;
- a worker that dies (``os._exit``, SIGKILL, segfault) costs exactly its own run, which is
  retried on a replacement worker; a crash that repeats on every attempt is the navigator's
  own and recorded as Fail-Other with the exit status (see :class:`Recorder`); failures of
  the machinery (a world that cannot be loaded, an OS error) are retried, never recorded;
- a run that exceeds its wall-clock limit (last resort; ``execute`` handles hanging
  navigators itself) has its worker killed and is recorded as Fail-Other;
- workers die with the driver (Linux ``PR_SET_PDEATHSIG``, plus a parent watch thread),
  so a killed campaign leaves no orphan writing traces behind the resumed one.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import shutil
import signal
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from navstress.campaign.plan import MapJob, Plan
from navstress.campaign.spec import CampaignSpec, load_campaign
from navstress.campaign.store import OUTCOMES, Store, disk_full, is_disk_full
from navstress.errors import GenerationError, NavigatorError, SpecError, WorldFileError
from navstress.isolate import describe_exit, die_with_parent
from navstress.run.batch import drop_partial_trace, failure_record
from navstress.run.record import RunRecord, RunTask

RecordCallback = Callable[[RunRecord], None]
#: Default wall-clock limit of one run: ``timeout_s * WALL_FACTOR + WALL_SLACK_S`` real seconds.
WALL_FACTOR = 2.0
WALL_SLACK_S = 120.0
#: Wall-clock limit of generating one world.
WORLD_LIMIT_S = 900.0
#: Attempts of one run (or world) in one ``campaign run`` before it is given up for this session.
MAX_ATTEMPTS = 3


@dataclass
class CampaignResult:
    """What one ``run_campaign`` call did."""

    directory: Path
    planned: int
    already_done: int
    recorded: int
    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0
    workers: int = 0
    unfinished: dict[str, str] = field(default_factory=dict)  # run_id -> last reason (infrastructure failures)


@dataclass(frozen=True)
class Infra:
    """A failure of navstress's own machinery during a task: never a result (the task is retried).

    ``kind``: ``world`` (the world on disk is unusable: it is regenerated), ``disk-full`` (the
    campaign stops, resumable), ``error`` (anything else: retried)."""

    kind: str
    reason: str


def _line(err: BaseException) -> str:
    text = " ".join(f"{type(err).__name__}: {err}".split())
    return text if len(text) <= 300 else text[:300] + "..."


# ---- work functions (run inside workers, local or Ray) -------------------------------------


def register_targets(targets: dict[str, str]) -> None:
    """Register spec-given ``module:attr`` navigators in this process."""
    if targets:
        from navstress.nav import registry

        for name, target in targets.items():
            registry.register(name, target, override=True)


def generate_world(job: MapJob) -> None:
    """Generate and save the world of ``job`` unless a complete one is already there."""
    from navstress.world.generate import generate
    from navstress.world.spec import parse_spec
    from navstress.world.world import is_world_dir

    if is_world_dir(job.world_dir):
        return
    generate(parse_spec(job.world), job.map_seed).save(job.world_dir)


def attempt_world(job: MapJob) -> str | Infra | None:
    """Generate ``job``'s world: None when done; a reason string when its spec cannot be generated
    (GenerationError or another navstress error: the same on every attempt, recorded as the runs'
    result); :class:`Infra` for a failure of the machinery (retried)."""
    try:
        generate_world(job)
        return None
    except (GenerationError, SpecError) as err:
        return " ".join(str(err).split())
    except Exception as err:
        if is_disk_full(err):
            return Infra("disk-full", _line(err))
        return Infra("error", f"world generation failed: {_line(err)}")


def attempt_run(task: RunTask) -> RunRecord | Infra:
    """Run one task: its record, or :class:`Infra` when navstress's machinery failed (the world on
    disk cannot be loaded, the disk is full, out of memory, another OS error). Any other exception
    from ``execute`` is a Fail-Other record (it repeats with the same task)."""
    t0 = time.perf_counter()
    try:
        from navstress.run.mission import execute

        return execute(task)
    except WorldFileError as err:
        return Infra("world", f"world unusable: {' '.join(str(err).split())}")
    except (OSError, MemoryError) as err:
        if is_disk_full(err):
            return Infra("disk-full", _line(err))
        return Infra("error", f"run failed in navstress: {_line(err)}")
    except Exception as err:  # execute() should not raise; if it does the campaign goes on
        broken = _world_unloadable(task.world_dir)
        if broken is not None:  # e.g. a truncated terrain file that World.load does not name
            return Infra("world", f"world unusable: {broken}")
        msg = f"run raised {type(err).__name__}: {err}".splitlines()[0]
        return failure_record(task, msg, time.perf_counter() - t0)


def _world_unloadable(world_dir: str) -> str | None:
    """Why the world at ``world_dir`` cannot be loaded, or None when it loads."""
    try:
        from navstress.world.world import World

        World.load(world_dir)
        return None
    except Exception as err:
        return f"world={world_dir!r} is corrupt: {_line(err)}"


def run_one(task: RunTask) -> RunRecord:
    """Run one task with ``navstress.run.mission.execute``; any failure becomes a Fail-Other record."""
    out = attempt_run(task)
    return failure_record(task, out.reason) if isinstance(out, Infra) else out


class Recorder:
    """Takes every end of a task from an executor (the driver's single writer): records results,
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

    def record(self, rec: RunRecord) -> None:
        self.unfinished.pop(rec.run_id, None)
        if self.store.add(rec):
            self.recorded += 1
            if self.on_record is not None:
                self.on_record(rec)

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
                self.record(failure_record(t, f"world generation failed: {result}"))
            return []
        kind = "disk-full" if result.kind == "disk-full" else "world"
        return [t for t in tasks if self.failed(t, kind, result.reason)]


# ---- driver ----------------------------------------------------------------------------------


def check_runnable(spec: CampaignSpec) -> None:
    """Every navigator and fault of ``spec`` exists, every navigator accepts its config and the
    ``sim:`` overrides are a valid SimConfig (SpecError naming the field otherwise). Nothing is
    written and no run is started (navigator factories validate their config, see
    :func:`navstress.nav.registry.validate_config`)."""
    from navstress.nav import faults as nav_faults
    from navstress.nav import registry
    from navstress.sim.config import SimConfig

    targets = {n.name: n.target for n in spec.navigators if n.target}
    for i, nav in enumerate(spec.navigators):
        if nav.name in targets:
            try:
                registry._make_spec(nav.name, targets[nav.name], "campaign spec")
            except NavigatorError as err:
                raise SpecError(f"navigators[{i}].target", nav.target, "a 'module:attr' navigator factory",
                                str(err)) from None
            continue
        try:
            registry.resolve(nav.name)
        except NavigatorError as err:
            raise SpecError(f"navigators[{i}].name", nav.name, "a registered navigator", str(err)) from None
    faults: list[str] = []
    for exp in spec.experiments:
        for f in spec.faults_of(exp):
            if f is None:
                continue
            try:
                nav_faults.get_fault(f)
            except NavigatorError as err:
                raise SpecError("faults", f, "a known fault or null (nominal)", str(err)) from None
            faults.append(f)
    SimConfig.from_mapping(dict(spec.sim))
    saved = dict(registry._registered)
    try:
        register_targets(targets)
        for i, nav in enumerate(spec.navigators):
            try:
                registry.validate_config(nav.name, dict(nav.config), field=f"navigators[{i}].config")
            except NavigatorError as err:  # a spec-given target that cannot be imported
                where = f"navigators[{i}].target" if nav.name in targets else f"navigators[{i}].name"
                raise SpecError(where, nav.target or nav.name, "a navigator that can be loaded",
                                str(err)) from None
    finally:
        registry._registered.clear()
        registry._registered.update(saved)


def run_campaign(spec_path: str | Path, directory: str | Path, *, workers: int | None = None,
                 executor: Literal["local", "ray"] = "local", ray_address: str | None = None,
                 wall_limit_s: float | None = None, on_record: RecordCallback | None = None,
                 on_start: Callable[[int, int, dict[str, int]], None] | None = None,
                 accept_large: bool = False, max_attempts: int = MAX_ATTEMPTS) -> CampaignResult:
    """Run (or resume) the campaign of ``spec_path`` into ``directory``.

    ``workers``: processes (local, default ``os.cpu_count()``) or concurrent Ray tasks (default:
    the cluster's CPUs). ``wall_limit_s``: per-run wall-clock limit (default
    ``timeout_s * 2 + 120``). ``on_start(done, planned, counts)`` and ``on_record(record)``
    feed progress displays. ``accept_large``: plan more than ``MAX_PLANNED_RUNS`` runs.
    Raises SpecError / StoreError before running anything when the spec, a navigator or sim
    config, or the directory is unusable; DiskFullError (nothing lost: resume later) when the
    disk fills. An interrupted campaign (KeyboardInterrupt, or the CLI's SIGTERM) leaves no
    partial file behind. Runs whose machinery failed ``max_attempts`` times stay pending
    (``CampaignResult.unfinished``)."""
    from navstress.campaign.spec import MAX_PLANNED_RUNS

    if workers is not None and workers < 1:
        raise SpecError("--workers", workers, "an integer >= 1")
    if executor not in ("local", "ray"):
        raise SpecError("--executor", executor, "local or ray")
    spec, text = load_campaign(spec_path, max_runs=None if accept_large else MAX_PLANNED_RUNS)
    check_runnable(spec)
    t0 = time.perf_counter()
    ray_ex: Any = None
    if executor == "ray":  # joined (or started) before the store is made: a cluster error writes nothing
        from navstress.campaign.ray_executor import RayExecutor

        limit0 = wall_limit_s if wall_limit_s is not None else spec.timeout_s * WALL_FACTOR + WALL_SLACK_S
        ray_ex = RayExecutor(workers, limit0, {n.name: n.target for n in spec.navigators if n.target},
                             address=ray_address)
    try:
        with Store.create(directory, spec, text) as store:
            store.cleanup_partials()
            p = store.plan()
            done = store.done_ids()
            pending = [t for t in p.tasks if t.run_id not in done]
            if on_start is not None:
                on_start(len(done), len(p.tasks), store.outcome_counts())
            limit = wall_limit_s if wall_limit_s is not None else spec.timeout_s * WALL_FACTOR + WALL_SLACK_S
            targets = {n.name: n.target for n in spec.navigators if n.target}
            rec = Recorder(store, on_record, max_attempts)
            try:
                if ray_ex is None:
                    n = workers if workers is not None else (os.cpu_count() or 1)
                    LocalExecutor(n, limit, targets).run(p, pending, rec)
                else:
                    n = ray_ex.workers
                    ray_ex.run(p, pending, rec)
            finally:
                store.cleanup_partials()  # whatever stopped the executors: no partial trace or world left
            return CampaignResult(Path(directory), len(p.tasks), len(done), rec.recorded, store.outcome_counts(),
                                  time.perf_counter() - t0, n, dict(rec.unfinished))
    finally:
        if ray_ex is not None:
            ray_ex.close()


def maps_needed(plan: Plan, pending: list[RunTask]) -> tuple[list[MapJob], dict[str, deque[RunTask]]]:
    """The maps that pending tasks need (plan order) and the pending tasks of each map."""
    by_map: dict[str, deque[RunTask]] = {}
    for t in pending:
        by_map.setdefault(t.world_dir, deque()).append(t)
    return [m for m in plan.maps if m.world_dir in by_map], by_map


class WorkQueue:
    """What an executor hands out next: each map's world first (once), then the map's runs;
    failed tasks come back to the front, runs on a broken world wait for its regeneration."""

    def __init__(self, plan: Plan, pending: list[RunTask]) -> None:
        from navstress.world.world import is_world_dir

        maps, self.by_map = maps_needed(plan, pending)
        self.jobs = {m.world_dir: m for m in plan.maps}
        self.to_generate: deque[MapJob] = deque()
        self.ready: deque[RunTask] = deque()
        self.generating: set[str] = set()
        for m in maps:
            if is_world_dir(m.world_dir):
                self.ready.extend(self.by_map.pop(m.world_dir))
            else:
                self.to_generate.append(m)
                self.generating.add(m.world_dir)

    def __bool__(self) -> bool:
        return bool(self.ready or self.to_generate)

    def next(self) -> tuple[str, Any]:
        """("run", RunTask) or ("world", MapJob); call only when the queue is not empty."""
        if self.ready:
            return "run", self.ready.popleft()
        return "world", self.to_generate.popleft()

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
            shutil.rmtree(world_dir, ignore_errors=True)
        self.generating.add(world_dir)
        self.to_generate.append(self.jobs[world_dir])


# ---- local executor --------------------------------------------------------------------------


def warm_up() -> float:
    """Run a 0.5 s mission on a small flat world so that this process's JIT and imports are done.

    Returns the seconds it took. Best effort: any failure is ignored (the real run will report it)."""
    import tempfile

    t0 = time.perf_counter()
    try:
        from navstress.run.mission import execute
        from navstress.world.spec import WorldSpec
        from navstress.world.world import World

        with tempfile.TemporaryDirectory(prefix="navstress-warmup-") as tmp:
            World.flat(WorldSpec(size_m=(20.0, 20.0))).save(Path(tmp) / "w")
            execute(RunTask(run_id="warm-up", world_dir=str(Path(tmp) / "w"), run_seed=0,
                            trace_path=str(Path(tmp) / "t.mcap"), timeout_s=0.5))
    except Exception:
        pass
    return time.perf_counter() - t0


def _worker_main(conn: mpc.Connection, parent_pid: int, targets: dict[str, str], warm: bool) -> None:
    """Worker loop: receive ("world", MapJob) or ("run", RunTask); answer ("started", None) when it
    begins, then ("ok"|"error", value)."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's business
    register_targets(targets)
    if warm:
        warm_up()
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        kind, payload = msg
        conn.send(("started", None))
        try:
            result: Any = attempt_world(payload) if kind == "world" else attempt_run(payload)
            conn.send(("ok", result))
        except Exception as err:
            conn.send(("error", f"{type(err).__name__}: {err}".splitlines()[0] + "\n" + traceback.format_exc(limit=3)))


@dataclass
class _Slot:
    proc: Any
    conn: mpc.Connection
    kind: str = ""
    payload: Any = None
    started: float = 0.0
    running: bool = False


class LocalExecutor:
    """A pool of ``workers`` processes that knows which job each one holds (see module doc)."""

    def __init__(self, workers: int, wall_limit_s: float, targets: dict[str, str] | None = None, *,
                 warm: bool = True) -> None:
        self.workers = workers
        self.warm = warm
        self.wall_limit_s = wall_limit_s
        self.targets = dict(targets or {})
        self._ctx = mp.get_context("spawn")

    def _spawn(self) -> _Slot:
        parent, child = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=_worker_main, args=(child, os.getpid(), self.targets, self.warm), daemon=True)
        proc.start()
        child.close()
        return _Slot(proc, parent)

    def run(self, plan: Plan, pending: list[RunTask], rec: Recorder) -> None:
        """Run ``pending`` (worlds first, per map), passing every end of a task to ``rec``."""
        q = WorkQueue(plan, pending)
        if not q:
            return
        slots = [self._spawn() for _ in range(min(self.workers, len(pending)))]
        clean = False
        try:
            while q or any(s.kind for s in slots):
                for s in slots:
                    if not s.kind and q:
                        self._send(s, *q.next())
                busy = [s for s in slots if s.kind]
                waitables: list[Any] = [s.conn for s in busy] + [s.proc.sentinel for s in busy]
                mpc.wait(waitables, timeout=1.0)
                now = time.monotonic()
                for i, s in enumerate(slots):
                    if not s.kind:
                        continue
                    outcome: tuple[str, Any] | None = None
                    while outcome is None and s.conn.poll():
                        try:
                            outcome = s.conn.recv()
                        except (EOFError, OSError):
                            break
                        if outcome[0] == "started":  # the clock starts when the worker (warm) begins
                            s.started, s.running, outcome = time.monotonic(), True, None
                    if outcome is None and not s.proc.is_alive():
                        s.proc.join(1.0)
                        outcome = ("died", describe_exit(s.proc.exitcode))
                    limit = self.wall_limit_s if s.kind == "run" else WORLD_LIMIT_S
                    if not s.running:  # still starting up (imports, warm-up): a generous limit
                        limit = WORLD_LIMIT_S
                    if outcome is None and now - s.started > limit:
                        s.proc.kill()
                        s.proc.join(5.0)
                        outcome = ("limit", f"{limit:g} s")
                    if outcome is None:
                        continue
                    if outcome[0] in ("died", "limit"):
                        s.conn.close()
                        slots[i] = self._spawn()
                    self._finish(s, outcome, now, q, rec)
            clean = True
        finally:
            for s in slots:
                if not clean:  # interrupted or failed: stop every worker now
                    s.proc.kill()
                try:
                    s.conn.send(None)
                except (OSError, ValueError):
                    pass
            for s in slots:
                s.proc.join(2.0)
                if s.proc.is_alive():
                    s.proc.kill()
                    s.proc.join(2.0)
                s.conn.close()

    def _send(self, s: _Slot, kind: str, payload: Any) -> None:
        s.kind, s.payload, s.started, s.running = kind, payload, time.monotonic(), False
        s.conn.send((kind, payload))

    @staticmethod
    def _finish(s: _Slot, outcome: tuple[str, Any], now: float, q: WorkQueue, rec: Recorder) -> None:
        kind, payload, wall = s.kind, s.payload, now - s.started
        s.kind, s.payload = "", None
        status, value = outcome
        if kind == "world":
            result: Any = value if status == "ok" else Infra("error", {
                "error": f"world generation failed: {str(value).splitlines()[0]}",
                "died": f"world generation killed its worker ({value})",
                "limit": f"world generation exceeded wall-clock limit ({value})"}[status])
            q.world_ended(payload, result, rec)
        elif status == "ok":
            q.run_ended(payload, value, rec, wall)
        elif status == "error":
            q.run_ended(payload, Infra("error", f"worker error: {str(value).splitlines()[0]}"), rec, wall)
        elif status == "died":
            q.run_died(payload, f"run killed its worker process ({value})", rec, wall)
        else:
            drop_partial_trace(payload)
            rec.record(failure_record(payload, f"run exceeded wall-clock limit ({value}); worker killed", wall))


def outcome_counts(records: list[RunRecord]) -> dict[str, int]:
    counts = {o: 0 for o in OUTCOMES}
    for r in records:
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    return counts


def with_trace(task: RunTask, trace_path: str) -> RunTask:
    """``task`` writing its trace elsewhere (replay)."""
    return replace(task, trace_path=trace_path)
