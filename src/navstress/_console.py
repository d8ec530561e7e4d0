"""The rich console every command prints with: the terminal's width on a terminal, and a
wide fixed width in logs and pipes (rich's 80-column default would truncate table cells)."""

from __future__ import annotations

from rich.console import Console

LOG_WIDTH = 160


def console(*, stderr: bool = False) -> Console:
    con = Console(stderr=stderr, highlight=False)
    if not con.is_terminal:
        con = Console(stderr=stderr, highlight=False, width=LOG_WIDTH, soft_wrap=False)
    return con
