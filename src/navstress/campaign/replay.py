"""Replay one recorded run from its seeds and compare the new trace with the stored one.

DESIGN invariant 3: same seeds, same machine -> bit-identical trace. :func:`replay` re-runs
the planned task of ``run_id`` (regenerating its world from the map seed if it is missing)
into a scratch trace and compares bytes.

Asked to record more than the campaign did (``lidar``, ``navigator_view``, or ``live``, which
implies the navigator's view), the replay writes the fuller trace of the same run (recording
changes nothing of the run: docs/design.md) and, its bytes being others by construction,
compares the record fields instead: the way to open any run of a campaign in Foxglove with its
lidar and its navigator's arcs, or to watch it live.
"""

from __future__ import annotations

import hashlib
import math
import shutil
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from navstress.campaign.store import Store
from navstress.campaign.work import generate_world, register_targets, run_one, with_trace
from navstress.errors import StoreError
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


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def replay(directory: str | Path, run_id: str, *, keep: str | Path | None = None, lidar: bool = False,
           navigator_view: bool = False, live: Any = None) -> ReplayResult:
    """Re-run ``run_id`` of the campaign in ``directory``; ``keep``: where to keep the new trace;
    ``lidar``, ``navigator_view``: record them too (module doc); ``live``: a
    :class:`~navstress.run.live.LiveSettings` to watch the replay in Foxglove."""
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
        targets = {n.name: n.target for n in store.spec.navigators if n.target}
    generate_world(job)
    register_targets(targets)
    scratch = Path(tempfile.mkdtemp(prefix="navstress-replay-"))
    fuller_task = replace(task, record_lidar=task.record_lidar or lidar,
                          record_navigator=task.record_navigator or navigator_view or live is not None)
    fuller = fuller_task != task
    try:
        new_trace = scratch / stored_trace.name
        if live is None:
            new = run_one(with_trace(fuller_task, str(new_trace)))
        else:
            from navstress.run.live import execute_live
            new = execute_live(with_trace(fuller_task, str(new_trace)), live)
        if not new_trace.is_file():
            raise StoreError(f"replay of run_id={run_id!r} wrote no trace ({new.outcome}: {new.reason})")
        a, b = _sha(stored_trace), _sha(new_trace)
        kept = None
        if keep is not None:
            kept = Path(keep)
            kept.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(new_trace, kept)
        diffs = tuple(f for f in COMPARED if not _same(getattr(stored, f), getattr(new, f)))
        same = not diffs if fuller else a == b
        return ReplayResult(run_id, same, stored_trace, a, b, stored, new, diffs, kept, fuller)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
