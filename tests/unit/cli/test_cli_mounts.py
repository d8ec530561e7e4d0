"""The root CLI's mount table: every root command comes from its module's ``app`` and the table's
one-line help (shown by ``navstress --help`` without importing the module) is that command's own."""

from __future__ import annotations

import importlib

import pytest
import typer.main
from typer._click.utils import make_default_short_help

from navstress.cli import MOUNTS, app, mounted


@pytest.mark.parametrize("name", list(MOUNTS))
def test_mount_table_help_is_the_commands_own(name: str) -> None:
    cmd = mounted(name)
    assert make_default_short_help(MOUNTS[name][1], 1000) == cmd.get_short_help_str(1000)


@pytest.mark.parametrize("module", sorted({m for m, _h in MOUNTS.values()}))
def test_every_command_of_a_module_is_mounted(module: str) -> None:
    """One pattern: a command module's ``app`` holds root commands only, each in the table."""
    group = typer.main.get_group(importlib.import_module(module).app)
    assert group.commands, module
    for name in group.commands:
        assert MOUNTS.get(name, ("", ""))[0] == module, f"{module} defines {name!r}, not mounted from it"


def test_root_lists_the_mount_table_in_order() -> None:
    root = typer.main.get_command(app)
    assert list(root.commands) == list(MOUNTS)  # type: ignore[attr-defined]
