"""BARN's score (docs/worlds.md, "The BARN benchmark") of the runs of a campaign on BARN worlds.

The BARN benchmark (Perille et al., 2020; its harness: the BARN repository Daffan/the-barn-challenge,
``run.py`` at commit bf5a226f) scores one run as

    score = success * t_opt / clip(t, 2 t_opt, 8 t_opt),    t_opt = L / (2 m/s)

with ``L`` the length of the polyline start -> the world's path cells -> goal in meters (its
``path_N.npy`` in lattice cells, ``x = i * 0.15 - 4.575``, ``y = j * 0.15 + 5.075``: run.py's
``path_coord_to_gazebo_coord``, RADIUS = 0.075) and ``t`` the run's time: from when the robot
is first 0.1 m away from its start to when it is first within 1 m of the goal. A score is in
[0, 0.5]: 0 for a failure, 0.5 for a success in at most twice the optimal time.

    >>> score(True, 30.0, 6.0), score(True, 5.0, 6.0), score(True, 60.0, 6.0), score(False, 12.0, 6.0)
    (0.2, 0.5, 0.125, 0.0)
    >>> cells_xy(np.array([[0, 0], [0, 1]])).round(3).tolist()
    [[-4.575, 5.075], [-4.575, 5.225]]
    >>> round(path_length(np.array([[0, 0], [0, 1]]), (-4.575, 5.075), (-4.575, 6.225)), 4)
    1.15

navstress's runs give each term: ``success`` is the run's outcome (navstress's success: the
navigator said it arrived within ``goal_tolerance_m`` of the goal, no collision, no timeout);
``t`` is measured on the run's ground-truth trajectory (its trace) by BARN's clock, or, for a run
without a readable trace, its simulated duration (the run's record says which: ``t_from``).

A campaign's runs are scored when their world is a BARN world: an explicit world whose source
is a file ``world_N.world`` beside a ``path_files/path_N.npy``, with BARN's mission (start
(-2.25, 3), goal (-2.25, 13) in the file's frame), as ``navstress campaign init --preset barn``
writes them. Scores are per navigator and fault (and robot), per world (the mean of its runs)
and overall (the mean over every run).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navstress.analysis.stats import config_key, fault_name
from navstress.campaign.presets import BARN_GOAL, BARN_START, barn_path_file
from navstress.campaign.spec import CampaignSpec
from navstress.errors import SpecError
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated

#: BARN's lattice: cell size and the origin of cell (0, 0) in its worlds' frame (run.py).
LATTICE_M = 0.15
ORIGIN_XY = (-0.075 - 30 * 0.15, 0.075 + 5.0)  # (-4.575, 5.075)
#: The speed BARN's optimal time assumes (m/s).
OPTIMAL_SPEED_MPS = 2.0
#: BARN's clock starts when the robot is this far from its start (m) ...
START_MOVE_M = 0.1
#: ... and stops when it is this close to the goal (m).
GOAL_RADIUS_M = 1.0
#: How close a mission must be to BARN's (m, rad) for its runs to be scored.
MISSION_TOL = 1e-6
_WORLD_FILE = re.compile(r"^world_(\d+)\.world$")


def optimal_time(length_m: float) -> float:
    """BARN's optimal time (s) of a path ``length_m`` long."""
    return length_m / OPTIMAL_SPEED_MPS


def score(success: bool, t_s: float, t_opt_s: float) -> float:
    """One run's BARN score: ``success * t_opt / clip(t, 2 t_opt, 8 t_opt)`` (SpecError for a
    ``t_opt`` that is not > 0 or a ``t`` that is NaN)."""
    if not (t_opt_s > 0) or math.isinf(t_opt_s):
        raise SpecError("t_opt_s", t_opt_s, "an optimal time in seconds > 0")
    if math.isnan(t_s):
        raise SpecError("t_s", t_s, "a time in seconds")
    if not success:
        return 0.0
    return t_opt_s / min(max(t_s, 2.0 * t_opt_s), 8.0 * t_opt_s)


def cells_xy(cells: np.ndarray) -> np.ndarray:
    """A path in BARN lattice cells (n, 2) as points (n, 2) in its world's frame (m)."""
    c = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([c[:, 0] * LATTICE_M + ORIGIN_XY[0], c[:, 1] * LATTICE_M + ORIGIN_XY[1]])


def path_length(cells: np.ndarray, start: tuple[float, float] = BARN_START[:2],
                goal: tuple[float, float] = BARN_GOAL) -> float:
    """The length (m) of the polyline ``start`` -> ``cells`` (in lattice cells) -> ``goal``."""
    pts = np.vstack([np.asarray(start[:2], np.float64)[None, :], cells_xy(cells), np.asarray(goal[:2], np.float64)[None, :]])
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def load_path(path: str | Path) -> np.ndarray:
    """A BARN path file (``path_N.npy``: integer lattice cells, shape (n, 2)); SpecError naming
    the file when it is missing, unreadable or of another shape."""
    p = Path(path)
    try:
        loaded = np.load(p, allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise SpecError("path file", str(p), "a BARN path file (a .npy array of lattice cells, shape (n, 2))",
                        f"it could not be read ({type(err).__name__}); restore it from the BARN folder") from None
    if not isinstance(loaded, np.ndarray):  # an .npz archive
        raise SpecError("path file", str(p), "a BARN path file (a .npy array of lattice cells, shape (n, 2))",
                        "it is an archive of several arrays")
    arr: np.ndarray = loaded
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1 or arr.dtype.kind not in "iuf" \
            or not np.isfinite(arr).all():
        raise SpecError("path file", str(p), "a BARN path file (a .npy array of lattice cells, shape (n, 2))",
                        f"it holds an array of shape {arr.shape} and type {arr.dtype}")
    return arr


def _interp_cross(t: np.ndarray, d: np.ndarray, k: int, level: float) -> float:
    """The time ``d`` crosses ``level`` between samples ``k - 1`` and ``k`` (linear)."""
    if k == 0:
        return float(t[0])
    d0, d1 = float(d[k - 1]), float(d[k])
    f = 0.0 if d1 == d0 else (level - d0) / (d1 - d0)
    return float(t[k - 1] + min(max(f, 0.0), 1.0) * (t[k] - t[k - 1]))


def barn_time(poses: np.ndarray, goal_offset: tuple[float, float]) -> float | None:
    """BARN's time of a run from its ground-truth poses ``(t, x, y, ...)`` rows: from when the
    robot is first :data:`START_MOVE_M` from its first pose to when it is first within
    :data:`GOAL_RADIUS_M` of the goal (its first pose + ``goal_offset``); None when it never gets
    there. Crossings are interpolated between samples."""
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim != 2 or p.shape[0] == 0 or p.shape[1] < 3:
        return None
    t, xy = p[:, 0], p[:, 1:3]
    start = xy[0]
    goal = start + np.asarray(goal_offset, np.float64)
    to_goal = np.hypot(*(xy - goal).T)
    near = np.flatnonzero(to_goal <= GOAL_RADIUS_M)
    if not len(near):
        return None
    reach = _interp_cross(t, to_goal, int(near[0]), GOAL_RADIUS_M)
    moved_d = np.hypot(*(xy - start).T)
    moved = np.flatnonzero(moved_d >= START_MOVE_M)
    t0 = _interp_cross(t, moved_d, int(moved[0]), START_MOVE_M) if len(moved) else float(t[0])
    return max(reach - min(t0, reach), 0.0)


# ---- the campaign's BARN worlds ----------------------------------------------------------------


@dataclass(frozen=True)
class BarnWorld:
    """A BARN world of a campaign: its configuration, its BARN index, its path file and the
    path's length and optimal time (None, with ``problem``, when the path file is unusable)."""

    experiment: str
    key: str
    index: int
    path_file: str
    length_m: float | None
    t_opt_s: float | None
    problem: str | None = None


def _is_barn_mission(world: dict[str, Any]) -> bool:
    m = world.get("mission")
    if not isinstance(m, dict):
        return False
    start, goal = m.get("start"), m.get("goal")
    try:
        return (len(start) == 3 and len(goal) == 2  # type: ignore[arg-type]
                and all(abs(float(a) - b) <= MISSION_TOL for a, b in zip(start[:2], BARN_START[:2]))  # type: ignore[index]
                and abs(float(start[2]) - BARN_START[2]) <= 1e-3  # type: ignore[index]
                and all(abs(float(a) - b) <= MISSION_TOL for a, b in zip(goal, BARN_GOAL)))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False


def barn_worlds(spec: CampaignSpec, base_dir: str | Path | None = None) -> list[BarnWorld]:
    """The BARN worlds of ``spec`` (see module doc): each explicit world whose source is a
    ``world_N.world`` beside ``path_files/path_N.npy`` with BARN's mission. A relative source
    path is taken relative to ``base_dir``."""
    out: list[BarnWorld] = []
    for exp in spec.experiments:
        if not exp.explicit:
            continue
        for cfg in exp.configurations(spec.world):
            src = cfg.world.get("source")
            path = src.get("path") if isinstance(src, dict) else None
            if not isinstance(path, str):
                continue
            f = Path(path)
            if not f.is_absolute() and base_dir is not None:
                f = Path(base_dir) / f
            m = _WORLD_FILE.match(f.name)
            if m is None or not _is_barn_mission(cfg.world):
                continue
            n = int(m.group(1))
            pf = barn_path_file(f.parent, n)
            if not pf.parent.is_dir():
                continue  # not laid out as BARN's folder: no path to score against
            try:
                length = path_length(load_path(pf))
            except SpecError as err:
                out.append(BarnWorld(exp.name, cfg.key, n, str(pf), None, None, str(err)))
                continue
            out.append(BarnWorld(exp.name, cfg.key, n, str(pf), length, optimal_time(length)))
    return out


# ---- scores -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BarnRun:
    """One scored run: its success, BARN's time ``t_s`` (None for a failure) and where it came
    from (``trace``: the ground-truth trajectory, BARN's clock; ``duration``: the simulated
    duration, the run had no readable trace), and its score."""

    run_id: str
    success: bool
    t_s: float | None
    t_from: str | None
    duration_s: float
    score: float

    def to_json(self) -> dict[str, Any]:
        return {"run_id": self.run_id, "success": self.success, "t_s": self.t_s, "t_from": self.t_from,
                "duration_s": self.duration_s, "score": self.score}


@dataclass
class BarnWorldScore:
    """The runs of one navigator (and fault) on one BARN world."""

    world: BarnWorld
    runs: list[BarnRun] = field(default_factory=list)

    @property
    def score(self) -> float | None:
        """The mean score of the world's runs (None without a run)."""
        return sum(r.score for r in self.runs) / len(self.runs) if self.runs else None

    @property
    def successes(self) -> int:
        return sum(r.success for r in self.runs)

    @property
    def mean_t_s(self) -> float | None:
        """The mean BARN time of the successful runs (None without one)."""
        ts = [r.t_s for r in self.runs if r.success and r.t_s is not None]
        return sum(ts) / len(ts) if ts else None

    def to_json(self) -> dict[str, Any]:
        w = self.world
        return {"experiment": w.experiment, "config": w.key, "world": w.index, "path_file": w.path_file,
                "path_length_m": w.length_m, "t_opt_s": w.t_opt_s, "runs": len(self.runs),
                "successes": self.successes, "mean_t_s": self.mean_t_s, "score": self.score,
                "run_scores": [r.to_json() for r in self.runs]}


@dataclass
class BarnGroup:
    """BARN's score of one navigator (``navigator@robot`` in a campaign of several robots) and fault."""

    navigator: str
    fault: str
    worlds: list[BarnWorldScore]

    @property
    def runs(self) -> int:
        return sum(len(w.runs) for w in self.worlds)

    @property
    def successes(self) -> int:
        return sum(w.successes for w in self.worlds)

    @property
    def score(self) -> float | None:
        """BARN's overall score: the mean over every run (None without a run)."""
        n = self.runs
        return sum(r.score for w in self.worlds for r in w.runs) / n if n else None

    def to_json(self) -> dict[str, Any]:
        return {"navigator": self.navigator, "fault": self.fault, "runs": self.runs, "successes": self.successes,
                "worlds": sum(1 for w in self.worlds if w.runs), "score": self.score,
                "per_world": [w.to_json() for w in self.worlds]}


@dataclass
class BarnScores:
    """BARN's score of a campaign: one :class:`BarnGroup` per navigator and fault, and notes
    (worlds whose path file is unusable, runs left out)."""

    groups: list[BarnGroup]
    worlds: list[BarnWorld]
    notes: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {"formula": "success * t_opt / clip(t, 2 t_opt, 8 t_opt), t_opt = path length / 2 m/s",
                "worlds": len(self.worlds), "groups": [g.to_json() for g in self.groups], "notes": list(self.notes)}


def is_scored(worlds: list[BarnWorld], rec: RunRecord) -> bool:
    """Whether ``rec`` is a successful run on one of ``worlds`` (its trajectory gives its time)."""
    return rec.outcome == Outcome.SUCCESS.value and any(
        w.experiment == rec.experiment and w.key == config_key(rec) for w in worlds)


def barn_goal_offset() -> tuple[float, float]:
    """The goal relative to the start in BARN's mission (m)."""
    return (BARN_GOAL[0] - BARN_START[0], BARN_GOAL[1] - BARN_START[1])


def barn_scores(spec: CampaignSpec, records: Iterable[RunRecord],
                trajectory: Callable[[RunRecord], np.ndarray | None],
                base_dir: str | Path | None = None, worlds: list[BarnWorld] | None = None) -> BarnScores | None:
    """BARN's score of ``records`` (a campaign's, navigator names as the analysis has them) on the
    BARN worlds of ``spec`` (``worlds``: :func:`barn_worlds` of it, when already known); None when
    the campaign has none. ``trajectory`` gives a successful run's ground-truth poses (None: no
    readable trace; the run's duration is then its time)."""
    if worlds is None:
        worlds = barn_worlds(spec, base_dir)
    if not worlds:
        return None
    by_key = {(w.experiment, w.key): w for w in worlds}
    notes = [f"{w.key}: not scored ({w.problem})" for w in worlds if w.problem is not None]
    offset = barn_goal_offset()
    groups: dict[tuple[str, str], dict[tuple[str, str], BarnWorldScore]] = {}
    refused = untimed = 0
    for r in records:
        w = by_key.get((r.experiment, config_key(r)))
        if w is None or w.t_opt_s is None:
            continue
        if ungenerated(r):
            refused += 1
            continue
        success = r.outcome == Outcome.SUCCESS.value
        t: float | None = None
        src: str | None = None
        if success:
            poses = trajectory(r)
            t = barn_time(poses, offset) if poses is not None else None
            src = "trace"
            if t is None:
                t, src = float(r.duration_s), "duration"
                untimed += 1
        s = score(success, t if t is not None else 0.0, w.t_opt_s)
        g = groups.setdefault((r.navigator, fault_name(r.fault)), {})
        g.setdefault((w.experiment, w.key), BarnWorldScore(w)).runs.append(
            BarnRun(r.run_id, success, t, src, float(r.duration_s), s))
    if refused:
        notes.append(f"{refused} run(s) on BARN worlds that could not be imported are left out (they never ran)")
    if untimed:
        notes.append(f"{untimed} successful run(s) without a readable trace: their time is their simulated duration "
                     "(from t = 0 to the navigator's arrival), not BARN's clock")
    order = {(w.experiment, w.key): i for i, w in enumerate(worlds)}
    out = [BarnGroup(nav, fault, sorted(ws.values(), key=lambda ws_: order[(ws_.world.experiment, ws_.world.key)]))
           for (nav, fault), ws in groups.items()]
    return BarnScores(out, worlds, notes)


__all__ = ["BarnGroup", "BarnRun", "BarnScores", "BarnWorld", "BarnWorldScore", "barn_scores", "barn_time",
           "barn_worlds", "cells_xy", "load_path", "optimal_time", "path_length", "score"]
