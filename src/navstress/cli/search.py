"""``navstress search``: search for the worlds where a stack fails (docs/search.md).

    navstress search init --objective failure -o failure.yaml

The group's subcommands are named (``init``); a first argument that names none of them is the
spec of the group's default command ``run`` (``navstress search SPEC -o DIR`` is ``navstress
search run SPEC -o DIR``). User errors raise
:class:`~navstress.errors.SpecError`; the root CLI prints them on one line and exits 2.
"""

from __future__ import annotations

import shlex
import signal
from pathlib import Path
from typing import Annotated

import typer
from typer import _click as click
from typer.core import TyperGroup

from navstress import _files
from navstress._console import literal
from navstress.campaign.registry import DEFAULT_EXECUTOR, executor_help
from navstress.errors import SpecError
from navstress.cli._common import MAX_WORKERS, Stopped, check_executor_flags, resumable
from navstress.search.driver import FOUND_WHAT, run_search
from navstress.search.presets import template_yaml
from navstress.search.progress import SearchProgress
from navstress.search.spec import MAX_BUDGET_RUNS, OBJECTIVES

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
    _files.write_atomic(out, text)
    typer.echo(literal(f"wrote {out} (objective {objective})"))


@search_app.command("run")
def run(
    spec: Annotated[Path, typer.Argument(help="Search spec (YAML; `navstress search init` writes one).")],
    out: Annotated[Path, typer.Option("--output", "-o", help="Search directory (created, or resumed).")],
    budget: Annotated[int | None, typer.Option("--budget", help="Run budget, replacing the spec's budget.runs.")] = None,
    workers: Annotated[int | None, typer.Option("--workers", "-j", help=f"Parallel runs, in [1, {MAX_WORKERS}] (default: all cores).")] = None,
    executor: Annotated[str, typer.Option("--executor", help=executor_help())] = DEFAULT_EXECUTOR,
    ray_address: Annotated[str | None, typer.Option("--ray-address", help="Ray cluster to join: HOST:PORT or auto (default: start a local one on 127.0.0.1). Joined within 60 s, or refused in one line with Ray's reason.")] = None,
    wall_limit: Annotated[float | None, typer.Option("--wall-limit", help="Per-run wall-clock limit in seconds (default timeout_s*2+120).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Run a search (resumes where it stopped if DIR already holds it).

    Generation after generation, the algorithm proposes worlds, each is judged on repeated runs,
    and at the end the elites are re-run with fresh run seeds; DIR gets search.json and suite/
    (the confirmed worlds, a campaign spec that `navstress campaign run` and `gate` run again).
    Exit 0 when the search ended, 1 when some runs stayed pending after repeated failures of the
    machinery (run again to retry them), 2 for a bad spec or directory, 130 on Ctrl-C and 143 on
    SIGTERM (run the same command again to resume: nothing recorded is lost or run twice)."""
    check_executor_flags(executor, workers, wall_limit)
    if budget is not None and (budget < 1 or budget > MAX_BUDGET_RUNS):
        raise SpecError("--budget", budget, f"a number of runs in [1, {MAX_BUDGET_RUNS}]")
    again = f"navstress search {shlex.quote(str(spec))} -o {shlex.quote(str(out))}" + (
        f" --budget {budget}" if budget is not None else "")

    def on_term(signum: int, frame: object) -> None:
        raise Stopped(signum)

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        with resumable(again, out), SearchProgress(enabled=not quiet) as bar:
            res = run_search(spec, out, budget=budget, workers=workers, executor=executor,
                             ray_address=ray_address, wall_limit_s=wall_limit, on_start=bar.on_start,
                             on_record=bar.on_record, on_generation=bar.on_generation)
    except (KeyboardInterrupt, Stopped) as err:
        signum = err.signum if isinstance(err, Stopped) else signal.SIGINT
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        typer.echo(literal(f"stopped by {signal.Signals(signum).name}; nothing recorded is lost; resume with: {again}"),
                   err=True)
        raise typer.Exit(128 + int(signum)) from None
    finally:
        signal.signal(signal.SIGTERM, old)
    if res.unfinished:
        first, why = next(iter(res.unfinished.items()))
        typer.echo(literal(f"{len(res.unfinished)} run(s) not recorded: navstress itself failed on each attempt "
                           f"(e.g. {first}: {why}); fix the cause and resume with: {again}"), err=True)
        raise typer.Exit(1)
    if res.budget_unused is not None:
        given = f"--budget {budget}" if budget is not None else f"budget.runs={res.budget_unused}"
        typer.echo(literal(f"note: this search had already ended: {given} changes nothing (its generations stopped at "
                           f"{res.runs} runs, under a budget of {res.spec.budget.runs}); to search with another "
                           "budget, run it into a new -o"))
    elif res.ended_before and res.recorded == 0:
        typer.echo(literal("this search had already ended: nothing was run"))
    what = FOUND_WHAT[res.spec.objective.name]
    found = len(res.found_keys)
    typer.echo(literal(
        f"{out}: {res.generations} generations, {len(res.evaluated)} candidates, {res.runs}/{res.spec.budget.runs} "
        f"runs (stopped at {res.stopped or 'the end'}), {res.confirm_runs} confirmation runs; {found} {what} seen, "
        f"{len(res.confirmed)} of {len(res.elites)} elites confirmed with fresh run seeds"))
    if res.suite is not None:
        typer.echo(literal(f"suite: {res.suite} (re-run it: navstress campaign run {shlex.quote(str(res.suite))} "
                           f"-o DIR; then navstress gate DIR)"))
    else:
        typer.echo(literal(f"no world confirmed: no suite written ({out / 'suite' / 'suite.json'} says why per elite)"))
