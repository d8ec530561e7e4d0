"""Pictures of a world: a heightmap PNG and a top-down preview.

Heightmap: a grayscale PNG of 16 bits (the default of ``world export -f png``) or 8 bits
(what every Gazebo version reads: the SDF export's default), north up (image row 0 is the
map's top edge, y = max), heights mapped linearly from [z_min, z_max] to [0, 2**bits - 1];
the range in meters is written as PNG text chunks (``navstress:z_min``, ``navstress:z_max``,
``navstress:cell_m``) and returned. Round trip error is at most half a quantisation step,
(z_max - z_min) / (2 * (2**bits - 1)): 1/131070 of the range at 16 bits, 1/510 at 8.

Preview: a hillshaded, colour-coded terrain with a colour bar in meters, obstacles coloured per
kind (boxes and walls as rotated rectangles, cylinders as discs: regular
:data:`CYLINDER_SEGMENTS`-gons inscribed in them), start (with heading arrow) and goal, the free
areas around them, axes in meters, and a title with the key descriptors.
:func:`draw_world` draws onto any matplotlib ``Axes`` so that trajectories can be
overlaid later on the same picture.
"""

from __future__ import annotations

import io
import math
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import PolyCollection
from matplotlib.colors import LightSource, LinearSegmentedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, FancyArrow, Patch
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from navstress import _files
from navstress.world.colours import GOAL_COLOUR as _GOAL
from navstress.world.colours import START_COLOUR as _START
from navstress.world.colours import TERRAIN_STOPS, kind_colour
from navstress.world.world import Terrain, World

#: The sides of the polygon a cylinder's disc is drawn as in a preview.
CYLINDER_SEGMENTS = 48

_Z_MIN, _Z_MAX, _CELL = "navstress:z_min", "navstress:z_max", "navstress:cell_m"


@dataclass(frozen=True)
class HeightmapInfo:
    """What :func:`write_heightmap_png` wrote: pixel 0 is ``z_min`` m, 2**bits - 1 is ``z_max`` m."""

    path: Path
    z_min: float
    z_max: float
    width: int
    height: int

    @property
    def z_range(self) -> float:
        return self.z_max - self.z_min


HEIGHTMAP_BITS = (8, 16)


def heightmap_png_bytes(heights: np.ndarray, cell_m: float, *, bits: int = 16) -> tuple[bytes, float, float]:
    """Encode a height grid (rows along +y) as a ``bits``-bit north-up PNG; returns (png, z_min, z_max).

    A flat grid (z_min == z_max) encodes as all zeros.
    """
    if bits not in HEIGHTMAP_BITS:
        raise ValueError(f"bits={bits!r}: expected one of {HEIGHTMAP_BITS}")
    h = np.asarray(heights, dtype=np.float64)
    if h.ndim != 2 or h.size == 0 or not np.all(np.isfinite(h)):
        raise ValueError("heights must be a non-empty 2-D array of finite values")
    z_min, z_max = float(h.min()), float(h.max())
    span = z_max - z_min
    top = float((1 << bits) - 1)
    dtype = np.uint16 if bits == 16 else np.uint8
    q = np.zeros(h.shape, dtype) if span <= 0 else np.rint((h - z_min) / span * top).astype(dtype)
    img = Image.fromarray(np.ascontiguousarray(q[::-1]))  # row 0 of the image = north edge
    info = PngInfo()
    info.add_text(_Z_MIN, repr(z_min))
    info.add_text(_Z_MAX, repr(z_max))
    info.add_text(_CELL, repr(float(cell_m)))
    buf = io.BytesIO()
    img.save(buf, format="PNG", pnginfo=info)
    return buf.getvalue(), z_min, z_max


def write_heightmap_png(terrain: Terrain, path: str | Path, *, bits: int = 16) -> HeightmapInfo:
    """Write the terrain as a ``bits``-bit grayscale PNG (one pixel per vertex), atomically."""
    p = Path(path)
    data, z_min, z_max = heightmap_png_bytes(terrain.heights, terrain.cell_m, bits=bits)
    _files.write_atomic(p, data)
    rows, cols = terrain.heights.shape
    return HeightmapInfo(path=p, z_min=z_min, z_max=z_max, width=cols, height=rows)


def read_heightmap_png(path: str | Path) -> tuple[np.ndarray, float, float]:
    """Read a heightmap PNG navstress wrote (8 or 16 bits): (heights rows along +y, z_min, z_max)."""
    with Image.open(path) as img:
        text: dict[str, Any] = dict(getattr(img, "text", {}))
        top = 255.0 if img.mode == "L" else 65535.0
        q = np.array(img, dtype=np.float64)
    if _Z_MIN not in text or _Z_MAX not in text:
        raise ValueError(f"{path}: not a navstress heightmap (no {_Z_MIN}/{_Z_MAX} text chunks)")
    z_min, z_max = float(text[_Z_MIN]), float(text[_Z_MAX])
    return (z_min + q[::-1] / top * (z_max - z_min)), z_min, z_max


# ---- preview ------------------------------------------------------------------------------

def terrain_cmap() -> Any:
    """The ground's colour map (matplotlib) of previews, meshes and the report's maps: light sand
    (low) -> olive -> brown (high), quiet enough for the obstacles to stand out."""
    return LinearSegmentedColormap.from_list("navstress_ground", list(TERRAIN_STOPS))


def obstruction_pct(world: World) -> float:
    """Percent of the map area covered by obstacle footprints (footprints never overlap)."""
    sx, sy = world.size_m
    return 100.0 * sum(o.area for o in world.obstacles) / (sx * sy)


def world_title(world: World) -> str:
    """A one/two-line title with the key descriptors: size, obstruction %, ground, seed."""
    sx, sy = world.size_m
    g = world.spec.ground
    if g.model == "fractal":
        ground = f"fractal ground (amp {g.amplitude_m:g} m, \u03bb {g.wavelength_m:g} m, {g.octaves} oct.)"
    elif g.model == "blender":
        ground = f"Blender s = {g.subdivisions}, d = {g.deformation:g}"
        if g.deformation == 0:
            ground += " (flat)"
    else:
        ground = f"s = {g.subdivisions}, d = {g.deformation:g} m"
        if g.deformation == 0:
            ground += " (flat)"
    counts: dict[str, int] = {}
    for o in world.obstacles:
        counts[o.kind] = counts.get(o.kind, 0) + 1
    parts = ", ".join(f"{n} {k}{'s' if n != 1 else ''}" for k, n in sorted(counts.items())) or "no obstacles"
    return (f"obstruction {obstruction_pct(world):.1f} %  \u00b7  {ground}  \u00b7  seed {world.seed}\n"
            f"{sx:g} m \u00d7 {sy:g} m, {parts}")


def ground_norm(h: np.ndarray) -> Normalize:
    """The ground colour scale over heights ``h``; flat ground is centred on its height, in a
    light tone rather than mid-brown."""
    z_min, z_max = float(h.min()), float(h.max())
    if z_max - z_min < 1e-6:
        z_min, z_max = z_min - 0.25, z_max + 0.75
    return Normalize(vmin=z_min, vmax=z_max)


def shaded_ground(terrain: Terrain) -> np.ndarray | None:
    """The hillshaded ground, float RGBA in [0, 1], (rows, cols, 4) with row 0 at y = 0 (light
    from the north-west); None when the ground is flat (nothing to shade)."""
    h = terrain.heights.astype(np.float64)
    if float(h.max() - h.min()) <= 1e-6:
        return None
    ls = LightSource(azdeg=315, altdeg=40)
    # LightSource assumes row 0 at the top; our row 0 is y = 0 (origin="lower"), so the light
    # would come from the south-east: shade the flipped grid and flip back instead.
    rgb: np.ndarray = ls.shade(h[::-1], cmap=terrain_cmap(), norm=ground_norm(h), blend_mode="soft", vert_exag=1.0,
                               dx=terrain.cell_m, dy=terrain.cell_m)[::-1]
    return rgb


def draw_world(ax: Axes, world: World, *, legend: bool = True, hillshade: bool = True) -> ScalarMappable:
    """Draw ``world`` top-down on ``ax`` (x right, y up, meters); returns the terrain mappable
    (for a colour bar). Later code can plot trajectories on the same ``ax``."""
    terrain = world.terrain
    h = terrain.heights.astype(np.float64)
    sx, sy = terrain.size_m
    norm = ground_norm(h)
    cmap = terrain_cmap()
    half = terrain.cell_m / 2
    extent = (-half, sx + half, -half, sy + half)
    rgb = shaded_ground(terrain) if hillshade else None
    if rgb is not None:
        ax.imshow(rgb, origin="lower", extent=extent, interpolation="bilinear", zorder=0)
    else:
        ax.imshow(h, origin="lower", extent=extent, cmap=cmap, norm=norm, interpolation="nearest", zorder=0)

    kinds = sorted({o.kind for o in world.obstacles})
    handles: list[Any] = []
    for kind in kinds:
        obs = [o for o in world.obstacles if o.kind == kind]
        colour = kind_colour(kind, kinds)
        polys = [o.corners() if o.shape == "box" else o.outline(CYLINDER_SEGMENTS) for o in obs]
        lw = 0.3 if len(obs) > 400 else 0.6
        ax.add_collection(PolyCollection(polys, facecolors=colour, edgecolors="black", linewidths=lw,
                                         alpha=0.95, zorder=3))
        handles.append(Patch(facecolor=colour, edgecolor="black", label=f"{kind} ({len(obs)})"))

    m = world.mission
    r = m.free_radius_m
    for (px, py), colour in (((m.start[0], m.start[1]), _START), (m.goal, _GOAL)):
        if r > 0:
            ax.add_patch(Circle((px, py), r, facecolor=colour, alpha=0.10, edgecolor=colour,
                                linestyle="--", linewidth=1.2, zorder=4))
    arrow_len = max(3.0, 0.06 * max(sx, sy))
    sxp, syp, yaw = m.start
    ax.add_patch(FancyArrow(sxp, syp, arrow_len * math.cos(yaw), arrow_len * math.sin(yaw),
                            width=arrow_len * 0.09, head_width=arrow_len * 0.32, head_length=arrow_len * 0.32,
                            length_includes_head=True, color=_START, zorder=6))
    ax.plot([sxp], [syp], marker="o", markersize=8, color=_START, markeredgecolor="white", zorder=7)
    ax.plot([m.goal[0]], [m.goal[1]], marker="*", markersize=17, color=_GOAL, markeredgecolor="white",
            markeredgewidth=1.0, zorder=7)

    ax.set_xlim(0, sx)
    ax.set_ylim(0, sy)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if legend:
        handles += [
            Line2D([], [], marker="o", color=_START, markeredgecolor="white", markersize=8, linestyle="",
                   label=f"start (yaw {math.degrees(yaw):.0f}\u00b0)"),
            Line2D([], [], marker="*", color=_GOAL, markeredgecolor="white", markersize=13, linestyle="",
                   label="goal"),
        ]
        if r > 0:
            handles.append(Patch(facecolor="#888888", alpha=0.25, edgecolor="#555555", linestyle="--",
                                 label=f"free area (r = {r:g} m)"))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                  fontsize=9, frameon=False)
    mappable = ScalarMappable(norm=norm, cmap=cmap)
    mappable.set_array(np.array([]))
    return mappable


def preview_png_bytes(world: World, *, dpi: int = 110) -> bytes:
    """Render the preview of ``world`` to PNG bytes (Agg backend; no display needed)."""
    sx, sy = world.size_m
    aspect = sy / sx
    fig = Figure(figsize=(9.5, max(4.0, 7.0 * aspect)), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    mappable = draw_world(ax, world)
    cbar = fig.colorbar(mappable, ax=ax, location="bottom", shrink=0.7, pad=0.01, aspect=40)
    cbar.set_label("ground height [m]")
    ax.set_title(world_title(world), fontsize=10.5, loc="left")
    ax.grid(True, color="white", alpha=0.35, linewidth=0.6)
    ax.set_axisbelow(False)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def write_preview(world: World, path: str | Path, *, dpi: int = 110) -> Path:
    """Write the top-down preview PNG of ``world`` to ``path`` (atomically); returns the path."""
    p = Path(path)
    _files.write_atomic(p, preview_png_bytes(world, dpi=dpi))
    return p


#: The preview written beside a world by ``navstress world generate``.
PREVIEW = "preview.png"


def save_with_preview(world: World, out: Path) -> None:
    """Save ``world`` to ``out`` with its preview (``PREVIEW``) so that either both appear or
    nothing does (the preview is rendered first)."""
    png = preview_png_bytes(world)  # render first: a failure here writes nothing
    existed = out.exists()
    try:
        world.save(out)
        _files.write_atomic(out / PREVIEW, png)
    except BaseException:
        if not existed:  # a world without its preview is partial output: take it back
            shutil.rmtree(out, ignore_errors=True)
        raise
