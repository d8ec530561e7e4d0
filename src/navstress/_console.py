"""The rich console every command prints with: the terminal's width on a terminal, and a
wide fixed width in logs and pipes (rich's 80-column default would truncate table cells).

Strings are printed literally: console markup (``[bold]``), emoji codes (``:smile:``) and
highlighting are off, and control characters (ANSI escapes, carriage returns) are shown as
``\\x1b``-style escapes, so a navigator's message, a path or a name reads exactly as written
and cannot restyle the terminal. Styled output is built from ``rich.text.Text`` objects.

    >>> import io
    >>> con = console(file=io.StringIO())
    >>> con.print("[debug] planning :smile: \\x1b[2J")
    >>> con.file.getvalue()
    '[debug] planning :smile: \\\\x1b[2J\\n'
"""

from __future__ import annotations

import re
from typing import IO, Any

from rich.console import Console
from rich.text import Text

LOG_WIDTH = 160
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def literal(text: str) -> str:
    """``text`` with control characters (other than newline and tab) written as escapes."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


class LiteralConsole(Console):
    """A rich Console whose plain strings are never interpreted (see the module doc)."""

    def render_str(self, text: str, **kwargs: Any) -> Text:
        kwargs["markup"] = False
        kwargs["emoji"] = False
        kwargs["highlight"] = False
        return super().render_str(literal(text), **kwargs)


def console(*, stderr: bool = False, file: IO[str] | None = None) -> Console:
    """The console commands print with (markup, emoji and highlighting off)."""
    opts: dict[str, Any] = {"stderr": stderr, "highlight": False, "markup": False, "emoji": False}
    if file is not None:
        opts["file"] = file
    con = LiteralConsole(**opts)
    if not con.is_terminal:
        con = LiteralConsole(**opts, width=LOG_WIDTH, soft_wrap=False)
    return con
