"""Drivable start and goal areas: the free discs levelled, with a bounded-slope transition.

The robot must stand at its start and make its initial scanning moves (turn on the spot, about
3 m forward), and stop at its goal, whatever the ground: a run that tips over in its first
seconds measures the world generator, not the navigation. So the generator levels the start and
goal free discs (radius ``R = mission.free_radius_m``) of the raw terrain, before any obstacle:

* **Flat set.** The vertices within ``R+ = R + sqrt(2) cell`` of the disc's centre: a superset of
  the vertices of every cell the closed disc touches, so every point of the disc lies on
  triangles whose three vertices are all in the flat set (exactly flat on the triangulated
  surface, :meth:`~navstress.world.world.Terrain.height_at`).
* **Level** ``z``: the mean raw height over the flat set, rounded to float32 (exact in the
  saved heights), as the obstacles' bases are. Every vertex of the flat set is set to ``z``.
* **Transition.** A vertex at distance ``u`` beyond ``R+`` gets ``h + W (z - h)`` with
  ``W = 1 - smoothstep(u / B)`` (``W = 0`` from ``u = B`` on): a smooth (C1) return to the raw
  terrain, as obstacle levelling blends (:mod:`navstress.world.placement`).
* **Added slope.** What levelling does to the steepness of the ground is measured on every
  edge ``(a, b)`` of the grid (along x, along y and the triangulation's diagonal): the slope it
  adds is ``(|h'(b) - h'(a)| - |h(b) - h(a)|) / |ab|``, a rise per metre (given in degrees as its
  angle, atan). A triangle's gradient grows by at most sqrt(2) times the largest added slope of
  its edges.
* **Width** ``B`` (tried from ``MIN_TRANSITION_M`` = 3 m, or two cells, up to
  ``MAX_TRANSITION_M`` = 25 m in steps of 10 %): the narrowest width whose levelling adds at most
  ``GENTLE_SLOPE_DEG`` = 5 deg to every edge; when none does, the width that adds the least, if
  that is at most ``MAX_ADDED_SLOPE_DEG`` = 20 deg. So a transition is as narrow as a gentle ramp
  allows and no wider: on ground within 0.15 m of the level around the disc, 3 m; 0.26 m off it,
  about 4.5 m; on a 2 deg tilt, about 8 m. Gentle, because a narrow ramp traps: with 10 deg and
  2 m, a start disc 0.26 m above or below the ground around it held ``reference-v1`` inside it
  for 400 s on 3 of 875 runs of the paper preset's ground classes (it took the ramp for a wall).
* **Bounded by construction.** ``h'(b) - h'(a) = (1 - W_b)(h_b - h_a) + (W_b - W_a)(z - h_a)`` (a
  taken in the transition ring), and ``W`` is ``1.5 / B``-Lipschitz, so the added slope is at most
  ``1.5 D(B) / B`` with ``D(B)`` the largest ``|z - h|`` over the ring ``0 < u < B``. The smallest
  ``B`` meeting ``1.5 D(B) / B <= tan(limit)`` is found exactly from the sorted ring vertices; it
  ends the search for either limit (so the search never misses a width that the bound proves
  good). Every levelled area thus adds at most 20 deg to any edge: the tests check it on families
  of rough worlds against the raw heights.
* **Refusal.** When no width up to 25 m adds at most 20 deg (the ground around the disc departs
  from the level so far, e.g. a disc on a long slope of 25 deg, that no transition returns to
  it gently), the world is refused: :class:`~navstress.errors.GenerationError` with a one-line
  reason naming the start or goal, its position, the level, the least slope a transition would
  add and the height difference. A disc that reaches outside the map is refused too
  (:func:`check_inside`; :class:`~navstress.world.spec.WorldSpec` already refuses such specs, this
  covers a spec built without validation).
* **Start and goal together.** When the two zones (flat set + transition) come closer than two
  cells, the two discs are levelled as one area: one level (the mean over both flat sets), ``u``
  the distance to the nearer flat set, one width from the union of their rings.
* **Obstacles** come after and keep out of the free discs; their levelling keeps the flat sets as
  they are (:func:`~navstress.world.placement.level_terrain` with :meth:`FreeAreas.pins`). A
  cluster of obstacles (one levelled base) that touches both flat sets cannot stand at two
  heights: the generator then levels start and goal together (``together=True``) and levels the
  obstacles again.

Nothing is done when ``R = 0`` (no free area asked for) or when the raw terrain is flat (every
height equal): such worlds keep their heights and descriptors byte for byte.

    >>> import numpy as np
    >>> from navstress.world.world import Mission
    >>> h = np.fromfunction(lambda i, j: 0.02 * j, (101, 101))  # a 2.9 degree tilt, 0.4 m cells
    >>> fa = level_free_areas(h, 0.4, Mission((10.0, 10.0, 0.0), (30.0, 30.0), 3.0), (40.0, 40.0))
    >>> [round(a.level_m, 3) for a in fa.areas], bool(fa.heights[25, 25] == np.float32(fa.areas[0].level_m))
    ([0.5, 1.5], True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from navstress.errors import GenerationError
from navstress.world.world import Mission

#: The slope a transition should add at most along any grid edge, in degrees (as a rise per metre:
#: its tangent), when a transition up to MAX_TRANSITION_M wide allows it.
GENTLE_SLOPE_DEG = 5.0
#: The slope a transition may add at most (degrees): a free area that needs more is refused.
MAX_ADDED_SLOPE_DEG = 20.0
#: The narrowest transition (m); also at least two cells.
MIN_TRANSITION_M = 3.0
#: The widest transition (m).
MAX_TRANSITION_M = 25.0
#: The ratio of successive widths tried.
LADDER = 1.1
#: Largest steepness of ``1 - smoothstep(t)`` over t in [0, 1].
_SMOOTHSTEP_SLOPE = 1.5


@dataclass(frozen=True)
class FreeArea:
    """One levelled area: ``names`` ("start", "goal" or both when levelled together), the disc
    centres, the flat set's radius ``flat_radius_m`` (R+), its level, the transition's width, the
    largest height difference the transition bridges, and the steepest slope (degrees) of the
    levelled ground's triangles in the transition."""

    names: tuple[str, ...]
    centres: tuple[tuple[float, float], ...]
    flat_radius_m: float
    level_m: float
    transition_m: float
    step_m: float
    slope_max_deg: float


@dataclass(frozen=True)
class FreeAreas:
    """Result of :func:`level_free_areas`: the heights (float64) and the areas levelled (none when
    nothing was done)."""

    heights: np.ndarray
    areas: tuple[FreeArea, ...]

    def descriptor(self) -> dict[str, Any] | None:
        """``{"start": {...}, "goal": {...}}`` (level, transition width, height step, steepest
        slope), or None when nothing was levelled (the world's descriptors then have no key)."""
        if not self.areas:
            return None
        out: dict[str, Any] = {}
        for a in self.areas:
            for n in a.names:
                out[n] = {"level_m": a.level_m, "transition_m": round(a.transition_m, 6),
                          "step_m": round(a.step_m, 6), "slope_max_deg": round(a.slope_max_deg, 4)}
        return dict(sorted(out.items()))

    def pins(self, shape: tuple[int, int], cell_m: float) -> Pins | None:
        """The flat sets, for obstacle levelling (:func:`navstress.world.placement.level_terrain`),
        or None when nothing was levelled."""
        if not self.areas:
            return None
        mask = np.full(shape, -1, np.int8)
        discs = []
        for k, a in enumerate(self.areas):
            for cx, cy in a.centres:
                discs.append((float(k), cx, cy, a.flat_radius_m))
                win = _window(shape, cell_m, cx, cy, a.flat_radius_m)
                sub = mask[win.rows, win.cols]
                sub[_distance(win, cell_m, cx, cy) <= a.flat_radius_m] = k
                mask[win.rows, win.cols] = sub
        return Pins(mask, np.array([a.level_m for a in self.areas], np.float64), np.array(discs, np.float64))


@dataclass(frozen=True)
class Pins:
    """Levelled flat sets that obstacle levelling must keep: ``mask`` (int8 grid: -1, or the index of
    the area whose flat set holds the vertex), ``levels`` (per area) and ``discs`` (rows: area index,
    centre x, centre y, flat-set radius)."""

    mask: np.ndarray
    levels: np.ndarray
    discs: np.ndarray


def check_inside(mission: Mission, size_m: tuple[float, float]) -> None:
    """GenerationError when the start or goal free disc reaches outside the map."""
    r = mission.free_radius_m
    sx, sy = size_m
    for name, (x, y) in (("start", mission.start[:2]), ("goal", mission.goal)):
        if not (r <= x <= sx - r and r <= y <= sy - r):
            raise GenerationError(
                f"the {name} at ({x:g}, {y:g}) has a free disc of mission.free_radius_m={r:g} that reaches outside "
                f"the {sx:g} x {sy:g} m map: the {name} must lie in [{r:g}, {sx - r:g}] x [{r:g}, {sy - r:g}]; move "
                f"the {name}, raise mission.inset_m or lower mission.free_radius_m")


@dataclass(frozen=True)
class _Win:
    rows: slice
    cols: slice
    i0: int
    j0: int
    ni: int
    nj: int


def _window(shape: tuple[int, int], cell: float, cx: float, cy: float, reach: float) -> _Win:
    rows, cols = shape
    i0, i1 = max(0, math.floor((cy - reach) / cell)), min(rows - 1, math.ceil((cy + reach) / cell))
    j0, j1 = max(0, math.floor((cx - reach) / cell)), min(cols - 1, math.ceil((cx + reach) / cell))
    return _Win(slice(i0, i1 + 1), slice(j0, j1 + 1), i0, j0, i1 - i0 + 1, j1 - j0 + 1)


def _union(a: _Win, b: _Win) -> _Win:
    i0, j0 = min(a.i0, b.i0), min(a.j0, b.j0)
    i1, j1 = max(a.i0 + a.ni, b.i0 + b.ni), max(a.j0 + a.nj, b.j0 + b.nj)
    return _Win(slice(i0, i1), slice(j0, j1), i0, j0, i1 - i0, j1 - j0)


def _distance(win: _Win, cell: float, cx: float, cy: float) -> np.ndarray:
    """Distance from each vertex of the window to (cx, cy)."""
    y = (win.i0 + np.arange(win.ni)) * cell - cy
    x = (win.j0 + np.arange(win.nj)) * cell - cx
    out: np.ndarray = np.sqrt(x[None, :] ** 2 + y[:, None] ** 2)
    return out


def _width(u: np.ndarray, dev: np.ndarray, b_min: float, b_max: float, per_m: float) -> float:
    """The smallest width B >= b_min with ``per_m * D(B) <= B``, D(B) = max ``dev`` over ``0 < u < B``,
    or inf when no B <= b_max is."""
    sel = (u > 0.0) & (u < b_max)
    us, ds = u[sel], dev[sel]
    order = np.argsort(us, kind="stable")
    us, ds = us[order], ds[order]
    cum = np.concatenate([[0.0], np.maximum.accumulate(ds)]) if ds.size else np.zeros(1)
    cand = np.maximum(b_min, per_m * cum)  # cand[i]: the width a ring of the i nearest vertices needs
    upper = np.concatenate([us, [math.inf]])  # ... and is that ring while B <= us[i]
    ok = np.flatnonzero(cand <= upper)
    if ok.size == 0 or cand[ok[0]] > b_max:
        return math.inf
    return float(cand[ok[0]])


def _blend(sub: np.ndarray, u: np.ndarray, z: float, b: float) -> np.ndarray:
    """The window's heights levelled to ``z`` with a transition of width ``b``."""
    t = np.clip(u / b, 0.0, 1.0)
    w = 1.0 - t * t * (3.0 - 2.0 * t)
    out: np.ndarray = np.where(u <= 0.0, z, np.where(u < b, sub + w * (z - sub), sub))
    return out


def edge_excess(levelled: np.ndarray, raw: np.ndarray, cell: float) -> np.ndarray:
    """Per vertex, the largest ``(|h'(b) - h'(a)| - |h(b) - h(a)|) / |ab|`` over the grid edges from
    it along +x, +y and the triangulation's diagonal (+x+y): the slope levelling added."""
    out = np.full(raw.shape, -np.inf)
    for di, dj, ln in ((0, 1, cell), (1, 0, cell), (1, 1, cell * math.sqrt(2.0))):
        rows, cols = raw.shape[0] - di, raw.shape[1] - dj
        dl = np.abs(levelled[di:, dj:] - levelled[:rows, :cols])
        dr = np.abs(raw[di:, dj:] - raw[:rows, :cols])
        np.maximum(out[:rows, :cols], (dl - dr) / ln, out=out[:rows, :cols])
    return out


def _triangle_slope_deg(h: np.ndarray, cell: float) -> np.ndarray:
    """Slope (degrees) of the two triangles of every cell (the simulator's triangulation), shape
    (2, rows - 1, cols - 1)."""
    dx0 = (h[:-1, 1:] - h[:-1, :-1]) / cell  # lower-right: (i,j)-(i,j+1) then (i,j+1)-(i+1,j+1)
    dy0 = (h[1:, 1:] - h[:-1, 1:]) / cell
    dy1 = (h[1:, :-1] - h[:-1, :-1]) / cell  # upper-left: (i,j)-(i+1,j) then (i+1,j)-(i+1,j+1)
    dx1 = (h[1:, 1:] - h[1:, :-1]) / cell
    out: np.ndarray = np.degrees(np.arctan(np.stack([np.hypot(dx0, dy0), np.hypot(dx1, dy1)])))
    return out


def level_free_areas(heights: np.ndarray, cell_m: float, mission: Mission, size_m: tuple[float, float],
                     *, together: bool = False, gentle_slope_deg: float = GENTLE_SLOPE_DEG,
                     max_slope_deg: float = MAX_ADDED_SLOPE_DEG, max_transition_m: float = MAX_TRANSITION_M) -> FreeAreas:
    """Level the start and goal free discs of ``heights`` (see the module docstring); ``together``:
    as one area, whatever the distance between them.

    Raises :class:`GenerationError` when a disc reaches outside the map, or when no transition up
    to ``max_transition_m`` wide levels a disc adding at most ``max_slope_deg`` to any edge."""
    check_inside(mission, size_m)
    h = np.asarray(heights, dtype=np.float64)
    r = float(mission.free_radius_m)
    if r <= 0.0 or h.size == 0 or float(h.min()) == float(h.max()):
        return FreeAreas(h, ())
    cell = float(cell_m)
    r_flat = r + math.sqrt(2.0) * cell
    tan_gentle, tan_max = math.tan(math.radians(gentle_slope_deg)), math.tan(math.radians(max_slope_deg))
    b_min = max(MIN_TRANSITION_M, 2.0 * cell)
    discs = (("start", (float(mission.start[0]), float(mission.start[1]))), ("goal", (float(mission.goal[0]), float(mission.goal[1]))))

    def _choose_width(sub: np.ndarray, u: np.ndarray, z: float, dev: np.ndarray) -> tuple[float, float]:
        """(B, the slope it adds): the narrowest ladder width adding at most tan_gentle; else the ladder
        width adding the least, if at most tan_max; else (inf, the least slope added)."""
        suff = _width(u, dev, b_min, max_transition_m, _SMOOTHSTEP_SLOPE / tan_gentle)
        best, best_b = math.inf, math.inf
        b = b_min
        while True:
            if b >= suff:  # the sufficient condition: adds at most tan_gentle by construction
                return suff, tan_gentle
            near = u < b + 2.0 * cell  # the zone and the edges leaving it
            rows, cols = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
            cut = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
            added = float(edge_excess(_blend(sub[cut], u[cut], z, b), sub[cut], cell).max())
            if added <= tan_gentle:
                return b, added
            if added < best:
                best, best_b = added, b
            if b >= max_transition_m:
                break
            b = min(b * LADDER, max_transition_m)
        if best_b == math.inf or best > tan_max:
            suff_max = _width(u, dev, b_min, max_transition_m, _SMOOTHSTEP_SLOPE / tan_max)
            if math.isfinite(suff_max):  # (by construction; the ladder missed it)
                return suff_max, tan_max
            return math.inf, best
        return best_b, best

    def solve(group: tuple[tuple[str, tuple[float, float]], ...]) -> tuple[_Win, np.ndarray, float, float, float]:
        win = None
        for _, (cx, cy) in group:
            w = _window(h.shape, cell, cx, cy, r_flat + max_transition_m)
            win = w if win is None else _union(win, w)
        assert win is not None
        u = np.min([_distance(win, cell, cx, cy) for _, (cx, cy) in group], axis=0) - r_flat
        sub = h[win.rows, win.cols]
        z = float(np.float32(sub[u <= 0.0].mean()))
        dev = np.abs(sub - z)
        b, worst = _choose_width(sub, u, z, dev)
        if not math.isfinite(b):
            names = " and ".join(f"{n} at ({x:g}, {y:g})" for n, (x, y) in group)
            far = float(dev[(u > 0.0) & (u < max_transition_m)].max(initial=0.0))
            raise GenerationError(
                f"the {names} cannot be made drivable: levelling its {r:g} m free disc to {z:.3g} m would add "
                f"{math.degrees(math.atan(worst)):.1f} deg of slope (the angle of the rise added per metre), more than "
                f"{max_slope_deg:g} deg, even with the best transition up to {max_transition_m:g} m wide (the "
                f"ground within {max_transition_m:g} m of the disc departs from that level by up to {far:.3g} m); use "
                "a gentler ground (lower ground.deformation or amplitude_m), another map seed or a smaller "
                "mission.free_radius_m")
        step = float(dev[(u > 0.0) & (u < b)].max(initial=0.0))
        return win, u, z, b, step

    solved = [] if together else [solve((d,)) for d in discs]
    (sx, sy), (gx, gy) = discs[0][1], discs[1][1]
    # zones (flat set + transition) closer than two cells are levelled together: no grid edge
    # then joins two zones of different levels
    if together or math.hypot(gx - sx, gy - sy) < 2 * r_flat + solved[0][3] + solved[1][3] + 2 * math.sqrt(2.0) * cell:
        groups: list[tuple[tuple[str, tuple[float, float]], ...]] = [discs]
        solved = [solve(discs)]
    else:
        groups = [(discs[0],), (discs[1],)]
    out = h.copy()
    for win, u, z, b, _ in solved:
        out[win.rows, win.cols] = _blend(out[win.rows, win.cols], u, z, b)
    areas = []
    for group, (win, u, z, b, step) in zip(groups, solved):
        zone = u < b
        slope = _triangle_slope_deg(out[win.rows, win.cols].astype(np.float32).astype(np.float64), cell)
        in_zone = zone[:-1, :-1] | zone[1:, :-1] | zone[:-1, 1:] | zone[1:, 1:]  # triangles touching the zone
        areas.append(FreeArea(tuple(n for n, _ in group), tuple(c for _, c in group), r_flat, z, b, step,
                              float(np.max(slope[:, in_zone], initial=0.0))))
    return FreeAreas(out, tuple(areas))
