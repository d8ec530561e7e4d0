"""The progress bar of long commands (``campaign run``, ``search``, ``demo``, ``run``, ``report``).

A module of its own: rich's progress display is imported by the commands that show one, not by
every command (``navstress --help`` included) through :mod:`navstress._console`.
"""

from __future__ import annotations

from types import TracebackType
from typing import Any

from rich.progress import Progress, TaskID

__all__ = ["Bar"]


class Bar(Progress):
    """A rich progress display that shows nothing before its first task and leaves nothing behind
    when its ``with`` block ends in an exception: the error's one line is then all a command writes
    on standard error (rich itself would end with a blank line, in a file or a pipe, and leave the
    bar on a terminal). Ended normally, it keeps its last frame, as rich does."""

    def __enter__(self) -> "Bar":
        return self  # started by the first task

    def add_task(self, *args: Any, **kwargs: Any) -> TaskID:
        if not self.disable and not self.live.is_started:
            self.start()
        return super().add_task(*args, **kwargs)

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        if self.disable or not self.live.is_started:
            return
        if e is not None:
            self.live.transient = True  # cleared from a terminal, never printed to a file or a pipe
            self.live.stop()
            return
        self.stop()
