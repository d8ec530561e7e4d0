"""The search report's pictures: the illumination map and the worlds found against runs spent for
the search and for random sampling (charts: Vega-Lite specifications drawn in the report, see
:mod:`navstress.analysis.charts`), and the best worlds with their runs' trajectories over their
height maps (PNG bytes).

Inputs are plain data a driver builds from its results (documented dataclasses, or dicts with the
same keys):

- :class:`MapPoint` (``{"x", "y", "fitness", "key"}``): one evaluated world on the map;
- :class:`Found` (``{"runs", "key", "found"}``): one evaluated candidate, ``runs`` being the runs
  spent so far when its evaluation ended, ``found`` whether it counts (revealing or failing);
- :class:`BestWorld`: a world (directory or loaded) with its runs' tracks
  (:class:`~navstress.run.figures.RunTrack`, see :func:`tracks_of`).

The best worlds are drawn on an Agg canvas of their own (no pyplot, no global backend); runs are drawn
with :mod:`navstress.run.figures` (its outcome colours everywhere in navstress) over
:func:`~navstress.world.export.images.draw_world`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navstress.analysis.charts import found_chart, illumination_chart
from navstress.errors import MISSING, NavstressError, SpecError
from navstress.run.figures import RunTrack, draw_tracks, legend, png_bytes
from navstress.run.figures import new_figure as _figure
from navstress.run.record import RunRecord
from navstress.run.trace import read_movers, read_poses
from navstress.search.objectives import DESCRIPTORS, get_descriptor
from navstress.world.export.images import draw_world
from navstress.world.world import World



def _get(obj: Any, name: str) -> Any:
    if isinstance(obj, Mapping):
        if name not in obj:
            raise SpecError(name, MISSING, f"a value for {name!r} in each entry")
        return obj[name]
    return getattr(obj, name)


# ---------------------------------------------------------------- (a) the illumination map


@dataclass(frozen=True)
class MapPoint:
    """One evaluated world on the illumination map: its two descriptor values and fitness."""

    x: float
    y: float
    fitness: float
    key: str = ""


def _points(points: Iterable[MapPoint | Mapping[str, Any]]) -> list[MapPoint]:
    out = []
    for p in points:
        mp = p if isinstance(p, MapPoint) else MapPoint(float(_get(p, "x")), float(_get(p, "y")),
                                                        float(_get(p, "fitness")), str(p.get("key", "")))
        if not all(math.isfinite(v) for v in (mp.x, mp.y, mp.fitness)):
            raise SpecError("points", mp, "finite descriptor values and fitness")
        out.append(mp)
    return out


def _check_grid(x_range: tuple[float, float], y_range: tuple[float, float], bins: tuple[int, int]) -> None:
    for name, (lo, hi) in (("x_range", x_range), ("y_range", y_range)):
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise SpecError(name, [lo, hi], "two finite numbers, low < high")
    for name, b in zip(("bins.x", "bins.y"), bins):
        if isinstance(b, bool) or not isinstance(b, int) or not 1 <= b <= 1000:
            raise SpecError(name, b, "an integer from 1 to 1000")


def cell_of(value: float, lo: float, hi: float, bins: int) -> int:
    """The cell index of ``value`` on an axis of ``bins`` equal cells over [lo, hi]; values outside
    go to the first or last cell (as pyribs' grid archive does)."""
    k = int(math.floor((value - lo) / (hi - lo) * bins))
    return min(max(k, 0), bins - 1)


def illumination_grid(points: Iterable[MapPoint | Mapping[str, Any]], x_range: tuple[float, float],
                      y_range: tuple[float, float], bins: tuple[int, int]) -> tuple[np.ndarray, list[list[str]]]:
    """(fitness, keys): per cell (row = y cell, column = x cell) the best fitness of the points that
    fall in it (NaN where none does) and that point's key (the first one on ties)."""
    _check_grid(x_range, y_range, bins)
    nx, ny = bins
    fit = np.full((ny, nx), np.nan)
    keys = [["" for _ in range(nx)] for _ in range(ny)]
    for p in _points(points):
        i, j = cell_of(p.y, *y_range, ny), cell_of(p.x, *x_range, nx)
        if math.isnan(fit[i, j]) or p.fitness > fit[i, j]:
            fit[i, j] = p.fitness
            keys[i][j] = p.key
    return fit, keys


def _axis(name: str, field: str, rng: tuple[float, float] | None, label: str | None
          ) -> tuple[tuple[float, float], str]:
    """(range, label) of one map axis: a registry descriptor (its natural range and unit unless
    given), or any other name (a path of the search space, e.g. ``ground.deformation``), which
    needs its range and is labelled by its name unless ``label`` is given."""
    if name in DESCRIPTORS or rng is None:
        d = get_descriptor(name, field)  # an unknown name without a range: the error lists the known ones
        return rng or (d.low, d.high), label or d.axis_label
    return rng, label or name


def illumination_map(points: Iterable[MapPoint | Mapping[str, Any]], *, x: str, y: str,
                     x_range: tuple[float, float] | None = None, y_range: tuple[float, float] | None = None,
                     bins: tuple[int, int] = (10, 10), fitness_label: str = "failure probability",
                     vmax: float = 1.0, title: str | None = None,
                     x_label: str | None = None, y_label: str | None = None) -> dict[str, Any]:
    """The illumination map's chart (a Vega-Lite specification,
    :func:`navstress.analysis.charts.illumination_chart`): a heatmap over the descriptors ``x`` and
    ``y`` (names of :data:`~navstress.search.objectives.DESCRIPTORS`, ranges defaulting to their
    natural ones, or paths of the search space such as ``ground.deformation``, whose ranges must be
    given), each cell coloured by its best world's fitness (0 to ``vmax``), empty cells blank; the
    axes say the descriptors' units (``x_label``/``y_label`` replace them) and the title how many
    cells are filled."""
    xr, xl = _axis(x, "x", x_range, x_label)
    yr, yl = _axis(y, "y", y_range, y_label)
    fit, keys = illumination_grid(points, xr, yr, bins)
    cells = [{"i": i, "j": j, "fitness": float(fit[i, j]), "key": keys[i][j]}
             for i in range(bins[1]) for j in range(bins[0]) if math.isfinite(fit[i, j])]
    return illumination_chart(cells, x_range=xr, y_range=yr, bins=bins, x_label=xl, y_label=yl,
                              fitness_label=fitness_label, vmax=vmax, title=title)


# ---------------------------------------------------------------- (b) found against runs spent


@dataclass(frozen=True)
class Found:
    """One evaluated candidate: ``runs`` spent so far when its evaluation ended, its world ``key``,
    and whether it counts as found (revealing or failing; the driver decides, e.g. confirmed)."""

    runs: int
    key: str
    found: bool


def found_curve(evaluations: Iterable[Found | Mapping[str, Any]]) -> list[tuple[int, int]]:
    """The step curve (runs spent, distinct worlds found so far), from (0, 0), one point per
    evaluation in the order of runs spent (ties in the given order); a world found twice counts
    once."""
    evs = []
    for e in evaluations:
        f = e if isinstance(e, Found) else Found(int(_get(e, "runs")), str(_get(e, "key")), bool(_get(e, "found")))
        if f.runs < 0:
            raise SpecError("runs", f.runs, "an integer >= 0")
        evs.append(f)
    seen: set[str] = set()
    out = [(0, 0)]
    for f in sorted(evs, key=lambda f: f.runs):
        if f.found:
            seen.add(f.key)
        out.append((f.runs, len(seen)))
    return out


def found_against_runs(methods: Mapping[str, Iterable[Found | Mapping[str, Any]]], *,
                       what: str = "revealing worlds", budget: int | None = None, title: str | None = None,
                       confirmed: Mapping[str, tuple[int, int]] | None = None) -> dict[str, Any]:
    """The chart (a Vega-Lite specification, :func:`navstress.analysis.charts.found_chart`) of the
    distinct worlds found against runs spent, one step line per method (e.g. ``search`` and
    ``random``, each :func:`found_curve` of its evaluations) on one axis; ``budget`` draws the run
    budget as a dashed line; ``confirmed`` maps a method to (runs spent, worlds confirmed), drawn as
    a star of the method's colour."""
    return found_chart({name: found_curve(evs) for name, evs in methods.items()}, what=what, budget=budget,
                       title=title, confirmed=confirmed)


# ---------------------------------------------------------------- (c) the best worlds and their runs


@dataclass(frozen=True)
class BestWorld:
    """A world to draw (a directory or a loaded :class:`World`) with its runs' tracks and a title."""

    world: World | str | Path
    tracks: Sequence[RunTrack]
    title: str = ""


def tracks_of(records: Iterable[RunRecord], root: str | Path, *, max_points: int = 2000,
              movers: bool = False) -> list[RunTrack]:
    """The tracks of ``records`` from their traces (a relative trace path is under ``root``, the
    campaign directory), thinned to at most ``max_points`` points, with the place of the first
    collision and (``movers``: the world has movers) the movers' poses; a run without a readable
    trace is left out."""
    out = []
    for r in records:
        if not r.trace:
            continue
        p = Path(r.trace)
        try:
            truth = read_poses(p if p.is_absolute() else Path(root) / p)
        except NavstressError:
            continue
        if not len(truth):
            continue
        col = None
        if r.first_collision_s is not None:
            k = int(np.argmin(np.abs(truth[:, 0] - r.first_collision_s)))
            col = (float(truth[k, 1]), float(truth[k, 2]))
        if max_points > 0 and len(truth) > max_points:
            idx = np.unique(np.append(np.linspace(0, len(truth) - 1, max_points).astype(int), len(truth) - 1))
            truth = truth[idx]
        mv = read_movers(p if p.is_absolute() else Path(root) / p) if movers else None
        out.append(RunTrack(f"r{r.run_index} {r.navigator} {r.fault or 'nominal'}", r.outcome, truth, None, col, mv,
                            r.first_collision_s))
    return out


def best_worlds_figure(worlds: Sequence[BestWorld], *, columns: int = 3, dpi: int = 80) -> bytes:
    """The best worlds side by side, each its height map (hillshaded terrain, obstacles, start and
    goal) with its runs' trajectories coloured by outcome."""
    if not worlds:
        raise SpecError("worlds", [], "at least one world to draw")
    if isinstance(columns, bool) or not isinstance(columns, int) or columns < 1:
        raise SpecError("columns", columns, "an integer >= 1")
    cols = min(columns, len(worlds))
    rows = -(-len(worlds) // cols)
    fig = _figure(4.4 * cols, 4.2 * rows, dpi)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax, bw in zip(axes, worlds):
        w = bw.world if isinstance(bw.world, World) else World.load(bw.world)
        draw_world(ax, w, legend=False)
        draw_tracks(ax, list(bw.tracks), world=w)
        if bw.tracks:
            legend(ax, loc="upper left", fontsize=6, framealpha=0.85)
        ax.set_title(bw.title, fontsize=8, loc="left")
    for ax in axes[len(worlds):]:
        ax.set_axis_off()
    return png_bytes(fig)
