"""``navstress world generate|show|export|drive`` (the ``world`` group)."""

from __future__ import annotations

import contextlib
import math
import os
import warnings
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.table import Table
from typer import _click as click

from navstress import _files
from navstress._console import console, literal
from navstress.cli._common import (MAX_SEED, RobotOpt, SensorAddOpt, SensorOpt, bounded_int, check_file_out,
                                   check_out_dir, load_robot_flag, load_robot_flags, probe_writable)
from navstress.errors import SpecError
from navstress.run.drive import DEFAULT_COURSE, drive, drive_picture, parse_course
from navstress.sim.model import world_to_mjcf
from navstress.world.export.images import PREVIEW, obstruction_pct, save_with_preview, write_heightmap_png, write_preview
from navstress.world.export.mesh import write_mesh
from navstress.world.export.sdf import write_sdf
from navstress.world.flags import build_spec, import_spec
from navstress.world.sources.notes import SourceWarning
from navstress.run.robot import check_stable
from navstress.world.generate import check_robot_fits, generate, sized_to_robot
from navstress.world.freespace import clearances_for, default_mission, free_space
from navstress.world.sources import module_for, occupancy
from navstress.world.world import Mission, World

EXPORT_FORMATS = ("mjcf", "sdf", "gltf", "glb", "obj", "png")

app = typer.Typer(rich_markup_mode=None)
world_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                        help="Generate, inspect and export worlds (terrain, obstacles, mission).")
app.add_typer(world_app, name="world")


def _descriptor_table(world: Any, title: str) -> Any:
    t = Table(title=title, show_header=True, header_style="bold", title_justify="left")
    t.add_column("descriptor")
    t.add_column("value", justify="right")
    spec = world.spec
    g = spec.ground
    rows: list[tuple[str, str]] = [
        ("size", f"{spec.size_m[0]:g} m x {spec.size_m[1]:g} m (cell {spec.cell_m:g} m)"),
        ("seed", str(world.seed)),
        ("ground", g.label()),
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


_HIDDEN = ("import_notes", "map_outline", "placement_", "traversability", "obstruction_", "n_obstacles", "height_m", "height_min", "height_max",
           "height_std")


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}={_fmt(x)}" for k, x in v.items()) or "-"
    if v is None:
        return "-"
    return str(v)


_M = "M"
_PCT = "PCT"


@world_app.command("generate")
def world_generate(
    *,
    output: Annotated[Path, typer.Option("--output", "-o", metavar="DIR", help=(
        "World directory to write (world.json, terrain.npz, preview.png). Must be new or an "
        "existing world directory, which is replaced."))],
    size: Annotated[str | None, typer.Option(metavar="M|WxH", help=(
        "Map size in meters: one side M for a square map or WxH; each in [10, 2000], a whole "
        "multiple of --cell. Default 100."))] = None,
    cell: Annotated[str | None, typer.Option(metavar=_M, help=(
        "Terrain cell size in meters, in [0.05, 2]. Default 0.4."))] = None,
    subdivisions: Annotated[str | None, typer.Option("--subdivisions", "-s", metavar="S", help=(
        "Ground subdivisions s: with --ground subdivide an integer in [0, 10], 2**s+1 control "
        "vertices per side; with --ground blender the cuts per edge in [1, 100], s+1 flat-faced "
        "segments per side (small s: large bumps; large s: small ones). Default 0."))] = None,
    deformation: Annotated[str | None, typer.Option("--deformation", "-d", metavar=_M, help=(
        "Ground deformation d in [0, 50]: scale of the vertical displacement of the vertices "
        "(subdivide: meters peak to peak; blender: Blender's Fractal value). Default 0 (flat)."))] = None,
    ground: Annotated[str | None, typer.Option(metavar="subdivide|blender|fractal", help=(
        "Ground model: 'blender' (the paper's tool: Blender's Subdivide with Fractal, uses -s/-d), "
        "'subdivide' (a smooth surface, uses -s/-d) or 'fractal' (multi-octave noise; set its "
        "parameters in a --spec file). Default subdivide."))] = None,
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
    movers: Annotated[str | None, typer.Option("--movers", metavar="TYPE=N,...", help=(
        "Movers (obstacles that move during a run) per type, e.g. pedestrians=5,vehicles=1 "
        "(built-in types: pedestrian, a 0.5 m disc 1.8 m tall at 0.5-1.5 m/s; vehicle, a 4.5 x 1.8 x "
        "1.5 m box up to 5 m/s; others under movers.types in a --spec file). Default none."))] = None,
    mover_behaviour: Annotated[str | None, typer.Option("--mover-behaviour", metavar="TYPE=KIND,...", help=(
        "Behaviour per mover type: crossing (the default), patrol, intercept or still-then-move, "
        "e.g. pedestrians=intercept; their parameters go under movers.behaviour in a --spec file."))] = None,
    generator: Annotated[str | None, typer.Option("--generator", metavar="outdoor|rooms|clutter", help=(
        "World generator: outdoor (the paper's worlds, the default), rooms (a floor plan of rooms and "
        "corridors) or clutter (BARN's cylinder fields); their parameters under rooms/clutter in a "
        "--spec file (docs/worlds.md)."))] = None,
    spec: Annotated[Path | None, typer.Option("--spec", metavar="FILE", help=(
        "WorldSpec file (YAML or JSON); the flags above override its fields."))] = None,
    seed: Annotated[str, typer.Option(metavar="N", help=(
        "Map seed, an integer in [0, 2**63-1]: the same spec and seed give the same world."))] = "0",
    robot: RobotOpt = None,
) -> None:
    """Generate one world from a spec and a seed; write it with a preview and print its descriptors.

    With --robot, the world is made for that robot: its start and goal free discs sized to it
    (unless the spec sets mission.free_radius_m) and its traversability (feasible, path_length_m)
    computed with its width."""
    seed_v = bounded_int("--seed", seed, 0, MAX_SEED)
    robot_v = load_robot_flag(robot)
    world_spec = build_spec(spec_file=spec, size=size, cell=cell, subdivisions=subdivisions,
                            deformation=deformation, ground=ground, trees=trees, buildings=buildings,
                            obstruction=obstruction, mix=mix, movers=movers, mover_behaviour=mover_behaviour,
                            generator=generator)
    if robot is not None and world_spec.generator == "outdoor":  # (rooms and clutter size their own free discs)
        world_spec = sized_to_robot(world_spec, robot_v, field="--robot")
    if output.is_symlink():  # a link named as -o is the user's choice: followed once, its target replaced
        output = Path(os.path.realpath(output))
    check_out_dir(output)
    world = generate(world_spec, seed_v, robot=robot_v if robot is not None else None)
    save_with_preview(world, output)
    con = console()
    con.print(_descriptor_table(world, f"world {output}"))
    con.print(f"wrote {output}/ (world.json, terrain.npz, {PREVIEW})")


@world_app.command("import")
def world_import(
    source: Annotated[Path, typer.Argument(metavar="SOURCE", help=(
        "A ROS map_server map (its YAML, naming a PGM or PNG image), a Gazebo world (.world or .sdf, "
        "SDF 1.4 to 1.9) or a navstress world directory."))],
    *,
    output: Annotated[Path, typer.Option("--output", "-o", metavar="DIR", help=(
        "World directory to write (world.json, terrain.npz, preview.png). Must be new or an "
        "existing world directory, which is replaced."))],
    kind: Annotated[str, typer.Option(metavar="auto|map|sdf|dir", help=(
        "What SOURCE is; auto (the default): by the file."))] = "auto",
    wall_height: Annotated[str | None, typer.Option("--wall-height", metavar=_M, help=(
        "A map's walls (its occupied cells) are this high, in (0, 100] m. Default 2."))] = None,
    unknown: Annotated[str | None, typer.Option(metavar="wall|free", help=(
        "A map's unknown cells become walls or free ground. Default wall."))] = None,
    meshes: Annotated[str | None, typer.Option(metavar="skip|bbox", help=(
        "An SDF world's mesh collisions: skip (listed in the warning) or their bounding boxes. Default skip."))] = None,
    start: Annotated[str | None, typer.Option(metavar="X,Y,YAW", help=(
        "The mission's start pose in the source's frame (m, m, rad). Default: the source's own, or drawn "
        "in the free space with the robot's clearance from --seed."))] = None,
    goal: Annotated[str | None, typer.Option(metavar="X,Y", help=(
        "The mission's goal in the source's frame (m). Give --start and --goal together."))] = None,
    seed: Annotated[str, typer.Option(metavar="N", help=(
        "Seed of a drawn mission, an integer in [0, 2**63-1]."))] = "0",
    robot: RobotOpt = None,
) -> None:
    """Import a world made elsewhere (an occupancy-grid map, a Gazebo world) as a navstress world.

    The world is shifted so its lower-left corner is (0, 0); world.json's source.origin says
    where that is in the source's frame, and missions given here are in the source's frame.
    Without --start/--goal, a source without a mission of its own (a map) gets one: the two points
    farthest apart in its largest free part where the robot (--robot) passes and turns."""
    seed_v = bounded_int("--seed", seed, 0, MAX_SEED)
    robot_v = load_robot_flag(robot)
    world_spec = import_spec(source, kind=kind, wall_height=wall_height, unknown=unknown, meshes=meshes,
                             start=start, goal=goal)
    if output.is_symlink():  # a link named as -o is the user's choice: followed once, its target replaced
        output = Path(os.path.realpath(output))
    check_out_dir(output)
    err = console(stderr=True)
    big = import_size_note(world_spec)
    with err.status(big or "importing...") if big and err.is_terminal else contextlib.nullcontext():
        # (a transient line on a terminal only: an error that follows stays the one line on stderr)
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", SourceWarning)
            try:
                world = generate(world_spec, seed_v, robot=robot_v if robot is not None else None)
            except SpecError as bad:  # a given point is refused: named by the flag that gave it
                flag = {"mission.start": "--start", "mission.goal": "--goal"}.get(bad.field)
                if flag is None:
                    raise
                raise SpecError(flag, bad.value, bad.expected, bad.fix) from None
        if start is None and world.mission.straight_distance_m == 0.0:  # the source has none: the default one
            world = with_mission(world, default_mission(world, half_width_m=robot_v.width_m / 2,
                                                        half_diagonal_m=robot_v.half_diagonal_m,
                                                        robot_name=robot_v.name))
        elif start is not None:
            check_mission_free(world, robot_v, world.mission.start[:2], world.mission.goal)
        save_with_preview(world, output)
    for w in said:  # what the source could not bring over: one line each (others as Python shows them)
        if issubclass(w.category, SourceWarning):
            click.echo(f"warning: {literal(str(w.message))}", err=True)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    for note in world.descriptors.get("import_notes", []):
        err.print(literal(f"warning: {note}"))
    con = console()
    con.print(_descriptor_table(world, f"world {output}"))
    con.print(f"wrote {output}/ (world.json, terrain.npz, {PREVIEW})")


def import_size_note(spec: Any) -> str | None:
    """A line announcing a large map's import (its size and memory), None for a small one."""
    src = spec.source
    if src is None:
        return None
    try:
        mod = module_for(src)
        if mod.KIND != "map":
            return None
        m = occupancy.read_yaml(Path(src.path))
        info = occupancy.image_info(m)
    except SpecError:
        return None  # (the import itself reports it)
    if info.width * info.height < 4_000_000:
        return None
    return (f"importing a {info.width}x{info.height} cell map ({info.width * info.height / 1e6:.1f} million cells, "
            f"about {info.width * info.height * occupancy.BYTES_PER_PIXEL / (1 << 30):.2g} GiB at the peak)...")


def with_mission(world: World, mission: Mission) -> World:
    return World(spec=world.spec, seed=world.seed, terrain=world.terrain, obstacles=world.obstacles, mission=mission,
                 descriptors=world.descriptors, movers=world.movers, source=world.source)


def check_mission_free(world: World, robot: Any, start: tuple[float, ...], goal: tuple[float, ...]) -> None:
    """A given start and goal (converted from the source's frame) must lie inside the world, where
    the robot stands clear of the walls (its half width and a margin)."""
    sx, sy = world.size_m
    o = world.source.origin if world.source is not None else (0.0, 0.0)
    fs = None
    for flag, pt in (("--start", start), ("--goal", goal)):
        shown = f"{pt[0] + o[0]:g},{pt[1] + o[1]:g}"
        if not (0.0 <= pt[0] <= sx and 0.0 <= pt[1] <= sy):
            raise SpecError(flag, shown, f"a point of the imported world, in the source's frame [{o[0]:g}, "
                            f"{o[0] + sx:g}] x [{o[1]:g}, {o[1] + sy:g}]", "give the point in the map's own frame")
        fs = fs or free_space(world)
        need = clearances_for(robot.width_m / 2, robot.half_diagonal_m)[0]
        i = min(int(pt[1] / fs.cell_m), fs.clearance.shape[0] - 1)
        j = min(int(pt[0] / fs.cell_m), fs.clearance.shape[1] - 1)
        if float(fs.clearance[i, j]) < need:
            raise SpecError(flag, shown, f"a free point where {robot.name} stands clear of the walls (at least "
                            f"{need:.3g} m from them; this one is {float(fs.clearance[i, j]):.3g} m)",
                            "move it into the free space (leave --start/--goal out for a drawn mission)")


@world_app.command("show")
def world_show(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", metavar="FILE", help=(
        "Where to write the preview PNG. Default: DIR/preview.png."))] = None,
) -> None:
    """Print a world's descriptors and write its top-down preview PNG."""
    world = World.load(world_dir)
    dest = output if output is not None else world_dir / PREVIEW
    check_file_out(dest)
    write_preview(world, dest)
    con = console()
    con.print(_descriptor_table(world, f"world {world_dir}"))
    con.print(f"wrote {dest}")



@world_app.command("export")
def world_export(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    fmt: Annotated[str, typer.Option("--format", "-f", metavar="|".join(EXPORT_FORMATS), help=(
        "mjcf: standalone MuJoCo model (heightfield + boxes, no robot); sdf: Gazebo SDF world with "
        "start and goal markers (writes FILE and FILE-stem_heightmap.png beside it, resampled to a 2^n+1 "
        "square, 8 bits: read by every Gazebo version); gltf/glb: mesh scene (y-up, normals, materials, "
        "the terrain textured by height); obj: the same as Wavefront OBJ, y-up, with FILE-stem.mtl and "
        "FILE-stem_terrain.png beside it; png: 16-bit heightmap (height range in its text chunks)."))],
    output: Annotated[Path, typer.Option("--output", "-o", metavar="FILE", help="File to write.")],
    heightmap_bits: Annotated[str | None, typer.Option("--heightmap-bits", metavar="8|16", help=(
        "Bits per pixel of the heightmap PNG (sdf and png only). sdf: default 8, the one Gazebo "
        "Fortress reads (16 bits are read by Garden and later only); png: default 16."))] = None,
) -> None:
    """Export a world to another tool's format."""
    f = fmt.lower()
    if f not in EXPORT_FORMATS:
        raise SpecError("--format", fmt, f"one of {', '.join(EXPORT_FORMATS)}")
    bits = None
    if heightmap_bits is not None:
        if f not in ("sdf", "png"):
            raise SpecError("--heightmap-bits", heightmap_bits, f"given only with --format sdf or png (not {f})")
        if heightmap_bits.strip() not in ("8", "16"):
            raise SpecError("--heightmap-bits", heightmap_bits, "8 or 16")
        bits = int(heightmap_bits)
    check_file_out(output)
    world = World.load(world_dir)
    if f == "mjcf":
        _files.write_atomic(output, world_to_mjcf(world).encode("utf-8"))
        written = [output]
    elif f == "sdf":
        r = write_sdf(world, output, heightmap_bits=bits or 8)
        written = [r.sdf_path, r.heightmap_path]
        rows, cols = world.terrain.heights.shape
        if (rows, cols) != (r.heightmap_side, r.heightmap_side):
            click.echo(f"note: heightmap resampled from {cols}x{rows} to {r.heightmap_side}x{r.heightmap_side} "
                       "(Gazebo needs a square 2^n+1 image)")
    elif f == "png":
        info = write_heightmap_png(world.terrain, output, bits=bits or 16)
        written = [output]
        top = (1 << (bits or 16)) - 1
        click.echo(f"heightmap {info.width}x{info.height}, 0..{top} = {info.z_min:.4g}..{info.z_max:.4g} m")
    else:
        written = write_mesh(world, output, "glb" if f == "gltf" and output.suffix.lower() == ".glb" else f)
    click.echo(literal("wrote " + ", ".join(str(p) for p in written)))


@world_app.command("drive")
def world_drive(
    world_dir: Annotated[Path, typer.Argument(metavar="DIR", help="A world directory.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", metavar="FILE", help=(
        "Picture of the real path and the odometry path over the world (default DIR/drive.png)."))] = None,
    course: Annotated[str | None, typer.Option(metavar="SEGMENTS", help=(
        "Open-loop course from the mission start: 'v,omega,seconds; ...' (m/s, rad/s, s). Default: 20 m "
        "straight, quarter turn on the spot, 12 m straight, a right curve, 15 m straight."))] = None,
    seed: Annotated[str, typer.Option(metavar="N", help="Run seed (sensor noise, jitter), an integer in [0, 2**63-1]. Default 0.")] = "0",
    robot: RobotOpt = None,
    sensor: SensorOpt = None,
    sensor_add: SensorAddOpt = None,
) -> None:
    """Drive a scripted course in the simulation and draw where the robot really went."""
    robot_v = load_robot_flags(robot, sensor, sensor_add)
    world = World.load(world_dir)
    check_robot_fits(world.mission.free_radius_m, robot_v, "--robot")
    segs = parse_course(course) if course is not None else DEFAULT_COURSE
    seed_v = bounded_int("--seed", seed, 0, MAX_SEED)
    dest = output if output is not None else world_dir / "drive.png"
    if dest.exists() and dest.is_dir():
        raise SpecError("--output", str(dest), "a PNG file path, not a directory")
    check_stable(robot_v)
    probe_writable(dest)
    res = drive(world, segs, seed=seed_v, robot=robot_v)
    t = res.truth
    dist = float(np.sum(np.hypot(np.diff(t[:, 1]), np.diff(t[:, 2])))) if len(t) > 1 else 0.0
    odo_err = (math.hypot(res.odometry[-1, 0] - t[-1, 1], res.odometry[-1, 1] - t[-1, 2])
               if len(res.odometry) and len(t) else 0.0)
    con = console()
    con.print(f"drove {dist:.1f} m in {res.sim_s:.1f} s simulated ({res.real_time_factor:.0f}x real time); "
              f"odometry off by {odo_err:.2f} m at the end; collisions: {len(res.collisions)}"
              + (f"; stopped: {res.stopped}" if res.stopped else ""))
    pic = drive_picture(world, res, dest, f"scripted drive of {robot_v.name} on {world_dir.name}: {dist:.0f} m, "
                        f"{len(res.collisions)} collision(s)", robot=robot_v)
    con.print(f"picture: {pic}")
