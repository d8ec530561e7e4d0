"""The ``rooms`` generator: a floor plan of rooms and corridors (docs/worlds.md, "Generators: rooms
and clutter"; parameters :class:`~navstress.world.spec.RoomsSpec`).

The building fills the map (or as much of it as room sides in ``[room_min_m, room_max_m]`` can
fill exactly; the rest is a strip outside its outer wall). Along y it is a stack of room bands and
horizontal corridors (each corridor between two bands, or one band and the outer wall, so that
every room has a side on a corridor); along x a vertical corridor, the spine, crosses every band
and joins the corridors. Each band is cut into rooms. Sizes are between wall centre lines; the
corridors' and doors' widths are clear widths.

Doors: each room gets a number of doors drawn in ``[doors_min, doors_max]``: ``doors_min`` onto
its corridor first (they always fit: the spec checks it), then the others onto a corridor, the
spine or a neighbouring room that still takes one (a door between two rooms counts for both); at
least a wall's thickness from every corner and between doors. Walls: boxes of kind ``wall``, one
per straight run between doors (runs merged along each line); at a junction the wall that runs on
owns the crossing square and the other stops at its face, so walls touch but never overlap.

Furniture (``furniture_pct`` percent of the rooms' floor, each room its share): boxes of kind
``furniture`` of a few sizes (:data:`FURNITURE`, turned by 0 or 90 degrees; two in three against a
wall, the others anywhere), 5 cm off walls and each other, off every doorway (the door's width plus the robot's clearance each side, as deep as the
door is wide plus the clearance) and off the mission's free discs; a piece that would split a
room's free space (cells of :func:`~navstress.world.generators.raster.raster_cell_for` at the
robot's clearance, 4-connected) is not placed. Every room is then checked reachable from the
start by a flood fill of the whole map (GenerationError otherwise).

Mission: with ``mission.start``/``goal`` given, those (each must be clear of walls and furniture
by the robot's clearance); else the start and goal at the centres of two rooms: ``mode: paper``
the rooms nearest the lower-left and upper-right corners, ``mode: random`` a random room and one
of the farther half of rooms from it (``rng(seed, "mission")``); in a plan of one room, the goal at
the centre of the corridor farthest from it; the start faces the goal. Free
discs: ``mission.free_radius_m`` when the spec sets it, else the robot's half diagonal + 0.5 m.

Sub-streams: ``rng(seed, "rooms", "layout")`` (bands, spine, rooms), ``("rooms", "doors")``,
``("rooms", "furniture")``, ``"mission"``; movers as the outdoor generator's.

    >>> from navstress.world.spec import WorldSpec
    >>> w = generate_rooms(WorldSpec(size_m=(20.0, 16.0), cell_m=0.1, generator="rooms"), seed=1)
    >>> w.descriptors["rooms"]["n_rooms"] >= 4, sorted({o.kind for o in w.obstacles})
    (True, ['wall'])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from navstress.errors import GenerationError, SpecError
from navstress.robot import RobotSpec
from navstress.seeding import rng
from navstress.world.barn_metrics import barn_descriptor, barn_difficulty_of
from navstress.world.descriptors import describe
from navstress.world.generators.raster import components, footprint_distance, free_raster, raster_cell_for
from navstress.world.generators.sizing import check_robot_fits
from navstress.world.movers import mover_descriptors, place_movers
from navstress.world.spec import RoomsSpec, WorldSpec
from navstress.world.world import Mission, Obstacle, Terrain, World

EPS = 1e-9
#: Furniture: (name, length, width, height) in meters; all of kind ``furniture``.
FURNITURE = (("desk", 1.6, 0.8, 0.75), ("table", 1.2, 0.8, 0.75), ("cabinet", 1.0, 0.5, 1.8),
             ("chair", 0.5, 0.5, 0.9), ("sofa", 2.0, 0.9, 0.85))
#: Gap kept between a piece of furniture and walls or other pieces (m).
FURNITURE_GAP_M = 0.05
#: Extra free-disc radius beyond the robot's half diagonal when the spec sets none (m).
FREE_MARGIN_M = 0.5
#: Tries per piece of furniture and per room before its share is left short.
FURNITURE_TRIES = 120
DOOR_TRIES = 20


@dataclass(frozen=True)
class Space:
    """A room or a corridor: the rectangle between its walls' centre lines."""

    kind: str  # "room" | "corridor"
    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2)

    def clear(self, t: float) -> tuple[float, float, float, float]:
        """The floor inside its walls (x0, y0, x1, y1)."""
        h = t / 2
        return (self.x0 + h, self.y0 + h, self.x1 - h, self.y1 - h)


class Edge(NamedTuple):
    """A stretch of one wall line between two spaces (or a space and the outside, -1)."""

    horizontal: bool
    at: float  # the line: y of a horizontal one, x of a vertical one
    a: float  # its extent along the line
    b: float
    low: int  # the space below (horizontal) or left of it, -1 none
    high: int  # the space above or right of it, -1 none


class Door(NamedTuple):
    edge: int
    d0: float  # the clear opening along the line
    d1: float


def _split(total: float, n: int, lo: float, hi: float, gen: np.random.Generator) -> list[float]:
    """``n`` lengths in [lo, hi] summing to ``total`` (n*lo <= total <= n*hi), drawn."""
    w = np.full(n, lo)
    extra = total - n * lo
    weights = gen.random(n) + 0.05
    for _ in range(n + 1):
        room = hi - w
        open_ = room > EPS
        if extra <= EPS or not open_.any():
            break
        share = weights * open_ / (weights * open_).sum() * extra
        add = np.minimum(share, room)
        w += add
        extra -= float(add.sum())
    return [float(v) for v in w]


def _counts(length: float, lo: float, hi: float) -> list[int]:
    """The room counts n >= 1 with n*lo <= length <= n*hi (0 for a length of 0)."""
    if length <= EPS:
        return [0]
    return [n for n in range(max(1, math.ceil(length / hi - EPS)), int(math.floor(length / lo + EPS)) + 1)]


def _feasible(length: float, lo: float, hi: float) -> bool:
    """Whether ``length`` is a whole number of rooms (or 0)."""
    return length <= EPS or bool(_counts(length, lo, hi))


def _bands(rs: RoomsSpec, height: float, gen: np.random.Generator) -> tuple[list[tuple[str, float]], float]:
    """The bands bottom to top as (kind, depth) ("room" or "corridor"), and their total (<= height)."""
    lo, hi, cp = rs.room_min_m, rs.room_max_m, rs.corridor_width_m + rs.wall_thickness_m
    combos: list[tuple[int, int]] = []
    fallback: tuple[float, int, int] = (-1.0, 0, 0)
    for n_s in (0, 1):
        for n_d in range(int(height // (2 * lo + cp)) + 1):
            if n_d + n_s == 0:
                continue
            least = n_d * (2 * lo + cp) + n_s * (lo + cp)
            most = n_d * (2 * hi + cp) + n_s * (hi + cp)
            if least <= height + EPS <= most + 2 * EPS:
                combos.append((n_d, n_s))
            elif most < height and most > fallback[0]:
                fallback = (most, n_d, n_s)
    if combos:
        n_d, n_s = combos[int(gen.integers(len(combos)))]
        total = height
    elif fallback[0] > 0:  # no exact fill: the tallest building that fits, the rest outside it
        total, n_d, n_s = fallback
    else:
        raise GenerationError(f"no room band and corridor fit a height of {height:.3g} m; enlarge the map")
    depths = _split(total - (n_d + n_s) * cp, 2 * n_d + n_s, lo, hi, gen)
    units = ["D"] * n_d + ["S"] * n_s
    order = [units[i] for i in gen.permutation(len(units))]
    out: list[tuple[str, float]] = []
    k = 0
    for u in order:
        if u == "D":
            out += [("room", depths[k]), ("corridor", cp), ("room", depths[k + 1])]
            k += 2
        else:
            pair = [("room", depths[k]), ("corridor", cp)]
            out += pair if gen.random() < 0.5 else pair[::-1]
            k += 1
    return out, total


def _spine(rs: RoomsSpec, width: float, gen: np.random.Generator) -> tuple[float, float]:
    """(left part, right part) lengths beside the spine, each a whole number of rooms (or 0)."""
    lo, hi, cp = rs.room_min_m, rs.room_max_m, rs.corridor_width_m + rs.wall_thickness_m
    rest = width - cp
    cands = sorted({0.0, rest, *np.linspace(0.0, rest, 241).tolist()})
    ok = [c for c in cands if _feasible(c, lo, hi) and _feasible(rest - c, lo, hi)]
    if ok:
        left = ok[int(gen.integers(len(ok)))]
        return left, rest - left
    # no exact fill: the largest whole number of rooms on one side, the rest outside the building
    n = max(1, int(math.floor(rest / lo + EPS)))
    best = max((m * hi for m in range(1, n + 1) if m * hi <= rest + EPS), default=lo)
    return 0.0, best


def _plan(spec: WorldSpec, gen: np.random.Generator) -> list[Space]:
    rs = spec.rooms
    t = rs.wall_thickness_m
    sx, sy = spec.size_m
    lo, hi, cp = rs.room_min_m, rs.room_max_m, rs.corridor_width_m + t
    bands, _total = _bands(rs, sy - t, gen)
    left, right = _spine(rs, sx - t, gen)
    x_a, x_s0 = t / 2, t / 2 + left
    x_s1 = x_s0 + cp
    x_b = x_s1 + right
    spaces: list[Space] = []
    y = t / 2
    for kind, depth in bands:
        y1 = y + depth
        if kind == "corridor":
            spaces.append(Space("corridor", x_a, y, x_b, y1))
        else:
            for p0, p1 in ((x_a, x_s0), (x_s1, x_b)):
                length = p1 - p0
                if length <= EPS:
                    continue
                ns = _counts(length, lo, hi)
                n = ns[int(gen.integers(len(ns)))]
                widths = _split(length, n, lo, hi, gen)
                x = p0
                for k, w in enumerate(widths):
                    x1 = p1 if k == n - 1 else x + w
                    spaces.append(Space("room", x, y, x1, y1))
                    x = x1
            spaces.append(Space("corridor", x_s0, y, x_s1, y1))  # the spine's piece of this band
        y = y1
    return spaces


def _edges(spaces: list[Space]) -> list[Edge]:
    """Every stretch of wall line between two spaces or a space and the outside."""
    out: list[Edge] = []
    for horizontal in (True, False):
        lines: dict[float, list[tuple[float, float, int, bool]]] = {}
        for i, s in enumerate(spaces):
            if horizontal:
                sides = ((s.y0, s.x0, s.x1, False), (s.y1, s.x0, s.x1, True))  # (line, a, b, space below it)
            else:
                sides = ((s.x0, s.y0, s.y1, False), (s.x1, s.y0, s.y1, True))
            for at, a, b, below in sides:
                lines.setdefault(round(at, 9), []).append((a, b, i, below))
        for at in sorted(lines):
            sides_ = lines[at]
            cuts = sorted({round(v, 9) for a, b, _i, _lw in sides_ for v in (a, b)})
            pieces: list[list[Any]] = []
            for p, q in zip(cuts, cuts[1:]):
                if q - p <= EPS:
                    continue
                m = (p + q) / 2
                low = next((i for a, b, i, below in sides_ if below and a < m < b), -1)
                high = next((i for a, b, i, below in sides_ if not below and a < m < b), -1)
                if low < 0 and high < 0:
                    continue
                if pieces and pieces[-1][2] == low and pieces[-1][3] == high and abs(pieces[-1][1] - p) <= EPS:
                    pieces[-1][1] = q
                else:
                    pieces.append([p, q, low, high])
            out += [Edge(horizontal, at, p, q, low, high) for p, q, low, high in pieces]
    return out


def _walled(e: Edge, spaces: list[Space]) -> bool:
    """Whether a wall stands on edge ``e`` (not between two corridors)."""
    return not (e.low >= 0 and e.high >= 0 and spaces[e.low].kind == "corridor" and spaces[e.high].kind == "corridor")


def _doors(spaces: list[Space], edges: list[Edge], rs: RoomsSpec, gen: np.random.Generator) -> list[Door]:
    t, w = rs.wall_thickness_m, rs.door_width_m
    rooms = [i for i, s in enumerate(spaces) if s.kind == "room"]
    want = {i: int(gen.integers(rs.doors_min, rs.doors_max + 1)) for i in rooms}
    have = dict.fromkeys(rooms, 0)
    doors: list[Door] = []
    by_line: dict[tuple[bool, float], list[tuple[float, float]]] = {}

    def place(k: int) -> bool:
        e = edges[k]
        lo_, hi_ = e.a + t / 2 + t, e.b - t / 2 - t - w
        if hi_ < lo_ - EPS:
            return False
        taken = by_line.setdefault((e.horizontal, round(e.at, 9)), [])
        for _ in range(DOOR_TRIES):
            d0 = lo_ + float(gen.random()) * max(0.0, hi_ - lo_)
            d1 = d0 + w
            if all(d1 + t <= a - EPS or d0 - t >= b + EPS for a, b in taken):
                taken.append((d0, d1))
                doors.append(Door(k, d0, d1))
                for side in (e.low, e.high):
                    if side in have:
                        have[side] += 1
                return True
        return False

    def sides(i: int) -> list[int]:
        return [k for k, e in enumerate(edges) if i in (e.low, e.high) and e.low >= 0 and e.high >= 0 and _walled(e, spaces)]

    side_of = {i: sides(i) for i in rooms}
    for i in rooms:  # doors_min doors onto its corridor (the longest stretch of wall on one)
        onto = [k for k in side_of[i] if spaces[edges[k].high if edges[k].low == i else edges[k].low].kind == "corridor"]
        if not onto:
            raise GenerationError(f"room {i} has no wall on a corridor (a floor plan the rooms generator should not make)")
        main = max(onto, key=lambda k: (edges[k].b - edges[k].a, -k))
        e = edges[main]
        n = rs.doors_min
        slack = (e.b - e.a) - 3 * t - n * w - (n - 1) * t  # spread at random around the n doors
        if slack < -EPS:
            raise GenerationError(f"no room for {n} door(s) of {w:g} m on a room's corridor side; "
                                  "narrow rooms.door_width_m or raise rooms.room_min_m")
        gaps = np.diff(np.concatenate([[0.0], np.sort(gen.random(n)), [1.0]])) * max(0.0, slack)
        d0 = e.a + 1.5 * t
        taken = by_line.setdefault((e.horizontal, round(e.at, 9)), [])
        for k in range(n):
            d0 += float(gaps[k])
            taken.append((d0, d0 + w))
            doors.append(Door(main, d0, d0 + w))
            have[i] += 1
            d0 += w + t
    for i in rooms:  # the others: onto a corridor or a neighbour room that still takes one
        cands = list(side_of[i])
        while have[i] < want[i] and cands:
            k = cands[int(gen.integers(len(cands)))]
            e = edges[k]
            other = e.high if e.low == i else e.low
            if spaces[other].kind == "room" and have[other] >= want[other] or not place(k):
                cands.remove(k)
    return doors


def _cut(runs: list[list[float]], cuts: list[tuple[float, float]]) -> list[list[float]]:
    """Intervals ``runs`` ([a, b]) less the intervals ``cuts``."""
    out = runs
    for c0, c1 in cuts:
        nxt: list[list[float]] = []
        for a, b in out:
            if c1 <= a + EPS or c0 >= b - EPS:
                nxt.append([a, b])
                continue
            if c0 - a > EPS:
                nxt.append([a, c0])
            if b - c1 > EPS:
                nxt.append([c1, b])
        out = nxt
    return out


def _walls(spaces: list[Space], edges: list[Edge], doors: list[Door], rs: RoomsSpec) -> list[Obstacle]:
    t, h = rs.wall_thickness_m, rs.wall_height_m
    lines: dict[tuple[bool, float], list[list[float]]] = {}
    for e in edges:
        if _walled(e, spaces):
            lines.setdefault((e.horizontal, round(e.at, 9)), []).append([e.a, e.b])
    material: dict[tuple[bool, float], list[list[float]]] = {}
    for key, segs in lines.items():
        segs.sort()
        runs: list[list[float]] = []
        for a, b in segs:
            if runs and a <= runs[-1][1] + EPS:
                runs[-1][1] = max(runs[-1][1], b)
            else:
                runs.append([a, b])
        ext = [[a - t / 2, b + t / 2] for a, b in runs]
        openings = [(d.d0, d.d1) for d in doors if (edges[d.edge].horizontal, round(edges[d.edge].at, 9)) == key]
        material[key] = _cut(ext, openings)
    hs = [(at, r) for (hor, at), rs_ in material.items() if hor for r in rs_]
    vs = [(at, r) for (hor, at), rs_ in material.items() if not hor for r in rs_]
    h_cuts: dict[int, list[tuple[float, float]]] = {}
    v_cuts: dict[int, list[tuple[float, float]]] = {}
    for hi_, (y, (ha, hb)) in enumerate(hs):
        for vi, (x, (va, vb)) in enumerate(vs):
            if not (x - t / 2 < hb - EPS and x + t / 2 > ha + EPS and y - t / 2 < vb - EPS and y + t / 2 > va + EPS):
                continue
            v_ends = va > y - t / 2 - EPS or vb < y + t / 2 + EPS
            h_ends = ha > x - t / 2 - EPS or hb < x + t / 2 + EPS
            if v_ends or not h_ends:  # the horizontal wall owns the crossing square
                v_cuts.setdefault(vi, []).append((y - t / 2, y + t / 2))
            else:
                h_cuts.setdefault(hi_, []).append((x - t / 2, x + t / 2))
    out: list[Obstacle] = []
    for k, (y, r) in enumerate(hs):
        for a, b in _cut([r], h_cuts.get(k, [])):
            out.append(Obstacle("wall", round((a + b) / 2, 9), round(y, 9), 0.0, (round(b - a, 9), t, h)))
    for k, (x, r) in enumerate(vs):
        for a, b in _cut([r], v_cuts.get(k, [])):
            out.append(Obstacle("wall", round(x, 9), round((a + b) / 2, 9), 0.0, (t, round(b - a, 9), h)))
    return [o for o in out if o.size[0] > 1e-6 and o.size[1] > 1e-6]


def _rect(o: Obstacle) -> tuple[float, float, float, float]:
    return (o.x - o.size[0] / 2, o.y - o.size[1] / 2, o.x + o.size[0] / 2, o.y + o.size[1] / 2)


def _free_radius(spec: WorldSpec, robot: RobotSpec) -> float:
    if "free_radius_m" in spec.mission.model_fields_set:
        return float(spec.mission.free_radius_m)
    return robot.half_diagonal_m + FREE_MARGIN_M


def _mission(spec: WorldSpec, spaces: list[Space], walls: list[Obstacle], robot: RobotSpec, r: float,
             gen: np.random.Generator) -> Mission:
    m = spec.mission
    rooms = [s for s in spaces if s.kind == "room"]
    sx, sy = spec.size_m
    if m.mode == "paper":
        a = min(range(len(rooms)), key=lambda k: (math.hypot(*rooms[k].centre), k))
        b = min(range(len(rooms)), key=lambda k: (math.hypot(rooms[k].centre[0] - sx, rooms[k].centre[1] - sy), k))
    else:
        a = int(gen.integers(len(rooms)))
        far = sorted(range(len(rooms)), key=lambda k: (-math.hypot(rooms[k].centre[0] - rooms[a].centre[0],
                                                                   rooms[k].centre[1] - rooms[a].centre[1]), k))
        far = [k for k in far if k != a][:max(1, (len(rooms) - 1 + 1) // 2)]
        b = far[int(gen.integers(len(far)))] if far else a
    def farthest(pool: list[Space], frm: Space) -> Space:
        return max(pool, key=lambda q: math.hypot(q.centre[0] - frm.centre[0], q.centre[1] - frm.centre[1]))

    goal_space = rooms[b]
    if a == b:  # the rooms nearest both corners are one: the room farthest from it, or (one room) a corridor
        others = [q for k, q in enumerate(rooms) if k != a]
        goal_space = farthest(others or [q for q in spaces if q.kind == "corridor"], rooms[a])
    start_xy = m.start[:2] if m.start is not None else rooms[a].centre
    goal = m.goal if m.goal is not None else goal_space.centre
    yaw = float(m.start[2]) if m.start is not None else math.atan2(goal[1] - start_xy[1], goal[0] - start_xy[0])
    clear = robot.width_m / 2
    for name, (x, y) in (("start", start_xy), ("goal", goal)):
        d = footprint_distance((1, 1), 1.0, walls, clear, origin=(float(x), float(y)))[0, 0]
        if d < clear:
            raise GenerationError(f"mission.{name}=({x:g}, {y:g}) is {d:.3g} m from a wall, closer than the robot's "
                                  f"clearance {clear:.3g} m; move it into a room or a corridor")
    return Mission(start=(float(start_xy[0]), float(start_xy[1]), yaw), goal=(float(goal[0]), float(goal[1])),
                   free_radius_m=r)


def _door_zones(edges: list[Edge], doors: list[Door], depth: float, margin: float) -> list[tuple[float, float, float, float]]:
    """The rectangles kept free of furniture before each door, on both sides."""
    out = []
    for d in doors:
        e = edges[d.edge]
        a, b = d.d0 - margin, d.d1 + margin
        if e.horizontal:
            out.append((a, e.at - depth, b, e.at + depth))
        else:
            out.append((e.at - depth, a, e.at + depth, b))
    return out


def _overlaps(r: tuple[float, float, float, float], s: tuple[float, float, float, float], gap: float = 0.0) -> bool:
    return r[0] < s[2] + gap and s[0] < r[2] + gap and r[1] < s[3] + gap and s[1] < r[3] + gap


def _disc_hits(r: tuple[float, float, float, float], cx: float, cy: float, rad: float) -> bool:
    dx = max(r[0] - cx, 0.0, cx - r[2])
    dy = max(r[1] - cy, 0.0, cy - r[3])
    return dx * dx + dy * dy < rad * rad


class _RoomRaster:
    """A room's floor as raster cells of the map's grid (centres (j + 1/2) * cell), for the check
    that furniture leaves its free space in one piece."""

    def __init__(self, clear: tuple[float, float, float, float], cell: float, walls: list[Obstacle], clearance: float):
        self.cell, self.clearance = cell, clearance
        j0, j1 = int(math.ceil(clear[0] / cell - 0.5)), int(math.floor(clear[2] / cell - 0.5))
        i0, i1 = int(math.ceil(clear[1] / cell - 0.5)), int(math.floor(clear[3] / cell - 0.5))
        self.shape = (max(0, i1 - i0 + 1), max(0, j1 - j0 + 1))
        self.origin = ((j0 + 0.5) * cell, (i0 + 0.5) * cell)
        near = [w for w in walls if _overlaps(_rect(w), clear, clearance + cell)]
        self.base = footprint_distance(self.shape, cell, near, clearance, origin=self.origin) >= clearance \
            if self.shape[0] and self.shape[1] else np.zeros(self.shape, bool)

    def one_piece(self, pieces: list[Obstacle]) -> bool:
        if not self.base.size:
            return True
        free = self.base & (footprint_distance(self.shape, self.cell, pieces, self.clearance, origin=self.origin)
                            >= self.clearance)
        labels = components(free)
        return int(labels.max()) <= 1


def _furniture(spec: WorldSpec, spaces: list[Space], edges: list[Edge], doors: list[Door], walls: list[Obstacle], *,
               mission: Mission, robot: RobotSpec, cell: float, gen: np.random.Generator) -> list[Obstacle]:
    rs = spec.rooms
    t, g = rs.wall_thickness_m, FURNITURE_GAP_M
    if rs.furniture_pct <= 0:
        return []
    clearance = robot.width_m / 2
    zones = _door_zones(edges, doors, rs.door_width_m + clearance, clearance)
    discs = ((mission.start[0], mission.start[1]), mission.goal)
    out: list[Obstacle] = []
    carry = 0.0  # the share a room did not take (or took too much), handed to the next
    for s in spaces:
        if s.kind != "room":
            continue
        clear = s.clear(t)
        area = (clear[2] - clear[0]) * (clear[3] - clear[1])
        target = area * rs.furniture_pct / 100.0 + carry
        raster = _RoomRaster(clear, cell, walls, clearance)
        room_zones = [z for z in zones if _overlaps(z, clear)]
        placed: list[Obstacle] = []
        got = 0.0
        misses = 0
        while misses < FURNITURE_TRIES:
            name, length, width, height = FURNITURE[int(gen.integers(len(FURNITURE)))]
            if gen.random() < 0.5:
                length, width = width, length
            if got + length * width / 2 > target:
                misses += 1
                if got + min(f[1] * f[2] for f in FURNITURE) / 2 > target:
                    break
                continue
            lx, ly = clear[0] + g, clear[1] + g
            hx, hy = clear[2] - g - length, clear[3] - g - width
            if hx < lx or hy < ly:
                misses += 1
                continue
            x0 = lx + float(gen.random()) * (hx - lx)
            y0 = ly + float(gen.random()) * (hy - ly)
            side = int(gen.integers(6))  # 0-3: against a wall (left, right, bottom, top); 4-5: anywhere
            if side < 2:
                x0 = (lx, hx)[side]
            elif side < 4:
                y0 = (ly, hy)[side - 2]
            r = (x0, y0, x0 + length, y0 + width)
            ok = not any(_overlaps(r, z) for z in room_zones)
            ok = ok and not any(_disc_hits(r, cx, cy, mission.free_radius_m) for cx, cy in discs)
            ok = ok and not any(_overlaps(r, _rect(p), g) for p in placed)
            piece = Obstacle("furniture", round(x0 + length / 2, 6), round(y0 + width / 2, 6), 0.0,
                             (length, width, height))
            if ok and raster.one_piece(placed + [piece]):
                placed.append(piece)
                got += length * width
                misses = 0
            else:
                misses += 1
        carry = target - got  # (signed: what one room took too much the next takes less)
        out += placed
    return out


def _check_reachable(spec: WorldSpec, spaces: list[Space], obstacles: list[Obstacle], mission: Mission,
                     robot: RobotSpec, cell: float) -> None:
    """GenerationError unless every room's free floor and the goal are reachable from the start."""
    free = free_raster(spec.size_m, cell, obstacles, robot.width_m / 2)
    labels = components(free)
    shape = labels.shape

    def at(x: float, y: float) -> int:
        i = min(max(int(math.floor(y / cell)), 0), shape[0] - 1)
        j = min(max(int(math.floor(x / cell)), 0), shape[1] - 1)
        return int(labels[i, j])

    home = at(mission.start[0], mission.start[1])
    if home == 0:
        raise GenerationError("the start is not clear of walls and furniture by the robot's clearance")
    if at(*mission.goal) != home:
        raise GenerationError("the goal cannot be reached from the start (rooms generator)")
    t = spec.rooms.wall_thickness_m
    for k, s in enumerate(spaces):
        c = s.clear(t)
        j0, j1 = int(math.ceil(c[0] / cell - 0.5)), int(math.floor(c[2] / cell - 0.5))
        i0, i1 = int(math.ceil(c[1] / cell - 0.5)), int(math.floor(c[3] / cell - 0.5))
        part = labels[max(i0, 0):i1 + 1, max(j0, 0):j1 + 1]
        seen = set(np.unique(part[part > 0]).tolist())
        if not seen:
            raise GenerationError(f"{s.kind} {k} has no floor the robot fits on (rooms generator)")
        if seen != {home}:
            raise GenerationError(f"{s.kind} {k} cannot be reached from the start (rooms generator)")


def generate_rooms(spec: WorldSpec, seed: int, *, robot: RobotSpec | None = None) -> World:
    """The ``rooms`` world of ``spec`` for ``seed`` (module doc). ``robot`` (default: the nominal
    RobotSpec) sets the clearance of the checks: a corridor or door it cannot pass is a SpecError."""
    rb = robot or RobotSpec()
    rs = spec.rooms
    if spec.obstacles.targets() or spec.obstacles.moves:
        raise SpecError("obstacles", "set", "no obstacle targets or moves with generator rooms (it places walls "
                        "and furniture itself)", "remove obstacles, or use rooms.furniture_pct")
    rs.check_robot(rb.width_m, rb.name)
    r = _free_radius(spec, rb)
    check_robot_fits(r, rb, "robot" if robot is not None else "mission.free_radius_m")
    spaces = _plan(spec, rng(seed, "rooms", "layout"))
    edges = _edges(spaces)
    doors = _doors(spaces, edges, rs, rng(seed, "rooms", "doors"))
    walls = _walls(spaces, edges, doors, rs)
    mission = _mission(spec, spaces, walls, rb, r, rng(seed, "mission"))
    cell = raster_cell_for(spec.size_m)
    furniture = _furniture(spec, spaces, edges, doors, walls, mission=mission, robot=rb, cell=cell,
                           gen=rng(seed, "rooms", "furniture"))
    obstacles = tuple(walls + furniture)
    _check_reachable(spec, spaces, list(obstacles), mission, rb, cell)
    rows, cols = spec.grid_shape
    terrain = Terrain(np.zeros((rows, cols), np.float32), spec.cell_m)
    desc = describe(spec, terrain, obstacles, mission, robot=robot)
    rooms = [s for s in spaces if s.kind == "room"]
    floor = sum((c[2] - c[0]) * (c[3] - c[1]) for c in (s.clear(rs.wall_thickness_m) for s in rooms))
    per_room = [sum(1 for d in doors if i in (edges[d.edge].low, edges[d.edge].high))
                for i, s in enumerate(spaces) if s.kind == "room"]
    xs = [s.x1 for s in spaces] + [s.x0 for s in spaces]
    ys = [s.y1 for s in spaces] + [s.y0 for s in spaces]
    desc["rooms"] = {
        "n_rooms": len(rooms), "n_corridors": sum(1 for s in spaces if s.kind == "corridor"),
        "n_doors": len(doors), "doors_per_room_min": min(per_room), "doors_per_room_max": max(per_room),
        "n_walls": len(walls), "n_furniture": len(furniture),
        "furniture_pct": 100.0 * sum(o.area for o in furniture) / floor if floor > 0 else 0.0,
        "building_m": [round(max(xs) - min(xs) + rs.wall_thickness_m, 6), round(max(ys) - min(ys) + rs.wall_thickness_m, 6)],
    }
    desc["barn"] = barn_descriptor(barn_difficulty_of(spec.size_m, obstacles, mission.start[:2], mission.goal, robot=rb))
    movers = place_movers(spec, mission, obstacles, seed)
    if not spec.movers.empty:
        desc.update(mover_descriptors(spec, movers))
    return World(spec=spec, seed=seed, terrain=terrain, obstacles=obstacles, mission=mission, descriptors=desc,
                 movers=movers)


def room_spaces(spec: WorldSpec, seed: int) -> list[Space]:
    """The rooms and corridors of the world of ``spec`` and ``seed`` (the layout stream alone: what the
    tests check the walls and the reachability against)."""
    return _plan(spec, rng(seed, "rooms", "layout"))


def door_list(spec: WorldSpec, seed: int) -> tuple[list[Space], list[Edge], list[Door]]:
    """The spaces, wall edges and doors of the world of ``spec`` and ``seed``."""
    spaces = room_spaces(spec, seed)
    edges = _edges(spaces)
    return spaces, edges, _doors(spaces, edges, spec.rooms, rng(seed, "rooms", "doors"))
