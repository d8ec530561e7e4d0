"""Live progress of a search: a rich bar over the run budget, with the generation, the best
fitness so far and the worlds found (what the objective looks for, seen in a candidate's runs)."""

from __future__ import annotations

from types import TracebackType

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TaskID, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from navstress._bar import Bar
from navstress._console import console as make_console
from navstress.run.record import RunRecord
from navstress.search.driver import GenerationReport


class SearchProgress:
    """Use as the ``on_start`` / ``on_record`` / ``on_generation`` callbacks of
    :func:`~navstress.search.driver.run_search` inside a ``with``. The bar counts the generations'
    runs against the budget; the confirmation's runs are shown after it, as a second line."""

    def __init__(self, console: Console | None = None, enabled: bool = True) -> None:
        self.console = console if console is not None else make_console(stderr=True)
        self._progress = Bar(TextColumn("[bold]{task.description}"), BarColumn(bar_width=24),
                                  MofNCompleteColumn(), TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                                  TextColumn("{task.fields[info]}"), console=self.console, disable=not enabled,
                                  transient=False)
        self._task: TaskID | None = None
        self._confirm: TaskID | None = None
        self._done = 0
        self._budget = 0

    def __enter__(self) -> "SearchProgress":
        self._progress.__enter__()
        return self

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        self._progress.__exit__(t, e, tb)

    def on_start(self, done: int, budget: int) -> None:
        self._budget = budget
        self._task = self._progress.add_task("search", total=budget, completed=min(done, budget), info="")

    def on_record(self, rec: RunRecord) -> None:
        if rec.experiment == "confirm":
            if self._confirm is None:
                self._confirm = self._progress.add_task("confirm", total=None, info="elites, fresh run seeds")
            self._progress.update(self._confirm, advance=1)
        elif self._task is not None:
            self._progress.update(self._task, advance=1)

    def on_generation(self, g: GenerationReport) -> None:
        if self._task is None:
            return
        if g.generation < 0:
            if self._confirm is not None:
                self._progress.update(self._confirm, total=self._progress.tasks[self._confirm].completed,
                                      info=f"{g.found} of {g.evaluated} elites confirmed")
            return
        self._progress.update(self._task, completed=g.runs, description=f"search g{g.generation + 1}",
                              info=f"{g.evaluated} worlds, {g.found} found, best {g.best:.2f}")
