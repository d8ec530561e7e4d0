"""``navstress sensor list`` (the ``sensor`` group): the sensor kinds a robot may carry and their
profiles, with the figures each profile sets (docs/sensors.md has their sources)."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.table import Table

from navstress import _json
from navstress._console import console, literal
from navstress.robot.describe import sensor_summary
from navstress.sensors import kind, user_kinds

app = typer.Typer(rich_markup_mode=None)
sensor_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                         help="Sensors: list the kinds a robot may carry and their profiles.")
app.add_typer(sensor_app, name="sensor")


@sensor_app.command("list")
def sensor_list(
    kind_names: Annotated[list[str] | None, typer.Argument(metavar="[KIND]...", help=(
        "Only these kinds (lidar3d, lidar2d, depth); all when none is given."))] = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print every kind, its parameters with their defaults, and every profile's full parameters as one "
        "JSON object on stdout."))] = False,
) -> None:
    """List the sensor kinds and their profiles (the figures a `profile:` sets; docs/sensors.md)."""
    ks = user_kinds()
    if kind_names:
        ks = {n: kind(n, where="KIND") for n in kind_names}
    if as_json:
        out = {name: {"summary": k.summary, "default_profile": k.default_profile,
                      "parameters": {f: i.description or "" for f, i in k.params.model_fields.items()},
                      "profiles": {p: k.params.model_validate(v).model_dump(mode="json")
                                   for p, v in k.profiles.items()}}
               for name, k in ks.items()}
        typer.echo(_json.pretty(out))
        return
    t = Table(show_header=True, header_style="bold")
    for c in ("kind", "profile", "figures", "parameters"):
        t.add_column(c)
    for name, k in ks.items():
        for i, (p, v) in enumerate(k.profiles.items()):
            figs = sensor_summary(name, k.params.model_validate(v).model_dump(mode="json"))
            t.add_row(name if i == 0 else "", p + (" (default)" if p == k.default_profile else ""), literal(figs),
                      ", ".join(k.params.model_fields) if i == 0 else "")
    console().print(t)
