"""Running a campaign: the driver, the local process-pool executor, and the work functions.

:func:`run_campaign` opens (or resumes) the store, validates that every navigator and fault
exists, cleans partial files, and hands the pending work to an executor. Executors return
results to the driver, which alone writes records (single writer).

The local executor keeps ``workers`` processes of its own (spawn context) and knows which
job each one holds, so that:

- each map's world is generated once, by one worker, before the runs on it are dispatched;
- a worker that dies (``os._exit``, SIGKILL, segfault) costs exactly its own run, recorded
  as Fail-Other with the exit status; a replacement worker is started;
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
import signal
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from navstress.campaign.plan import MapJob, Plan
from navstress.campaign.spec import CampaignSpec, load_campaign
from navstress.campaign.store import OUTCOMES, Store
from navstress.errors import NavigatorError, SpecError
from navstress.run.record import RunRecord, RunTask

RecordCallback = Callable[[RunRecord], None]
#: Default wall-clock limit of one run: ``timeout_s * WALL_FACTOR + WALL_SLACK_S`` real seconds.
WALL_FACTOR = 2.0
WALL_SLACK_S = 120.0
#: Wall-clock limit of generating one world.
WORLD_LIMIT_S = 900.0


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


def failure_record(task: RunTask, reason: str, wall_s: float = 0.0) -> RunRecord:
    """A Fail-Other record for a run that produced no result of its own (crash, limit, no world)."""
    return RunRecord(
        run_id=task.run_id, experiment=task.experiment, config=dict(task.config), map_index=task.map_index,
        run_index=task.run_index, map_seed=task.map_seed, run_seed=task.run_seed, navigator=task.navigator,
        fault=task.fault, outcome="fail-other", reason=reason, duration_s=0.0, wall_s=wall_s,
        goal_distance_m=math.nan, path_length_m=0.0, tortuousness=0.0, collisions=0, first_collision_s=None,
        errors=[reason], trace=None)


def drop_partial_trace(task: RunTask) -> None:
    """Remove the partial trace a killed run left behind (TraceWriter's ``.NAME.partial``)."""
    p = Path(task.trace_path)
    p.with_name(f".{p.name}.partial").unlink(missing_ok=True)


def run_one(task: RunTask) -> RunRecord:
    """Run one task with ``navstress.run.mission.execute``; an unexpected exception becomes Fail-Other."""
    t0 = time.perf_counter()
    try:
        from navstress.run.mission import execute

        return execute(task)
    except Exception as err:  # execute() should not raise; if it does the campaign goes on
        msg = f"run raised {type(err).__name__}: {err}".splitlines()[0]
        return failure_record(task, msg, time.perf_counter() - t0)


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


# ---- driver ----------------------------------------------------------------------------------


def check_runnable(spec: CampaignSpec) -> None:
    """Every navigator and fault of ``spec`` exists (SpecError naming the field otherwise)."""
    from navstress.nav import faults as nav_faults
    from navstress.nav import registry

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
    for exp in spec.experiments:
        for f in spec.faults_of(exp):
            if f is None:
                continue
            try:
                nav_faults.get_fault(f)
            except NavigatorError as err:
                raise SpecError("faults", f, "a known fault or null (nominal)", str(err)) from None


def run_campaign(spec_path: str | Path, directory: str | Path, *, workers: int | None = None,
                 executor: Literal["local", "ray"] = "local", ray_address: str | None = None,
                 wall_limit_s: float | None = None, on_record: RecordCallback | None = None,
                 on_start: Callable[[int, int, dict[str, int]], None] | None = None) -> CampaignResult:
    """Run (or resume) the campaign of ``spec_path`` into ``directory``.

    ``workers``: processes (local, default ``os.cpu_count()``) or concurrent Ray tasks (default:
    the cluster's CPUs). ``wall_limit_s``: per-run wall-clock limit (default
    ``timeout_s * 2 + 120``). ``on_start(done, planned, counts)`` and ``on_record(record)``
    feed progress displays. Raises SpecError / StoreError before running anything when the
    spec or directory is unusable."""
    spec, text = load_campaign(spec_path)
    check_runnable(spec)
    t0 = time.perf_counter()
    with Store.create(directory, spec, text) as store:
        store.cleanup_partials()
        p = store.plan()
        done = store.done_ids()
        pending = [t for t in p.tasks if t.run_id not in done]
        if on_start is not None:
            on_start(len(done), len(p.tasks), store.outcome_counts())
        limit = wall_limit_s if wall_limit_s is not None else spec.timeout_s * WALL_FACTOR + WALL_SLACK_S
        targets = {n.name: n.target for n in spec.navigators if n.target}
        recorded = 0

        def sink(rec: RunRecord) -> None:
            nonlocal recorded
            if store.add(rec):
                recorded += 1
                if on_record is not None:
                    on_record(rec)

        if executor == "local":
            n = workers if workers is not None else (os.cpu_count() or 1)
            if n < 1:
                raise SpecError("--workers", n, "an integer >= 1")
            LocalExecutor(n, limit, targets).run(p, pending, sink)
        elif executor == "ray":
            from navstress.campaign.ray_executor import RayExecutor

            ex = RayExecutor(workers, limit, targets, address=ray_address)
            n = ex.workers
            ex.run(p, pending, sink)
        else:
            raise SpecError("--executor", executor, "local or ray")
        return CampaignResult(Path(directory), len(p.tasks), len(done), recorded, store.outcome_counts(),
                              time.perf_counter() - t0, n)


def maps_needed(plan: Plan, pending: list[RunTask]) -> tuple[list[MapJob], dict[str, deque[RunTask]]]:
    """The maps that pending tasks need (plan order) and the pending tasks of each map."""
    by_map: dict[str, deque[RunTask]] = {}
    for t in pending:
        by_map.setdefault(t.world_dir, deque()).append(t)
    return [m for m in plan.maps if m.world_dir in by_map], by_map


# ---- local executor --------------------------------------------------------------------------


def _die_with_parent(parent_pid: int) -> None:
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:
            pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


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
    _die_with_parent(parent_pid)
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
            if kind == "world":
                generate_world(payload)
                result: Any = None
            else:
                result = run_one(payload)
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

    def run(self, plan: Plan, pending: list[RunTask], sink: RecordCallback) -> None:
        """Run ``pending`` (worlds first, per map), passing every record to ``sink``."""
        maps, by_map = maps_needed(plan, pending)
        from navstress.world.world import is_world_dir

        to_generate: deque[MapJob] = deque()
        ready: deque[RunTask] = deque()
        for m in maps:
            if is_world_dir(m.world_dir):
                ready.extend(by_map.pop(m.world_dir))
            else:
                to_generate.append(m)
        if not ready and not to_generate:
            return
        slots = [self._spawn() for _ in range(min(self.workers, len(pending)))]
        try:
            while ready or to_generate or any(s.kind for s in slots):
                for s in slots:
                    if s.kind:
                        continue
                    if ready:
                        self._send(s, "run", ready.popleft())
                    elif to_generate:
                        self._send(s, "world", to_generate.popleft())
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
                    self._finish(s, outcome, now, by_map, ready, sink)
                    if outcome[0] in ("died", "limit"):
                        s.conn.close()
                        slots[i] = self._spawn()
        finally:
            for s in slots:
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

    def _finish(self, s: _Slot, outcome: tuple[str, Any], now: float, by_map: dict[str, deque[RunTask]],
                ready: deque[RunTask], sink: RecordCallback) -> None:
        kind, payload, wall = s.kind, s.payload, now - s.started
        s.kind, s.payload = "", None
        status, value = outcome
        if kind == "world":
            tasks = by_map.pop(payload.world_dir, deque())
            if status == "ok":
                ready.extend(tasks)
                return
            why = {"error": f"world generation failed: {str(value).splitlines()[0]}",
                   "died": f"world generation killed its worker ({value})",
                   "limit": f"world generation exceeded wall-clock limit ({value})"}[status]
            for t in tasks:
                sink(failure_record(t, why))
            return
        if status == "ok":
            sink(value)
        elif status == "error":
            sink(failure_record(payload, f"worker error: {str(value).splitlines()[0]}", wall))
        elif status == "died":
            drop_partial_trace(payload)
            sink(failure_record(payload, f"run killed its worker process ({value})", wall))
        else:
            drop_partial_trace(payload)
            sink(failure_record(payload, f"run exceeded wall-clock limit ({value}); worker killed", wall))


def outcome_counts(records: list[RunRecord]) -> dict[str, int]:
    counts = {o: 0 for o in OUTCOMES}
    for r in records:
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    return counts


def with_trace(task: RunTask, trace_path: str) -> RunTask:
    """``task`` writing its trace elsewhere (replay)."""
    return replace(task, trace_path=trace_path)
