"""Replay one recorded run from its seeds and compare the new trace with the stored one.

DESIGN invariant 3: same seeds, same machine -> bit-identical trace. :func:`replay` re-runs
the planned task of ``run_id`` (regenerating its world from the map seed if it is missing)
into a scratch trace and compares bytes.

Asked to record more than the campaign did (``lidar``, ``navigator_view``, or ``live``, which
implies the navigator's view), the replay writes the fuller trace of the same run (recording
changes nothing of the run: docs/design.md) and, its bytes being others by construction,
compares the record fields instead: the way to open any run of a campaign in Foxglove with its
lidar and its navigator's arcs, or to watch it live.

The run is replayed as campaigns run it: in a worker process (:mod:`navstress.isolate`, through
:func:`navstress.run.batch.run_isolated`) with a wall-clock limit, so that a navigator that
exits, kills its process or hangs ends the replay with a reason (:attr:`ReplayResult.failure`),
never the command, and what it started ends with it. A live replay runs in the worker too (the
worker serves the Foxglove WebSocket, as ``navstress run --live`` does). The scratch folder is
this process's own (``navstress-replay-<pid>-...``): removed whatever happens to the worker, and
those of replays killed outright (SIGKILL) are removed by the next replay.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from navstress import _files
from navstress.campaign.store import Store
from navstress.campaign.work import generate_world, register_targets, with_trace
from navstress.errors import StoreError
from navstress.isolate import Worker
from navstress.run.batch import PRELOAD, default_wall_limit_s, run_isolated
from navstress.run.record import RunRecord

#: Record fields that must match for a faithful replay (wall time, trace path excluded).
COMPARED = ("outcome", "reason", "duration_s", "goal_distance_m", "path_length_m", "tortuousness", "collisions",
            "first_collision_s")


@dataclass(frozen=True)
class ReplayResult:
    """``identical``: the new trace has the same bytes as the stored one."""

    run_id: str
    identical: bool
    stored_trace: Path
    stored_sha256: str
    new_sha256: str
    stored: RunRecord
    new: RunRecord
    record_differences: tuple[str, ...]  # COMPARED fields whose values differ
    kept_trace: Path | None
    #: the replay recorded more than the stored trace (lidar, the navigator's view): its bytes are
    #: not compared, ``identical`` means the same record
    fuller: bool = False
    #: why the replay did not finish (its navigator's process died, or did not end within the
    #: wall-clock limit): ``new`` is then a Fail-Other record with this reason and no trace
    failure: str | None = None


SCRATCH_PREFIX = "navstress-replay-"


def sweep_scratch(parent: Path | None = None) -> list[Path]:
    """Remove the scratch folders of replays whose process is gone (killed outright: SIGKILL),
    and return them; each is named with its process id (``navstress-replay-<pid>-...``)."""
    return _files.sweep_dead_scratch(SCRATCH_PREFIX, parent)


def replay_wall_limit_s(timeout_s: float, live: Any = None) -> float:
    """The default wall-clock limit of a replay of a run of ``timeout_s`` simulated seconds: a
    campaign's (``timeout_s * 2 + 120``); a live replay is paced by its ``speed`` and first waits
    for a client (as ``navstress run --live``)."""
    if live is None:
        return default_wall_limit_s(timeout_s)
    return default_wall_limit_s(timeout_s / float(live.speed)) + float(live.wait_s)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def replay(directory: str | Path, run_id: str, *, keep: str | Path | None = None, lidar: bool = False,
           navigator_view: bool = False, live: Any = None, wall_limit_s: float | None = None) -> ReplayResult:
    """Re-run ``run_id`` of the campaign in ``directory``; ``keep``: where to keep the new trace;
    ``lidar``, ``navigator_view``: record them too (module doc); ``live``: a
    :class:`~navstress.run.live.LiveSettings` to watch the replay in Foxglove; ``wall_limit_s``:
    the replay's wall-clock limit (default :func:`replay_wall_limit_s`)."""
    with Store.open(directory) as store:
        task = store.task(run_id)
        stored = next((r for r in store.records() if r.run_id == run_id), None)
        if stored is None:
            raise StoreError(f"run_id={run_id!r} has not run yet in {str(directory)!r}; "
                             "finish it first with the command that made it (`navstress campaign run` or "
                             "`navstress search`, the same spec and -o)")
        if stored.trace is None:
            raise StoreError(f"run_id={run_id!r} has no stored trace (outcome {stored.outcome}: {stored.reason}); "
                             "nothing to compare")
        stored_trace = (store.root / stored.trace).resolve()
        if not stored_trace.is_file():
            raise StoreError(f"trace={str(stored_trace)!r} of run_id={run_id!r} is missing")
        job = next(m for m in store.plan().maps if m.world_dir == task.world_dir)
        _files.check_below(store.root, job.world_dir, "campaign", "campaign directory")  # a missing world is generated there
        targets = {n.name: n.target for n in store.spec.navigators if n.target}
    generate_world(job)
    register_targets(targets)  # before the worker starts: it registers what this process has
    sweep_scratch()
    scratch = Path(tempfile.mkdtemp(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-"))
    fuller_task = replace(task, record_lidar=task.record_lidar or lidar,
                          record_navigator=task.record_navigator or navigator_view or live is not None)
    fuller = fuller_task != task
    limit = wall_limit_s if wall_limit_s is not None else replay_wall_limit_s(task.timeout_s, live)
    try:
        new_trace = scratch / stored_trace.name
        with Worker(limit, preload=PRELOAD) as worker:
            new = run_isolated(with_trace(fuller_task, str(new_trace)), worker, live)
        a = _sha(stored_trace)
        if not new_trace.is_file():
            # the navigator's process died or hung (or the run raised out of its loop): no trace
            diffs = tuple(f for f in COMPARED if not _same(getattr(stored, f), getattr(new, f)))
            return ReplayResult(run_id, False, stored_trace, a, "", stored, new, diffs, None, fuller,
                                failure=new.reason)
        b = _sha(new_trace)
        kept = None
        if keep is not None:
            kept = Path(keep)
            _files.copy_atomic(new_trace, kept)  # never through a link at --keep (replaced, its target untouched)
        diffs = tuple(f for f in COMPARED if not _same(getattr(stored, f), getattr(new, f)))
        same = not diffs if fuller else a == b
        return ReplayResult(run_id, same, stored_trace, a, b, stored, new, diffs, kept, fuller)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
