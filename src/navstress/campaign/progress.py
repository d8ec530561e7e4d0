"""Live progress of a campaign: a rich bar with ETA and outcome counts.

The ETA is rich's estimate from the runs finished *in this session* (a resumed campaign
starts from what is already recorded, and that part does not count toward the speed). With
adaptive repetition the total is an upper bound ("up to N"), lowered as streams stop early.
"""

from __future__ import annotations

from types import TracebackType

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TaskID, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from navstress._bar import Bar
from navstress._console import console as make_console
from navstress.campaign.store import OUTCOMES
from navstress.run.record import RunRecord

_SHORT = {"success": ("ok", "green"), "fail-collision": ("collision", "red"), "fail-error": ("error", "magenta"),
          "fail-timeout": ("timeout", "yellow"), "fail-other": ("other", "cyan")}


def format_counts(counts: dict[str, int], markup: bool = True) -> str:
    """'ok 3  collision 1  error 0  timeout 0  other 0' (with colours when ``markup``)."""
    parts = []
    for o in OUTCOMES:
        label, colour = _SHORT[o]
        parts.append(f"[{colour}]{label} {counts.get(o, 0)}[/]" if markup else f"{label} {counts.get(o, 0)}")
    return "  ".join(parts)


class CampaignProgress:
    """Use as ``on_start`` / ``on_record`` callbacks of :func:`run_campaign` inside a ``with``."""

    def __init__(self, console: Console | None = None, enabled: bool = True) -> None:
        self.console = console if console is not None else make_console(stderr=True)
        self.counts = {o: 0 for o in OUTCOMES}
        self._progress = Bar(TextColumn("[bold]campaign"), BarColumn(bar_width=24), MofNCompleteColumn(),
                                  TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                                  TextColumn("{task.fields[counts]}"), console=self.console,
                                  disable=not enabled, transient=False)
        self._task: TaskID | None = None

    def __enter__(self) -> "CampaignProgress":
        self._progress.__enter__()
        return self

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        self._progress.__exit__(t, e, tb)

    def on_start(self, done: int, planned: int, counts: dict[str, int]) -> None:
        self.counts = {o: counts.get(o, 0) for o in OUTCOMES}
        # the bar counts this session's runs so the ETA reflects the current speed
        self._task = self._progress.add_task("runs", total=planned - done, counts=format_counts(self.counts))
        self._done_before = done

    def on_planned(self, planned: int) -> None:
        """A new upper bound of the campaign's runs (adaptive repetition stopped some streams)."""
        if self._task is not None:
            self._progress.update(self._task, total=planned - self._done_before)

    def on_record(self, rec: RunRecord) -> None:
        self.counts[rec.outcome] = self.counts.get(rec.outcome, 0) + 1
        if self._task is not None:
            self._progress.update(self._task, advance=1, counts=format_counts(self.counts))
