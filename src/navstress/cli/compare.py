"""``navstress compare``: paired A/B comparison of two navigators, faults or stack versions.

    navstress compare demo-out/campaign --a reference-v1 --b reference-v1:small-footprint
    navstress compare v1-campaign v2-campaign --a reference-v1
    navstress compare v1-campaign v2-campaign --a reference-v1 --b my-nav --json ab.json

Exit 0 whatever the comparison finds (``navstress gate`` is the pass/fail command); 2 on bad
input. The statistics live in :mod:`navstress.analysis.compare`.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from navstress._console import console, literal
from navstress._percent import percent, points, setting
from navstress._files import write_atomic
from navstress.analysis.compare import Comparison, PairedStats, compare, first_navigator, parse_arm
from navstress.analysis.stats import dumps
from navstress.cli._common import probe_writable
from navstress.errors import SpecError

app = typer.Typer(rich_markup_mode=None)


def _pts(lo: float, hi: float) -> str:
    return f"[{points(lo)}, {points(hi)}]"


def _row(c: PairedStats, holm: bool, ratio: float = 1.0) -> list[str]:
    d = c.duration_s
    dur = "-" if d.diff is None else f"{d.diff:+.1f}" + ("" if d.ci is None else f" [{d.ci[0]:+.1f}, {d.ci[1]:+.1f}]")
    return [c.label, str(c.pairs), percent(c.rate_a), percent(c.rate_b), points(c.diff), _pts(*c.ci),
            f"{c.a_only}/{c.b_only}", f"{c.p_value:.3g}", f"{c.p_adjusted:.3g}" if holm and c.p_adjusted is not None
            else "-", dur, f"{c.collided_a} -> {c.collided_b}",
            f"{c.width_ratio:.2f}" if holm else f"{ratio:.2f}"]


def _print(cmp: Comparison) -> None:
    con = console()
    typer.echo(literal(f"A = {cmp.a.label} ({cmp.dir_a}; robot {cmp.robot_a}), B = {cmp.b.label} ({cmp.dir_b}; "
                      f"robot {cmp.robot_b}): "
                      f"{cmp.overall.pairs} pairs of runs with the same map and run seeds"))
    typer.echo(literal(cmp.headline()))
    t = Table(title=f"B against A, paired runs (success rates; {setting(cmp.confidence)} intervals of B - A in "
              "percentage points)")
    for col in ("configuration", "pairs", "A", "B", "B-A", "interval", "only A/only B", "p McNemar", "p Holm",
                "duration B-A s", "runs w/ collision", "width paired/unpaired"):
        t.add_column(col)
    for c in cmp.configs:
        t.add_row(*_row(c, True))
    t.add_row(*_row(cmp.overall, False, cmp.width_ratio))
    con.print(t)
    typer.echo(literal(cmp.collision_line()))
    f = cmp.runs_factor
    if f is None:
        gain = "no run differs from another, so the gain cannot be measured"
    elif math.isinf(f):
        gain = ("A and B agree pair by pair: the paired variance of B - A is 0, where an unpaired design would "
                "keep the run-to-run scatter")
    else:
        gain = f"an unpaired design would need about {f:.1f}x the runs for the same variance of B - A"
    typer.echo(f"pairing (common random numbers): paired intervals are {cmp.width_ratio:.2f} of the unpaired width "
               f"(summed over the configurations); {gain}")
    for n in cmp.notes:
        typer.echo(literal(n))


def compare_cmd(
    directories: Annotated[list[Path], typer.Argument(
        metavar="DIR [DIR_B]", help="Campaign directory holding A and B; or two campaign directories made from "
        "the same spec and seed (A's runs from the first, B's from the second).")],
    a: Annotated[str | None, typer.Option("--a", metavar="NAV[:FAULT]", help=(
        "Side A: a navigator and optionally a fault (default with two directories: the first navigator, "
        "nominal)."))] = None,
    b: Annotated[str | None, typer.Option("--b", metavar="NAV[:FAULT]", help=(
        "Side B (default with two directories: the same as --a)."))] = None,
    confidence: Annotated[float, typer.Option("--confidence", help="Confidence of the intervals, in (0, 1).")] = 0.95,
    alpha: Annotated[float, typer.Option("--alpha", help="Significance level of the Holm-corrected tests.")] = 0.05,
    json_out: Annotated[Path | None, typer.Option("--json", metavar="FILE", help=(
        "Also write every figure as JSON to FILE ('-': only the JSON, on standard output)."))] = None,
) -> None:
    """Compare two navigators, faults or stack versions run by run on the same worlds and seeds."""
    if not 1 <= len(directories) <= 2:
        raise SpecError("DIR", " ".join(map(str, directories)), "one campaign directory, or two made from the "
                        "same spec and seed")
    if len(directories) == 1 and (a is None or b is None):
        raise SpecError("--a" if a is None else "--b", "(not given)", "NAV[:FAULT] for both --a and --b when one campaign "
                        "directory is given", "e.g. --a reference-v1 --b reference-v1:small-footprint")
    if json_out is not None and str(json_out) != "-" and json_out.is_dir():
        raise SpecError("--json", str(json_out), "a JSON file path, not a directory")
    arm_a = parse_arm(a, "--a") if a is not None else None
    arm_b = parse_arm(b, "--b") if b is not None else None
    if arm_a is None:
        arm_a = first_navigator(directories[0])
    if json_out is not None and str(json_out) != "-":
        probe_writable(json_out)
    cmp = compare(directories[0], arm_a, arm_b or arm_a, directories[1] if len(directories) == 2 else None,
                  confidence=confidence, alpha=alpha)
    if json_out is not None and str(json_out) == "-":
        sys.stdout.write(dumps(cmp.to_json()) + "\n")
        return
    _print(cmp)
    if json_out is not None:
        write_atomic(json_out, dumps(cmp.to_json()))
        typer.echo(literal(f"wrote {json_out}"))


app.command("compare")(compare_cmd)
