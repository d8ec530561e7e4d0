"""The ``navstress`` command line: the root app, its one-line error handling, and the mount
table of its commands.

    navstress world generate --trees 6 --seed 1 -o worlds/trees6
    navstress world show worlds/trees6
    navstress world export worlds/trees6 --format sdf -o trees6.sdf
    navstress demo -o demo-out

One pattern for every command group: a module ``navstress.cli.<group>`` defines ``app``, a
Typer whose commands are root commands (a group such as ``world``, or single commands such as
``run``); :data:`MOUNTS` names, per root command, its module and its one-line help. The root
imports a module when one of its commands runs (or its ``--help`` is asked), so that
``navstress --help`` imports no simulator, plotting or analysis code. The command modules only
parse flags and print; the work is done by the domain packages.

Every user error (a :class:`~navstress.errors.NavstressError` or a bad flag) prints ONE line on
stderr, ``error: <field>=<value> is invalid: expected ...; fix``, exits with code 2 and writes
nothing. So does an ``OSError`` met while a command works (a read-only or full disk, a
permission, a folder where a file is expected): the line names the path the user gave and what
to do (:func:`os_error_line`). Text a user or a navigator wrote is printed literally.
"""

from __future__ import annotations

import errno
import importlib
import os
import re
import sys
from collections.abc import Iterator, MutableMapping, Sequence
from pathlib import Path
from typing import Annotated, Any

import typer
import typer.main
from typer import _click as click
from typer._click.utils import make_default_short_help
from typer.core import TyperGroup

from navstress import __version__
from navstress._console import literal
from navstress.errors import NavstressError

EXIT_USAGE = 2

#: Root command -> (module defining it in its ``app``, its one-line help), in ``--help`` order.
#: A test checks each help line against the command's own help.
MOUNTS: dict[str, tuple[str, str]] = {
    "demo": ("navstress.cli.campaign", "Run the demo campaign (worlds, missions, faults) and write its HTML report."),
    "run": ("navstress.cli.run", "Run the navigator on a world's mission, classify each run, write traces and a picture."),
    "replay": ("navstress.cli.campaign", "Re-run one run from its recorded seeds; exit 0 if the new trace is "
               "byte-identical, 1 if not."),
    "analyze": ("navstress.cli.analysis", "Print the campaign's difficulty levels, indeterminism and fault power."),
    "report": ("navstress.cli.analysis", "Write one self-contained HTML report (figures embedded) of a campaign or a search."),
    "compare": ("navstress.cli.compare", "Compare two navigators, faults or stack versions run by run on the same worlds and seeds."),
    "world": ("navstress.cli.world", "Generate, inspect and export worlds (terrain, obstacles, mission)."),
    "trace": ("navstress.cli.trace", "Export a run's trace to other tools (a ROS 2 bag for RViz)."),
    "nav": ("navstress.cli.nav", "Navigators under test: list them, list faults, check conformance."),
    "robot": ("navstress.cli.robot", "Robots: list the profiles, show a robot (figures and a drawing), check its simulation."),
    "sensor": ("navstress.cli.sensor", "Sensors: list the kinds a robot may carry and their profiles."),
    "campaign": ("navstress.cli.campaign", "Plan, run, follow and export campaigns of many runs."),
    "search": ("navstress.cli.search", "Search for the worlds where a stack fails (a ready spec: `navstress search init`)."),
    "gate": ("navstress.cli.gate", "Exit 0 if every gated configuration meets the success bar with confidence, 1 if not (CI)."),
}


def mounted(name: str) -> click.Command:
    """The root command ``name``, from its module's ``app`` (imported now)."""
    module = importlib.import_module(MOUNTS[name][0])
    group = typer.main.get_group(module.app)
    return group.commands[name]


class _Mounted(MutableMapping[str, click.Command]):
    """The root's commands: every name of :data:`MOUNTS`, each loaded on first use."""

    def __init__(self) -> None:
        self._loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self._loaded:
            if name not in MOUNTS:
                raise KeyError(name)
            self._loaded[name] = mounted(name)
        return self._loaded[name]

    def __setitem__(self, name: str, cmd: click.Command) -> None:
        self._loaded[name] = cmd

    def __delitem__(self, name: str) -> None:
        del self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        yield from MOUNTS
        yield from (n for n in self._loaded if n not in MOUNTS)

    def __len__(self) -> int:
        return len(MOUNTS) + sum(1 for n in self._loaded if n not in MOUNTS)


class _Root(TyperGroup):
    """Root group: commands mounted from :data:`MOUNTS` on use; user errors become one line on
    stderr and exit code 2."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self.commands = _Mounted()

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list from :data:`MOUNTS` (no command module is imported for it)."""
        limit = formatter.width - 6 - max(len(n) for n in MOUNTS)
        with formatter.section("Commands"):
            formatter.write_dl([(n, make_default_short_help(h, limit)) for n, (_m, h) in MOUNTS.items()])

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             windows_expand_args: bool = True, **extra: Any) -> Any:
        _notes_on_one_line()
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var,
                              standalone_mode=False, windows_expand_args=windows_expand_args, **extra)
        except click.exceptions.NoArgsIsHelpError as e:
            click.echo(e.ctx.get_help())
            sys.exit(0)
        except click.exceptions.UsageError as e:
            _fail(_usage_line(e))
        except click.exceptions.ClickException as e:
            _fail(e.format_message())
        except NavstressError as e:
            _fail(str(e))
        except OSError as e:
            _fail(os_error_line(e))
        except MemoryError:
            _fail("memory=exhausted is invalid: expected a task that fits in this machine's memory; "
                  "use a smaller map or a larger --cell, or fewer workers")
        except KeyboardInterrupt:
            click.echo("aborted", err=True)
            sys.exit(130)
        sys.exit(rv if isinstance(rv, int) else 0)


def _usage_line(e: Any) -> str:
    msg = " ".join(str(e.format_message()).split()).rstrip(".")
    msg = msg[:1].lower() + msg[1:]
    param = getattr(e, "param", None)
    opts = list(getattr(param, "opts", None) or [])
    if opts and not any(o in msg for o in opts):
        msg = f"{'/'.join(opts)}: {msg}"
    return f"{msg}; see --help"


_OS_FIXES = {
    errno.EACCES: "permission denied; choose a path you may write or change its permissions",
    errno.EPERM: "operation not permitted; choose a path you may write or change its permissions",
    errno.EROFS: "read-only file system; choose a path on a writable file system",
    errno.EISDIR: "it is a directory; name a file (inside it, for instance)",
    errno.ENOTDIR: "a part of the path is a file, not a folder; choose another path",
    errno.EEXIST: "something already exists there; choose another path or remove it",
    errno.ENOENT: "no such file or folder; check the path (create its folder first)",
    errno.ENOSPC: "no space left on the device; free some space and run again",
    errno.EDQUOT: "disk quota exceeded; free some space and run again",
    errno.ENAMETOOLONG: "the name is too long; choose a shorter path",
    errno.ELOOP: "too many symbolic links; check the path",
}


_TEMP_NAME = re.compile(r"^\.(?P<name>.+?)(?:\.tmp|\.partial|\.[A-Za-z0-9_]{8})$")


def _user_path(path: Any) -> Any:
    """The path the user named, for the temporary names files are written under
    (``.NAME.tmp``, ``.NAME.partial``, ``.NAME.XXXXXXXX``) before they are renamed into place."""
    if path is None:
        return None
    p = Path(os.fsdecode(path))
    m = _TEMP_NAME.match(p.name)
    return str(p.with_name(m.group("name"))) if m else str(p)


def os_error_line(e: OSError) -> str:
    """One line for an OSError raised while a command works: the path, what failed, what to do.

        >>> os_error_line(PermissionError(13, "Permission denied", "/x/out.sdf"))
        "path='/x/out.sdf' is invalid: expected a path navstress can write and read (Permission denied, EACCES); permission denied; choose a path you may write or change its permissions"
    """
    raw = e.filename if e.filename is not None else e.filename2
    code = e.errno
    what = " ".join(str(e.strerror or type(e).__name__).split())
    if code is None:  # e.g. pyarrow's: "Failed to open local file '/x'. Detail: [errno 13] Permission denied"
        m = re.search(r"\[errno (\d+)\]\s*([^\n]*)", str(e))
        code = int(m.group(1)) if m else None
        what = m.group(2).strip() if m else " ".join(str(e).split())[:200]
    if raw is None:  # a library's OSError with the path in its message only
        q = re.search(r"'(/[^']+)'", str(e))
        raw = q.group(1) if q else None
        what = os.strerror(code) if code else what
    path = _user_path(raw)
    name = errno.errorcode.get(code or 0, "")
    fix = _OS_FIXES.get(code or 0, "check the path, its permissions and the free space")
    if path is not None:
        field = f"path={str(path)!r}"
    elif code in (errno.ENOSPC, errno.EDQUOT):
        field = "disk='full'"
    else:
        field = "file system"
    return (f"{field} is invalid: expected a path navstress can write and read ({what}{', ' + name if name else ''}); "
            f"{fix}")


def _fail(line: str) -> None:
    line = literal(" ".join(line.split()))
    click.echo(f"error: {line}", err=True)
    sys.exit(EXIT_USAGE)


def _version(value: bool) -> None:
    if value:
        click.echo(f"navstress {__version__}")
        raise typer.Exit()


app = typer.Typer(cls=_Root, add_completion=False, no_args_is_help=True,
                  rich_markup_mode=None, pretty_exceptions_enable=False,
                  help="Stress-test robot navigation software in generated virtual worlds.")

@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                help="Print the navstress version and exit.")] = False) -> None:
    """Stress-test robot navigation software in generated virtual worlds."""



def _notes_on_one_line() -> None:
    """The registry's notes to the user (:class:`navstress.nav.registry.NavigatorNote`, e.g. which
    version an unversioned navigator name chose) on one line, ``note: ...``, without the source
    line Python's warnings print; every other warning as Python prints it."""
    import warnings

    shown = warnings.showwarning
    if getattr(shown, "navstress_notes", False):
        return

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: Any = None, line: str | None = None) -> None:
        if category.__name__ == "NavigatorNote":
            click.echo(f"note: {message}", err=True)
            return
        shown(message, category, filename, lineno, file, line)

    show.navstress_notes = True  # type: ignore[attr-defined]
    warnings.showwarning = show


def main() -> None:
    """Console-script entry point (``navstress``)."""
    app()
