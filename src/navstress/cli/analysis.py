"""``navstress analyze DIR`` and ``navstress report DIR -o report.html [--baseline DIR2]`` (a search
directory's report has a Search section, ``navstress.search.report``).

User errors raise :class:`~navstress.errors.NavstressError` subclasses (the root CLI prints
them on one line and exits 2).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer
from rich.progress import BarColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from navstress import _files
from navstress._bar import Bar
from navstress._console import console, literal
from navstress._percent import percent, setting
from navstress.analysis.analyze import Analysis, analyze
from navstress.analysis.difficulty import DifficultyParams
from navstress.analysis.report import build_report
from navstress.analysis.stats import dumps, params_text, reason_line
from navstress.cli._common import MAX_TIMEOUT_S, probe_writable
from navstress.errors import SpecError
from navstress.search.report import load_search_dir, search_sections

app = typer.Typer(rich_markup_mode=None)


def _zone(indifference: float) -> str:
    """" +/- 25%" for a verdict rule with an indifference zone, "" without."""
    return f" +/- {setting(indifference)}" if indifference else ""


#: Most k-means clusters (``--k``).
MAX_K = 1000
#: The analysis's own names of the options ``analyze`` and ``report`` take.
_OPTIONS = {"threshold": "--threshold", "k": "--k", "weights": "--weights", "dt": "--dt", "navigator": "--navigator"}


def _params(threshold: float, k: int, weights: str, dt: float) -> DifficultyParams:
    """The analysis options both commands take, checked (``--dt`` first)."""
    if not (dt > 0 and math.isfinite(dt) and dt <= MAX_TIMEOUT_S):
        raise SpecError("--dt", dt, f"a time step in seconds in (0, {MAX_TIMEOUT_S:g}]")
    if not 0.0 <= threshold <= 1.0:
        raise SpecError("--threshold", threshold, "a success rate in [0, 1], e.g. 0.25")
    if not 2 <= k <= MAX_K:
        raise SpecError("--k", k, f"an integer in [2, {MAX_K}] (clusters)")
    try:
        w = tuple(float(v) for v in weights.split(","))
    except ValueError:
        raise SpecError("--weights", weights, "three comma-separated numbers, e.g. 0.5,0.25,0.25") from None
    if len(w) != 3:
        raise SpecError("--weights", weights, "three comma-separated numbers, e.g. 0.5,0.25,0.25")
    with _as_options():
        return DifficultyParams(threshold=threshold, k=k, weights=(w[0], w[1], w[2]))


@contextmanager
def _as_options() -> Iterator[None]:
    """An analysis error about one of the options names the option (``dt`` -> ``--dt``): a time step
    too small for the runs' length, a navigator the campaign did not run."""
    try:
        yield
    except SpecError as err:
        flag = _OPTIONS.get(err.field)
        if flag is None:
            raise
        raise SpecError(flag, err.value, err.expected, err.fix) from None


Threshold = Annotated[float, typer.Option("--threshold", help="Success rate below which a configuration is very difficult.")]
K = Annotated[int, typer.Option("--k", help="k-means clusters for the other configurations.")]
Weights = Annotated[str, typer.Option("--weights", help="Weights of success rate, duration, tortuousness.")]
Navigator = Annotated[str | None, typer.Option("--navigator", help="Navigator whose nominal runs define difficulty (default: the first).")]
Dt = Annotated[float, typer.Option("--dt", help="Time step of the indeterminism curves [s].")]


def analyze_cmd(
    directory: Annotated[Path, typer.Argument(help="Campaign directory.")],
    json_out: Annotated[Path | None, typer.Option("--json", metavar="FILE", help=(
        "Also write every number as JSON to FILE ('-': only the JSON, on standard output)."))] = None,
    threshold: Threshold = 0.25, k: K = 2, weights: Weights = "0.5,0.25,0.25", navigator: Navigator = None,
    dt: Dt = 1.0,
) -> None:
    """Print the campaign's difficulty levels, indeterminism and fault power."""
    params = _params(threshold, k, weights, dt)
    to_stdout = json_out is not None and str(json_out) == "-"
    if json_out is not None and not to_stdout and json_out.is_dir():
        raise SpecError("--json", str(json_out), "a JSON file path, not a directory")
    with _as_options():
        a = analyze(directory, params=params, navigator=navigator, dt=dt)
    if to_stdout:
        typer.echo(dumps(a.to_json()))
        return
    con = console()
    refused = (f"; {a.refused_runs} runs on {a.refused_maps} map{'s' if a.refused_maps != 1 else ''} the world "
               "generator refused, left out of every statistic") if a.refused_runs else ""
    con.print(literal(f"campaign {a.name}: {a.done}/{a.planned} runs recorded; "
                      + ", ".join(f"{n} {o}" for o, n in a.outcome_counts.items()) + refused))
    robots = ", ".join(f"{n} ({d})" for n, d in a.robots)
    con.print(literal(f"robot {robots}" if len(a.robots) <= 1 else
                      f"robots {robots}: each result below is one navigator@robot's"))
    for kind, path, sha in a.sources:
        con.print(literal(f"world source: {kind} {path} (sha256 {sha[:12]})"))
    if not a.done:
        con.print("no run recorded yet: nothing to analyse")
    t = Table(title=f"Difficulty (nominal runs of {a.navigator})")
    for c in ("class", "parameters", "runs", "success [95% CI]", "med. duration s", "med. tortuousness",
              "infeasible maps", "refused maps", "level"):
        t.add_column(c)
    for s in a.nominal:
        r = s.success_rate
        t.add_row(s.experiment, params_text(s.params), f"{s.runs}/{s.planned}",
                  "-" if r is None else f"{percent(r)} [{percent(s.ci_low)}, {percent(s.ci_high)}]",
                  "-" if s.median_duration_s is None else f"{s.median_duration_s:.1f}",
                  "-" if s.median_tortuousness is None else f"{s.median_tortuousness:.4f}",
                  "{}/{}".format(*a.infeasible.get(s.key, (0, 0))), f"{len(s.refused.maps)}/{a.maps_of(s.key)}",
                  a.level(s.experiment, s.config_key))
    con.print(t)
    for (e, key), rf in a.refused.items():
        n = len(rf.maps)
        con.print(literal(f"refused maps in {e} {key}: {n} of {a.maps_of((e, key))} (runs left out: {rf.runs}); "
                          f"first: {reason_line(rf.reason)}"))
    for o in a.overlaps:
        con.print(f"fuzzy threshold in {o.experiment}: {o.a} and {o.b} overlap over {o.lo:g}..{o.hi:g}")
    verdict_table = _verdict_table(a)
    if verdict_table is not None:
        con.print(verdict_table)
    if a.indeterminism:
        ti = Table(title=f"Indeterminism of {a.navigator} (nominal): max distance between repeated runs "
                   "(mean over maps)")
        for c in ("class", "configuration", "runs", "maps", "peak m", "time-mean m", "final m"):
            ti.add_column(c)
        for (e, key), cs in a.indeterminism.items():
            for g, cv in cs.items():
                ti.add_row(e, key, g, str(cv.n_maps), f"{cv.peak_m:.2f}", f"{cv.mean_m:.2f}", f"{cv.final_m:.2f}")
        con.print(ti)
    if a.power_levels:
        tp = Table(title=f"Fault-revealing power per level: faults of {a.navigator}")
        for c in ("level", "fault", "runs", "with collision", "new failures", "nominal runs", "nominal with collision"):
            tp.add_column(c)
        for p in a.power_levels:
            tp.add_row(p.level, p.fault, str(p.runs), str(p.collisions), str(p.new_failures), str(p.nominal_runs),
                       str(p.nominal_collisions))
        con.print(tp)
    best = [cr for cr in a.correlations if cr.rho_level is not None][:3]
    for cr in best:
        con.print(f"descriptor {cr.descriptor}: Spearman rho with level ({a.navigator}) {cr.rho_level:+.2f} "
                  f"over {cr.n} configurations")
    if json_out is not None:
        text = dumps(a.to_json())
        _files.write_atomic(json_out, text)  # written whole, then renamed into place
        con.print(f"wrote {json_out}")


def _verdict_table(a: Analysis) -> Table | None:
    """Per configuration (of the navigators shown): runs, pass probability with its exact
    interval, verdict, and how many of its worlds fail, are flaky or are undecided."""
    v = a.verdicts
    cfgs = [c for c in v.configurations if a.shows(c.navigator)]
    if not cfgs and not any(a.shows(c.navigator) for c in v.refused):
        return None
    own = any(v.rule_for(c.experiment) != v.rule for c in cfgs)
    title = (f"Verdicts per configuration: pass probability [exact {setting(v.rule.confidence)} interval]; "
             f"verdict: >= {setting(v.rule.threshold)}{_zone(v.rule.indifference)} with {setting(v.rule.confidence)} "
             "confidence")
    if own:
        title = "Verdicts per configuration: pass probability [exact interval]; verdict by each experiment's rule"
    t = Table(title=title)
    gone = [c for c in v.refused if a.shows(c.navigator)]
    refused = any(c.refused_worlds for c in cfgs) or bool(gone)
    cols = ["class", "configuration", "navigator", "fault", "runs", "pass probability", "verdict",
            *(["rule"] if own else []), "worlds", "failing", "flaky", "undecided", *(["refused"] if refused else [])]
    for col in cols:
        t.add_column(col, justify="right" if col in ("runs", "worlds", "failing", "flaky", "undecided", "refused")
                     else "left")
    for c in cfgs:
        tally = dict(c.world_verdicts)
        rule = [f">= {setting(c.threshold)}{_zone(c.indifference)} at {setting(c.confidence)}"] if own else []
        t.add_row(c.experiment, c.config_key, c.navigator, c.fault, str(c.runs),
                  f"{percent(c.pass_probability)} [{percent(c.ci[0])}, {percent(c.ci[1])}]", c.verdict, *rule,
                  str(c.worlds), str(tally.get("fails", 0)), str(tally.get("flaky", 0)),
                  str(tally.get("undecided", 0)), *([str(c.refused_worlds)] if refused else []))
    for g in gone:  # every recorded map refused: no verdict
        t.add_row(g.experiment, g.config_key, g.navigator, g.fault, "0", "-", "no generated maps",
                  *(["-"] if own else []), "0", "0", "0", "0", str(g.worlds))
    return t


def report_cmd(
    directory: Annotated[Path, typer.Argument(help="Campaign directory (finished, running or empty).")],
    out: Annotated[Path, typer.Option("--output", "-o", help="HTML file to write.")] = Path("report.html"),
    threshold: Threshold = 0.25, k: K = 2, weights: Weights = "0.5,0.25,0.25", navigator: Navigator = None,
    dt: Dt = 1.0,
    baseline: Annotated[Path | None, typer.Option(
        "--baseline", help="Another search directory (e.g. the same spec with algorithm random) whose worlds "
                           "found against runs spent are drawn beside this search's.")] = None,
) -> None:
    """Write one self-contained HTML report (figures embedded) of a campaign or a search."""
    params = _params(threshold, k, weights, dt)
    if out.exists() and out.is_dir():
        raise SpecError("--output", str(out), "an HTML file path, not a directory")
    if baseline is not None:  # both must be searches: checked before anything is drawn or written
        load_search_dir(baseline, "--baseline")
        load_search_dir(directory, "directory")
    probe_writable(out)  # before the analysis and the figures, not after
    sections = search_sections(directory, baseline=baseline)
    # how far it is, on standard error (a paper-sized campaign takes half a minute); gone when done
    err = console(stderr=True)
    with Bar(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=err, transient=True, disable=not err.is_terminal) as prog:
        bar = prog.add_task("report: reading the campaign", total=2)

        def step(what: str, done: int, total: int) -> None:
            prog.update(bar, description=f"report: {what}", completed=done, total=total)

        with _as_options():
            path = build_report(directory, out, params=params, navigator=navigator, dt=dt, sections=sections,
                                progress=step)
    typer.echo(literal(f"report: {path.resolve()}"))


app.command("analyze")(analyze_cmd)
app.command("report")(report_cmd)
