"""The report's map pictures as inline SVG: a world drawn once, its runs drawn over it as vectors.

A campaign's report shows every map with the runs of each navigator and fault over it (the
paper preset: 345 maps, about 500 pictures, 2,375 runs). Drawn with matplotlib and embedded as
PNGs, those pictures weighed about 115 kB and took about half a second each. Here a world is
drawn once per map, as an SVG ``<g>`` in a hidden ``<defs>`` block: its terrain as one small
hillshaded PNG (one pixel per terrain cell, the same colours and light as ``draw_world``), its
obstacles (boxes and walls as polygons, cylinders as circles), start and goal as vector shapes; each picture ``<use>``\\ s it and adds its runs as
polylines (simplified with Ramer-Douglas-Peucker to a tenth of a percent of the map's size, well
under a pixel at the size they are shown), coloured by outcome, each carrying ``data-run`` so
the report's script links it with its row in the runs table, and a ``<title>`` (hovering a run
names it). Vectors stay sharp when the picture is enlarged (a click on a picture does that).

Coordinates are metres with the y axis flipped (SVG's y grows downwards): a world point (x, y)
is drawn at (x, sy - y), rounded to 5 cm.
"""

from __future__ import annotations

import base64
import functools
import io
import math
from typing import Any

import numpy as np
from matplotlib import colormaps
from PIL import Image

from navstress.analysis.polyline import rdp_keep
from navstress.run.figures import MOVER_COLOUR, OUTCOME_COLOURS, RunTrack, movers_at
from navstress.world.colours import GOAL_COLOUR as _GOAL
from navstress.world.colours import START_COLOUR as _START
from navstress.world.colours import kind_colour
from navstress.world.export.images import ground_norm, shaded_ground, terrain_cmap
from navstress.world.world import World

#: Colour steps of a perceived map's height.
PERCEIVED_LEVELS = 48

#: Styles of the pictures (the report embeds them once): outcome colours as classes, so that a
#: polyline carries a short class name rather than its colour.
CSS = "".join(
    [".map{width:100%;height:auto;border:1px solid #ddd;background:#fff;cursor:zoom-in;display:block}",
     ".maps figure{width:380px}.maps figure:has(.big){width:100%;max-width:1100px}.map.big{cursor:zoom-out}",
     ".map polyline{fill:none;stroke-width:1.6px;stroke-linejoin:round;vector-effect:non-scaling-stroke;"
     "opacity:.9}",
     ".map polyline.perceived{stroke:#2b83ba;stroke-dasharray:4 3}",
     ".map .obs{stroke:#000;stroke-width:.5px;vector-effect:non-scaling-stroke}",
     ".map .outline{fill:none;stroke:#000;stroke-width:.6px;vector-effect:non-scaling-stroke}",
     ".map .mv{fill:%s;stroke:#000;stroke-width:.5px;vector-effect:non-scaling-stroke;opacity:.8}" % MOVER_COLOUR,
     ".map .mvpath{fill:none;stroke:%s;stroke-width:.8px;vector-effect:non-scaling-stroke;opacity:.55}"
     % MOVER_COLOUR,
     ".map g.hl polyline{stroke-width:4px;opacity:1}",
     ".map.dim g[data-run]:not(.hl){opacity:.15}",
     "tr.hl td{background:#fff3b0}",
     ".legend span{display:inline-block;margin-right:1em;font-size:.85em}",
     ".legend i{display:inline-block;width:1.6em;height:.3em;vertical-align:middle;margin-right:.3em}"]
    + [".o-%s{stroke:%s}.o-%s circle,circle.o-%s{fill:%s;stroke:#fff}" % (o, c, o, o, c)
       for o, c in OUTCOME_COLOURS.items()])


def _png(img: Any) -> str:
    """A PIL image (or an (rows, cols, 3|4) uint8 array, row 0 at the top) as a PNG data URI."""
    buf = io.BytesIO()
    (img if isinstance(img, Image.Image) else Image.fromarray(img)).save(buf, format="PNG", compress_level=6)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _terrain_uri(rgb: np.ndarray) -> str:
    """The terrain picture as a data URI. A shaded surface is a smooth picture: JPEG (quality 85)
    stores it in about a sixth of the PNG's bytes, each channel within 1 level of 255 on average
    and 4 at the 99th percentile (measured on the paper preset's rough maps). One colour (flat
    ground) is a PNG of a few hundred bytes."""
    if (rgb == rgb[0, 0]).all():
        return _png(rgb)
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="JPEG", quality=85)
    return "data:image/jpeg;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def terrain_rgb(world: World) -> np.ndarray:
    """The hillshaded terrain, one pixel per cell, row 0 at the top (largest y), uint8 RGB:
    the colours and light of ``draw_world`` (flat ground in one light tone)."""
    rgb = shaded_ground(world.terrain)
    if rgb is None:
        h = world.terrain.heights.astype(np.float64)
        rgb = terrain_cmap()(ground_norm(h)(h))
    return np.asarray(np.clip(rgb[::-1, :, :3] * 255 + 0.5, 0, 255), dtype=np.uint8)


def _n(v: float) -> str:
    """A coordinate rounded to 5 cm, without a trailing ``.0``."""
    return _nq(int(round(v * 20)))


@functools.lru_cache(maxsize=1 << 16)
def _nq(q: int) -> str:
    """:func:`_n` of ``q / 20`` (``q``: a coordinate in 5 cm steps); memoised, since a report
    writes the same few thousand numbers millions of times."""
    r = q / 20
    return str(q // 20) if q % 20 == 0 else f"{r:.2f}".rstrip("0")


def _q(v: np.ndarray) -> list[int]:
    """``round(v * 20)`` of every element (numpy's rint rounds half to even, as ``round``)."""
    return np.rint(np.asarray(v, dtype=np.float64) * 20).astype(np.int64).tolist()  # type: ignore[no-any-return]


def _path(corners: np.ndarray, sy: float) -> str:
    """A closed polygon: the first corner absolute, the others relative to the one before (the
    5 cm grid of :func:`_n`: each corner rounded, then differenced, so no error accumulates)."""
    return _paths([corners], sy)[0]


def _circle(x: float, y: float, r: float, sy: float) -> str:
    """A closed circle (a cylinder's footprint) as two half-circle arcs of a path, on the 5 cm grid."""
    rq, xq, yq = _q(np.array([r, x - r, sy - y]))
    return (f"M{_nq(xq)} {_nq(yq)}a{_nq(rq)} {_nq(rq)} 0 1 0 {_nq(2 * rq)} 0"
            f"a{_nq(rq)} {_nq(rq)} 0 1 0 {_nq(-2 * rq)} 0z")


def _paths(polygons: list[np.ndarray], sy: float) -> list[str]:
    """:func:`_path` of each polygon ((n, 2) corners), rounded all at once."""
    if not polygons:
        return []
    c = np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polygons])
    qx, qy = _q(c[:, 0]), _q(sy - c[:, 1])
    out, at = [], 0
    for p in polygons:
        n = len(p)
        xs, ys = qx[at:at + n], qy[at:at + n]
        at += n
        out.append(f"M{_nq(xs[0])} {_nq(ys[0])}"
                   + "".join(f"l{_nq(bx - ax)} {_nq(by - ay)}" for ax, bx, ay, by in zip(xs, xs[1:], ys, ys[1:]))
                   + "z")
    return out


def simplify(xy: np.ndarray, tol: float) -> np.ndarray:
    """Ramer-Douglas-Peucker: the points of the polyline ``xy`` (N, 2) to keep so that no dropped
    point is farther than ``tol`` from the simplified line; first and last always kept (compiled:
    :func:`navstress.analysis.polyline.rdp_keep`)."""
    a = np.ascontiguousarray(xy, dtype=np.float64)
    if len(a) <= 2:
        return xy
    return np.asarray(xy[rdp_keep(a, float(tol))])


def _finite(xy: np.ndarray) -> np.ndarray:
    """The rows of (N, 2) ``xy`` that are finite (a diverged simulation may leave NaN poses)."""
    a = np.asarray(xy, dtype=np.float64)
    return a[np.isfinite(a).all(axis=1)]


def _points(xy: np.ndarray, sy: float, tol: float) -> str:
    s = simplify(_finite(xy), tol)
    return " ".join(f"{_nq(x)},{_nq(y)}" for x, y in zip(_q(s[:, 0]), _q(sy - s[:, 1])))


def world_defs(world: World, gid: str) -> str:
    """The world as an SVG ``<g id=gid>`` (for a hidden ``<defs>``): terrain image, obstacles by
    kind, the start and goal free areas, the start's heading and the goal."""
    sx, sy = world.size_m
    c = world.terrain.cell_m
    rows, cols = world.terrain.heights.shape
    # pixel centres on the grid's nodes: the image spans half a cell past every edge
    parts = [f'<g id="{gid}"><image href="{_terrain_uri(terrain_rgb(world))}" x="{_n(-c / 2)}" y="{_n(sy - (rows - 0.5) * c)}" '
             f'width="{_n(cols * c)}" height="{_n(rows * c)}" preserveAspectRatio="none" '
             'style="image-rendering:auto"/>']
    kinds = sorted({o.kind for o in world.obstacles})
    paths = _obstacle_paths(world)
    for kind in kinds:
        d = "".join(p for o, p in zip(world.obstacles, paths) if o.kind == kind)
        parts.append(f'<path class="obs" fill="{kind_colour(kind, kinds)}" d="{d}"><title>{kind}</title></path>')
    m = world.mission
    r = m.free_radius_m
    if r > 0:
        for (px, py), col in (((m.start[0], m.start[1]), _START), (m.goal, _GOAL)):
            parts.append(f'<circle cx="{_n(px)}" cy="{_n(sy - py)}" r="{_n(r)}" fill="{col}" fill-opacity=".1" '
                         f'stroke="{col}" stroke-dasharray="4 3" vector-effect="non-scaling-stroke"/>')
    x0, y0, yaw = m.start
    ln = max(3.0, 0.06 * max(sx, sy))
    parts.append(f'<line x1="{_n(x0)}" y1="{_n(sy - y0)}" x2="{_n(x0 + ln * math.cos(yaw))}" '
                 f'y2="{_n(sy - y0 - ln * math.sin(yaw))}" stroke="{_START}" stroke-width="3px" '
                 'vector-effect="non-scaling-stroke"/>')
    k = max(sx, sy) / 100.0  # marker sizes: about 1 % of the map
    parts.append(f'<circle cx="{_n(x0)}" cy="{_n(sy - y0)}" r="{_n(1.2 * k)}" fill="{_START}" stroke="#fff" '
                 'vector-effect="non-scaling-stroke"><title>start</title></circle>')
    gx, gy = m.goal
    star = []
    for i in range(10):
        rad = (2.2 if i % 2 == 0 else 0.9) * k
        a = math.pi / 2 + i * math.pi / 5
        star.append(f"{_n(gx + rad * math.cos(a))},{_n(sy - gy - rad * math.sin(a))}")
    parts.append(f'<polygon points="{" ".join(star)}" fill="{_GOAL}" stroke="#fff" '
                 'vector-effect="non-scaling-stroke"><title>goal</title></polygon></g>')
    return "".join(parts)


def _outline_d(world: World) -> str:
    """Every obstacle's footprint, as one path's ``d``."""
    return "".join(_obstacle_paths(world))


_OBSTACLE_PATHS: dict[int, tuple[World, list[str]]] = {}


def _obstacle_paths(world: World) -> list[str]:
    """:func:`_path` of every obstacle's footprint, in ``world.obstacles`` order; kept for the
    last few worlds (a report draws a world's obstacles and then their outlines)."""
    hit = _OBSTACLE_PATHS.get(id(world))
    if hit is not None and hit[0] is world:
        return hit[1]
    sy = world.size_m[1]
    boxes = [o for o in world.obstacles if o.shape == "box"]
    box_paths = iter(_paths([o.corners() for o in boxes], sy))
    paths = [next(box_paths) if o.shape == "box" else _circle(o.x, o.y, o.size[0] / 2, sy) for o in world.obstacles]
    if len(_OBSTACLE_PATHS) >= 8:
        _OBSTACLE_PATHS.pop(next(iter(_OBSTACLE_PATHS)))
    _OBSTACLE_PATHS[id(world)] = (world, paths)
    return paths


def obstacle_outlines(world: World) -> str:
    """Every obstacle's footprint as one outline path (over a perceived map)."""
    d = _outline_d(world)
    return f'<path class="outline" d="{d}"/>' if d else ""


def outline_defs(world: World, gid: str) -> tuple[str, str]:
    """(defs, use): every obstacle's outline once as ``<path id=gid>`` for a hidden ``<defs>``, and
    the ``<use>`` that draws it in a picture of the same world ('' and '' without obstacles)."""
    d = _outline_d(world)
    # styled here: the page's ".map .outline" rule does not reach a path drawn through <use> from elsewhere
    return (f'<path id="{gid}" d="{d}" fill="none" stroke="#000" stroke-width=".6px" '
            'vector-effect="non-scaling-stroke"/>', f'<use href="#{gid}"/>') if d else ("", "")


def _movers_at(world: World, movers: tuple[np.ndarray, np.ndarray], at: float, sy: float) -> str:
    out = []
    for mv, x, y, corners in movers_at(world, movers[0], movers[1], at):
        if corners is None:
            out.append(f'<circle class="mv" cx="{_n(x)}" cy="{_n(sy - y)}" r="{_n(mv.size[0] / 2)}"/>')
        else:
            out.append(f'<path class="mv" d="{_path(corners, sy)}"/>')
    return "".join(out)


def runs_svg(world: World, gid: str, tracks: list[tuple[str, RunTrack, str]], *, perceived: bool = False,
             label: str = "", attrs: str = "") -> str:
    """A picture: the world ``gid`` (from :func:`world_defs`) with ``tracks`` over it, each a
    (run id, track, tooltip); ``perceived``: the navigator's belief too, dashed; a track with
    movers shows where they were at its first collision (and their paths, in a one-run picture)."""
    sx, sy = world.size_m
    tol = 1e-3 * max(sx, sy)
    k = max(sx, sy) / 100.0
    body = []
    for run_id, tr, tip in tracks:
        cls = f"o-{tr.outcome}"
        g = [f'<g class="{cls}" data-run="{run_id}"><title>{tip}</title>']
        if tr.movers is not None and len(world.movers):
            if len(tracks) == 1:
                times, poses = tr.movers
                for i in range(poses.shape[1]):
                    g.append(f'<polyline class="mvpath" points="{_points(poses[:, i, :2], sy, tol)}"/>')
            if tr.collision_t is not None:
                g.append(_movers_at(world, tr.movers, tr.collision_t, sy))
        xy = _finite(tr.truth[:, 1:3]) if len(tr.truth) else np.zeros((0, 2))
        if len(xy):
            g.append(f'<polyline points="{_points(xy, sy, tol)}"/>')
            x, y = xy[-1]
            g.append(f'<circle cx="{_n(x)}" cy="{_n(sy - y)}" r="{_n(0.7 * k)}" '
                     'vector-effect="non-scaling-stroke"/>')
        if perceived and tr.perceived is not None and len(tr.perceived):
            g.append(f'<polyline class="perceived" points="{_points(tr.perceived[:, 1:3], sy, tol)}"/>')
        body.append("".join(g) + "</g>")
    return (f'<svg class="map" viewBox="0 0 {_n(sx)} {_n(sy)}" role="img" aria-label="{label}" {attrs}>'
            f'<use href="#{gid}"/>{"".join(body)}</svg>')


def perceived_svg(world: World, grid: np.ndarray, origin_xy: tuple[float, float], cell_m: float,
                  track: tuple[str, RunTrack, str] | None, *, label: str = "", attrs: str = "",
                  outlines: str | None = None) -> tuple[str, float]:
    """The navigator's final perceived elevation map (viridis, unknown cells pink) under the real
    obstacles' outlines (``outlines``: the markup that draws them, e.g. a ``<use>`` of
    :func:`outline_defs`; by default drawn here) and the run's real trajectory; returns the SVG and
    the unknown share of the map (cells inside it that were never seen)."""
    sx, sy = world.size_m
    g = np.asarray(grid, dtype=np.float64)
    rows, cols = g.shape
    unknown = ~np.isfinite(g)
    cx = origin_xy[0] + (np.arange(cols) + 0.5) * cell_m
    cy = origin_xy[1] + (np.arange(rows) + 0.5) * cell_m
    inside = ((cy >= 0) & (cy <= sy))[:, None] & ((cx >= 0) & (cx <= sx))[None, :]
    share = float(unknown[inside].mean()) if inside.any() else 1.0
    # a palette picture: index 0 the unknown pink, 1..LEVELS the viridis colours of the height
    # in LEVELS equal steps between the lowest and the highest known cell (a picture: the exact
    # heights are in the trace)
    idx = np.zeros((rows, cols), dtype=np.uint8)
    if (~unknown).any():
        lo, hi = float(np.min(g[~unknown])), float(np.max(g[~unknown]))
        t = (np.where(unknown, lo, g) - lo) / max(hi - lo, 1e-9)
        idx[~unknown] = 1 + np.minimum((t[~unknown] * PERCEIVED_LEVELS).astype(np.int64), PERCEIVED_LEVELS - 1)
    palette = [0xF4, 0xC2, 0xD7] + list(colormaps["viridis"](np.linspace(0, 1, PERCEIVED_LEVELS), bytes=True)[:, :3]
                                         .reshape(-1).tolist())
    pic = Image.frombytes("P", (cols, rows), np.ascontiguousarray(idx[::-1]).tobytes())
    pic.putpalette(palette)
    img = _png(pic)
    top = sy - (origin_xy[1] + rows * cell_m)
    body = [f'<rect width="{_n(sx)}" height="{_n(sy)}" fill="#fff"/>',
            f'<image href="{img}" x="{_n(origin_xy[0])}" y="{_n(top)}" width="{_n(cols * cell_m)}" '
            f'height="{_n(rows * cell_m)}" preserveAspectRatio="none" style="image-rendering:pixelated"/>',
            obstacle_outlines(world) if outlines is None else outlines]
    if track is not None and len(_finite(track[1].truth[:, 1:3])):
        run_id, tr, tip = track
        tol = 1e-3 * max(sx, sy)
        body.append(f'<g class="o-{tr.outcome}" data-run="{run_id}"><title>{tip}</title>'
                    f'<polyline points="{_points(tr.truth[:, 1:3], sy, tol)}"/></g>')
    return (f'<svg class="map" viewBox="0 0 {_n(sx)} {_n(sy)}" role="img" aria-label="{label}" {attrs}>'
            + "".join(body) + "</svg>", share)


def legend_html(labels: dict[str, str]) -> str:
    """The outcome colours, the start, the goal, the movers and the perceived line, once."""
    items = [f'<span><i style="background:{OUTCOME_COLOURS[o]}"></i>{lab}</span>' for o, lab in labels.items()]
    items += [f'<span><b style="color:{_START}">\u25cf</b> start</span>',
              f'<span><b style="color:{_GOAL}">\u2605</b> goal</span>',
              '<span><i style="background:repeating-linear-gradient(90deg,#2b83ba 0 4px,transparent 4px 7px)">'
              "</i>perceived (the navigator's belief)</span>",
              f'<span><b style="color:{MOVER_COLOUR}">\u25cf</b> movers at a collision</span>']
    return '<p class="legend">' + "".join(items) + "</p>"
