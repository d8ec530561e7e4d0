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
#: Every character that is not shown as itself on one line: controls (newline and tab too),
#: Unicode format characters (bidirectional overrides, zero widths), line and paragraph separators,
#: surrogates and the byte-order mark.
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u00ad\u061c\u180e\u200b-\u200f\u2028-\u202e\u2060-\u206f"
                          "\ud800-\udfff\ufeff\ufff9-\ufffb]")


def _escape(m: re.Match[str]) -> str:
    c = m.group()
    return f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}"


def literal(text: str) -> str:
    """``text`` with control characters (other than newline and tab) written as escapes."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


def one_line(text: str, limit: int = LOG_WIDTH) -> str:
    """Text someone else sent (a network client), safe to print on one line: every character that
    could move the cursor, restyle the terminal, break the line or hide text is escaped
    (``\\x1b``, ``\\n``, ``\\u202e``), and the result is at most ``limit`` characters (a longer one
    ends with how long it was).

        >>> one_line("a\\x1b[2J\\nb\\u202ec")
        'a\\\\x1b[2J\\\\x0ab\\\\u202ec'
        >>> one_line("x" * 500, 40)
        'xxxxxxxxxxxxxxxxxx... (500 characters)'
    """
    out = _UNPRINTABLE.sub(_escape, text)
    if len(out) <= limit:
        return out
    tail = f"... ({len(text):,} characters)"
    return out[: max(0, limit - len(tail))] + tail


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

