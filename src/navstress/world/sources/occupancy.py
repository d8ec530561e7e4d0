"""A ROS ``map_server`` map (its YAML and its PGM or PNG image) as a source (``kind: map``;
docs/worlds.md, "Imported maps (occupancy grids)").

The YAML and the image are read as ROS 2's ``nav2_map_server`` reads them (``map_io.cpp``,
``loadMapYaml`` and ``loadMapFromFile``; the ROS 1 ``map_server`` wiki page says the same):

- ``image`` (a path, relative to the YAML's folder), ``resolution`` (m per cell), ``origin``
  ``[x, y, yaw]`` (the pose of the image's lower-left cell's corner in the map frame; yaw
  counter-clockwise), ``negate`` (0/1, false/true), ``occupied_thresh``, ``free_thresh``,
  ``mode`` (``trinary``, the default, ``scale`` or ``raw``). ``map_server`` requires all but
  ``mode``; navstress fills in those that a map lacks with ROS 1 ``map_saver``'s values
  (``origin [0, 0, 0]``, ``negate 0``, ``occupied_thresh 0.65``, ``free_thresh 0.196``).
- A pixel's ``shade`` is the mean of its red, green and blue values over the image's largest
  value (a grey image: its value), in ``trinary`` mode with its alpha value as a fourth channel
  when the image has one; ``occ = shade`` when negated, else ``1 - shade``.
- ``trinary``: occupied when ``occ > occupied_thresh``, free when ``occ < free_thresh``, unknown
  otherwise. ``scale``: unknown where the pixel is not opaque; else occupied / free as in
  trinary, and between the thresholds a partial value ``rint(99..100 * (occ - free) / (occupied
  - free))``. ``raw``: the value ``round(255 shade)`` (negate ignored), unknown above 100.
- Image row 0 is the map's top (its largest y).

A cell of value 100 is a wall, 0..99 free ground (a partial value as Nav2's costmap static layer
takes it by default: ``lethal_cost_threshold`` 100, ``trinary_costmap`` true), unknown (-1) a
wall or free ground as ``options.unknown`` says. The wall cells are merged into few
axis-aligned rectangles (:func:`rectangles`), boxes of kind ``wall`` ``options.wall_height_m``
high, turned by the origin's yaw. The world is flat, shifted so that the map's lower-left corner
(of its bounding box, when turned) is (0, 0), padded on the right and top to whole terrain cells
and 10 m; ``World.source.origin`` is that corner in the map frame.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navstress.errors import SpecError
from navstress.specfile import load_file
from navstress.world.sources.digest import file_sha256
from navstress.world.spec import SourceSpec, WorldSpec, check_memory, max_world_bytes, MAX_WORLD_GIB_ENV
from navstress.world.world import Mission, Obstacle, Terrain, World, WorldSource

KIND = "map"

#: What ``map_server`` calls the modes.
MODES = ("trinary", "scale", "raw")
#: The values navstress uses for fields a map YAML leaves out (ROS 1 ``map_saver`` writes these).
DEFAULTS: dict[str, Any] = {"origin": [0.0, 0.0, 0.0], "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196,
                            "mode": "trinary"}
#: Peak bytes per image pixel of an import (the image, its shades and codes, the runs, the free
#: space grid and its distance transform), with a margin; the world's own grid is added.
BYTES_PER_PIXEL = 64
#: Smallest side of an imported world (WorldSpec's) and largest.
MIN_SIDE_M, MAX_SIDE_M = 10.0, 2000.0
#: Largest terrain grid side (vertices) an import makes: the ground is flat, so a coarser cell costs nothing.
MAX_GRID_SIDE = 1000
#: A note is added when a map makes more walls than this (a noisy map: each speck a wall).
MANY_WALLS = 20_000

FREE, OCCUPIED, UNKNOWN = 0, 1, 2


def claims(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in (".yaml", ".yml")


# ---- the YAML ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class MapYaml:
    """A map YAML's fields, checked (``image`` made absolute)."""

    path: Path
    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str


def _bad(path: Path, key: str, value: Any, expected: str, fix: str) -> SpecError:
    return SpecError(f"{path} {key}", value, expected, fix)


def _number(path: Path, key: str, v: Any, expected: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise _bad(path, key, v, expected, f"set {key}: in the map YAML")
    return float(v)


def read_yaml(path: Path) -> MapYaml:
    """The map YAML at ``path``, its fields checked (SpecError naming the file, the field and the fix)."""
    data = load_file(path, field=str(path))
    if not isinstance(data, dict) or "image" not in data:
        raise SpecError(str(path), "a YAML without image:", "a ROS map_server map YAML (image:, resolution:, "
                        "origin:, negate:, occupied_thresh:, free_thresh:)", "name the map's YAML, or set --kind")
    raw = {**DEFAULTS, **data}
    image = raw["image"]
    if not isinstance(image, str) or not image.strip():
        raise _bad(path, "image", image, "the path of the map's PGM or PNG image", "set image: in the map YAML")
    img = Path(image)
    if not img.is_absolute():
        img = path.parent / img
    if "resolution" not in data:
        raise SpecError(f"{path} resolution", "missing", "the map's resolution in m per cell, > 0",
                        "add resolution: to the map YAML")
    res = _number(path, "resolution", raw["resolution"], "the map's resolution in m per cell, a number > 0")
    if not res > 0:
        raise _bad(path, "resolution", raw["resolution"], "the map's resolution in m per cell, a number > 0",
                   "set resolution: in the map YAML")
    o = raw["origin"]
    if not isinstance(o, list) or len(o) != 3:
        raise _bad(path, "origin", o, "[x, y, yaw]: three numbers (m, m, rad)", "set origin: in the map YAML")
    origin = tuple(_number(path, "origin", v, "[x, y, yaw]: three finite numbers (m, m, rad)") for v in o)
    neg = raw["negate"]
    if neg not in (0, 1) or isinstance(neg, float):
        raise _bad(path, "negate", neg, "0 or 1 (true or false)", "set negate: in the map YAML")
    occ = _number(path, "occupied_thresh", raw["occupied_thresh"], "a probability in [0, 1]")
    free = _number(path, "free_thresh", raw["free_thresh"], "a probability in [0, 1]")
    for key, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise _bad(path, key, raw[key], "a probability in [0, 1]", f"set {key}: in the map YAML")
    if free >= occ:
        raise _bad(path, "free_thresh", raw["free_thresh"], f"a threshold below occupied_thresh={occ:g} "
                   "(free cells are the ones less likely occupied)", "swap or fix the thresholds in the map YAML "
                   "(map_server's usual: occupied_thresh 0.65, free_thresh 0.196)")
    mode = raw["mode"]
    if mode not in MODES:
        raise _bad(path, "mode", mode, f"one of {', '.join(MODES)}", "set mode: in the map YAML (or leave it out: trinary)")
    return MapYaml(path=path, image=img, resolution=res, origin=(origin[0], origin[1], origin[2]), negate=bool(neg),
                   occupied_thresh=occ, free_thresh=free, mode=str(mode))


# ---- the image: header, then pixels -----------------------------------------------------------


@dataclass(frozen=True)
class ImageInfo:
    """An image's header: ``fmt`` (``pgm`` or ``png``), size, and for a PGM its maximum value,
    encoding (``P2`` text or ``P5`` binary) and where its pixels start."""

    path: Path
    fmt: str
    width: int
    height: int
    maxval: int = 255
    magic: str = ""
    data_offset: int = 0


_PNG_SIG = b"\x89PNG\r\n\x1a\n"


def image_info(m: MapYaml) -> ImageInfo:
    """The header of ``m``'s image (its pixels are not read)."""
    p = m.image
    if not p.is_file():
        raise _bad(m.path, "image", str(p), f"an existing PGM or PNG file (none at {p}; a relative path is relative "
                   "to the YAML's folder)", "fix image: in the map YAML or put the image beside it")
    try:
        with open(p, "rb") as f:
            head = f.read(4096)
    except OSError as err:
        raise _bad(m.path, "image", str(p), f"a readable PGM or PNG file ({err.strerror})", "check its permissions") from None
    if head.startswith(_PNG_SIG):
        if len(head) < 24 or head[12:16] != b"IHDR":
            raise _bad(m.path, "image", str(p), "a PNG file (its header is cut short)", "save the image again")
        w, h = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        return ImageInfo(path=p, fmt="png", width=w, height=h)
    if head[:2] in (b"P2", b"P5"):
        return _pgm_header(m, p, head)
    raise _bad(m.path, "image", str(p), f"a PGM (P2 or P5) or PNG image (its first bytes are {head[:8]!r})",
               "convert the image to PGM or PNG and name it in image:")


def _pgm_header(m: MapYaml, p: Path, head: bytes) -> ImageInfo:
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:
        while pos < len(head) and head[pos:pos + 1].isspace():
            pos += 1
        if pos < len(head) and head[pos:pos + 1] == b"#":
            while pos < len(head) and head[pos:pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        start = pos
        while pos < len(head) and head[pos:pos + 1].isdigit():
            pos += 1
        if start == pos:
            raise _bad(m.path, "image", str(p), "a PGM image (its header: width, height and maximum value)",
                       "save the image again")
        fields.append(int(head[start:pos]))
    w, h, maxval = fields
    if not 0 < maxval < 65536 or w <= 0 or h <= 0:
        raise _bad(m.path, "image", str(p), f"a PGM image of size > 0 and maximum value in [1, 65535] (it says "
                   f"{w}x{h}, maximum {maxval})", "save the image again")
    return ImageInfo(path=p, fmt="pgm", width=w, height=h, maxval=maxval, magic=head[:2].decode(), data_offset=pos + 1)


def estimate_bytes(info: ImageInfo, spec: WorldSpec) -> int:
    """Peak memory of importing this image into a world of ``spec``."""
    return info.width * info.height * BYTES_PER_PIXEL + spec.memory_estimate_bytes


@dataclass(frozen=True, eq=False)
class Pixels:
    """An image's pixels: ``channels`` (h, w, c) integers, c = 1 (grey), 2 (grey, alpha), 3
    (RGB) or 4 (RGBA), each channel in [0, ``maxval``]."""

    channels: np.ndarray
    maxval: int


def read_pixels(m: MapYaml, info: ImageInfo) -> Pixels:
    if info.fmt == "pgm":
        return Pixels(_pgm_pixels(m, info), info.maxval)
    return _png_pixels(m, info)


def _pgm_pixels(m: MapYaml, info: ImageInfo) -> np.ndarray:
    n = info.width * info.height
    data = info.path.read_bytes()[info.data_offset:]
    if info.magic == "P5":
        dt = np.dtype(">u2") if info.maxval > 255 else np.dtype("u1")
        if len(data) < n * dt.itemsize:
            raise _bad(m.path, "image", str(info.path), f"a PGM image with {info.width}x{info.height} pixels (the "
                       f"file holds {len(data) // dt.itemsize})", "the image is cut short: save it again")
        a = np.frombuffer(data, dt, count=n)
    else:
        text = b" ".join(line.split(b"#", 1)[0] for line in data.splitlines())
        try:
            a = np.array(text.split(), dtype=np.int64)
        except ValueError:
            raise _bad(m.path, "image", str(info.path), "a P2 PGM image (whitespace-separated numbers)",
                       "save the image again") from None
        if len(a) < n:
            raise _bad(m.path, "image", str(info.path), f"a PGM image with {info.width}x{info.height} pixels (the "
                       f"file holds {len(a)})", "the image is cut short: save it again")
        a = a[:n]
    if int(a.max(initial=0)) > info.maxval:
        raise _bad(m.path, "image", str(info.path), f"a PGM image whose values are at most its maximum {info.maxval}",
                   "save the image again")
    return a.reshape(info.height, info.width, 1)


def _png_pixels(m: MapYaml, info: ImageInfo) -> Pixels:
    from PIL import Image

    try:
        with Image.open(info.path) as opened:
            opened.load()
            im: Image.Image = opened
            mode = im.mode
            if mode in ("P", "PA"):
                im = im.convert("RGBA" if "transparency" in im.info or mode == "PA" else "RGB")
                mode = im.mode
            elif mode == "1":
                im = im.convert("L")
                mode = "L"
            elif mode not in ("L", "LA", "RGB", "RGBA", "I", "I;16", "I;16B", "I;16L"):
                raise _bad(m.path, "image", str(info.path), f"a grey or RGB(A) PNG (this one is {mode})",
                           "save it as a grey PNG")
            a = np.asarray(im)
    except SpecError:
        raise
    except (OSError, ValueError, SyntaxError, zlib.error) as err:
        raise _bad(m.path, "image", str(info.path), f"a readable PNG image ({type(err).__name__}: {err})".splitlines()[0],
                   "save the image again") from None
    if mode.startswith("I"):
        maxval = 65535
        a = a.astype(np.int64)
    else:
        maxval = 255
    if a.ndim == 2:
        a = a[:, :, None]
    return Pixels(a, maxval)


# ---- pixels -> cells --------------------------------------------------------------------------


def classify(m: MapYaml, px: Pixels) -> np.ndarray:
    """The map's cells (uint8: FREE, OCCUPIED, UNKNOWN), rows as in the image (row 0 the top),
    by nav2_map_server's rules (module docstring) and Nav2's costmap's reading of its values."""
    a = px.channels
    c = a.shape[2]
    has_alpha = c in (2, 4)
    nsum = 4 if m.mode == "trinary" and has_alpha else 3
    top = nsum * px.maxval
    # a table over every possible sum: the same double arithmetic as map_io.cpp for each
    s = np.arange(top + 1, dtype=np.float64)
    shade = (s / nsum) / px.maxval
    occ = shade if m.negate else 1.0 - shade
    lut = np.full(top + 1, UNKNOWN, np.uint8)
    if m.mode == "raw":
        v = np.round(shade * 255)
        lut[v == 100] = OCCUPIED
        lut[(v >= 0) & (v < 100)] = FREE
    else:
        lut[occ < m.free_thresh] = FREE
        lut[m.occupied_thresh < occ] = OCCUPIED
        if m.mode == "scale":
            mid = ~(occ < m.free_thresh) & ~(m.occupied_thresh < occ)
            val = np.rint((occ - m.free_thresh) / (m.occupied_thresh - m.free_thresh) * 100.0)
            lut[mid & (val >= 100)] = OCCUPIED
            lut[mid & (val < 100)] = FREE
    if c == 1:  # a grey pixel is (v, v, v): the table at 3 v, indexed by v itself
        codes: np.ndarray = lut[::3][a[:, :, 0]]
    else:
        sums = a[:, :, 0].astype(np.int64) * 3 if c == 2 else a[:, :, :3].sum(axis=2, dtype=np.int64)
        if nsum == 4:
            sums += a[:, :, -1]
        codes = lut[sums]
    if m.mode == "scale" and has_alpha:
        codes[a[:, :, -1] != px.maxval] = UNKNOWN
    return codes


def rectangles(mask: np.ndarray) -> np.ndarray:
    """Axis-aligned rectangles that cover the True cells of ``mask`` exactly, without overlap:
    (n, 4) int64 rows ``(i0, j0, i1, j1)`` (half-open: rows i0..i1-1, columns j0..j1-1).

    Each row's runs of True cells, and a run merged with the runs of the rows after it that span
    the same columns (a greedy extension: each rectangle is as wide as its run, then as tall as
    identical runs go); done along the rows and along the columns, the fewer rectangles kept. A
    straight wall of any thickness is one rectangle, a room's outline four."""
    from navstress.world._gridkernels import col_runs, row_runs

    m = np.ascontiguousarray(mask, dtype=np.bool_)
    if m.ndim != 2 or m.size == 0:
        return np.zeros((0, 4), np.int64)
    a = _merge(row_runs(m))
    if len(a) <= 1:
        return a
    b = _merge(col_runs(m))[:, [1, 0, 3, 2]]
    return a if len(a) <= len(b) else b


def _merge(runs: np.ndarray) -> np.ndarray:
    """Runs ``(line, start, end)`` merged across consecutive lines with the same (start, end):
    rows ``(line0, start, line1, end)``."""
    if len(runs) == 0:
        return np.zeros((0, 4), np.int64)
    r, a, b = runs[:, 0], runs[:, 1], runs[:, 2]
    order = np.lexsort((r, b, a))
    r, a, b = r[order], a[order], b[order]
    new = np.ones(len(r), bool)
    new[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1]) | (r[1:] != r[:-1] + 1)
    first = np.flatnonzero(new)
    last = np.r_[first[1:], len(r)] - 1
    return np.stack([r[first], a[first], r[last] + 1, b[first]], axis=1).astype(np.int64)


# ---- the world ---------------------------------------------------------------------------------


def terrain_cell(resolution: float, extent_m: float) -> float:
    """The imported world's terrain cell: the map's resolution, at least 0.1 m and coarse enough
    for at most :data:`MAX_GRID_SIDE` vertices a side (the ground is flat), rounded up to 0.05 m, at most 2 m."""
    c = max(resolution, 0.1, extent_m / MAX_GRID_SIDE)
    return min(2.0, math.ceil(c / 0.05 - 1e-9) * 0.05)


def _side(extent: float, cell: float) -> float:
    n = max(math.ceil(extent / cell - 1e-9), math.ceil(MIN_SIDE_M / cell - 1e-9))
    return round(n * cell, 9)


@dataclass(frozen=True, eq=False)
class Layout:
    """Where the map lies in the world: the map frame's point at the world's (0, 0)
    (``origin``), the world's size and terrain cell, and the map's cells' frame in the world
    (corner ``corner`` of cell (0, 0) of the flipped grid, turned by ``yaw``)."""

    origin: tuple[float, float]
    size_m: tuple[float, float]
    cell_m: float
    corner: tuple[float, float]
    yaw: float


def layout(m: MapYaml, width: int, height: int) -> Layout:
    """The imported world's frame and size for a map of ``width`` x ``height`` cells (SpecError
    when it spans more than navstress's largest world)."""
    ox, oy, yaw = m.origin
    w, h = width * m.resolution, height * m.resolution
    if yaw == 0.0:
        lo = (0.0, 0.0)
        ext = (w, h)
    else:
        c, s = math.cos(yaw), math.sin(yaw)
        xs = [c * x - s * y for x, y in ((0, 0), (w, 0), (0, h), (w, h))]
        ys = [s * x + c * y for x, y in ((0, 0), (w, 0), (0, h), (w, h))]
        lo = (min(xs), min(ys))
        ext = (max(xs) - lo[0], max(ys) - lo[1])
    if max(ext) > MAX_SIDE_M:
        raise _bad(m.path, "resolution", m.resolution, f"a map at most {MAX_SIDE_M:g} m a side (navstress's largest "
                   f"world; {width}x{height} cells at {m.resolution:g} m span {ext[0]:.6g} x {ext[1]:.6g} m)",
                   "check resolution: (metres per cell), or crop the map")
    cell = terrain_cell(m.resolution, max(ext))
    size = (_side(ext[0], cell), _side(ext[1], cell))
    return Layout(origin=(ox + lo[0], oy + lo[1]), size_m=size, cell_m=cell, corner=(-lo[0], -lo[1]), yaw=yaw)


def walls(rects: np.ndarray, m: MapYaml, lay: Layout, height_m: float) -> tuple[Obstacle, ...]:
    """The boxes of ``rects`` (in the image's flipped grid: row 0 at the bottom) in the world's frame."""
    if len(rects) == 0:
        return ()
    r = m.resolution
    i0, j0, i1, j1 = (rects[:, k].astype(np.float64) for k in range(4))
    lx, ly = (j0 + j1) * (r / 2), (i0 + i1) * (r / 2)
    sx, sy = (j1 - j0) * r, (i1 - i0) * r
    if lay.yaw == 0.0:
        x, y = lx + lay.corner[0], ly + lay.corner[1]
    else:
        c, s = math.cos(lay.yaw), math.sin(lay.yaw)
        x, y = c * lx - s * ly + lay.corner[0], s * lx + c * ly + lay.corner[1]
    h = float(height_m)
    yaw = float(lay.yaw)
    return tuple(Obstacle(kind="wall", x=float(a), y=float(b), yaw=yaw, size=(float(u), float(v), h))
                 for a, b, u, v in zip(x.tolist(), y.tolist(), sx.tolist(), sy.tolist()))


@dataclass(frozen=True, eq=False)
class MapCells:
    """A map read into cells: its YAML, the cells (row 0 at the BOTTOM, i.e. flipped from the
    image), the blocked cells (walls, and unknown ones when imported as walls), the layout."""

    yaml: MapYaml
    cells: np.ndarray
    blocked: np.ndarray
    layout: Layout


def read_map(path: Path, options: SourceSpec) -> MapCells:
    """Read and check the map at ``path``: its YAML, its image's header, the memory it needs (a
    map too large is refused before its pixels are read), then its cells."""
    m = read_yaml(path)
    info = image_info(m)
    lay = layout(m, info.width, info.height)
    spec = _spec(lay, options)
    need, limit = estimate_bytes(info, spec), max_world_bytes()
    if need > limit:
        raise _bad(m.path, "image", str(info.path), f"a map needing at most {limit / (1 << 30):.3g} GiB of memory to "
                   f"import (its {info.width}x{info.height} cells need about {need / (1 << 30):.3g} GiB)",
                   f"crop or downsample the map, or raise {MAX_WORLD_GIB_ENV}")
    codes = np.ascontiguousarray(classify(m, read_pixels(m, info))[::-1])
    walls_of = np.array([False, True, options.unknown == "wall"])  # FREE, OCCUPIED, UNKNOWN
    return MapCells(yaml=m, cells=codes, blocked=walls_of[codes], layout=lay)


def _spec(lay: Layout, options: SourceSpec) -> WorldSpec:
    return check_memory(WorldSpec(size_m=lay.size_m, cell_m=lay.cell_m, source=options))


def _outline(m: MapYaml, lay: Layout, shape: tuple[int, ...]) -> list[list[float]]:
    w, h = shape[1] * m.resolution, shape[0] * m.resolution
    c, s = math.cos(lay.yaw), math.sin(lay.yaw)
    out = []
    for x, y in ((0.0, 0.0), (w, 0.0), (w, h), (0.0, h)):
        if lay.yaw == 0.0:
            out.append([x + lay.corner[0], y + lay.corner[1]])
        else:
            out.append([c * x - s * y + lay.corner[0], s * x + c * y + lay.corner[1]])
    return out


def load(path: Path, options: SourceSpec) -> World:
    """The map at ``path`` as a world (module docstring); its mission a placeholder (zero
    length, at the map's centre): the map has none, missions are given or drawn in the free space."""
    mc = read_map(path, options)
    m, lay = mc.yaml, mc.layout
    rects = rectangles(mc.blocked)
    obstacles = walls(rects, m, lay, options.wall_height_m)
    spec = _spec(lay, options)
    rows, cols = spec.grid_shape
    n = mc.cells.size
    counts = np.bincount(mc.cells.ravel(), minlength=3)
    notes: list[str] = []
    if lay.yaw != 0.0:
        notes.append(f"the map's origin yaw is {lay.yaw:g} rad: its walls are turned by it, the world is the turned "
                     "map's bounding box")
    if counts[UNKNOWN] and options.unknown == "wall":
        notes.append(f"{100 * counts[UNKNOWN] / n:.1f} % of the map's cells are unknown and became walls "
                     "(--unknown free: free ground)")
    if len(obstacles) > MANY_WALLS:
        notes.append(f"{len(obstacles)} walls: the map is noisy (each speck is a wall); clean it up or "
                     "raise occupied_thresh for a faster simulation")
    cx, cy = lay.size_m[0] / 2, lay.size_m[1] / 2
    desc: dict[str, Any] = {
        "map_cells": [int(mc.cells.shape[1]), int(mc.cells.shape[0])],
        "map_resolution_m": m.resolution,
        "map_occupied_pct": round(100 * float(counts[OCCUPIED]) / n, 4),
        "map_unknown_pct": round(100 * float(counts[UNKNOWN]) / n, 4),
        "map_free_pct": round(100 * float(counts[FREE]) / n, 4),
        "walls": len(obstacles),
        # the map's outline in the world (its lower-left, lower-right, upper-right, upper-left corners): the
        # padding around it is outside the map, never free space for missions (navstress.world.freespace)
        "map_outline_m": _outline(m, lay, mc.cells.shape),
    }
    if notes:
        desc["import_notes"] = notes
    src = WorldSource(kind=KIND, path=str(path.resolve()), sha256=file_sha256(path, m.image), origin=lay.origin)
    return World(spec=spec, seed=0, terrain=Terrain(np.zeros((rows, cols), np.float32), spec.cell_m),
                 obstacles=obstacles, mission=Mission(start=(cx, cy, 0.0), goal=(cx, cy), free_radius_m=0.0),
                 descriptors=desc, source=src)
