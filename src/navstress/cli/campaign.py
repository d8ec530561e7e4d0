"""``navstress campaign init|run|status|export``, ``navstress replay`` and ``navstress demo``.

    navstress campaign init --preset demo -o demo.yaml
    navstress campaign run demo.yaml -o demo-campaign --workers 2
    navstress campaign status demo-campaign
    navstress campaign export demo-campaign --format parquet
    navstress replay demo-campaign trees/tree=4/m0/r1/reference-v1/nominal

User errors raise :class:`~navstress.errors.SpecError` / :class:`~navstress.errors.StoreError`;
the root CLI prints them on one line and exits 2.
"""

from __future__ import annotations

import shlex
import signal
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from navstress import _files, _json
from navstress._console import console, literal
from navstress._percent import percent
from navstress.campaign.executors import run_campaign
from navstress.campaign.presets import ALL_PRESETS, preset_yaml
from navstress.campaign.progress import CampaignProgress, format_counts
from navstress.campaign.registry import DEFAULT_EXECUTOR, executor_help
from navstress.campaign.replay import replay as do_replay
from navstress.campaign.spec import MAX_WORKERS
from navstress.campaign.store import OUTCOMES, Store
from navstress.cli._common import (MAX_WALL_S, LidarOpt, LiveHostOpt, LiveOpt, LivePortOpt, LiveWaitOpt,
                                   NavigatorViewOpt, SpeedOpt, Stopped, bounded_int, check_executor_flags,
                                   live_banner, live_settings, number, resumable)
from navstress.errors import SpecError, WorldFileError

app = typer.Typer(rich_markup_mode=None)
campaign_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                           help="Plan, run, follow and export campaigns of many runs.")
app.add_typer(campaign_app, name="campaign")


@campaign_app.command("init")
def init(
    out: Annotated[Path, typer.Option("--output", "-o", help="Spec file to write (YAML).")],
    preset: Annotated[str, typer.Option("--preset", help="demo (85 runs: trees, terrain with adaptive repetition, movers; under a minute on 2 cores), paper (the paper's five classes, 2,375 runs), dynamic (intercepting pedestrians: their count and how close they aim, 90 runs) or barn (the BARN benchmark's protocol on the worlds of --barn DIR: its 50 test worlds x 10 runs, or all 300 with --all; the report adds BARN's score).")] = "demo",
    barn: Annotated[Path | None, typer.Option("--barn", metavar="DIR", help="The BARN worlds folder of --preset barn, laid out as in the BARN repository (world_N.world and path_files/path_N.npy).")] = None,
    all_worlds: Annotated[bool, typer.Option("--all", help="With --preset barn: all 300 BARN worlds (3,000 runs), not the 50 of its test set.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Write a ready campaign spec from a preset."""
    if preset not in ALL_PRESETS:
        raise SpecError("--preset", preset, f"one of {list(ALL_PRESETS)}")
    if preset != "barn" and (barn is not None or all_worlds):
        raise SpecError("--barn" if barn is not None else "--all", str(barn) if barn is not None else True,
                        "no --barn or --all with --preset " + preset, "use --preset barn, or leave them out")
    if out.exists() and not force:
        raise SpecError("--output", str(out), "a path that does not exist yet", "pass --force to overwrite it")
    if out.is_dir():
        raise SpecError("--output", str(out), "a file path (this is a folder)")
    text = preset_yaml(preset, folder=barn, all_worlds=all_worlds)  # checks the BARN folder before anything is written
    _files.write_atomic(out, text)
    typer.echo(literal(f"wrote {out} (preset {preset})"))


@campaign_app.command("run")
def run(
    spec: Annotated[Path, typer.Argument(help="Campaign spec (YAML).")],
    out: Annotated[Path, typer.Option("--output", "-o", help="Campaign directory (created, or resumed).")],
    workers: Annotated[int | None, typer.Option("--workers", "-j", help="Parallel runs, in [1, 1024] (default: all cores).")] = None,
    executor: Annotated[str, typer.Option("--executor", help=executor_help())] = DEFAULT_EXECUTOR,
    ray_address: Annotated[str | None, typer.Option("--ray-address", help="Ray cluster to join: HOST:PORT or auto (default: start a local one on 127.0.0.1). Joined within 60 s, or refused in one line with Ray's reason.")] = None,
    wall_limit: Annotated[float | None, typer.Option("--wall-limit", help="Per-run wall-clock limit in seconds (default timeout_s*2+120).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    yes: Annotated[bool, typer.Option("--yes", "-y", help="Accept a plan of more than 100,000 runs.")] = False,
) -> None:
    """Run a campaign (resumes where it stopped if DIR already holds it).

    Exit 0 when every planned run is recorded, whatever the outcomes (a failing run is a result;
    `navstress gate` turns results into pass or fail), 1 when some runs stayed pending after repeated
    failures of the machinery (run again to retry them), 2 for a bad spec or directory or a
    full disk, 130 on Ctrl-C and 143 on SIGTERM (run the same command again to resume)."""
    check_executor_flags(executor, workers, wall_limit)
    resume = f"navstress campaign run {_quote(spec)} -o {_quote(out)}" + (" --yes" if yes else "")

    def on_term(signum: int, frame: object) -> None:
        raise Stopped(signum)

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        with resumable(resume, out), CampaignProgress(enabled=not quiet) as bar:
            res = run_campaign(spec, out, workers=workers, executor=executor,
                               ray_address=ray_address, wall_limit_s=wall_limit, on_start=bar.on_start,
                               on_record=bar.on_record, accept_large=yes, on_planned=bar.on_planned)
    except (KeyboardInterrupt, Stopped) as err:
        signum = err.signum if isinstance(err, Stopped) else signal.SIGINT
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second SIGTERM must not cut the message
        typer.echo(literal(f"stopped by {signal.Signals(signum).name}; nothing recorded is lost; resume with: {resume}"),
                   err=True)
        raise typer.Exit(128 + int(signum)) from None
    finally:
        signal.signal(signal.SIGTERM, old)
    typer.echo(literal(f"{out}: {res.already_done + res.recorded}/{res.planned} runs recorded "
               f"({res.recorded} this session, {res.wall_s:.0f} s, {res.workers} workers); "
               + format_counts(res.counts, markup=False)))
    if res.unfinished:
        first, why = next(iter(res.unfinished.items()))
        typer.echo(literal(f"{len(res.unfinished)} run(s) not recorded: navstress itself failed on each attempt "
                   f"(e.g. {first}: {why}); fix the cause and resume with: {resume}"), err=True)
        raise typer.Exit(1)


def _quote(p: Path) -> str:
    return shlex.quote(str(p))


@campaign_app.command("status")
def status(
    directory: Annotated[Path, typer.Argument(help="Campaign directory.")],
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print the status as one JSON object on stdout (counts by outcome; planned, recorded and pending "
        "runs; per experiment and per navigator and fault) instead of tables."))] = False,
) -> None:
    """Show progress and outcome counts, per experiment and per navigator and fault."""
    if as_json:
        with Store.open(directory) as store:
            typer.echo(_json.dumps(status_json(store), indent=2))
        return
    with Store.open(directory) as store:
        done, planned = store.progress()
        table = Table(title=f"campaign {store.spec.name}: {done}/{planned} runs ({percent(done / max(planned, 1))})")
        table.add_column("experiment")
        table.add_column("done", justify="right")
        for o in OUTCOMES:
            table.add_column(o, justify="right")
        for name, d, p, counts in store.per_experiment():
            table.add_row(name, f"{d}/{p}", *(str(counts[o]) for o in OUTCOMES))
        total = store.outcome_counts()
        table.add_row("all", f"{done}/{planned}", *(str(total[o]) for o in OUTCOMES))
        console().print(table)
        groups = store.per_navigator()
        if len(groups) > 1:
            by_nav = Table(title="per navigator and fault")
            by_nav.add_column("navigator")
            by_nav.add_column("fault")
            by_nav.add_column("done", justify="right")
            for o in OUTCOMES:
                by_nav.add_column(o, justify="right")
            for nav, fault, d, p, counts in groups:
                by_nav.add_row(nav, fault, f"{d}/{p}", *(str(counts[o]) for o in OUTCOMES))
            console().print(by_nav)
        retried = store.attempts()
        if retried:
            typer.echo(f"failed attempts kept: {len(retried)} (of {len({a[0] for a in retried})} runs; "
                       "navstress's own failures, retried)")
        mean = store.mean_wall_s()
        if mean is not None and done < planned:
            typer.echo(f"remaining: {planned - done} runs, about {(planned - done) * mean / 3600:.1f} h of "
                       f"single-worker time at {mean:.1f} s/run")


def status_json(store: Store) -> dict[str, Any]:
    """What ``campaign status --json`` prints: every count of the status tables, by name."""
    def part(recorded: int, planned: int, counts: dict[str, int]) -> dict[str, Any]:
        return {"planned": planned, "recorded": recorded, "pending": max(planned - recorded, 0),
                "counts": {o: int(counts.get(o, 0)) for o in OUTCOMES}}

    done, planned = store.progress()
    retried = store.attempts()
    return {"campaign": store.spec.name, "directory": str(store.root), **part(done, planned, store.outcome_counts()),
            "experiments": [{"experiment": name, **part(d, p, counts)} for name, d, p, counts in store.per_experiment()],
            "navigators": [{"navigator": nav, "fault": fault, **part(d, p, counts)}
                           for nav, fault, d, p, counts in store.per_navigator()],
            "failed_attempts": {"attempts": len(retried), "runs": len({a[0] for a in retried})},
            "mean_wall_s": store.mean_wall_s()}


@campaign_app.command("export")
def export(
    directory: Annotated[Path, typer.Argument(help="Campaign directory.")],
    fmt: Annotated[str, typer.Option("--format", "-f", help="csv or parquet.")] = "csv",
    out: Annotated[Path | None, typer.Option("--output", "-o", help="File to write (default DIR/TABLE.FORMAT).")] = None,
    table: Annotated[str, typer.Option("--table", help=(
        "runs (one row per run), verdicts (one row per world: pass probability, exact interval, verdict) or "
        "configurations (the same per configuration, its worlds pooled); the same key columns in each."))] = "runs",
) -> None:
    """Write the runs table, the worlds' verdicts or the configurations' verdicts, as CSV or Parquet."""
    if fmt not in ("csv", "parquet"):
        raise SpecError("--format", fmt, "csv or parquet")
    if table not in ("runs", "verdicts", "configurations"):
        raise SpecError("--table", table, "runs, verdicts or configurations")
    if out is not None and out.is_dir():
        raise SpecError("--output", str(out), f"a {fmt} file path, not a directory")
    if table != "runs":
        from navstress.analysis.verdicts import export_verdicts  # local: scipy

        path, n = export_verdicts(directory, table, fmt, out if out is not None else Path(directory) / f"{table}.{fmt}")
        typer.echo(literal(f"wrote {path} ({n} {'worlds' if table == 'verdicts' else table})"))
        return
    with Store.open(directory) as store:
        path = store.export(fmt, out)  # type: ignore[arg-type]
        n = store.progress()[0]
    typer.echo(literal(f"wrote {path} ({n} runs)"))


def replay(
    directory: Annotated[Path, typer.Argument(help="Campaign directory.")],
    run_id: Annotated[str, typer.Argument(help="The run to replay (a run_id of the runs table).")],
    *,
    keep: Annotated[Path | None, typer.Option("--keep", help="Keep the new trace at this path.")] = None,
    lidar: LidarOpt = False,
    navigator_view: NavigatorViewOpt = False,
    live: LiveOpt = False,
    live_host: LiveHostOpt = "127.0.0.1",
    live_port: LivePortOpt = "8765",
    live_wait: LiveWaitOpt = "30",
    speed: SpeedOpt = "1",
    wall_limit: Annotated[str | None, typer.Option(metavar="S", help=(
        "Wall-clock limit of the replay in real seconds, > 0 (a navigator that hangs is killed and the "
        "replay ends, exit 1). Default: timeout * 2 + 120 (with --live: timeout / speed * 2 + 120 + "
        "--live-wait).")) ] = None,
) -> None:
    """Re-run one run from its recorded seeds; exit 0 if the new trace is byte-identical, 1 if not.

    The run is replayed in a worker process with a wall-clock limit, as campaigns run it: a
    navigator whose process dies (os._exit, a signal) or that does not end within --wall-limit
    ends the replay with one line saying which, exit 1 (the replay is not the stored run).
    With --lidar, --navigator-view or --live the replay records more than the campaign did (to
    open the run in Foxglove with its lidar and its navigator's arcs, --keep FILE, or to watch it
    live): its trace differs by construction, so the run's record is compared instead (exit 0 when
    outcome, reason, duration, distances and collisions are the stored ones). Exit 2 on bad input,
    130 on Ctrl-C, 143 on SIGTERM (nothing is left behind)."""
    if (lidar or navigator_view) and keep is None and not live:
        raise SpecError("--keep", None, "a file for the fuller trace that --lidar/--navigator-view record "
                        "(or --live to watch the run)")
    if keep is not None and keep.is_dir():
        raise SpecError("--keep", str(keep), "a file path (this is a directory)")
    wall_v = None
    if wall_limit is not None:
        wall_v = number("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
        if not 0 < wall_v <= MAX_WALL_S:
            raise SpecError("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    settings = live_settings(live_host, live_port, live_wait, speed) if live else None
    if settings is not None:
        typer.echo(live_banner(settings))  # on standard output, with the result: standard error is for the one error line

    def on_term(signum: int, frame: object) -> None:
        raise Stopped(signum)

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        r = do_replay(directory, run_id, keep=keep, lidar=lidar, navigator_view=navigator_view, live=settings,
                      wall_limit_s=wall_v)
    except Stopped as err:  # the worker and the scratch folder are gone already
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        typer.echo(f"replay stopped by {signal.Signals(err.signum).name}; nothing was written", err=True)
        raise typer.Exit(128 + int(err.signum)) from None
    finally:
        signal.signal(signal.SIGTERM, old)
    if r.failure is not None:
        typer.echo(literal(f"DIFFERENT: {run_id}: stored {r.stored.outcome} ({r.stored.reason}); the replay did not "
                           f"finish: {r.failure}; no trace to compare"))
        raise typer.Exit(1)
    typer.echo(literal(f"{run_id}: stored {r.stored.outcome} ({r.stored.reason}); replayed {r.new.outcome} ({r.new.reason})"))
    if r.kept_trace is not None:
        typer.echo(literal(f"kept the new trace at {r.kept_trace}"))
    if r.fuller:
        if r.identical:
            typer.echo("same run: its record matches the stored one (the new trace records more than the stored "
                       "one, so its bytes are not compared)")
            return
        typer.echo(f"DIFFERENT: record fields that differ: {', '.join(r.record_differences)}")
        raise typer.Exit(1)
    if r.identical:
        typer.echo(literal(f"identical: the new trace has the same bytes as {r.stored_trace} (sha256 {r.new_sha256[:16]})"))
        return
    typer.echo(f"DIFFERENT: stored sha256 {r.stored_sha256[:16]}, replayed {r.new_sha256[:16]}; "
               f"record fields that differ: {', '.join(r.record_differences) or 'none'}")
    raise typer.Exit(1)


app.command("replay")(replay)


# ---- demo ---------------------------------------------------------------------------------


@app.command("demo")
def demo(
    output: Annotated[Path, typer.Option("--output", "-o", metavar="DIR", help=(
        "Folder for the demo (DIR/demo.yaml, the campaign in DIR/campaign, DIR/report.html). "
        "Run again to resume an interrupted demo."))] = Path("demo-out"),
    workers: Annotated[str | None, typer.Option("--workers", "-j", metavar="N", help=(
        "Parallel runs, an integer in [1, 1024] (default: all cores)."))] = None,
) -> None:
    """Run the demo campaign (worlds, missions, faults) and write its HTML report."""
    n_workers = None
    if workers is not None:
        n_workers = bounded_int("--workers", workers, 1, MAX_WORKERS)
    if output.exists() and not output.is_dir():
        raise WorldFileError(f"--output={str(output)!r} is invalid: expected a folder; choose another path")
    if output.is_dir():
        ours = {"demo.yaml", "campaign", "report.html"}
        others = [p.name for p in output.iterdir() if p.name not in ours and not p.name.startswith(".")]
        if others:
            raise WorldFileError(f"--output={str(output)!r} is invalid: expected a new folder or a previous demo "
                                 f"(it holds {others[0]!r}); choose another path or remove it")
    output.mkdir(parents=True, exist_ok=True)
    _files.refuse_links(output)  # demo.yaml, campaign/, report.html: never through a planted link
    spec_path = output / "demo.yaml"
    text = preset_yaml("demo")
    if not spec_path.exists() or spec_path.read_text(encoding="utf-8") != text:
        _files.write_atomic(spec_path, text)
    con = console()
    con.print(f"demo campaign: {spec_path} -> {output / 'campaign'}")
    again = f"navstress demo -o {_quote(output)}" + (f" --workers {n_workers}" if n_workers is not None else "")
    with resumable(again, output / "campaign"), CampaignProgress() as bar:
        res = run_campaign(spec_path, output / "campaign", workers=n_workers, on_start=bar.on_start,
                           on_record=bar.on_record, on_planned=bar.on_planned)
    con.print(f"{res.already_done + res.recorded}/{res.planned} runs recorded in {res.wall_s:.0f} s with "
              f"{res.workers} workers: " + format_counts(res.counts, markup=False))
    con.print("writing the report ...")
    from navstress.analysis.report import build_report  # local: 2.8 s of imports, for the demo only

    report = build_report(output / "campaign", output / "report.html")
    con.print(f"report: {report.resolve()}")
