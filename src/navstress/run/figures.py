"""Pictures of runs drawn over their world (``navstress run``, ``navstress world drive``, and
the search report's best worlds; the HTML report's maps use its outcome colours in SVG,
:mod:`navstress.analysis.svgmap`).

    trajectories_png(world, [RunTrack(...), ...], "runs.png")

Colours follow the outcome everywhere in navstress: success green, collision red, error
orange, timeout purple, other grey. Figures are drawn on an Agg canvas of their own (no
pyplot, no global backend set).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon

from navstress import _files
from navstress.world.export.images import draw_world
from navstress.world.world import Mover, World

OUTCOME_COLOURS = {
    "success": "#1a9641",
    "fail-collision": "#d7191c",
    "fail-error": "#f08a24",
    "fail-timeout": "#7b3294",
    "fail-other": "#6b6b6b",
}
OUTCOME_LABELS = {"success": "Success", "fail-collision": "Fail-Collision", "fail-error": "Fail-Error",
                  "fail-timeout": "Fail-TimeOut", "fail-other": "Fail-Other"}


@dataclass(frozen=True)
class RunTrack:
    """One run to draw: its real trajectory (N, >=3: t, x, y, ...), outcome, optional perceived one."""

    label: str
    outcome: str
    truth: np.ndarray
    perceived: np.ndarray | None = None
    collision_xy: tuple[float, float] | None = None
    #: the movers of the run (``RunResult.movers`` / ``trace.read_movers``): times (m,), poses (m, n, 4)
    movers: tuple[np.ndarray, np.ndarray] | None = None
    collision_t: float | None = None  # when the first collision happened (where the movers were then)
    #: the robot's true footprint (n, 2) in base_link (``RobotSpec.footprint_points``), drawn where
    #: the run ended; None: not drawn
    footprint: np.ndarray | None = None


MOVER_COLOUR = "#2c5fd6"


def footprint_at(ring: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """The footprint ``ring`` (n, 2, base_link) placed at a trajectory row ``pose`` (t, x, y, z,
    yaw, ...): its outline (n, 2) in the map frame.

        >>> footprint_at(np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([0, 10, 20, 0, np.pi / 2])).round(6).tolist()
        [[10.0, 21.0], [9.0, 20.0]]
    """
    yaw = float(pose[4])
    c, s = np.cos(yaw), np.sin(yaw)
    r = np.asarray(ring, dtype=np.float64)
    out: np.ndarray = np.column_stack([pose[1] + c * r[:, 0] - s * r[:, 1], pose[2] + s * r[:, 0] + c * r[:, 1]])
    return out


def draw_footprint(ax: Any, ring: np.ndarray, pose: np.ndarray, colour: str = "black", label: str | None = None) -> None:
    """The robot's outline (its true footprint ``ring``) at the trajectory row ``pose``."""
    ax.add_patch(Polygon(footprint_at(ring, pose), closed=True, fill=False, ec=colour, lw=1.0, zorder=7, label=label))


def movers_at(world: World, times: np.ndarray, poses: np.ndarray,
              at: float) -> list[tuple[Mover, float, float, np.ndarray | None]]:
    """Where each mover of a run's track (times (m,), poses (m, n, 4)) was at time ``at``: its
    centre interpolated between samples, and for a box its footprint's corners (4, 2) at the
    heading of the next sample (None for a disc)."""
    out: list[tuple[Mover, float, float, np.ndarray | None]] = []
    if not len(times):
        return out
    for i, mv in enumerate(world.movers[: poses.shape[1]]):
        x = float(np.interp(at, times, poses[:, i, 0]))
        y = float(np.interp(at, times, poses[:, i, 1]))
        corners = None
        if mv.shape != "disc":
            yaw = float(poses[min(int(np.searchsorted(times, at)), len(times) - 1), i, 3])
            c, s = np.cos(yaw), np.sin(yaw)
            hl, hw = mv.size[0] / 2, mv.size[1] / 2
            corners = np.array([(x + c * a - s * b, y + s * a + c * b)
                                for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])
        out.append((mv, x, y, corners))
    return out


def draw_movers(ax: Any, world: World, times: np.ndarray, poses: np.ndarray, at: float | None,
                seen: set[str], *, paths: bool = True) -> None:
    """The movers' paths (``paths``: thin lines, a dot where each ended) and, at time ``at`` (a
    collision), their footprints where they were then (interpolated between samples)."""
    if not len(times):
        return
    for i in range(poses.shape[1] if paths else 0):
        ax.plot(poses[:, i, 0], poses[:, i, 1], "-", color=MOVER_COLOUR, lw=0.8, alpha=0.55, zorder=5,
                label=None if "mover" in seen else "movers' paths")
        seen.add("mover")
        ax.plot(poses[-1, i, 0], poses[-1, i, 1], ".", color=MOVER_COLOUR, ms=4, zorder=5)
    if at is None:
        return
    for mv, x, y, corners in movers_at(world, times, poses, at):
        lab = None if "mover_at" in seen else "movers at the collision"
        seen.add("mover_at")
        if corners is None:
            ax.add_patch(Circle((x, y), mv.size[0] / 2, fc=MOVER_COLOUR, ec="black", lw=0.6, alpha=0.8, zorder=9,
                                label=lab))
        else:
            ax.add_patch(Polygon(corners, closed=True, fc=MOVER_COLOUR, ec="black", lw=0.6, alpha=0.8, zorder=9,
                                 label=lab))


def draw_tracks(ax: Any, tracks: list[RunTrack], *, perceived: bool = False, world: World | None = None) -> None:
    """Overlay tracks on an axes that already shows the world (see ``draw_world``); with
    ``world``, the movers of tracks that have them too (:func:`draw_movers`)."""
    seen: set[str] = set()
    for tr in tracks:
        if world is not None and tr.movers is not None:
            # several runs: only where the movers were at each run's collision (paths would hide the runs)
            draw_movers(ax, world, tr.movers[0], tr.movers[1], tr.collision_t, seen, paths=len(tracks) == 1)
        col = OUTCOME_COLOURS.get(tr.outcome, "#000000")
        lab = OUTCOME_LABELS.get(tr.outcome, tr.outcome)
        if len(tr.truth):
            ax.plot(tr.truth[:, 1], tr.truth[:, 2], "-", color=col, lw=1.6, alpha=0.9,
                    label=None if lab in seen else lab, zorder=6)
            ax.plot(tr.truth[-1, 1], tr.truth[-1, 2], "o", color=col, ms=5, mec="white", mew=0.8, zorder=7)
            seen.add(lab)
            if tr.footprint is not None:
                draw_footprint(ax, tr.footprint, tr.truth[-1], col)
        if perceived and tr.perceived is not None and len(tr.perceived):
            ax.plot(tr.perceived[:, 1], tr.perceived[:, 2], "--", color="#2b83ba", lw=1.2,
                    label=None if "perceived" in seen else "perceived (navigator's belief)", zorder=6)
            seen.add("perceived")
        if tr.collision_xy is not None:
            ax.plot(*tr.collision_xy, "X", color="#d7191c", ms=10, mec="black", mew=0.8, zorder=8,
                    label=None if "collision" in seen else "collision")
            seen.add("collision")


def world_axes(figsize: tuple[float, float] = (8.2, 7.2), dpi: int = 110) -> tuple[Figure, Any]:
    """A figure on its own Agg canvas and its one axes."""
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig, fig.subplots()


def trajectories_png(world: World, tracks: list[RunTrack], path: str | Path, *, title: str | None = None,
                     perceived: bool = False, dpi: int = 110) -> Path:
    """Write a PNG of ``world`` with every track overlaid, colour-coded by outcome."""
    fig, ax = world_axes(dpi=dpi)
    draw_world(ax, world, legend=False)
    draw_tracks(ax, tracks, perceived=perceived, world=world)
    legend(ax, loc="upper left", fontsize=8, framealpha=0.85)
    if title:
        ax.set_title(title, fontsize=10, loc="left")
    return save_png(fig, path)


def legend(ax: Any, **kw: Any) -> None:
    """``ax.legend(**kw)`` when something is labelled (matplotlib warns on stderr otherwise)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def save_png(fig: Figure, path: str | Path) -> Path:
    """Lay out and write ``fig`` as a PNG atomically (a partial file never takes the name)."""
    fig.tight_layout()
    out = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    _files.write_atomic(out, buf.getvalue())
    return out


def new_figure(w: float, h: float, dpi: int, *, constrained: bool = True) -> Any:
    """A matplotlib Figure on the Agg canvas (no global pyplot state), ``w`` x ``h`` inches."""
    fig = Figure(figsize=(w, h), dpi=dpi, layout="constrained" if constrained else None)
    FigureCanvasAgg(fig)
    return fig


def png_bytes(fig: Any) -> bytes:
    """Render a matplotlib Figure to PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
