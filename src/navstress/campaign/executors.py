"""The campaign engine: one runner for everything that runs a campaign's runs.

:func:`open_runner` takes a validated :class:`CampaignSpec` (read from a file by ``campaign run``
and ``demo``, made in code by a search), the name of an executor and the directory of its store:
it checks that the spec can run (every navigator, fault and ``sim:`` override, before anything is
written), makes the executor from the registry (:mod:`navstress.campaign.registry`: ``local``,
``ray``, a plug-in's), joining or starting its machines, and opens (or resumes) the store. The
:class:`CampaignRunner` it gives runs sessions: each hands the store's pending runs to the
scheduling core (:func:`navstress.campaign.scheduler.resume`), which alone writes records (single
writer); a search grows the campaign between sessions (:meth:`CampaignRunner.extend`) and keeps the
executor's workers from one session to the next (``keep``). :func:`run_campaign` is one session of
the campaign of a spec file. See docs/campaigns.md, "Executors".
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navstress.campaign.registry import DEFAULT_EXECUTOR, ExecutorOptions, check_executor, make_executor
from navstress.campaign.scheduler import (MAX_ATTEMPTS, Executor, PlannedCallback, RecordCallback, Session,
                                          StartCallback, resume)
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
            _, note = registry.resolve(nav.name)
        except NavigatorError as err:
            raise SpecError(f"navigators[{i}].name", nav.name, "a registered navigator", str(err)) from None
        if note:  # said once here; the runs' own resolutions are quiet (run.mission.execute)
            warnings.warn(note, registry.NavigatorNote, stacklevel=2)
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


class CampaignRunner:
    """The store of a campaign and the executor that runs its runs, for one command: each
    :meth:`run` is a session (the pending runs of the store, recorded by the scheduling core);
    :meth:`extend` grows the campaign between sessions. Made by :func:`open_runner`."""

    def __init__(self, store: Store, executor: Executor, *, wall_limit_s: float,
                 max_attempts: int = MAX_ATTEMPTS, opened: float | None = None) -> None:
        self.store = store
        self.executor = executor
        self.wall_limit_s = wall_limit_s
        self.max_attempts = max_attempts
        #: when the command's work began (time.perf_counter: after the spec's checks, before the
        #: executor's start): a result's wall_s counts from here
        self.opened = opened if opened is not None else time.perf_counter()

    @property
    def workers(self) -> int:
        return self.executor.workers

    def extend(self, spec: CampaignSpec) -> int:
        """Grow the campaign to ``spec``, made in code (:meth:`Store.extend`); its new runs run at
        the next :meth:`run`. Returns the runs added."""
        return self.store.extend(spec)

    def run(self, *, on_record: RecordCallback | None = None, on_start: StartCallback | None = None,
            on_planned: PlannedCallback | None = None) -> Session:
        """Run the store's pending runs (:func:`~navstress.campaign.scheduler.resume`)."""
        return resume(self.store, self.executor, wall_limit_s=self.wall_limit_s, on_record=on_record,
                      on_start=on_start, max_attempts=self.max_attempts, on_planned=on_planned)


def check_workers(workers: int | None) -> None:
    """``--workers``: None (the executor's default) or an integer >= 1 (SpecError naming it)."""
    if workers is not None and workers < 1:
        raise SpecError("--workers", workers, "an integer >= 1")


@contextmanager
def open_runner(spec: CampaignSpec, directory: str | Path, *, text: str | None = None,
                executor: str = DEFAULT_EXECUTOR, workers: int | None = None, address: str | None = None,
                wall_limit_s: float | None = None, keep: bool = False,
                max_attempts: int = MAX_ATTEMPTS) -> Iterator[CampaignRunner]:
    """The runner of the validated ``spec`` in ``directory``: the spec checked runnable
    (:func:`check_runnable`; nothing written yet), the executor made (``executor``: a registered
    name; ``workers``, ``address``: its :class:`~navstress.campaign.registry.ExecutorOptions`;
    ``keep``: its workers kept between sessions), joined or started before the store is made (a
    cluster error writes nothing), then the store created or reopened to resume (``text``: the
    text ``spec`` was read from, its ``spec.yaml``; None for a spec made in code). On the way out
    the store is closed and the executor ended, whatever ended the block.

    ``wall_limit_s``: per-run wall-clock limit (default ``timeout_s * 2 + 120``). SpecError /
    StoreError before anything runs when the spec, a navigator, the executor or the directory is
    unusable."""
    check_workers(workers)
    check_executor(executor)
    limit = wall_limit_s if wall_limit_s is not None else default_wall_limit_s(spec.timeout_s)
    check_runnable(spec, build_limit_s=min(limit, BUILD_LIMIT_S))
    targets = {n.name: n.target for n in spec.navigators if n.target}
    with ExitStack() as stack:
        opened = time.perf_counter()
        ex = make_executor(executor, ExecutorOptions(workers, targets, address, keep))
        stack.callback(ex.close)
        store = stack.enter_context(Store.create(directory, spec, text))
        yield CampaignRunner(store, ex, wall_limit_s=limit, max_attempts=max_attempts, opened=opened)


def run_campaign(spec_path: str | Path, directory: str | Path, *, workers: int | None = None,
                 executor: str = DEFAULT_EXECUTOR, ray_address: str | None = None,
                 wall_limit_s: float | None = None, on_record: RecordCallback | None = None,
                 on_start: StartCallback | None = None,
                 accept_large: bool = False, max_attempts: int = MAX_ATTEMPTS,
                 on_planned: PlannedCallback | None = None) -> CampaignResult:
    """Run (or resume) the campaign of ``spec_path`` into ``directory``: one session of
    :func:`open_runner`'s runner (``campaign run`` and ``demo``).

    ``workers``: processes (local, default ``os.cpu_count()``) or concurrent Ray tasks (default:
    the cluster's CPUs). ``executor``: a name of :mod:`navstress.campaign.registry`.
    ``wall_limit_s``: per-run wall-clock limit (default ``timeout_s * 2 + 120``).
    ``on_start(done, planned, counts)`` and ``on_record(record)``
    feed progress displays; with adaptive repetition ``planned`` is an upper bound (each undecided
    stream counts its rule's max), lowered through ``on_planned(planned)`` as streams stop, and
    ``CampaignResult.planned`` is the final count. ``accept_large``: plan more than ``MAX_PLANNED_RUNS`` runs.
    Raises SpecError / StoreError before running anything when the spec, a navigator or sim
    config, the executor or the directory is unusable; DiskFullError (nothing lost: resume later)
    when the disk fills. An interrupted campaign (KeyboardInterrupt, or the CLI's SIGTERM) leaves no
    partial file behind. Runs whose machinery failed ``max_attempts`` times stay pending
    (``CampaignResult.unfinished``)."""
    check_workers(workers)
    check_executor(executor)
    spec, text = load_campaign(spec_path, max_runs=None if accept_large else MAX_PLANNED_RUNS)
    with open_runner(spec, directory, text=text, executor=executor, workers=workers, address=ray_address,
                     wall_limit_s=wall_limit_s, max_attempts=max_attempts) as runner:
        s = runner.run(on_record=on_record, on_start=on_start, on_planned=on_planned)
        result = CampaignResult(Path(directory), s.planned, s.already_done, s.recorded, runner.store.outcome_counts(),
                                time.perf_counter() - runner.opened, runner.workers, s.unfinished)
    return result
