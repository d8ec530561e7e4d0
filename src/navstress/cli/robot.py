"""``navstress robot list|show|check`` (the ``robot`` group)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from navstress import _json
from navstress._console import console, literal
from navstress.cli._common import check_file_out
from navstress.robot import PROFILES, resolve_robot
from navstress.robot.describe import describe, rows, write_picture

app = typer.Typer(rich_markup_mode=None)
robot_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                        help="Robots: list the profiles, show a robot (figures and a drawing), check its simulation.")
app.add_typer(robot_app, name="robot")

ROBOT_HELP = "A robot profile (navstress robot list) or a robot file (.yaml, .yml, .json; docs/robots.md)."


@robot_app.command("list")
def robot_list() -> None:
    """List the robot profiles: drive, size, mass, top speed."""
    t = Table(show_header=True, header_style="bold")
    for c, j in (("profile", "left"), ("drive", "left"), ("size (m)", "right"), ("mass (kg)", "right"),
                 ("top speed (m/s)", "right"), ("digest", "left")):
        t.add_column(c, justify=j)  # type: ignore[arg-type]
    for name, r in PROFILES.items():
        size = f"{r.length_m:.3g} x {r.width_m:.3g} x {r.ground_clearance_m + r.body_height_m:.3g}"
        t.add_row(name, r.drive, size, f"{r.mass_kg:g}", f"{r.max_speed_mps:g}", r.digest)
    console().print(t)


@robot_app.command("show")
def robot_show(
    ref: Annotated[str, typer.Argument(metavar="NAME|FILE", help=ROBOT_HELP)],
    output: Annotated[Path | None, typer.Option("--output", "-o", metavar="FILE", help=(
        "Write the robot's top view (footprint, wheels, casters, sensor mounts) to FILE: .svg (or no "
        "suffix) or .png."))] = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print the description, every derived figure and the digest as one JSON object on stdout."))] = False,
) -> None:
    """Print a robot's description, its derived figures and digest; draw its top view with -o."""
    robot = resolve_robot(ref)
    if output is not None:
        check_file_out(output)
        write_picture(robot, output)
    if as_json:
        typer.echo(_json.pretty(describe(robot)))
        return
    t = Table(title=f"robot {literal(robot.name)}", show_header=True, header_style="bold", title_justify="left")
    t.add_column("figure")
    t.add_column("value")
    for k, v in rows(robot):
        t.add_row(k, literal(v))
    con = console()
    con.print(t)
    if output is not None:
        con.print(f"wrote {literal(str(output))}")


def _check_json(check: Any) -> dict[str, Any]:
    return {"robot": check.robot, "digest": check.digest, "timestep_s": check.timestep_s,
            "passed": check.passed, "problems": check.problems(),
            "legs": [{f: getattr(leg, f) for f in ("name", "commanded_v", "commanded_w", "measured_v", "measured_w",
                                                     "v_error", "w_error", "odom_heading_ratio", "odom_position_error_m",
                                                     "max_pitch_deg", "pitch_swing_deg", "passed", "why")}
                     for leg in check.legs]}


def _f(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


@robot_app.command("check")
def robot_check(
    ref: Annotated[str, typer.Argument(metavar="NAME|FILE", help=ROBOT_HELP)],
    quick: Annotated[bool, typer.Option("--quick", help="Shorter legs (a smoke test, not a validation).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the legs' figures as one JSON object on stdout.")] = False,
) -> None:
    """Drive the robot through the validation course on flat ground and print each leg's tracking and
    odometry errors; exit 1 if a leg fails."""
    robot = resolve_robot(ref)
    # local: the simulator (MuJoCo, numba kernels) only for this command, not for `robot list/show`
    from navstress.sim.validation import check_robot  # type: ignore[import-not-found, unused-ignore]

    check = check_robot(robot, quick=quick)
    if as_json:
        typer.echo(_json.pretty(_check_json(check)))
    else:
        t = Table(title=f"robot {literal(check.robot)} ({check.digest}), time step {check.timestep_s * 1000:g} ms",
                  show_header=True, header_style="bold", title_justify="left")
        for c in ("leg", "v cmd/meas (m/s)", "w cmd/meas (rad/s)", "v err", "w err", "odom heading",
                  "odom pos err (m)", "pitch max/swing (deg)", "result"):
            t.add_column(c)
        for leg in check.legs:
            t.add_row(literal(leg.name), f"{leg.commanded_v:.3g} / {leg.measured_v:.3g}",
                      f"{leg.commanded_w:.3g} / {leg.measured_w:.3g}", f"{leg.v_error:.3g}", f"{leg.w_error:.3g}",
                      _f(leg.odom_heading_ratio, ".3f"), f"{leg.odom_position_error_m:.3g}",
                      f"{leg.max_pitch_deg:.2f} / {leg.pitch_swing_deg:.2f}",
                      "PASS" if leg.passed else f"FAIL: {literal(leg.why)}")
        con = console()
        con.print(t)
        con.print("PASS" if check.passed else "FAIL: " + literal("; ".join(check.problems())))
    if not check.passed:
        raise typer.Exit(1)
