"""The navigator's own view in a trace (``record_navigator``): reference-v1's arcs after every
step and its map once per simulated second; recording it never changes a run; hooks that
misbehave are a warning, not a lost run; the same drawings come over the line protocol."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from navstress.nav.api import Command, DebugDraw, DebugLine, DebugPoints, DebugText, NavMission, Observation, Status
from navstress.robot import RobotSpec
from navstress.run.mission import MAP_TRACE_PERIOD_S, execute, run_mission
from navstress.run.record import RunTask
from navstress.run.trace import (TOPIC_MAP, TOPIC_PERCEIVED, TraceWriter, read_commands, read_debug, read_events,
                                 read_grid, read_grids, read_poses)
from navstress.world import Mission, Obstacle, World, WorldSpec
from tests.support.world_fixtures import trees_world_dir

pytestmark = pytest.mark.slow

ELECTED_WIDTH = 0.12  # reference-v1 draws the elected arc this wide, the others 0.04


@pytest.fixture(scope="module")
def world_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return trees_world_dir(tmp_path_factory.mktemp("worlds"))


def _task(world_dir: Path, out: Path, **kw: object) -> RunTask:
    base = dict(run_id="v/0", world_dir=str(world_dir), run_seed=5, trace_path=str(out / "run.mcap"),
                timeout_s=30.0)
    base.update(kw)
    return RunTask(**base)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def runs(world_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    out = {}
    for name, view in (("plain", False), ("view", True), ("view2", True)):
        d = tmp_path_factory.mktemp(name)
        out[name] = execute(_task(world_dir, d, record_navigator=view))
    return out


def test_recording_the_view_does_not_change_the_run(runs: dict[str, object]) -> None:
    plain, view = runs["plain"], runs["view"]
    for f in ("outcome", "reason", "duration_s", "path_length_m", "collisions"):
        assert getattr(plain, f) == getattr(view, f), f
    assert plain.duration_s > 25  # type: ignore[attr-defined]
    for read in (read_poses, lambda p: read_poses(p, TOPIC_PERCEIVED), read_commands):
        np.testing.assert_array_equal(read(plain.trace), read(view.trace))  # type: ignore[attr-defined]
    assert read_debug(plain.trace) == [] and len(read_grids(plain.trace)) == 1  # type: ignore[attr-defined]
    # and the recording is deterministic: the same task gives the same bytes
    assert Path(view.trace).read_bytes() == Path(runs["view2"].trace).read_bytes()  # type: ignore[attr-defined]


def test_the_arcs_follow_the_robot_and_the_elected_one_is_driven(runs: dict[str, object]) -> None:
    trace = runs["view"].trace  # type: ignore[attr-defined]
    draws = read_debug(trace)
    cmds = read_commands(trace)
    # one drawing per step: every command (and the final status, when the run ended on one)
    assert len(draws) in (len(cmds), len(cmds) + 1)
    assert np.array_equal(np.array([t for t, _ in draws[:len(cmds)]]), cmds[:, 0])
    perceived = read_poses(trace, TOPIC_PERCEIVED)
    navigating = [(t, d) for t, d in draws if d.lines]
    assert len(navigating) > 0.3 * len(draws)  # the scan manoeuvre first (~17 s of these 30), then arcs every step
    for t, d in navigating:
        assert all(ln.frame == "map" and ln.points.shape == (16, 3) for ln in d.lines)  # the robot, 15 nodes
        elected = [ln for ln in d.lines if ln.width_m == pytest.approx(ELECTED_WIDTH)]
        assert len(elected) <= 1 and len(d.lines) <= 19  # 20 paths, one of them the turn on the spot
        (text,) = d.texts
        assert text.frame == "robot" and "electable" in text.text
        # every arc starts where the navigator believed it was at that step
        k = int(np.searchsorted(perceived[:, 0], t - 1e-9))
        assert perceived[k, 0] == t
        start = np.array([ln.points[0, :2] for ln in d.lines])
        assert np.abs(start - perceived[k, 1:3]).max() < 1e-9, t
        if elected:
            assert text.text.startswith("arc ")
            # the elected arc bends the way the robot was told to turn
            k = int(np.searchsorted(cmds[:, 0], t - 1e-9))
            if k == len(cmds):
                continue  # the final status: no command followed
            c = cmds[k]
            p = elected[0].points
            heading = np.arctan2(*(p[1, 1::-1] - p[0, 1::-1]))
            turn = np.arctan2(*(p[-1, 1::-1] - p[-2, 1::-1])) - heading
            turn = (turn + np.pi) % (2 * np.pi) - np.pi
            assert abs(turn) < 1e-6 or np.sign(turn) == np.sign(c[2]) or abs(c[2]) < 1e-9, (t, turn, c)
    assert any(d.texts[0].text == "scan turn" for _, d in draws)


def test_the_map_grows_once_per_second_and_ends_as_the_final_map(runs: dict[str, object]) -> None:
    rec = runs["view"]
    grids = read_grids(rec.trace)  # type: ignore[attr-defined]
    final = read_grid(rec.trace, TOPIC_MAP)  # type: ignore[attr-defined]
    assert final is not None
    fv, (fx, fy), cell = final
    snaps, last = grids[:-1], grids[-1]
    assert np.array_equal(last[1], fv, equal_nan=True) and last[0] == pytest.approx(rec.duration_s)  # type: ignore[attr-defined]
    times = np.array([g[0] for g in snaps])
    assert times[0] < 0.2 and len(snaps) >= int(rec.duration_s / MAP_TRACE_PERIOD_S) - 1  # type: ignore[attr-defined]
    gaps = np.diff(times)
    assert gaps.min() >= MAP_TRACE_PERIOD_S - 1e-9 and gaps.max() < MAP_TRACE_PERIOD_S + 0.2
    known_before = 0
    for _t, v, (ox, oy), c in snaps:
        assert c == cell
        known = np.isfinite(v)
        # cut to its known cells: every border row and column holds one
        assert known[0].any() and known[-1].any() and known[:, 0].any() and known[:, -1].any()
        # placed in the final map, every cell it knew is known there (reference-v1 never forgets)
        i0, j0 = round((oy - fy) / cell), round((ox - fx) / cell)
        assert (ox - fx) / cell == pytest.approx(j0) and (oy - fy) / cell == pytest.approx(i0)
        window = fv[i0:i0 + v.shape[0], j0:j0 + v.shape[1]]
        assert window.shape == v.shape and np.isfinite(window[known]).all()
        assert known.sum() >= known_before  # the map only grows
        known_before = int(known.sum())
    assert known_before > 0.5 * np.isfinite(fv).sum()


# ---- navigators whose hooks misbehave: a warning, and the run is the same

class Straight:
    """Drives straight at 0.8 m/s and draws a line ahead of itself (or what ``make`` says)."""

    def __init__(self, make: object = None, final_map: object = None) -> None:
        self.make = make
        self._map = final_map
        self.calls = 0

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.x = mission.start[0]

    def step(self, obs: Observation) -> Command | Status:
        if obs.pose is not None:
            self.x = obs.pose.x
        return Command(0.8, 0.0) if obs.t < 6.0 else Status("arrived")

    def debug(self) -> object:
        self.calls += 1
        if callable(self.make):
            return self.make(self.calls)
        return DebugDraw(lines=(DebugLine(np.array([[self.x, 5.0, 0.1], [self.x + 2.0, 5.0, 0.1]])),),
                         points=(DebugPoints(np.array([[self.x, 5.0, 0.5]]), "robot"),),
                         texts=(DebugText((0.0, 0.0, 1.0), f"x={self.x:.1f}"),))

    def final_map(self) -> object:
        if callable(self._map):
            return self._map()
        return np.array([[np.nan, 1.0], [np.nan, np.nan]]), (0.0, 0.0), 0.5

    def close(self) -> None:
        pass


def _world() -> World:
    return World.flat(WorldSpec(size_m=(30.0, 30.0)), obstacles=(Obstacle("tree", 20.0, 20.0, 0.0, (1, 1, 5), 0.0),),
                      mission=Mission((5.0, 5.0, 0.0), (25.0, 5.0), 2.0))


def _boom(n: int) -> object:
    raise RuntimeError("drawing bug")


@pytest.mark.parametrize("make,final_map,warning", [
    (_boom, None, "navigator debug(): raised RuntimeError: drawing bug"),
    (lambda n: "arcs", None, "navigator debug(): debug returned str"),
    (lambda n: DebugDraw(lines=(DebugLine(np.zeros((25_000, 3))),)), None, "more than 20,000"),
    (lambda n: DebugDraw(lines=(DebugLine(np.array([[0, 0, 0], [1, np.inf, 0]])),)), None, "not finite"),
    (lambda n: DebugDraw(texts=(DebugText((0, 0, 0), "x", "base_link"),)), None, "is not one of 'map', 'robot'"),
    (None, lambda: "map", "navigator final_map(): final_map returned"),
    (None, lambda: (np.zeros(3), (0, 0), 0.5), "expected a 2-D grid"),
    (None, lambda: _boom(0), "navigator final_map(): raised RuntimeError"),
])
def test_a_hook_that_misbehaves_is_a_warning_and_the_run_is_unchanged(make: object, final_map: object,
                                                                      warning: str, tmp_path: Path) -> None:
    w = _world()
    plain = run_mission(w, Straight(), run_seed=3, timeout_s=20.0)
    nav = Straight(make, final_map)
    tw = TraceWriter(tmp_path / "v.mcap")
    r = run_mission(w, nav, run_seed=3, timeout_s=20.0, trace=tw, record_navigator=True)
    tw.close()
    assert r.classification == plain.classification and np.array_equal(r.truth, plain.truth)
    warned = [m for _t, level, m in r.events if level == "warning"]
    assert len(warned) == 1 and warning in warned[0], warned
    assert "not recorded from here on" in warned[0]
    if make is not None:
        assert nav.calls == 1 and read_debug(tmp_path / "v.mcap") == []  # asked once, never again
    else:  # no snapshot, and its final map is left out too, with no second warning
        assert len(read_grids(tmp_path / "v.mcap")) == 0 and r.final_map is None
    assert any("not recorded" in e.message for e in read_events(tmp_path / "v.mcap"))


def test_a_good_drawing_lands_in_its_frames(tmp_path: Path) -> None:
    tw = TraceWriter(tmp_path / "v.mcap")
    r = run_mission(_world(), Straight(), run_seed=3, timeout_s=20.0, trace=tw, record_navigator=True)
    tw.close()
    draws = read_debug(tmp_path / "v.mcap")
    assert len(draws) == len(r.commands) + 1 and not [e for e in r.events if e[1] == "warning"]
    t, d = draws[10]
    (ln,) = d.lines
    (pt,) = d.points
    (tx,) = d.texts
    assert (ln.frame, pt.frame, tx.frame) == ("map", "robot", "robot")
    assert tx.text == f"x={ln.points[0, 0]:.1f}" and ln.points[1, 0] - ln.points[0, 0] == pytest.approx(2.0)
    (snap,) = {(g[1].tobytes(), g[2]) for g in read_grids(tmp_path / "v.mcap")[:-1]}
    assert snap == (np.array([[1.0]], dtype=np.float32).tobytes(), (0.5, 0.0))  # cut to its one known cell


def test_the_line_protocol_carries_the_same_drawings(world_dir: Path, tmp_path: Path) -> None:
    """reference-v1 served over the line protocol (``python -m navstress.nav.external``) draws,
    step for step, what it draws in-process."""
    from navstress.nav.external import ExternalNavigator
    from navstress.nav.registry import make_navigator

    w = World.load(world_dir)
    local_tw = TraceWriter(tmp_path / "local.mcap")
    run_mission(w, make_navigator("reference-v1"), run_seed=5, timeout_s=25.0, trace=local_tw,
                record_navigator=True)
    local_tw.close()
    remote_tw = TraceWriter(tmp_path / "remote.mcap")
    with ExternalNavigator([sys.executable, "-m", "navstress.nav.external", "reference-v1"],
                           step_budget_s=20.0) as remote:
        r = run_mission(w, remote, run_seed=5, timeout_s=25.0, trace=remote_tw, record_navigator=True)
    remote_tw.close()
    assert not [e for e in r.events if "not recorded" in e[2]], r.events
    local, far = read_debug(tmp_path / "local.mcap"), read_debug(tmp_path / "remote.mcap")
    assert len(local) == len(far) > 100
    assert any(d.lines for _, d in far)
    for (ta, a), (tb, b) in zip(local, far):
        assert ta == tb and [x.text for x in a.texts] == [x.text for x in b.texts]
        assert len(a.lines) == len(b.lines)
        for la, lb in zip(a.lines, b.lines):
            np.testing.assert_array_equal(la.points, lb.points)
            assert (la.colour, la.width_m) == (lb.colour, lb.width_m)
    # a host that does not record the view does not ask for drawings
    with ExternalNavigator([sys.executable, "-m", "navstress.nav.external", "reference-v1"],
                           step_budget_s=20.0) as remote:
        run_mission(w, remote, run_seed=5, timeout_s=2.0)
        assert remote.debug() is None
