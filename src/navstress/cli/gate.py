"""``navstress gate DIR --min-success P``: the CI verdict on a campaign (exit 0, 1 or 2).

    navstress gate demo-out/campaign --min-success 0.8 --junit gate.xml

Exit 0 when every gated configuration meets the bar with confidence, 1 when one does not (one
line per failing configuration with its evidence, then a summary line), 2 on bad input. The
verdict is computed by :mod:`navstress.analysis.gate`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstress import _json
from navstress._console import literal
from navstress.analysis.gate import GateRule, gate, write_junit
from navstress.cli._common import integer, number, probe_writable
from navstress.errors import SpecError

app = typer.Typer(rich_markup_mode=None)

#: Most collision runs --max-collisions takes (a bigger bar checks nothing).
MAX_COLLISIONS = 10**9


@app.command("gate")
def gate_cmd(
    directory: Annotated[Path, typer.Argument(metavar="DIR", help="Campaign directory.")],
    min_success: Annotated[str, typer.Option("--min-success", metavar="P", help=(
        "Success rate every gated configuration must meet, in [0, 1]: its one-sided exact (Clopper-Pearson) "
        "lower confidence bound must be >= P."))],
    confidence: Annotated[str, typer.Option("--confidence", metavar="C", help=(
        "Confidence of that lower bound, strictly between 0 and 1. Default 0.95."))] = "0.95",
    max_collisions: Annotated[str | None, typer.Option("--max-collisions", metavar="N", help=(
        "Also fail a configuration with more than N Fail-Collision runs (N >= 0)."))] = None,
    navigator: Annotated[list[str] | None, typer.Option("--navigator", metavar="NAME", help=(
        "Gate only this navigator (repeat for several). Default: every navigator of the campaign."))] = None,
    fault: Annotated[list[str] | None, typer.Option("--fault", metavar="NAME", help=(
        "Gate the runs with this fault ('nominal' for none; repeat for several). Default: nominal only."))] = None,
    junit: Annotated[Path | None, typer.Option("--junit", metavar="FILE", help=(
        "Also write JUnit XML: one test case per world x navigator x fault."))] = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print the verdict as one JSON object on stdout (every gated configuration with its counts, bound and "
        "worlds) instead of the lines; the exit code is the same."))] = False,
) -> None:
    """Exit 0 if every gated configuration meets the success bar with confidence, 1 if not (CI)."""
    p = number("--min-success", min_success, "a success rate in [0, 1]")
    if not 0.0 <= p <= 1.0:
        raise SpecError("--min-success", min_success, "a success rate in [0, 1]", "e.g. 0.8")
    c = number("--confidence", confidence, "a probability strictly between 0 and 1")
    if not 0.0 < c < 1.0:
        raise SpecError("--confidence", confidence, "a probability strictly between 0 and 1", "e.g. 0.95")
    n_col = None
    if max_collisions is not None:
        n_col = integer("--max-collisions", max_collisions, f"an integer in [0, {MAX_COLLISIONS}]")
        if not 0 <= n_col <= MAX_COLLISIONS:
            raise SpecError("--max-collisions", max_collisions, f"an integer in [0, {MAX_COLLISIONS}]")
    if junit is not None:
        if junit.is_dir():
            raise SpecError("--junit", str(junit), "an XML file path, not a directory")
        probe_writable(junit)
    result = gate(directory, GateRule(p, c, n_col), navigators=tuple(navigator) if navigator else None,
                  faults=tuple(fault) if fault else None)
    if junit is not None:
        write_junit(result, junit)
    if as_json:
        typer.echo(_json.dumps({**result.to_json(), "summary": result.summary(),
                               "junit": None if junit is None else str(junit)}, indent=2))
    else:
        for cfg in result.failing:
            typer.echo(literal(cfg.line(result.rule)))
        typer.echo(literal(result.summary()))
        if junit is not None:
            typer.echo(literal(f"wrote {junit}"))
    if not result.passed:
        raise typer.Exit(1)
