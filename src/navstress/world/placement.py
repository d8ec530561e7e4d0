"""Obstacle placement and ground levelling.

Placement (per obstacle type, largest mean footprint first, each type from its own
sub-stream ``rng(seed, "obstacles", kind)``):

* Obstacles are axis-aligned boxes (``yaw = 0``, the paper's default); sides and height are
  drawn uniformly in ``[base*(1-v), base*(1+v)]`` (``v`` = the type's variability).
* Bookkeeping is a conservative occupancy raster (cell ``r`` <= 0.25 m and <= a quarter of the
  smallest obstacle side, at most 4 M cells): an obstacle marks every raster cell its closed
  footprint touches, and the start/goal free discs mark every cell they touch. A candidate is
  accepted iff it lies inside the map (exact test) and every raster cell its footprint touches
  is free. Two boxes that overlap with positive area share an interior point, whose cell both
  mark, so accepted obstacles never overlap and never enter a free disc (exact, not
  approximate; the raster only makes the packing slightly less dense, by < 2 r per gap).
* Candidates are not drawn uniformly over the map (naive rejection sampling stalls near 28 %
  for 9 m buildings on 100 m): each round computes, with a summed-area table, the raster cells
  around which a box of the type's smallest size would fit, draws candidate cells uniformly
  among those (position uniform inside the cell) and accepts them sequentially (numba). This
  is random sequential adsorption restricted to the free space; rounds repeat until the target
  is met or no proposal fits for :data:`STALL_ROUNDS` rounds.
* Stopping and trimming: a type stops once within ``tol = min(STOP_TOL_PP pp, half a mean
  footprint)`` of its target. An obstacle that would overshoot the target by more than ``tol``
  has its sides scaled down (same aspect) so that the type lands exactly on its target; at most
  one obstacle per type is trimmed (its size may then be below the variability envelope).

Walls (the spec's ``obstacles.walls``, :mod:`navstress.world.shapes`) stand before placement:
each wall box marks every raster cell its closed (turned) footprint touches, so placed boxes keep
clear of them as they keep clear of each other.

Local moves (:func:`apply_moves`, the spec's ``obstacles.moves``) then shift single obstacles,
each only when the moved footprint keeps the constraints above, tested exactly on the real
shapes (turned boxes, cylinders: :mod:`navstress.world.shapes`).

Levelling (:func:`level_terrain`): an obstacle's *vertex box* is the set of terrain vertices
of every cell its footprint touches (the footprint's bounding box pushed out to the vertex
lattice: an apron of 0 to 1 cell). Every vertex of the vertex box is set to the base height
``z``, so the footprint lies exactly on the triangulated ground (no floating, no buried
corner). Obstacles whose vertex boxes share a vertex (gaps below about two cells) must share
``z``: they form a cluster (union-find) whose ``z`` is the mean raw height over the union of
their vertex boxes (so on rough ground a dense forest stands on terraces). Outside the vertex
boxes, within ``blend_m`` of one, the height is ``h + W * (z* - h)`` with
``W = max_k (1 - smoothstep(e_k / blend_m))`` and ``z*`` the inverse-square-distance weighted
mean of the nearby obstacles' ``z`` (``e_k`` = distance to vertex box k), which tends to
``z_k`` next to box k: a smooth return to the raw terrain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple, Sequence

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))
from navstress._records import full_record
from navstress.errors import GenerationError
from navstress.seeding import rng
from navstress.world import shapes
from navstress.world.freearea import Pins
from navstress.world.spec import ObstacleType, WorldSpec
from navstress.world.world import Mission, Obstacle

STOP_TOL_PP = 0.25  # stop a type once within this many percentage points of its target
FAIL_TOL_PP = 0.5  # the contract: achieved within 0.5 pp of the target, or GenerationError
STALL_ROUNDS = 4
MAX_ROUNDS = 2000
MAX_RASTER_CELLS = 4_000_000
BLEND_M = 2.0


@dataclass(frozen=True)
class Raster:
    """A conservative occupancy raster over the map: ``occ[b, a]`` covers
    x in [a*rx, (a+1)*rx), y in [b*ry, (b+1)*ry)."""

    occ: np.ndarray
    rx: float
    ry: float
    size_x: float
    size_y: float


@dataclass
class PlacementResult:
    """Obstacles placed plus bookkeeping per type (percentages of the map area)."""

    obstacles: list[Obstacle] = field(default_factory=list)
    achieved_pct: dict[str, float] = field(default_factory=dict)
    target_pct: dict[str, float] = field(default_factory=dict)
    attempts: dict[str, int] = field(default_factory=dict)
    rounds: dict[str, int] = field(default_factory=dict)
    trimmed: dict[str, int] = field(default_factory=dict)
    raster_cell_m: float = 0.0


def make_raster(size_x: float, size_y: float, min_side: float) -> Raster:
    """An empty raster with cells <= min(0.25, min_side/4) m (coarser if it would exceed 4 M cells)."""
    r = min(0.25, min_side / 4.0)
    r = max(r, math.sqrt(size_x * size_y / MAX_RASTER_CELLS))
    nx, ny = max(1, math.ceil(size_x / r)), max(1, math.ceil(size_y / r))
    return Raster(np.zeros((ny, nx), np.uint8), size_x / nx, size_y / ny, size_x, size_y)


def mark_disc(ras: Raster, cx: float, cy: float, radius: float) -> None:
    """Mark every raster cell that the closed disc touches (conservatively)."""
    if radius <= 0:
        return
    ny, nx = ras.occ.shape
    a0, a1 = max(0, int((cx - radius) // ras.rx)), min(nx - 1, int((cx + radius) // ras.rx))
    b0, b1 = max(0, int((cy - radius) // ras.ry)), min(ny - 1, int((cy + radius) // ras.ry))
    if a1 < a0 or b1 < b0:
        return
    xa = np.arange(a0, a1 + 1) * ras.rx
    yb = np.arange(b0, b1 + 1) * ras.ry
    dx = np.maximum(np.maximum(xa - cx, cx - (xa + ras.rx)), 0.0)
    dy = np.maximum(np.maximum(yb - cy, cy - (yb + ras.ry)), 0.0)
    hit = dx[None, :] ** 2 + dy[:, None] ** 2 <= radius * radius * (1 + 1e-9) + 1e-12
    ras.occ[b0:b1 + 1, a0:a1 + 1] |= hit.astype(np.uint8)


def free_centres(occ: np.ndarray, kx: int, ky: int) -> np.ndarray:
    """Flat indices of cells (b, a) whose (2ky+1) x (2kx+1) window is inside and all free."""
    ny, nx = occ.shape
    if 2 * kx + 1 > nx or 2 * ky + 1 > ny:
        return np.zeros(0, np.int64)
    s = np.zeros((ny + 1, nx + 1), np.int64)
    np.cumsum(np.cumsum(occ, axis=0, dtype=np.int64), axis=1, out=s[1:, 1:])
    wy, wx = 2 * ky + 1, 2 * kx + 1
    win = s[wy:, wx:] - s[:-wy, wx:] - s[wy:, :-wx] + s[:-wy, :-wx]
    bb, aa = np.nonzero(win == 0)
    out: np.ndarray = (bb + ky) * nx + (aa + kx)
    return out


#: The constants of one round of :func:`_accept`: a record (numpy structured dtype, one field a
#: line); :func:`new_round` demands every field.
ROUND = np.dtype([
    ("rx", np.float64), ("ry", np.float64),  # the raster's cell sides (m)
    ("size_x", np.float64), ("size_y", np.float64),  # the map's size (m)
    ("achieved", np.float64),  # obstacle area of the type placed before this round (m^2)
    ("target", np.float64),  # the type's target area (m^2)
    ("stop_tol", np.float64),  # the type stops within this of its target (m^2)
], align=True)
ROUND_FIELDS: frozenset[str] = frozenset(ROUND.names or ())


def new_round(**values: float) -> np.ndarray:
    """A one-record :data:`ROUND` array; every field must be given."""
    return full_record(ROUND, "ROUND", values)


class Candidates(NamedTuple):
    """One round's candidate obstacles of a type, in the order they are tried (:func:`_accept`)."""

    x: np.ndarray  # centres (m)
    y: np.ndarray
    sx: np.ndarray  # sides (m); an accepted obstacle's trimmed in place
    sy: np.ndarray
    keep: np.ndarray  # bool, written: accepted


@numba.njit(cache=True)
def _accept(occ: np.ndarray, cand: Candidates, rnd: np.ndarray) -> tuple[float, int, int]:
    """Sequentially accept candidates whose footprint cells are free; marks them, trims sizes
    in ``cand.sx``/``cand.sy`` in place (the round's constants: the one-record :data:`ROUND`
    array ``rnd``). Returns (achieved area, candidates tried, trimmed count)."""
    r = rnd[0]
    rx, ry, size_x, size_y, achieved, target, stop_tol = r.rx, r.ry, r.size_x, r.size_y, r.achieved, r.target, \
        r.stop_tol
    xs, ys, sxs, sys_, keep = cand.x, cand.y, cand.sx, cand.sy, cand.keep
    ny, nx = occ.shape
    tried = 0
    trimmed = 0
    for k in range(xs.shape[0]):
        if achieved >= target - stop_tol:
            break
        tried += 1
        sx = sxs[k]
        sy = sys_[k]
        area = sx * sy
        if achieved + area > target + stop_tol:
            f = math.sqrt((target - achieved) / area)
            sx *= f
            sy *= f
            area = sx * sy
        x0, x1 = xs[k] - sx / 2, xs[k] + sx / 2
        y0, y1 = ys[k] - sy / 2, ys[k] + sy / 2
        if x0 < 0.0 or y0 < 0.0 or x1 > size_x or y1 > size_y:
            continue
        a0 = int(math.floor(x0 / rx))
        a1 = min(nx - 1, int(math.floor(x1 / rx)))
        b0 = int(math.floor(y0 / ry))
        b1 = min(ny - 1, int(math.floor(y1 / ry)))
        ok = True
        for b in range(b0, b1 + 1):
            for a in range(a0, a1 + 1):
                if occ[b, a] != 0:
                    ok = False
                    break
            if not ok:
                break
        if not ok:
            continue
        for b in range(b0, b1 + 1):
            for a in range(a0, a1 + 1):
                occ[b, a] = 1
        if sx != sxs[k]:
            trimmed += 1
        sxs[k] = sx
        sys_[k] = sy
        keep[k] = True
        achieved += area
    return achieved, tried, trimmed


def _type_order(targets: dict[str, float], types: dict[str, ObstacleType]) -> list[str]:
    return sorted(targets, key=lambda k: (-types[k].base_m[0] * types[k].base_m[1], k))


def place_obstacles(spec: WorldSpec, mission: Mission, seed: int, fixed: Sequence[Obstacle] = (), *,
                    blocked: Sequence[Obstacle] = ()) -> PlacementResult:
    """Place every type's obstacles to its obstruction target (see the module docstring), clear of
    the ``fixed`` obstacles already there (the spec's walls: each marks every raster cell its
    closed footprint touches, :func:`navstress.world.shapes.mark`, so that no placed box overlaps it).

    ``blocked``: obstacles already there (an imported world's geometry), which the placed ones
    keep out of in the same way as ``fixed``.

    Raises :class:`GenerationError` naming the achieved value, the target and why, when a
    type ends more than 0.5 percentage points below its target."""
    types = spec.obstacles.all_types()
    targets = spec.obstacles.targets()
    size_x, size_y = spec.size_m
    map_area = size_x * size_y
    res = PlacementResult(target_pct=dict(targets))
    if not targets:
        return res
    min_side = min(min(types[k].base_m) * (1 - types[k].variability) for k in targets)
    ras = make_raster(size_x, size_y, min_side)
    res.raster_cell_m = max(ras.rx, ras.ry)
    sx0, sy0, _ = mission.start
    for cx, cy in ((sx0, sy0), mission.goal):
        mark_disc(ras, cx, cy, mission.free_radius_m)
    for o in fixed:
        shapes.mark(ras.occ, ras.rx, ras.ry, o)
    ny, nx = ras.occ.shape
    for o in blocked:  # (none for a generated world)
        shapes.mark(ras.occ, ras.rx, ras.ry, o)
    for kind in _type_order(targets, types):
        t = types[kind]
        gen = rng(seed, "obstacles", kind)
        v = t.variability
        lo_x, hi_x = t.base_m[0] * (1 - v), t.base_m[0] * (1 + v)
        lo_y, hi_y = t.base_m[1] * (1 - v), t.base_m[1] * (1 + v)
        mean_area = t.base_m[0] * t.base_m[1]
        target_area = targets[kind] / 100.0 * map_area
        stop_tol = min(STOP_TOL_PP / 100.0 * map_area, mean_area / 2)
        kx = max(0, math.ceil(lo_x / 2 / ras.rx) - 1)
        ky = max(0, math.ceil(lo_y / 2 / ras.ry) - 1)
        achieved, tried, trimmed, rounds, stall = 0.0, 0, 0, 0, 0
        placed: list[Obstacle] = []
        while achieved < target_area - stop_tol and rounds < MAX_ROUNDS and stall < STALL_ROUNDS:
            rounds += 1
            cells = free_centres(ras.occ, kx, ky)
            if cells.size == 0:
                break
            need = math.ceil((target_area - achieved) / mean_area)
            n = int(min(max(2 * need, 16), 200_000))
            pick = cells[gen.integers(0, cells.size, n)]
            in_cell = gen.random((n, 2))  # the position in the cell, uniform
            xs = (pick % nx + in_cell[:, 0]) * ras.rx
            ys = (pick // nx + in_cell[:, 1]) * ras.ry
            sxs = gen.uniform(lo_x, hi_x, n)
            sys_ = gen.uniform(lo_y, hi_y, n)
            szs = gen.uniform(t.height_m * (1 - v), t.height_m * (1 + v), n)
            keep = np.zeros(n, np.bool_)
            new_ach, k_tried, k_trim = _accept(ras.occ, Candidates(xs, ys, sxs, sys_, keep),
                                               new_round(rx=ras.rx, ry=ras.ry, size_x=size_x, size_y=size_y,
                                                         achieved=achieved, target=target_area, stop_tol=stop_tol))
            tried += k_tried
            trimmed += k_trim
            stall = stall + 1 if new_ach == achieved else 0
            achieved = new_ach
            for k in np.flatnonzero(keep):
                placed.append(Obstacle(kind=kind, x=float(xs[k]), y=float(ys[k]), yaw=0.0,
                                       size=(float(sxs[k]), float(sys_[k]), float(szs[k]))))
        pct = 100.0 * sum(o.area for o in placed) / map_area
        res.obstacles.extend(placed)
        res.achieved_pct[kind] = pct
        res.attempts[kind] = tried
        res.rounds[kind] = rounds
        res.trimmed[kind] = trimmed
        if pct < targets[kind] - FAIL_TOL_PP:
            why = ("no free position left" if rounds < MAX_ROUNDS else f"gave up after {MAX_ROUNDS} rounds")
            raise GenerationError(
                f"obstruction of '{kind}' reached {pct:.2f}% of the map, target {targets[kind]:.2f}% "
                f"(tolerance {FAIL_TOL_PP} pp): {why} for a {lo_x:g}x{lo_y:g} m or larger footprint after "
                f"{tried} attempts in {rounds} rounds ({len(placed)} placed); lower the target, use "
                "smaller obstacles, a larger map or a smaller mission.free_radius_m")
    return res


def _boxes(obstacles: list[Obstacle]) -> np.ndarray:
    """(n, 4) rows (x0, y0, x1, y1): each footprint's axis-aligned bounding box (exact for every
    shape: :func:`navstress.world.shapes.aabb`; a box's from its corners, as always)."""
    if not obstacles:
        return np.zeros((0, 4))
    return np.array([shapes.aabb(o) for o in obstacles], np.float64).reshape(-1, 4)


def _disc_clear(box: np.ndarray, cx: float, cy: float, r: float) -> bool:
    """Whether the closed box keeps out of the open disc of radius ``r`` around (cx, cy)."""
    ex = max(float(box[0]) - cx, 0.0, cx - float(box[2]))
    ey = max(float(box[1]) - cy, 0.0, cy - float(box[3]))
    return ex * ex + ey * ey >= r * r


def _clear_of_disc(o: Obstacle, box: np.ndarray, cx: float, cy: float, r: float) -> bool:
    """Whether the footprint of ``o`` (bounding box ``box``) keeps out of the open disc: a box not
    turned by its bounding box (the test of before shapes existed), others exactly."""
    if shapes.is_axis_box(o):
        return _disc_clear(box, cx, cy, r)
    return shapes.disc_clear(o, cx, cy, r)


def apply_moves(obstacles: list[Obstacle], spec: WorldSpec, mission: Mission,
                fixed: Sequence[Obstacle] = ()) -> tuple[list[Obstacle], list[int]]:
    """The obstacles after ``spec.obstacles.moves``, and for each move the index of the obstacle
    it moved, or -1 when it was not applied.

    Each move takes the obstacle whose centre is nearest its ``at`` (the first in placement order
    on a tie) and translates it by ``by`` if the moved footprint stays inside the map, shares no
    interior point with another obstacle's footprint nor with one of ``fixed`` (obstacles that
    are never moved: the spec's walls; touching is allowed) and keeps out of the start and goal
    free discs (exact tests on the real shapes, :mod:`navstress.world.shapes`: boxes turned or
    not, cylinders); otherwise the obstacle stays where it is. Moves apply one after the other,
    each to the obstacles as the previous ones left them; sizes, kinds and the order of the
    obstacles never change."""
    moves = spec.obstacles.moves
    out = list(obstacles)
    if not moves or not out:  # (nothing to do: no box is computed for a world without moves)
        return out, [-1] * len(moves)
    done: list[int] = []
    size_x, size_y = spec.size_m
    sx, sy, _ = mission.start
    discs = ((sx, sy), mission.goal)
    fixed = list(fixed)
    boxes = _boxes(out)
    fixed_boxes = _boxes(fixed)
    centres = np.array([(o.x, o.y) for o in out]).reshape(-1, 2)
    for mv in moves:
        ax, ay = mv.at
        k = int(np.argmin((centres[:, 0] - ax) ** 2 + (centres[:, 1] - ay) ** 2))
        dx, dy = mv.by
        moved = replace(out[k], x=out[k].x + dx, y=out[k].y + dy)
        b = _boxes([moved])[0]  # from the moved obstacle itself: the very box the world will hold
        ok = bool(b[0] >= 0.0 and b[1] >= 0.0 and b[2] <= size_x and b[3] <= size_y)
        ok = ok and all(_clear_of_disc(moved, b, cx, cy, mission.free_radius_m) for cx, cy in discs)
        if ok:
            hit = (b[0] < boxes[:, 2]) & (boxes[:, 0] < b[2]) & (b[1] < boxes[:, 3]) & (boxes[:, 1] < b[3])
            hit[k] = False
            # bounding boxes overlap: the footprints too for boxes not turned, else the exact test says
            ok = not any(shapes.overlap(moved, out[i]) for i in np.flatnonzero(hit))
        if ok and fixed:
            hit = (b[0] < fixed_boxes[:, 2]) & (fixed_boxes[:, 0] < b[2]) & (b[1] < fixed_boxes[:, 3]) \
                & (fixed_boxes[:, 1] < b[3])
            ok = not any(shapes.overlap(moved, fixed[i]) for i in np.flatnonzero(hit))
        if ok:
            out[k] = moved
            boxes[k] = b
            centres[k] = (moved.x, moved.y)
        done.append(k if ok else -1)
    return out, done


@numba.njit(cache=True)
def _find(parent: np.ndarray, k: int) -> int:
    while parent[k] != k:
        parent[k] = parent[parent[k]]
        k = parent[k]
    return k


class LevelBoxes(NamedTuple):
    """The obstacles' footprint bounding boxes (:func:`_level`), one entry per obstacle (m)."""

    x0: np.ndarray
    x1: np.ndarray
    y0: np.ndarray
    y1: np.ndarray


class PinArrays(NamedTuple):
    """:class:`~navstress.world.freearea.Pins` as :func:`_level` takes them."""

    mask: np.ndarray  # int8 per vertex: -1, or the area whose flat set holds it
    levels: np.ndarray  # per area: its level
    discs: np.ndarray  # rows: area index, centre x, centre y, flat-set radius


class LevelOut(NamedTuple):
    """What :func:`_level` writes besides the heights."""

    z: np.ndarray  # per obstacle: the z of its base
    root: np.ndarray  # per obstacle: the first obstacle of its cluster
    joined: np.ndarray  # (1,): an obstacle whose cluster holds vertices of two areas of different levels, or -1


@numba.njit(cache=True)
def _level(h: np.ndarray, cell: float, blend: float, boxes: LevelBoxes, pins: PinArrays,
           result: LevelOut) -> np.ndarray:
    """Level the vertex boxes of all obstacles (clusters sharing a vertex get one z), then blend;
    returns the heights.

    ``pins.mask`` (-1 or an area index per vertex): vertices kept as they are (the free areas'
    flat sets); a cluster holding one takes that area's level ``pins.levels`` (the first area's
    when it holds two); ``pins.discs`` (area, x, y, radius) are extra sources of the blend's z*.
    ``result.joined[0]``: an obstacle whose cluster holds vertices of two areas of different levels,
    else -1."""
    x0s, x1s, y0s, y1s = boxes.x0, boxes.x1, boxes.y0, boxes.y1
    pin, pin_z, discs = pins.mask, pins.levels, pins.discs
    zs_out, root_out, bad_out = result.z, result.root, result.joined
    rows, cols = h.shape
    n = x0s.shape[0]
    bj0 = np.empty(n, np.int64)
    bj1 = np.empty(n, np.int64)
    bi0 = np.empty(n, np.int64)
    bi1 = np.empty(n, np.int64)
    parent = np.arange(n)
    owner = np.full((rows, cols), -1, np.int64)
    for k in range(n):
        bj0[k] = max(0, int(math.floor(x0s[k] / cell)))
        bj1[k] = min(cols - 1, int(math.ceil(x1s[k] / cell)))
        bi0[k] = max(0, int(math.floor(y0s[k] / cell)))
        bi1[k] = min(rows - 1, int(math.ceil(y1s[k] / cell)))
        for i in range(bi0[k], bi1[k] + 1):
            for j in range(bj0[k], bj1[k] + 1):
                o = owner[i, j]
                if o < 0:
                    owner[i, j] = k
                else:
                    ra = _find(parent, o)
                    rb = _find(parent, k)
                    if ra != rb:
                        parent[max(ra, rb)] = min(ra, rb)
    acc = np.zeros(n)
    cnt = np.zeros(n, np.int64)
    rpin = np.full(n, -1, np.int64)
    bad_out[0] = -1
    for i in range(rows):
        for j in range(cols):
            o = owner[i, j]
            if o >= 0:
                r = _find(parent, o)
                acc[r] += h[i, j]
                cnt[r] += 1
                a = pin[i, j]
                if a >= 0:
                    if rpin[r] < 0:
                        rpin[r] = a
                    elif rpin[r] != a and pin_z[rpin[r]] != pin_z[a] and bad_out[0] < 0:
                        bad_out[0] = o
    zr = np.zeros(n)
    for k in range(n):
        if rpin[k] >= 0:
            zr[k] = pin_z[rpin[k]]  # a free area's level (float32-exact)
        elif cnt[k] > 0:
            zr[k] = np.float32(acc[k] / cnt[k])  # exactly representable in the float32 output
    for k in range(n):
        root_out[k] = _find(parent, k)
        zs_out[k] = zr[root_out[k]]
    out = h.copy()
    wmax = np.zeros((rows, cols))
    sm = np.zeros((rows, cols))
    smz = np.zeros((rows, cols))
    reach = int(math.ceil(blend / cell))
    for k in range(n):
        for i in range(max(0, bi0[k] - reach), min(rows - 1, bi1[k] + reach) + 1):
            dy = max(max(bi0[k] - i, i - bi1[k]), 0) * cell
            for j in range(max(0, bj0[k] - reach), min(cols - 1, bj1[k] + reach) + 1):
                if owner[i, j] >= 0:
                    continue
                dx = max(max(bj0[k] - j, j - bj1[k]), 0) * cell
                e = math.sqrt(dx * dx + dy * dy)
                if e >= blend:
                    continue
                t = e / blend
                w = 1.0 - t * t * (3.0 - 2.0 * t)
                if w > wmax[i, j]:
                    wmax[i, j] = w
                m = 1.0 / (e * e)
                sm[i, j] += m
                smz[i, j] += m * zs_out[k]
    for i in range(rows):
        for j in range(cols):
            if pin[i, j] >= 0:
                continue
            if owner[i, j] >= 0:
                out[i, j] = zr[_find(parent, owner[i, j])]
            elif wmax[i, j] > 0.0:
                for d in range(discs.shape[0]):  # a free area near: a source of z* too
                    dx, dy = j * cell - discs[d, 1], i * cell - discs[d, 2]
                    e = math.sqrt(dx * dx + dy * dy) - discs[d, 3]
                    if 0.0 < e < blend:
                        m = 1.0 / (e * e)
                        sm[i, j] += m
                        smz[i, j] += m * pin_z[int(discs[d, 0])]
                out[i, j] = h[i, j] + wmax[i, j] * (smz[i, j] / sm[i, j] - h[i, j])
    return out


@dataclass(frozen=True)
class Levelled:
    """Result of :func:`level_terrain`."""

    heights: np.ndarray  # float32
    obstacles: list[Obstacle]  # with z set
    n_clusters: int  # groups of obstacles sharing a levelled base
    largest_cluster: int
    #: an obstacle whose cluster holds vertices of two pinned areas of different levels (it stands at
    #: the first one's, and the other area is not flat there), else -1
    joined: int = -1


def level_terrain(heights: np.ndarray, cell_m: float, obstacles: list[Obstacle],
                  blend_m: float = BLEND_M, *, pins: Pins | None = None) -> Levelled:
    """Level the ground under every obstacle (see the module docstring); any yaw is accepted
    (the levelled box is the axis-aligned bounding box of the footprint).

    ``pins``: the free areas' flat sets (:mod:`navstress.world.freearea`), kept as they are: an
    obstacle cluster whose vertex boxes hold one of their vertices stands at that area's level, and
    the blend near them tends to it. A cluster holding vertices of two areas levelled at different
    heights is reported in ``Levelled.joined`` (:func:`navstress.world.generate` then levels the two
    areas at one height and levels again)."""
    h = np.asarray(heights, dtype=np.float64)
    if not obstacles:
        return Levelled(h.astype(np.float32), [], 0, 0)
    bb = _boxes(obstacles)  # exact footprint bounding boxes (a cylinder's: x +- r)
    lo, hi = bb[:, :2], bb[:, 2:]
    zs = np.zeros(len(obstacles))
    roots = np.zeros(len(obstacles), np.int64)
    if pins is None:
        pins = Pins(np.full(h.shape, -1, np.int8), np.zeros(0), np.zeros((0, 4)))
    joined = np.zeros(1, np.int64)
    out = _level(h, float(cell_m), float(blend_m),
                 LevelBoxes(lo[:, 0].copy(), hi[:, 0].copy(), lo[:, 1].copy(), hi[:, 1].copy()),
                 PinArrays(pins.mask, pins.levels, pins.discs), LevelOut(zs, roots, joined))
    placed = [replace(o, z=float(z)) for o, z in zip(obstacles, zs)]  # (its shape kept)
    sizes = np.bincount(roots)
    return Levelled(out.astype(np.float32), placed, int(np.count_nonzero(sizes)), int(sizes.max()), int(joined[0]))
