"""End to end: real missions, real MuJoCo simulation, real reference navigator, real traces."""

from pathlib import Path

import numpy as np
import pytest

from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.registry import make_navigator
from navstress.robot import RobotSpec
from navstress.run.mission import execute, run_mission
from navstress.run.record import RunTask
from navstress.run.trace import (TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_ROBOT, _messages, read_events, read_grid,
                                 read_metadata, read_poses, read_transforms)
from navstress.world import Obstacle, World, WorldSpec
from tests.support.world_fixtures import trees_world_dir

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def small_world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return trees_world_dir(tmp_path_factory.mktemp("worlds"))


def task(world_dir: Path, out: Path, **kw: object) -> RunTask:
    base = dict(run_id="t/0", world_dir=str(world_dir), run_seed=5, trace_path=str(out / "run.mcap"), timeout_s=90.0)
    base.update(kw)
    return RunTask(**base)  # type: ignore[arg-type]


def test_reference_reaches_the_goal_and_trace_holds_the_run(small_world: Path, tmp_path: Path) -> None:
    rec = execute(task(small_world, tmp_path))
    assert rec.outcome == "success", rec.reason
    assert rec.goal_distance_m <= 2.0
    assert rec.collisions == 0 and rec.duration_s > 10
    w = World.load(small_world)
    straight = w.mission.straight_distance_m
    assert straight * 0.9 < rec.path_length_m < straight * 2.0
    truth = read_poses(rec.trace)
    assert truth[-1, 0] == pytest.approx(rec.duration_s)
    assert np.hypot(truth[-1, 1] - w.mission.goal[0], truth[-1, 2] - w.mission.goal[1]) == pytest.approx(rec.goal_distance_m)
    perceived = read_poses(rec.trace, TOPIC_PERCEIVED)
    assert len(perceived) > 10
    # the perceived trajectory is close to, but not the same as, the real one
    gap = np.hypot(*(np.interp(perceived[:, 0], truth[:, 0], truth[:, k]) - perceived[:, k] for k in (1, 2)))
    assert 0.0 < float(np.median(gap)) < 1.0
    grid = read_grid(rec.trace, TOPIC_MAP)
    assert grid is not None and np.isnan(grid[0]).any() and np.isfinite(grid[0]).any()
    assert read_metadata(rec.trace)["run_seed"] == "5"
    assert "Success" in read_events(rec.trace)[-1].message
    _check_frames(rec.trace, truth, perceived)
    # the navigator's commands, one per control cycle on simulated time, within the robot's limits;
    # the robot moved the way it was told (forward on average, as commanded)
    from navstress.run.trace import read_commands
    cmds = read_commands(rec.trace)
    rate = 10.0  # reference-v1's control rate
    assert abs(len(cmds) - rec.duration_s * rate) <= 0.1 * rec.duration_s * rate + 2
    assert (np.diff(cmds[:, 0]) > 0).all() and 0.0 <= cmds[0, 0] and cmds[-1, 0] <= rec.duration_s
    robot = RobotSpec()
    assert (np.abs(cmds[:, 1]) <= robot.max_speed_mps + 1e-9).all() and cmds[:, 1].mean() > 0.1
    assert float(np.mean(cmds[:, 1])) == pytest.approx(rec.path_length_m / rec.duration_s, rel=0.35)


def _check_frames(trace: str, truth: np.ndarray, perceived: np.ndarray) -> None:
    """The frame tree a Foxglove user follows: map -> base_link -> lidar from the truth, and
    map -> perceived/base_link -> perceived/lidar from the belief; the robot's body on both."""
    tf = read_transforms(trace)
    assert set(tf) == {("map", "base_link"), ("base_link", "lidar"), ("map", "perceived/base_link"),
                       ("perceived/base_link", "perceived/lidar")}
    np.testing.assert_allclose(tf[("map", "base_link")], truth, atol=1e-9)
    np.testing.assert_allclose(tf[("map", "perceived/base_link")], perceived, atol=1e-9)
    mount = RobotSpec().lidar
    for parent in ("base_link", "perceived/base_link"):
        (row,) = tf[(parent, parent.replace("base_link", "lidar"))]
        assert row[1:4] == pytest.approx([mount.x_m, mount.y_m, mount.z_m]) and row[4:] == pytest.approx([0, 0, 0])
    ((_t, _lt, update),) = list(_messages(trace, [TOPIC_ROBOT]))
    robot = RobotSpec()
    bodies = {e.frame_id: e for e in update.entities}
    assert set(bodies) == {"base_link", "perceived/base_link"} and all(e.frame_locked for e in bodies.values())
    size = bodies["base_link"].cubes[0].size
    assert (size.x, size.y, size.z) == pytest.approx((robot.length_m, robot.width_m, robot.body_height_m))


def test_same_task_same_trace_bytes(small_world: Path, tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    ra = execute(task(small_world, tmp_path / "a", timeout_s=20.0))
    rb = execute(task(small_world, tmp_path / "b", timeout_s=20.0))
    assert Path(ra.trace).read_bytes() == Path(rb.trace).read_bytes()
    rc = execute(task(small_world, tmp_path, timeout_s=20.0, run_seed=6))
    assert not np.array_equal(read_poses(ra.trace)[:, 1:3], read_poses(rc.trace)[:, 1:3])


def test_timeout_is_classified(small_world: Path, tmp_path: Path) -> None:
    rec = execute(task(small_world, tmp_path, timeout_s=8.0))
    assert rec.outcome == "fail-timeout"
    assert rec.duration_s == pytest.approx(8.0, abs=0.01)


class Raises:
    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.n = 0

    def step(self, obs: Observation) -> Command | Status:
        self.n += 1
        if self.n > 5:
            raise ZeroDivisionError("planner bug")
        return Command(0.5, 0.0)

    def close(self) -> None:
        pass


class GivesUp(Raises):
    def step(self, obs: Observation) -> Command | Status:
        return Status("error", "no arc elected")


class RamsTheWall(Raises):
    def step(self, obs: Observation) -> Command | Status:
        return Command(1.0, 0.0)


def wall_world() -> World:
    spec = WorldSpec(size_m=(30.0, 30.0))
    from navstress.world import Mission
    return World.flat(spec, obstacles=(Obstacle("building", 12.0, 5.0, 0.0, (2.0, 8.0, 3.0), 0.0),),
                      mission=Mission((5.0, 5.0, 0.0), (25.0, 5.0), 3.0))


@pytest.mark.parametrize("nav,outcome,text", [
    (Raises(), "fail-other", "navigator raised ZeroDivisionError: planner bug"),
    (GivesUp(), "fail-error", "no arc elected"),
    (RamsTheWall(), "fail-collision", "collision"),
])
def test_navigator_failures_are_classified(nav: Raises, outcome: str, text: str) -> None:
    r = run_mission(wall_world(), nav, run_seed=1, timeout_s=30.0)
    assert r.classification.outcome.value == outcome
    assert text in r.classification.reason


def test_collision_stops_in_front_of_the_wall() -> None:
    r = run_mission(wall_world(), RamsTheWall(), run_seed=1, timeout_s=30.0)
    assert r.facts.first_collision_s is not None
    # the chassis centre stays in front of the wall face (x = 11) by about half the robot length
    assert r.truth[:, 1].max() < 11.0 - 0.4


def test_lidar_clouds_in_the_trace_land_on_the_obstacles(tmp_path: Path) -> None:
    from navstress.run.trace import TOPIC_LIDAR, TraceWriter, _messages

    w = wall_world()
    tw = TraceWriter(tmp_path / "l.mcap")
    r = run_mission(w, GivesUp(), run_seed=1, timeout_s=5.0, trace=tw, record_lidar=True)
    tw.close()
    assert r.classification.outcome.value == "fail-error"
    clouds = [m for _t, _lt, m in _messages(tmp_path / "l.mcap", [TOPIC_LIDAR])]
    assert len(clouds) == 1  # the run ended at its first control cycle: one scan
    pts = np.frombuffer(clouds[0].data, dtype="<f4").reshape(-1, 3)
    # in the map frame: ground hits at z ~ 0, wall-face hits at x ~ 11 (the box spans x 11..13, y 1..9)
    ground = pts[np.abs(pts[:, 2]) < 0.1]
    face = pts[(pts[:, 2] > 0.3) & (pts[:, 1] > 2) & (pts[:, 1] < 8)]
    assert len(ground) > 1000 and len(face) > 20
    assert np.allclose(face[:, 0], 11.0, atol=0.15)


@pytest.mark.parametrize("timeout", [3.0, 3.004, 3.005, 3.0149])
def test_timeouts_off_the_physics_grid_end(timeout: float) -> None:
    # the clock moves in 10 ms physics steps; a timeout between two steps must still end the run
    r = run_mission(wall_world(), Idle(), run_seed=2, timeout_s=timeout)
    assert r.classification.outcome.value == "fail-timeout"
    assert abs(r.duration_s - timeout) <= 0.01


class Idle(Raises):
    def step(self, obs: Observation) -> Command | Status:
        return Command(0.0, 0.0)


# ---- the mission area (geofence)

class Straight:
    """Drives straight ahead at 1 m/s whatever it sees, and keeps the mission it was given."""

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.mission = mission

    def step(self, obs: Observation) -> Command | Status:
        return Command(1.0, 0.0)

    def close(self) -> None:
        pass


@pytest.mark.parametrize("yaw", [0.0, np.pi / 2, np.pi, -np.pi / 2])
def test_driving_off_the_map_is_the_stacks_own_failure(yaw: float) -> None:
    """Straight off each edge: Fail-Error 'left the mission area', not the infrastructure's Fail-Other."""
    from navstress.world import Mission

    w = World.flat(WorldSpec(size_m=(12.0, 12.0)), mission=Mission((6.0, 6.0, yaw), (6.0, 6.0), 1.0))
    nav = Straight()
    r = run_mission(w, nav, run_seed=1, timeout_s=30.0)
    assert r.classification.outcome.value == "fail-error", r.classification.reason
    assert r.classification.reason.startswith("left the mission area (geofence) at t=")
    x0, y0, x1, y1 = nav.mission.bounds  # type: ignore[misc]
    assert (x0, y0, x1, y1) == pytest.approx((0.7, 0.7, 11.3, 11.3))
    x, y = r.truth[-1, 1:3]
    assert not (x0 < x < x1 and y0 < y < y1)  # it did leave, and the run stopped right there
    assert 4.0 < r.duration_s < 8.0


def test_bounds_reach_in_process_and_external_navigators() -> None:
    import json
    import sys

    from navstress.nav.external import ExternalNavigator
    from navstress.run.mission import mission_bounds
    from navstress.sim.config import SimConfig

    w = wall_world()
    cfg = SimConfig(map_margin_m=1.5)
    expected = mission_bounds(w, cfg)
    assert expected == (1.5, 1.5, 28.5, 28.5)
    local = Straight()
    run_mission(w, local, run_seed=1, timeout_s=1.0, sim_config=cfg)
    assert local.mission.bounds == expected
    script = Path(__file__).resolve().parents[1] / "support" / "navigators" / "mission_nav.py"
    with ExternalNavigator([sys.executable, str(script)], step_budget_s=10.0) as remote:
        r = run_mission(w, remote, run_seed=1, timeout_s=1.0, sim_config=cfg)
    sent = json.loads(r.facts.error)  # type: ignore[arg-type]
    assert tuple(sent["bounds"]) == expected
    assert tuple(sent["goal"]) == w.mission.goal


def test_reference_near_the_edge_stays_inside() -> None:
    """The goal lies beyond the map's edge: reference-v1 approaches it along the edge but keeps
    inside its geofence (it used to drive off the map)."""
    from navstress.world import Mission

    w = World.flat(WorldSpec(size_m=(24.0, 12.0)), mission=Mission((3.0, 2.5, 0.0), (18.0, -0.5), 2.0))
    r = run_mission(w, make_navigator("reference-v1"), run_seed=3, timeout_s=30.0)
    assert "mission area" not in r.classification.reason, r.classification.reason
    assert r.truth[:, 2].min() > 0.7
    assert r.truth[-1, 1] > 12.0  # it did make its way toward the goal
