"""What a campaign's workers do, whichever executor runs them: generate a map's world, run a task.

The functions here run inside worker processes (local pool or Ray tasks) and in ``replay``.
They never raise for a failure of the work: :func:`attempt_world` and :func:`attempt_run`
return the result, or an :class:`Infra` for a failure of navstress's own machinery (which the
scheduler retries, see :mod:`navstress.campaign.scheduler`).
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

from navstress import _files
from navstress.campaign.plan import MapJob
from navstress.campaign.store import is_disk_full
from navstress.errors import GenerationError, OutputPathError, SpecError, WorldFileError
from navstress.nav import registry
from navstress.run.batch import failure_record
from navstress.run.mission import execute
from navstress.run.record import GENERATION_FAILED, RunRecord, RunTask
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec, parse_spec
from navstress.world.world import World, is_world_dir


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


def register_targets(targets: dict[str, str]) -> None:
    """Register spec-given ``module:attr`` navigators in this process."""
    for name, target in targets.items():
        registry.register(name, target, override=True)


def generate_world(job: MapJob) -> None:
    """Generate and save the world of ``job`` unless a complete one is already there."""
    if is_world_dir(job.world_dir):
        return
    robot = None if job.robot is None else RunTask("", "", 0, "", robot=job.robot).robot_spec()
    generate(parse_spec(job.world), job.map_seed, robot=robot).save(job.world_dir)


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
        return Infra("error", f"{GENERATION_FAILED}: {_line(err)}")


def attempt_run(task: RunTask) -> RunRecord | Infra:
    """Run one task: its record, or :class:`Infra` when navstress's machinery failed (the world on
    disk cannot be loaded, the disk is full, out of memory, another OS error). Any other exception
    from ``execute`` is a Fail-Other record (it repeats with the same task)."""
    t0 = time.perf_counter()
    try:
        return execute(task)
    except WorldFileError as err:
        return Infra("world", f"world unusable: {' '.join(str(err).split())}")
    except OutputPathError as err:  # a link planted in the campaign directory meanwhile: never a result
        return Infra("error", _line(err))
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
        World.load(world_dir)
        return None
    except Exception as err:
        return f"world={world_dir!r} is corrupt: {_line(err)}"


def run_one(task: RunTask) -> RunRecord:
    """Run one task with ``navstress.run.mission.execute``; any failure becomes a Fail-Other record."""
    out = attempt_run(task)
    return failure_record(task, out.reason) if isinstance(out, Infra) else out


def with_trace(task: RunTask, trace_path: str) -> RunTask:
    """``task`` writing its trace elsewhere (replay)."""
    return replace(task, trace_path=trace_path)


WARM_UP_PREFIX = "navstress-warmup-"


def sweep_warm_ups(parent: Path | None = None) -> list[Path]:
    """Remove the warm-up directories of processes that are gone, and return them.

    A worker is often stopped while it warms up (a campaign that ends first, a pool shut down,
    a kill), and a killed process cannot remove its temporary directory: each is named with its
    process id (``navstress-warmup-<pid>-...``), so the next warm-up removes those whose process
    no longer runs. A directory of a live process (or a reused pid) is left alone."""
    return _files.sweep_dead_scratch(WARM_UP_PREFIX, parent)


def warm_up() -> float:
    """Run a 0.5 s mission on a small flat world so that this process's JIT and imports are done.

    Returns the seconds it took. Best effort: any failure is ignored (the real run will report it).
    The scratch directory is named with this process's id, and warm-up directories left by killed
    processes are removed first (:func:`sweep_warm_ups`)."""
    t0 = time.perf_counter()
    try:
        sweep_warm_ups()
        with tempfile.TemporaryDirectory(prefix=f"{WARM_UP_PREFIX}{os.getpid()}-") as tmp:
            World.flat(WorldSpec(size_m=(20.0, 20.0))).save(Path(tmp) / "w")
            execute(RunTask(run_id="warm-up", world_dir=str(Path(tmp) / "w"), run_seed=0,
                            trace_path=str(Path(tmp) / "t.mcap"), timeout_s=0.5))
    except Exception:
        pass
    return time.perf_counter() - t0
