"""Gazebo SDF (1.9) world: heightmap ground, static boxes and cylinders, sun, physics.

The ground is a ``<heightmap>`` whose grayscale PNG is written beside the ``.sdf`` and
referenced by a relative URI (resolved against the SDF file by sdformat >= 9 / gz-sim;
Gazebo classic may need the folder on ``GAZEBO_RESOURCE_PATH``). The PNG has **8 bits** by
default: Gazebo Fortress (ign-common 4) reads a 16-bit heightmap as no terrain at all, every
version reads 8 bits; ``heightmap_bits=16`` is finer and for Garden and later only. Gazebo
scales the brightest pixel to the ``<size>``'s height, so the image always spans 0 to
2**bits - 1 (a flat map: all 0, and Gazebo's scale falls back to the size). Gazebo requires
square heightmap images of side 2**n + 1, so the terrain is **resampled** onto the next such
grid covering the whole map (a 251 x 251 grid becomes 257 x 257): the resampled values are the
triangulated surface (``Terrain.height_at``) at the new vertices, so the ground differs from
the simulator's by at most the piecewise-linear interpolation error between old vertices,
plus quantisation ((z_max - z_min) / 510 at 8 bits, / 131070 at 16).

Obstacles are static models named ``<kind>_<index>`` with ``<pose>x y z 0 0 yaw</pose>``
where z = obstacle base + half its height (the shape's centre), and a collision and a visual of
the obstacle's shape: a ``<box>`` of its size (boxes and walls), or a ``<cylinder>`` of its radius
and height as ``<length>`` (SDF's cylinders stand along z, as navstress's).
The mission is two static, visual-only models standing on the ground (nothing collides with
them): ``mission_start`` (a green disc with an arrow along the start heading) and
``mission_goal`` (a red disc and pole). Movers are not exported: they are steered during a
run by navstress's controller, which Gazebo does not have.

    >>> from navstress.world import World, WorldSpec
    >>> xml, png = sdf_world(World.flat(WorldSpec(size_m=(20.0, 20.0))), "ground.png")
    >>> xml.startswith("<?xml") and png.startswith(b"\\x89PNG")
    True
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from navstress._files import write_atomic_group
from navstress.world.export._grid import MARKER, MARKER_RGBA, next_pow2_plus1, resample_square
from navstress.world.export.images import heightmap_png_bytes
from navstress.world.world import World

SDF_VERSION = "1.9"
_COLOURS = {"tree": (0.12, 0.44, 0.23), "building": (0.23, 0.29, 0.39), "wall": (0.55, 0.53, 0.5)}
_DEFAULT_COLOUR = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class SdfExport:
    """What :func:`write_sdf` wrote."""

    sdf_path: Path
    heightmap_path: Path
    heightmap_side: int
    z_min: float
    z_max: float


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrs: str) -> ET.Element:
    el = ET.SubElement(parent, tag, attrs)
    if text is not None:
        el.text = text
    return el


def _number_text(v: float) -> str:
    """``v`` as SDF text: 9 significant digits (``%.9g``)."""
    return f"{v:.9g}"


def _material(parent: ET.Element, rgb: tuple[float, float, float]) -> None:
    mat = _sub(parent, "material")
    c = " ".join(_number_text(v) for v in rgb) + " 1"
    _sub(mat, "ambient", c)
    _sub(mat, "diffuse", c)
    _sub(mat, "specular", "0.1 0.1 0.1 1")


def sdf_world(world: World, heightmap_uri: str, *, step_s: float = 0.002,
              heightmap_bits: int = 8) -> tuple[str, bytes]:
    """The SDF text of ``world`` and the PNG bytes of its heightmap (to be saved at ``heightmap_uri``)."""
    text, png, _, _, _ = _build(world, heightmap_uri, step_s, heightmap_bits)
    return text, png


_MARK_R, _MARK_T, _ARROW_L, _ARROW_W, _POLE_H = (MARKER[k] for k in (
    "radius", "thickness", "arrow_length", "arrow_width", "pole_height"))


def _rgb(key: str) -> tuple[float, float, float]:
    r, g, b, _ = MARKER_RGBA[key]
    return (r / 255, g / 255, b / 255)


_START_RGB, _GOAL_RGB = _rgb("start"), _rgb("goal")


def _visual(link: ET.Element, name: str, pose: str, geometry: tuple[str, dict[str, str]],
            rgb: tuple[float, float, float]) -> None:
    v = _sub(link, "visual", name=name)
    _sub(v, "pose", pose)
    g = _sub(_sub(v, "geometry"), geometry[0])
    for tag, text in geometry[1].items():
        _sub(g, tag, text)
    _material(v, rgb)


def _mission_models(w: ET.Element, world: World) -> None:
    ms, t = world.mission, world.terrain
    sx, sy, yaw = ms.start
    start = _sub(w, "model", name="mission_start")
    _sub(start, "static", "true")
    _sub(start, "pose", f"{_number_text(sx)} {_number_text(sy)} {_number_text(t.height_at(sx, sy))} 0 0 {_number_text(yaw)}")
    link = _sub(start, "link", name="link")
    disc = ("cylinder", {"radius": _number_text(_MARK_R), "length": _number_text(_MARK_T)})
    _visual(link, "disc", f"0 0 {_number_text(_MARK_T / 2)} 0 0 0", disc, _START_RGB)
    _visual(link, "heading", f"{_number_text(_ARROW_L / 2)} 0 {_number_text(_MARK_T * 1.5)} 0 0 0",
            ("box", {"size": f"{_number_text(_ARROW_L)} {_number_text(_ARROW_W)} {_number_text(_MARK_T)}"}), _START_RGB)
    gx, gy = ms.goal
    goal = _sub(w, "model", name="mission_goal")
    _sub(goal, "static", "true")
    _sub(goal, "pose", f"{_number_text(gx)} {_number_text(gy)} {_number_text(t.height_at(gx, gy))} 0 0 0")
    link = _sub(goal, "link", name="link")
    _visual(link, "disc", f"0 0 {_number_text(_MARK_T / 2)} 0 0 0", disc, _GOAL_RGB)
    _visual(link, "pole", f"0 0 {_number_text(_POLE_H / 2)} 0 0 0",
            ("cylinder", {"radius": "0.05", "length": _number_text(_POLE_H)}), _GOAL_RGB)


def _build(world: World, heightmap_uri: str, step_s: float,
           heightmap_bits: int) -> tuple[str, bytes, int, float, float]:
    terrain = world.terrain
    rows, cols = terrain.heights.shape
    side = next_pow2_plus1(max(rows, cols))
    grid = resample_square(terrain, side)
    png, z_min, z_max = heightmap_png_bytes(grid, terrain.cell_m, bits=heightmap_bits)
    sx, sy = terrain.size_m
    z_span = z_max - z_min if z_max > z_min else 1.0  # a flat map: all pixels 0 -> z_min

    sdf = ET.Element("sdf", version=SDF_VERSION)
    w = _sub(sdf, "world", name=f"navstress_{world.seed}")
    phys = _sub(w, "physics", name="default", type="ode")
    _sub(phys, "max_step_size", _number_text(step_s))
    _sub(phys, "real_time_factor", "1")
    _sub(phys, "real_time_update_rate", _number_text(1.0 / step_s))
    _sub(w, "gravity", "0 0 -9.81")
    scene = _sub(w, "scene")
    _sub(scene, "ambient", "0.5 0.5 0.5 1")
    _sub(scene, "background", "0.7 0.8 0.95 1")
    _sub(scene, "shadows", "true")

    sun = _sub(w, "light", name="sun", type="directional")
    _sub(sun, "cast_shadows", "true")
    _sub(sun, "pose", f"{_number_text(sx / 2)} {_number_text(sy / 2)} {_number_text(z_max + 50)} 0 0 0")
    _sub(sun, "diffuse", "0.85 0.85 0.8 1")
    _sub(sun, "specular", "0.2 0.2 0.2 1")
    _sub(sun, "direction", "-0.5 0.4 -0.8")

    ground = _sub(w, "model", name="ground")
    _sub(ground, "static", "true")
    link = _sub(ground, "link", name="link")
    for tag in ("collision", "visual"):
        el = _sub(link, tag, name=tag)
        hm = _sub(_sub(el, "geometry"), "heightmap")
        _sub(hm, "uri", heightmap_uri)
        _sub(hm, "size", f"{_number_text(sx)} {_number_text(sy)} {_number_text(z_span)}")
        _sub(hm, "pos", f"{_number_text(sx / 2)} {_number_text(sy / 2)} {_number_text(z_min)}")
        if tag == "visual":
            _material(el, (0.76, 0.69, 0.53))

    for k, o in enumerate(world.obstacles):
        m = _sub(w, "model", name=f"{o.kind}_{k:04d}")
        _sub(m, "static", "true")
        _sub(m, "pose", f"{_number_text(o.x)} {_number_text(o.y)} {_number_text(o.z + o.size[2] / 2)} 0 0 {_number_text(o.yaw)}")
        ln = _sub(m, "link", name="link")
        size = " ".join(_number_text(v) for v in o.size)
        for tag in ("collision", "visual"):
            el = _sub(ln, tag, name=tag)
            if o.is_cylinder:
                cyl = _sub(_sub(el, "geometry"), "cylinder")
                _sub(cyl, "radius", _number_text(o.size[0] / 2))
                _sub(cyl, "length", _number_text(o.size[2]))
            else:
                _sub(_sub(_sub(el, "geometry"), "box"), "size", size)
            if tag == "visual":
                _material(el, _COLOURS.get(o.kind, _DEFAULT_COLOUR))

    _mission_models(w, world)
    ms = world.mission
    w.append(ET.Comment(f" mission: start (x, y, yaw) = ({ms.start[0]:g}, {ms.start[1]:g}, "
                        f"{math.degrees(ms.start[2]):.1f} deg), goal = ({ms.goal[0]:g}, {ms.goal[1]:g}) "))
    ET.indent(sdf)
    text = '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(sdf, encoding="unicode") + "\n"
    return text, png, side, z_min, z_max


def write_sdf(world: World, path: str | Path, *, step_s: float = 0.002, heightmap_bits: int = 8) -> SdfExport:
    """Write ``path`` (.sdf) and ``<stem>_heightmap.png`` beside it (each atomically)."""
    p = Path(path)
    hm = p.with_name(f"{p.stem}_heightmap.png")
    text, png, side, z_min, z_max = _build(world, hm.name, step_s, heightmap_bits)
    write_atomic_group({p: text.encode("utf-8"), hm: png})  # both or neither
    return SdfExport(sdf_path=p, heightmap_path=hm, heightmap_side=side, z_min=z_min, z_max=z_max)
