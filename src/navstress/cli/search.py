"""``navstress search``: search for the worlds where a stack fails (docs/search.md).

    navstress search init --objective failure -o failure.yaml

The group's subcommands are named (``init``); a first argument that names none of them is the
spec of the group's default command ``run`` (``navstress search SPEC -o DIR`` is ``navstress
search run SPEC -o DIR``) once that command is defined. User errors raise
:class:`~navstress.errors.SpecError`; the root CLI prints them on one line and exits 2.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer
from typer import _click as click
from typer.core import TyperGroup

from navstress._console import literal
from navstress.errors import SpecError
from navstress.search.presets import template_yaml
from navstress.search.spec import OBJECTIVES

#: The subcommand a first argument that names no subcommand goes to (``navstress search SPEC``).
DEFAULT_COMMAND = "run"


class DefaultGroup(TyperGroup):
    """A group whose first argument, when it names no subcommand (and is no option), is the first
    argument of :data:`DEFAULT_COMMAND`."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and not args[0].startswith("-") and args[0] not in self.commands and DEFAULT_COMMAND in self.commands:
            args = [DEFAULT_COMMAND, *args]
        result: list[str] = super().parse_args(ctx, args)
        return result


SEARCH_HELP = "Search for the worlds where a stack fails (a ready spec: `navstress search init`)."

app = typer.Typer(rich_markup_mode=None)
search_app = typer.Typer(cls=DefaultGroup, no_args_is_help=True, rich_markup_mode=None,
                         help=SEARCH_HELP)
app.add_typer(search_app, name="search")


@search_app.command("init")
def init(
    out: Annotated[Path, typer.Option("--output", "-o", help="Spec file to write (YAML).")],
    objective: Annotated[str, typer.Option("--objective", help=f"One of {', '.join(OBJECTIVES)}.")] = "failure",
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Write a ready, commented search spec for an objective."""
    text = template_yaml(objective)
    if out.exists() and not force:
        raise SpecError("--output", str(out), "a path that does not exist yet", "pass --force to overwrite it")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, out)
    typer.echo(literal(f"wrote {out} (objective {objective})"))
