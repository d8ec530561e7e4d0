"""Running a campaign: the driver, and the choice of executor.

:func:`run_campaign` validates the spec (every navigator, fault and ``sim:`` override, before
anything is written), joins or starts the executor's machines, opens (or resumes) the store and
hands the pending work to the scheduling core (:func:`navstress.campaign.scheduler.resume`),
which alone writes records (single writer). The executors are thin:
:class:`~navstress.campaign.local.LocalExecutor` (a process pool on this machine) and
:class:`~navstress.campaign.ray_executor.RayExecutor`; see docs/campaigns.md, "Executors".
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from navstress.campaign.local import LocalExecutor
from navstress.campaign.ray_executor import RayExecutor
from navstress.campaign.scheduler import MAX_ATTEMPTS, PlannedCallback, RecordCallback, StartCallback, resume
from navstress.campaign.spec import MAX_PLANNED_RUNS, CampaignSpec, load_campaign
from navstress.campaign.store import Store
from navstress.campaign.work import register_targets
from navstress.errors import NavigatorError, SpecError
from navstress.nav import faults as nav_faults
from navstress.nav import registry
from navstress.run.batch import check_buildable, default_wall_limit_s
from navstress.sim.config import SimConfig


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


#: Longest wait for a navigator built to validate its config (in a worker process) before the
#: campaign goes on without that check (its runs then say what the navigator does).
BUILD_LIMIT_S = 120.0


def check_runnable(spec: CampaignSpec, *, build_limit_s: float = BUILD_LIMIT_S) -> None:
    """Every navigator and fault of ``spec`` exists, every navigator accepts its config and the
    ``sim:`` overrides are a valid SimConfig (SpecError naming the field otherwise). Nothing is
    written and no run is started (navigator factories validate their config, see
    :func:`navstress.nav.registry.validate_config`; one without a ``validate_config`` hook is built
    to validate it, in a worker process: this process never runs a navigator's code; at most
    ``build_limit_s`` seconds, a campaign's per-run limit when it is shorter)."""
    targets = {n.name: n.target for n in spec.navigators if n.target}
    for i, nav in enumerate(spec.navigators):
        if nav.name in targets:
            try:
                registry.make_spec(nav.name, targets[nav.name], "campaign spec")
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
    SimConfig.from_mapping(dict(spec.sim))
    saved = registry.registered()
    try:
        register_targets(targets)
        built: list[tuple[str, dict[str, Any], str]] = []  # validated by building them: in a worker
        for i, nav in enumerate(spec.navigators):
            field = f"navigators[{i}].config"
            try:
                if registry.builds_to_validate(nav.name):
                    built.append((nav.name, dict(nav.config), field))
                else:
                    registry.validate_config(nav.name, dict(nav.config), field=field)
            except NavigatorError as err:  # a spec-given target that cannot be imported
                where = f"navigators[{i}].target" if nav.name in targets else f"navigators[{i}].name"
                raise SpecError(where, nav.target or nav.name, "a navigator that can be loaded",
                                str(err)) from None
        if built:  # a navigator that exits, crashes or hangs there is left to its runs to classify
            check_buildable(registry.validate_each, built, wall_limit_s=build_limit_s)
    finally:
        registry.set_registered(saved)


def run_campaign(spec_path: str | Path, directory: str | Path, *, workers: int | None = None,
                 executor: Literal["local", "ray"] = "local", ray_address: str | None = None,
                 wall_limit_s: float | None = None, on_record: RecordCallback | None = None,
                 on_start: StartCallback | None = None,
                 accept_large: bool = False, max_attempts: int = MAX_ATTEMPTS,
                 on_planned: PlannedCallback | None = None) -> CampaignResult:
    """Run (or resume) the campaign of ``spec_path`` into ``directory``.

    ``workers``: processes (local, default ``os.cpu_count()``) or concurrent Ray tasks (default:
    the cluster's CPUs). ``wall_limit_s``: per-run wall-clock limit (default
    ``timeout_s * 2 + 120``). ``on_start(done, planned, counts)`` and ``on_record(record)``
    feed progress displays; with adaptive repetition ``planned`` is an upper bound (each undecided
    stream counts its rule's max), lowered through ``on_planned(planned)`` as streams stop, and
    ``CampaignResult.planned`` is the final count. ``accept_large``: plan more than ``MAX_PLANNED_RUNS`` runs.
    Raises SpecError / StoreError before running anything when the spec, a navigator or sim
    config, or the directory is unusable; DiskFullError (nothing lost: resume later) when the
    disk fills. An interrupted campaign (KeyboardInterrupt, or the CLI's SIGTERM) leaves no
    partial file behind. Runs whose machinery failed ``max_attempts`` times stay pending
    (``CampaignResult.unfinished``)."""
    if workers is not None and workers < 1:
        raise SpecError("--workers", workers, "an integer >= 1")
    if executor not in ("local", "ray"):
        raise SpecError("--executor", executor, "local or ray")
    spec, text = load_campaign(spec_path, max_runs=None if accept_large else MAX_PLANNED_RUNS)
    limit = wall_limit_s if wall_limit_s is not None else default_wall_limit_s(spec.timeout_s)
    check_runnable(spec, build_limit_s=min(limit, BUILD_LIMIT_S))
    t0 = time.perf_counter()
    targets = {n.name: n.target for n in spec.navigators if n.target}
    with ExitStack() as stack:
        ex: LocalExecutor | RayExecutor
        if executor == "ray":  # joined (or started) before the store is made: a cluster error writes nothing
            ex = stack.enter_context(RayExecutor(workers, targets, address=ray_address))
        else:
            ex = LocalExecutor(workers if workers is not None else (os.cpu_count() or 1), targets)
        store = stack.enter_context(Store.create(directory, spec, text))
        s = resume(store, ex, wall_limit_s=limit, on_record=on_record, on_start=on_start, max_attempts=max_attempts,
                   on_planned=on_planned)
        result = CampaignResult(Path(directory), s.planned, s.already_done, s.recorded, store.outcome_counts(),
                                time.perf_counter() - t0, ex.workers, s.unfinished)
    return result
