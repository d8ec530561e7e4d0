"""The ``navstress`` command line.

    navstress world generate --trees 6 --seed 1 -o worlds/trees6
    navstress world show worlds/trees6
    navstress world export worlds/trees6 --format sdf -o trees6.sdf
    navstress demo -o demo-out

Every user error (a :class:`~navstress.errors.NavstressError` or a bad flag) prints ONE line on
stderr, ``error: <field>=<value> is invalid: expected ...; fix``, exits with code 2 and writes
nothing. So does an ``OSError`` met while a command works (a read-only or full disk, a
permission, a folder where a file is expected): the line names the path the user gave and what
to do (:func:`os_error_line`). Text a user or a navigator wrote is printed literally.
"""

from __future__ import annotations

import errno
import math
import os
import re
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from typer import _click as click
from typer.core import TyperGroup

from navstress import __version__, _files
from navstress.campaign.spec import MAX_WORKERS
from navstress.errors import NavstressError, SpecError, WorldFileError

EXIT_USAGE = 2
PREVIEW = "preview.png"
EXPORT_FORMATS = ("mjcf", "sdf", "gltf", "glb", "obj", "png")


class _OneLineErrors(TyperGroup):
    """Root group: user errors become one line on stderr and exit code 2."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             windows_expand_args: bool = True, **extra: Any) -> Any:
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
    from navstress._console import literal

    line = literal(" ".join(line.split()))
    click.echo(f"error: {line}", err=True)
    sys.exit(EXIT_USAGE)


def _version(value: bool) -> None:
    if value:
        click.echo(f"navstress {__version__}")
        raise typer.Exit()


app = typer.Typer(cls=_OneLineErrors, add_completion=False, no_args_is_help=True,
                  rich_markup_mode=None, pretty_exceptions_enable=False,
                  help="Stress-test robot navigation software in generated virtual worlds.")
world_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                        help="Generate, inspect and export worlds (terrain, obstacles, mission).")
app.add_typer(world_app, name="world")


@app.callback()
def _root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                help="Print the navstress version and exit.")] = False) -> None:
    """Stress-test robot navigation software in generated virtual worlds."""


# ---- flag parsing -------------------------------------------------------------------------

def _number(flag: str, raw: str, expected: str) -> float:
    try:
        v = float(raw)
    except ValueError:
        raise SpecError(flag, raw, expected) from None
    if math.isnan(v) or math.isinf(v):
        raise SpecError(flag, raw, expected)
    return v


def _integer(flag: str, raw: str, expected: str) -> int:
    try:
        return int(raw)
    except ValueError:
        raise SpecError(flag, raw, expected) from None


#: Largest seed a flag takes (seeds are stored as signed 64-bit integers).
MAX_SEED = 2**63 - 1
#: Longest simulated run (one day, as a campaign spec's timeout_s) and longest wall-clock limit.
MAX_TIMEOUT_S = 86_400.0
MAX_WALL_S = 30 * 86_400.0
#: Most runs one `navstress run` makes (a campaign is the tool for more).
MAX_RUNS = 10_000


def _bounded_int(flag: str, raw: str, lo: int, hi: int) -> int:
    expected = f"an integer in [{lo}, {hi}]"
    v = _integer(flag, raw, expected)
    if not lo <= v <= hi:
        raise SpecError(flag, raw, expected)
    return v


_KIND_ALIASES = {"trees": "tree", "buildings": "building"}


def parse_mix(raw: str) -> dict[str, float]:
    """``"trees=3,buildings=1"`` -> ``{"tree": 3.0, "building": 1.0}`` (plural names accepted)."""
    expected = "comma-separated TYPE=WEIGHT pairs with weights >= 0"
    fix = "e.g. --mix trees=1,buildings=1"
    out: dict[str, float] = {}
    for part in raw.split(","):
        name, sep, weight = part.partition("=")
        name = name.strip().lower()
        if not sep or not name:
            raise SpecError("--mix", raw, expected, fix)
        try:
            w = float(weight)
        except ValueError:
            raise SpecError("--mix", raw, expected, fix) from None
        if not w >= 0 or math.isinf(w):
            raise SpecError("--mix", raw, expected, fix)
        key = _KIND_ALIASES.get(name, name)
        if key in out:
            raise SpecError("--mix", raw, f"{expected}, each type once", fix)
        out[key] = w
    return out


# spec field (prefix) -> flag that sets it
_FIELD_FLAGS = {
    "size_m": "--size", "cell_m": "--cell", "ground.subdivisions": "--subdivisions",
    "ground.deformation": "--deformation", "ground.model": "--ground",
    "obstacles.obstruction.tree": "--trees", "obstacles.obstruction.building": "--buildings",
    "obstacles.total": "--obstruction", "obstacles.mix": "--mix",
}


def build_spec(*, spec_file: Path | None = None, size: str | None = None, cell: str | None = None,
               subdivisions: str | None = None, deformation: str | None = None, ground: str | None = None,
               trees: str | None = None, buildings: str | None = None, obstruction: str | None = None,
               mix: str | None = None) -> Any:
    """The WorldSpec from an optional spec file with flags overriding it (raises SpecError
    naming the flag when a flag value is the culprit)."""
    from navstress.world.spec import load_spec, parse_spec

    data: dict[str, Any] = load_spec(spec_file).model_dump(mode="python") if spec_file else {}
    given: set[str] = set()
    if size is not None:
        parts = size.lower().split("x")
        if len(parts) > 2:
            raise SpecError("--size", size, "a map side M or WxH in meters")
        vals = [_number("--size", p, "a map side M or WxH in meters") for p in parts]
        data["size_m"] = (vals[0], vals[-1])
        given.add("--size")
    if cell is not None:
        data["cell_m"] = _number("--cell", cell, "a cell size in meters")
        given.add("--cell")
    g = dict(data.get("ground", {}))
    if subdivisions is not None:
        g["subdivisions"] = _integer("--subdivisions", subdivisions, "an integer >= 0")
        given.add("--subdivisions")
    if deformation is not None:
        g["deformation"] = _number("--deformation", deformation, "a displacement scale in meters >= 0")
        given.add("--deformation")
    if ground is not None:
        g["model"] = ground
        given.add("--ground")
    data["ground"] = g
    o = dict(data.get("obstacles", {}))
    per_type = {k: v for k, v in (("tree", trees), ("building", buildings)) if v is not None}
    if per_type and obstruction is not None:
        raise SpecError("--obstruction", obstruction, "either --trees/--buildings or --obstruction with --mix",
                        "not both")
    if per_type:
        obs = dict(o.get("obstruction", {})) if o.get("total") is None else {}
        for kind, raw in per_type.items():
            flag = "--trees" if kind == "tree" else "--buildings"
            obs[kind] = _number(flag, raw, "a percentage in [0, 100)")
            given.add(flag)
        o.update(obstruction=obs, total=None, mix=None)
    if obstruction is not None:
        o.update(total=_number("--obstruction", obstruction, "a percentage in [0, 100)"), obstruction={})
        given.add("--obstruction")
    if mix is not None:
        if o.get("total") is None:
            raise SpecError("--mix", mix, "to be used with --obstruction (a total to split)",
                            "add --obstruction PCT or use --trees/--buildings")
        o["mix"] = parse_mix(mix)
        given.add("--mix")
    data["obstacles"] = o
    try:
        return parse_spec(data)
    except SpecError as e:
        for prefix, flag in _FIELD_FLAGS.items():
            flagged = flag in given or (flag == "--mix" and "--obstruction" in given)
            if flagged and (e.field == prefix or e.field.startswith(prefix + ".")):
                raise SpecError(flag, e.value, e.expected, e.fix) from None
        raise


def _check_out_dir(path: Path, flag: str = "--output") -> None:
    from navstress.world.world import is_world_dir

    if path.exists() and not is_world_dir(path):
        raise WorldFileError(f"{flag}={str(path)!r} is invalid: expected a new path or an existing world "
                             "directory (it exists and is not a world); choose another path or remove it")


def _save_with_preview(world: Any, out: Path) -> None:
    """Save the world and its preview so that either both appear or nothing does."""
    from navstress.world.export.images import preview_png_bytes
    from navstress.world.export._grid import write_atomic

    png = preview_png_bytes(world)  # render first: a failure here writes nothing
    existed = out.exists()
    try:
        world.save(out)
        write_atomic(out / PREVIEW, png)
    except BaseException:
        if not existed:  # a world without its preview is partial output: take it back
            shutil.rmtree(out, ignore_errors=True)
        raise


def _descriptor_table(world: Any, title: str) -> Any:
    from rich.table import Table

    from navstress.world.export.images import obstruction_pct

    t = Table(title=title, show_header=True, header_style="bold", title_justify="left")
    t.add_column("descriptor")
    t.add_column("value", justify="right")
    spec = world.spec
    g = spec.ground
    rows: list[tuple[str, str]] = [
        ("size", f"{spec.size_m[0]:g} m x {spec.size_m[1]:g} m (cell {spec.cell_m:g} m)"),
        ("seed", str(world.seed)),
        ("ground", f"subdivide s={g.subdivisions} d={g.deformation:g} m" if g.model == "subdivide"
         else f"fractal amp={g.amplitude_m:g} m wavelength={g.wavelength_m:g} m octaves={g.octaves}"),
        ("obstruction", f"{obstruction_pct(world):.2f} %"),
    ]
    ms = world.mission
    rows.append(("mission", f"({ms.start[0]:g}, {ms.start[1]:g}) -> ({ms.goal[0]:g}, {ms.goal[1]:g}), "
                            f"{ms.straight_distance_m:.1f} m"))
    d = world.descriptors
    if d.get("obstruction_target_pct"):
        target = sum(d["obstruction_target_pct"].values())
        rows[3] = ("obstruction", f"{rows[3][1]} (target {target:g} %)")
    counts: dict[str, int] = {}
    for o in world.obstacles:
        counts[o.kind] = counts.get(o.kind, 0) + 1
    rows.insert(4, ("obstacles", ", ".join(f"{n} {k}{'s' if n != 1 else ''}" for k, n in sorted(counts.items()))
                    or "none"))
    if "height_min_m" in d:
        rows.append(("height", f"{_fmt(d['height_min_m'])} .. {_fmt(d['height_max_m'])} m "
                               f"(std {_fmt(d.get('height_std_m'))} m)"))
    for key, val in sorted(d.items()):
        if key.startswith(_HIDDEN):
            continue
        rows.append((key, _fmt(val)))
    for k, v in rows:
        t.add_row(k, v)
    return t


_HIDDEN = ("placement_", "traversability", "obstruction_", "n_obstacles", "height_m", "height_min", "height_max",
           "height_std")


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}={_fmt(x)}" for k, x in v.items()) or "-"
    if v is None:
        return "-"
    return str(v)


def _console() -> Any:
    from navstress._console import console

    return console()


# ---- world commands -----------------------------------------------------------------------

_M = "M"
_PCT = "PCT"


@world_app.command("generate")
def world_generate(
    output: Annotated[Path, typer.Option("--output", "-o", metavar="DIR", help=(
        "World directory to write (world.json, terrain.npz, preview.png). Must be new or an "
        "existing world directory, which is replaced."))],
    size: Annotated[str | None, typer.Option(metavar="M|WxH", help=(
        "Map size in meters: one side M for a square map or WxH; each in [10, 2000], a whole "
        "multiple of --cell. Default 100."))] = None,
    cell: Annotated[str | None, typer.Option(metavar=_M, help=(
        "Terrain cell size in meters, in [0.05, 2]. Default 0.4."))] = None,
    subdivisions: Annotated[str | None, typer.Option("--subdivisions", "-s", metavar="S", help=(
        "Ground subdivisions s, an integer in [0, 10]: 2**s+1 control vertices per side "
        "(small s: large smooth bumps; large s: small sharp ones). Default 0."))] = None,
    deformation: Annotated[str | None, typer.Option("--deformation", "-d", metavar=_M, help=(
        "Ground deformation d in meters, in [0, 50]: scale of the vertical displacement of the "
        "control vertices. Default 0 (flat)."))] = None,
    ground: Annotated[str | None, typer.Option(metavar="subdivide|fractal", help=(
        "Ground model: 'subdivide' (the paper's, uses -s/-d) or 'fractal' (multi-octave "
        "noise; set its parameters in a --spec file). Default subdivide."))] = None,
    trees: Annotated[str | None, typer.Option(metavar=_PCT, help=(
        "Percent of the map area covered by trees (1 m x 1 m x 5 m boxes), in [0, 100). Default 0."))] = None,
    buildings: Annotated[str | None, typer.Option(metavar=_PCT, help=(
        "Percent of the map area covered by buildings (9 m x 9 m x 8 m boxes), in [0, 100). "
        "Above about 28% placement may not find room. Default 0."))] = None,
    obstruction: Annotated[str | None, typer.Option(metavar=_PCT, help=(
        "Total obstruction percent in [0, 100), split between types by --mix. Not with "
        "--trees/--buildings."))] = None,
    mix: Annotated[str | None, typer.Option(metavar="TYPE=W,...", help=(
        "Weights splitting --obstruction between obstacle types, e.g. trees=3,buildings=1 "
        "(weights >= 0; 'tree'/'trees' and 'building'/'buildings' both accepted)."))] = None,
    spec: Annotated[Path | None, typer.Option("--spec", metavar="FILE", help=(
        "WorldSpec file (YAML or JSON); the flags above override its fields."))] = None,
    seed: Annotated[str, typer.Option(metavar="N", help=(
        "Map seed, an integer in [0, 2**63-1]: the same spec and seed give the same world."))] = "0",
) -> None:
    """Generate one world from a spec and a seed; write it with a preview and print its descriptors."""
    from navstress.world.generate import generate

    seed_v = _bounded_int("--seed", seed, 0, MAX_SEED)
    world_spec = build_spec(spec_file=spec, size=size, cell=cell, subdivisions=subdivisions,
                            deformation=deformation, ground=ground, trees=trees, buildings=buildings,
                            obstruction=obstruction, mix=mix)
    _check_out_dir(output)
    world = generate(world_spec, seed_v)
    _save_with_preview(world, output)
    con = _console()
    con.print(_descriptor_table(world, f"world {output}"))
    con.print(f"wrote {output}/ (world.json, terrain.npz, {PREVIEW})")


@world_app.command("show")
def world_show(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", metavar="FILE", help=(
        "Where to write the preview PNG. Default: DIR/preview.png."))] = None,
) -> None:
    """Print a world's descriptors and write its top-down preview PNG."""
    from navstress.world.export.images import write_preview
    from navstress.world.world import World

    world = World.load(world_dir)
    dest = output if output is not None else world_dir / PREVIEW
    _check_file_out(dest)
    write_preview(world, dest)
    con = _console()
    con.print(_descriptor_table(world, f"world {world_dir}"))
    con.print(f"wrote {dest}")


def _check_file_out(dest: Path) -> None:
    if dest.exists() and dest.is_dir():
        raise SpecError("--output", str(dest), "a file path (this is a directory)")


def probe_writable(dest: Path) -> None:
    """Fail now (OSError naming ``dest``) if a file cannot be created where ``dest`` will be
    written, before long work whose result would be lost; leaves nothing behind."""
    _files.probe_writable(dest)


@world_app.command("export")
def world_export(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    fmt: Annotated[str, typer.Option("--format", "-f", metavar="|".join(EXPORT_FORMATS), help=(
        "mjcf: standalone MuJoCo model (heightfield + boxes, no robot); sdf: Gazebo SDF world "
        "(writes FILE and FILE-stem_heightmap.png beside it, resampled to a 2^n+1 square); "
        "gltf/glb: mesh scene (y-up); obj: mesh (z-up world coordinates); png: 16-bit heightmap "
        "(height range in its text chunks)."))],
    output: Annotated[Path, typer.Option("--output", "-o", metavar="FILE", help="File to write.")],
) -> None:
    """Export a world to another tool's format."""
    from navstress.world.export._grid import write_atomic
    from navstress.world.world import World

    f = fmt.lower()
    if f not in EXPORT_FORMATS:
        raise SpecError("--format", fmt, f"one of {', '.join(EXPORT_FORMATS)}")
    _check_file_out(output)
    world = World.load(world_dir)
    if f == "mjcf":
        from navstress.sim.model import world_to_mjcf  # lazily: the simulator is heavy

        write_atomic(output, world_to_mjcf(world).encode("utf-8"))
        written = [output]
    elif f == "sdf":
        from navstress.world.export.sdf import write_sdf

        r = write_sdf(world, output)
        written = [r.sdf_path, r.heightmap_path]
        rows, cols = world.terrain.heights.shape
        if (rows, cols) != (r.heightmap_side, r.heightmap_side):
            click.echo(f"note: heightmap resampled from {cols}x{rows} to {r.heightmap_side}x{r.heightmap_side} "
                       "(Gazebo needs a square 2^n+1 image)")
    elif f == "png":
        from navstress.world.export.images import write_heightmap_png

        info = write_heightmap_png(world.terrain, output)
        written = [output]
        click.echo(f"heightmap {info.width}x{info.height}, 0..65535 = {info.z_min:.4g}..{info.z_max:.4g} m")
    else:
        from navstress.world.export.mesh import write_mesh

        write_mesh(world, output, "glb" if f == "gltf" and output.suffix.lower() == ".glb" else f)
        written = [output]
    from navstress._console import literal

    click.echo(literal("wrote " + ", ".join(str(p) for p in written)))


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
    from navstress.analysis.report import build_report
    from navstress.campaign.executors import run_campaign
    from navstress.campaign.presets import preset_yaml
    from navstress.campaign.progress import CampaignProgress, format_counts

    n_workers = None
    if workers is not None:
        n_workers = _bounded_int("--workers", workers, 1, MAX_WORKERS)
    if output.exists() and not output.is_dir():
        raise WorldFileError(f"--output={str(output)!r} is invalid: expected a folder; choose another path")
    if output.is_dir():
        ours = {"demo.yaml", "campaign", "report.html"}
        others = [p.name for p in output.iterdir() if p.name not in ours and not p.name.startswith(".")]
        if others:
            raise WorldFileError(f"--output={str(output)!r} is invalid: expected a new folder or a previous demo "
                                 f"(it holds {others[0]!r}); choose another path or remove it")
    output.mkdir(parents=True, exist_ok=True)
    spec_path = output / "demo.yaml"
    text = preset_yaml("demo")
    if not spec_path.exists() or spec_path.read_text(encoding="utf-8") != text:
        tmp = spec_path.with_name(".demo.yaml.tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(spec_path)
    con = _console()
    con.print(f"demo campaign: {spec_path} -> {output / 'campaign'}")
    with CampaignProgress() as bar:
        res = run_campaign(spec_path, output / "campaign", workers=n_workers, on_start=bar.on_start,
                           on_record=bar.on_record)
    con.print(f"{res.already_done + res.recorded}/{res.planned} runs recorded in {res.wall_s:.0f} s with "
              f"{res.workers} workers: " + format_counts(res.counts, markup=False))
    con.print("writing the report ...")
    report = build_report(output / "campaign", output / "report.html")
    con.print(f"report: {report.resolve()}")


@world_app.command("drive")
def world_drive(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", metavar="FILE", help=(
        "Picture of the real path and the odometry path over the world (default DIR/drive.png)."))] = None,
    course: Annotated[str | None, typer.Option(metavar="SEGMENTS", help=(
        "Open-loop course from the mission start: 'v,omega,seconds; ...' (m/s, rad/s, s). Default: 20 m "
        "straight, quarter turn on the spot, 12 m straight, a right curve, 15 m straight."))] = None,
    seed: Annotated[str, typer.Option(metavar="N", help="Run seed (sensor noise, jitter), an integer in [0, 2**63-1]. Default 0.")] = "0",
) -> None:
    """Drive a scripted course in the simulation and draw where the robot really went."""
    from navstress.run.drive import DEFAULT_COURSE, drive, drive_picture, parse_course
    from navstress.world.world import World

    world = World.load(world_dir)
    segs = parse_course(course) if course is not None else DEFAULT_COURSE
    seed_v = _bounded_int("--seed", seed, 0, MAX_SEED)
    dest = output if output is not None else world_dir / "drive.png"
    if dest.exists() and dest.is_dir():
        raise SpecError("--output", str(dest), "a PNG file path, not a directory")
    probe_writable(dest)
    res = drive(world, segs, seed=seed_v)
    t = res.truth
    dist = float(np.sum(np.hypot(np.diff(t[:, 1]), np.diff(t[:, 2])))) if len(t) > 1 else 0.0
    odo_err = (math.hypot(res.odometry[-1, 0] - t[-1, 1], res.odometry[-1, 1] - t[-1, 2])
               if len(res.odometry) and len(t) else 0.0)
    con = _console()
    con.print(f"drove {dist:.1f} m in {res.sim_s:.1f} s simulated ({res.real_time_factor:.0f}x real time); "
              f"odometry off by {odo_err:.2f} m at the end; collisions: {len(res.collisions)}"
              + (f"; stopped: {res.stopped}" if res.stopped else ""))
    pic = drive_picture(world, res, dest, f"scripted drive on {world_dir.name}: {dist:.0f} m, "
                        f"{len(res.collisions)} collision(s)")
    con.print(f"picture: {pic}")


# ---- runs ------------------------------------------------------------------------------------

_NAV_CONFIG_HELP = ("Configuration passed to the navigator: a JSON/YAML file, or inline JSON/YAML text "
                    "such as '{\"command\": [\"./my_nav\"]}'.")


def _navigator_config(raw: str | None) -> dict[str, Any]:
    """``--navigator-config``: a file path or inline JSON/YAML (SpecError naming the flag)."""
    if raw is None:
        return {}
    from navstress.nav.registry import load_config

    return dict(load_config(raw, field="--navigator-config"))


def _check_navigator(name: str, fault: str | None, config: dict[str, Any]) -> None:
    """Fail fast (one line, exit 2) on an unknown navigator or fault, before any output is made."""
    import warnings

    from navstress.nav.registry import make_navigator, validate_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        validate_config(name, config, fault=fault)
        nav = make_navigator(name, config or None, fault=fault)
    nav.close()


@app.command("run")
def run_cmd(
    world_dir: Annotated[Path, typer.Argument(metavar="WORLD_DIR", help="A world directory (navstress world generate).")],
    output: Annotated[Path, typer.Option("--output", "-o", metavar="OUT", help=(
        "Folder for the traces (run-NNN.mcap), records (runs.jsonl) and trajectories.png; must be new or empty."))],
    navigator: Annotated[str, typer.Option(metavar="NAME", help=(
        "Navigator under test, by registered name (see `navstress nav list`).")) ] = "reference-v1",
    navigator_config: Annotated[str | None, typer.Option(metavar="FILE|TEXT", help=_NAV_CONFIG_HELP)] = None,
    fault: Annotated[str | None, typer.Option(metavar="NAME", help=(
        "Inject a named fault into the navigator (see `navstress nav faults`)."))] = None,
    runs: Annotated[str, typer.Option(metavar="N", help="Number of runs (each with its own run seed), in [1, 10000]. Default 1.")] = "1",
    seed: Annotated[str, typer.Option(metavar="N", help="Root seed of the run seeds, an integer in [0, 2**63-1]. Default 0.")] = "0",
    timeout: Annotated[str, typer.Option(metavar="S", help="Simulated-time limit of a run in seconds, in (0, 86400]. Default 400.")] = "400",
    goal_tolerance: Annotated[str, typer.Option(metavar="M", help="Success radius around the goal in meters, > 0. Default 2.")] = "2",
    lidar: Annotated[bool, typer.Option("--lidar", help=(
        "Also record lidar point clouds in the traces (one full scan per simulated second, map frame).")) ] = False,
    wall_limit: Annotated[str | None, typer.Option(metavar="S", help=(
        "Wall-clock limit of one run in real seconds, > 0 (a navigator that hangs is killed and its run "
        "recorded as Fail-Other). Default: timeout * 2 + 120.")) ] = None,
) -> None:
    """Run the navigator on a world's mission, classify each run, write traces and a picture."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from navstress.run.batch import batch_picture, plan_batch, run_batch
    from navstress.world.world import World

    n = _bounded_int("--runs", runs, 1, MAX_RUNS)
    seed_v = _bounded_int("--seed", seed, 0, MAX_SEED)
    timeout_v = _number("--timeout", timeout, f"a duration in seconds in (0, {MAX_TIMEOUT_S:g}]")
    if not 0 < timeout_v <= MAX_TIMEOUT_S:
        raise SpecError("--timeout", timeout, f"a duration in seconds in (0, {MAX_TIMEOUT_S:g}]")
    tol = _number("--goal-tolerance", goal_tolerance, "a distance in meters > 0")
    if tol <= 0:
        raise SpecError("--goal-tolerance", goal_tolerance, "a distance in meters > 0")
    wall_v = None
    if wall_limit is not None:
        wall_v = _number("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
        if not 0 < wall_v <= MAX_WALL_S:
            raise SpecError("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    from navstress.run.batch import check_buildable, default_wall_limit_s

    world_seed = World.load(world_dir).seed  # a clear error for a non-world, before anything is written
    cfg = _navigator_config(navigator_config)
    # built in a worker process: a navigator that exits, crashes or hangs there is the runs' to classify
    check_buildable(_check_navigator, navigator, fault, cfg,
                    wall_limit_s=wall_v if wall_v is not None else default_wall_limit_s(timeout_v))
    if output.exists() and (not output.is_dir() or any(output.iterdir())):
        raise WorldFileError(f"--output={str(output)!r} is invalid: expected a new or empty folder; "
                             "choose another path or remove it")
    created = not output.exists()
    con = _console()
    counts: dict[str, int] = {}
    try:
        tasks = plan_batch(world_dir, output, navigator=navigator, navigator_config=cfg, fault=fault, runs=n,
                           seed=seed_v, timeout_s=timeout_v, goal_tolerance_m=tol, record_lidar=lidar,
                           map_seed=world_seed)
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), TextColumn("{task.fields[counts]}"), console=con) as prog:
            bar = prog.add_task("runs", total=n, counts="")

            def done(rec: Any) -> None:
                counts[rec.outcome] = counts.get(rec.outcome, 0) + 1
                prog.update(bar, advance=1, counts="  ".join(f"{k}={v}" for k, v in sorted(counts.items())))

            records = run_batch(tasks, output, done, wall_limit_s=wall_v)
    except BaseException:
        if created and not counts:  # nothing recorded: leave nothing behind
            shutil.rmtree(output, ignore_errors=True)
        raise
    from rich.table import Table

    table = Table(title=f"{navigator}{' + ' + fault if fault else ''} on {world_dir}")
    for col in ("run", "outcome", "sim s", "wall s", "goal m", "path m", "reason"):
        table.add_column(col)
    for r in records:
        table.add_row(r.run_id, r.outcome, f"{r.duration_s:.1f}", f"{r.wall_s:.1f}", f"{r.goal_distance_m:.2f}",
                      f"{r.path_length_m:.1f}", r.reason)
    con.print(table)
    pic = batch_picture(world_dir, records, output / "trajectories.png",
                        f"{navigator}{' + ' + fault if fault else ''}: {n} run(s) on {world_dir.name}")
    con.print(f"traces and records in {output}/, picture: {pic}")


# ---- navigators ---------------------------------------------------------------------------------

nav_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                      help="Navigators under test: list them, list faults, check conformance.")
app.add_typer(nav_app, name="nav")


@nav_app.command("list")
def nav_list() -> None:
    """List the registered navigators (built-in and third-party entry points)."""
    from navstress.nav.registry import list_navigators

    con = _console()
    for spec in list_navigators():
        con.print(f"  {spec.id:<24} {spec.target_text}")


@nav_app.command("faults")
def nav_faults() -> None:
    """List the faults that --fault can inject."""
    from navstress.nav.faults import list_faults

    con = _console()
    for f in list_faults():
        con.print(f"  {f.name:<18} {f.description}")


@nav_app.command("check")
def nav_check(
    name: Annotated[str, typer.Argument(metavar="NAME", help="Registered navigator name, e.g. reference-v1.")],
    navigator_config: Annotated[str | None, typer.Option(metavar="FILE|TEXT", help=_NAV_CONFIG_HELP)] = None,
    wall_limit: Annotated[str, typer.Option(metavar="S", help=(
        "Wall-clock limit of each check in real seconds, > 0: a navigator that hangs fails the check "
        "it hangs in. Default 300.")) ] = "300",
) -> None:
    """Run the conformance checks on a navigator (in a worker process); exit 1 if any check fails."""
    import warnings

    from navstress.nav.check import check_in_worker, format_report
    from navstress.nav.registry import validate_config

    wall_v = _number("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    if not 0 < wall_v <= MAX_WALL_S:
        raise SpecError("--wall-limit", wall_limit, f"a duration in seconds in (0, {MAX_WALL_S:g}]")
    cfg = _navigator_config(navigator_config)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        validate_config(name, cfg)  # the same up-front check as `campaign run` (one line, exit 2)
    report = check_in_worker(name, cfg or None, wall_limit_s=wall_v)
    _console().print(format_report(report))
    if not report.passed:
        raise typer.Exit(1)


# ---- campaigns ---------------------------------------------------------------------------------

def _mount_campaigns() -> None:
    from navstress.campaign.cli import campaign_app, replay

    app.add_typer(campaign_app, name="campaign")
    app.command("replay")(replay)

    from navstress.analysis.cli import register as register_analysis

    register_analysis(app)


_mount_campaigns()


def main() -> None:
    """Console-script entry point (``navstress``)."""
    app()


if __name__ == "__main__":
    main()
