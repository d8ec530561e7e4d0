"""The robot of a run: ``run_mission(robot=...)`` with every profile, the trace carrying the robot
(name, digest, description, footprint, mount frames), RunTask's robot, and replay's robot read from
the record's trace. Cheap runs (a few simulated seconds, no lidar): nothing here depends on how
well a small base drives."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from navstress.errors import SpecError, StoreError
from navstress.nav.registry import make_navigator
from navstress.robot import PROFILES, Footprint, Mount, RobotSpec
from navstress.run.mission import execute, run_mission
from navstress.run.record import RunTask
from navstress.run.robot import description, robot_of, task_robot, with_recorded_robot
from navstress.run.trace import (BELIEF, ROBOT_METADATA, TOPIC_ROBOT, TraceWriter, _messages, read_metadata,
                                 read_robot, read_transforms)
from navstress.sim.config import SimConfig
from tests.support.world_fixtures import small_world

CHEAP = SimConfig(lidar_enabled=False)


def _run(robot: object, path: Path, fault: str | None = None) -> RobotSpec:
    tw = TraceWriter(path, {"run_seed": "1"})
    try:
        run_mission(small_world(bumpy=False), make_navigator("reference-v1", None, fault=fault), run_seed=1,
                    robot=robot, timeout_s=1.0, trace=tw, sim_config=CHEAP)
        tw.close()
    except BaseException:
        tw.abort()
        raise
    return read_robot(path)


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_every_profile_runs_and_its_trace_carries_it(name: str, tmp_path: Path) -> None:
    robot = PROFILES[name]
    back = _run(name, tmp_path / "run.mcap")
    assert back == robot and back.digest == robot.digest
    md = read_metadata(tmp_path / "run.mcap", ROBOT_METADATA)
    assert md["name"] == name and md["digest"] == robot.digest and md["description"] == description(robot)
    assert np.allclose(np.array(json.loads(md["footprint"])), robot.footprint_points(), atol=1e-9)
    tf = read_transforms(tmp_path / "run.mcap")
    for mount, m in robot.mounts.items():  # each mount a frame below base_link (and the belief's)
        for prefix in ("", BELIEF):
            rows = tf[(prefix + "base_link", prefix + mount)]
            assert np.allclose(rows[0, 1:4], m.xyz)


def test_run_mission_takes_a_robotspec_a_name_or_a_description(tmp_path: Path) -> None:
    jackal = PROFILES["jackal"]
    assert _run(jackal, tmp_path / "a.mcap") == jackal
    assert _run("jackal", tmp_path / "b.mcap") == jackal
    assert _run(description(jackal), tmp_path / "c.mcap") == jackal
    assert _run(None, tmp_path / "d.mcap") == RobotSpec()


@pytest.mark.parametrize("bad", ["jackall", "rmp-400", "Husky2", "nope.yaml"])
def test_an_unknown_robot_is_refused_before_anything_runs(bad: str, tmp_path: Path) -> None:
    with pytest.raises(SpecError) as err:
        run_mission(small_world(bumpy=False), make_navigator("reference-v1"), run_seed=1, robot=bad, timeout_s=1.0)
    assert "\n" not in str(err.value) and str(err.value).startswith("robot")
    if not bad.endswith(".yaml"):
        assert "did you mean" in str(err.value)


def test_the_navigator_is_told_the_robot_and_under_the_fault_what_it_believes(tmp_path: Path) -> None:
    seen: list[RobotSpec] = []

    class Spy:
        def reset(self, mission: object, robot: RobotSpec, *, seed: int) -> None:
            seen.append(robot)

        def step(self, obs: object) -> object:
            from navstress.nav.api import Status
            return Status("arrived")

        def close(self) -> None:
            pass

    from navstress.nav.faults import FaultyNavigator, SmallFootprint, small_footprint
    w = small_world(bumpy=False)
    run_mission(w, Spy(), run_seed=1, robot="turtlebot4", timeout_s=1.0, sim_config=CHEAP)  # type: ignore[arg-type]
    run_mission(w, FaultyNavigator(Spy(), SmallFootprint()), run_seed=1, robot="turtlebot4",  # type: ignore[arg-type]
                timeout_s=1.0, sim_config=CHEAP)
    told = PROFILES["turtlebot4"].model_copy(update={"sensors": ()})  # its resolved suite: lidar off, none
    assert seen == [told, small_footprint(told)]


# ---- the trace's robot, over families of robots ---------------------------------------------------

def _convex_polygon(draw: st.DrawFn) -> list[tuple[float, float]]:
    n = draw(st.integers(3, 9))
    gaps = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n)))
    angles = np.cumsum(gaps / gaps.sum() * 2 * math.pi)  # every gap < pi: the origin is inside
    if np.max(gaps / gaps.sum() * 2 * math.pi) >= math.pi * 0.95:
        angles = np.linspace(0, 2 * math.pi, n, endpoint=False)
    a, b = draw(st.floats(0.1, 1.5)), draw(st.floats(0.1, 1.5))
    return [(round(a * math.cos(t), 6), round(b * math.sin(t), 6)) for t in angles]  # on an ellipse: convex


@st.composite
def robots(draw: st.DrawFn) -> RobotSpec:
    shape = draw(st.sampled_from(["box", "circle", "polygon"]))
    base = PROFILES[draw(st.sampled_from(sorted(PROFILES)))].model_dump()
    fp: dict[str, object] = {"shape": shape}
    if shape == "circle":
        fp["radius_m"] = draw(st.floats(0.05, 1.5))
    elif shape == "polygon":
        fp["points"] = _convex_polygon(draw)
    else:
        base["length_m"], base["width_m"] = draw(st.floats(0.1, 3.0)), draw(st.floats(0.1, 3.0))
    top = base["ground_clearance_m"] - base["wheel_radius_m"] + base["body_height_m"]
    names = draw(st.lists(st.sampled_from(["lidar", "camera", "imu", "gps_antenna"]), unique=True, max_size=4))
    base["mounts"] = {n: Mount(xyz=(draw(st.floats(-1, 1)), draw(st.floats(-1, 1)), top + draw(st.floats(0.01, 1))),
                               rpy=(draw(st.floats(-3, 3)), draw(st.floats(-1.5, 1.5)), draw(st.floats(-3, 3))))
                      for n in names}
    base["footprint"] = Footprint(**fp)  # type: ignore[arg-type]
    base["name"] = draw(st.sampled_from(["ours", "a robot", "jäckal-2"]))
    return RobotSpec(**base)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(robots())
def test_a_traces_robot_reads_back_as_written(tmp_path: Path, robot: RobotSpec) -> None:
    path = tmp_path / "r.mcap"
    with TraceWriter(path) as tw:
        tw.robot(robot, belief=True)
    assert read_robot(path) == robot
    md = read_metadata(path, ROBOT_METADATA)
    assert (md["name"], md["digest"]) == (robot.name, robot.digest)
    assert np.allclose(np.array(json.loads(md["footprint"])), robot.footprint_points(), atol=1e-8)
    tf = read_transforms(path)
    frames = {c for (p, c) in tf if p == "base_link"}
    assert frames == set(robot.mounts) | {"lidar"}
    for name, m in robot.mounts.items():
        assert np.allclose(tf[("base_link", name)][0, 1:4], m.xyz)
    (_topic, _t, update), = list(_messages(path, [TOPIC_ROBOT]))
    ent = update.entities[0]
    outline = np.array([(p.x, p.y) for p in ent.lines[0].points])
    ring = robot.footprint_points()
    assert np.allclose(outline, np.vstack([ring, ring[:1]]), atol=1e-9)  # the true shape, closed
    if robot.footprint.shape == "box":
        assert len(ent.cubes) == 1 and not ent.triangles
    else:  # a prism of the outline: every vertex on the ring
        pts = np.array([(p.x, p.y) for p in ent.triangles[0].points])
        assert len(pts) == 2 * len(ring) and np.allclose(pts[: len(ring)], ring)


def test_a_trace_without_a_robot_reads_as_the_rmp400(tmp_path: Path) -> None:
    with TraceWriter(tmp_path / "old.mcap", {"run_seed": "3"}):
        pass
    assert read_robot(tmp_path / "old.mcap") == PROFILES["rmp400"]
    with open(tmp_path / "old.mcap", "rb") as f:
        assert [m.name for m in make_reader(f).iter_metadata()] == ["navstress.run"]


def test_a_damaged_robot_description_is_one_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.mcap"
    tw = TraceWriter(p)
    tw._w._writer.add_metadata(ROBOT_METADATA, {"name": "x", "description": '{"mass_kg": -3}'})
    tw.close()
    with pytest.raises(StoreError) as err:
        read_robot(p)
    assert "\n" not in str(err.value) and "bad.mcap" in str(err.value)


# ---- RunTask and replay ---------------------------------------------------------------------------

def test_a_task_of_the_default_robot_keeps_its_json(tmp_path: Path) -> None:
    t = RunTask(run_id="r", world_dir="w", run_seed=1, trace_path="t.mcap")
    assert "robot" not in json.loads(t.to_json())
    assert task_robot("rmp400") is None and task_robot(RobotSpec()) is None
    for name in sorted(set(PROFILES) - {"rmp400"}):
        tj = RunTask(run_id="r", world_dir="w", run_seed=1, trace_path="t.mcap", robot=task_robot(name))
        back = RunTask.from_json(tj.to_json())
        assert back == tj and robot_of(back.robot) == PROFILES[name]


def test_replay_simulates_the_recorded_robot(tmp_path: Path) -> None:
    wdir = tmp_path / "w"
    small_world(bumpy=False).save(wdir)
    task = RunTask(run_id="r", world_dir=str(wdir), run_seed=4, trace_path=str(tmp_path / "a.mcap"), timeout_s=1.0,
                   sim_overrides={"lidar_enabled": False}, robot=task_robot("jackal"))
    execute(task)
    # a task that names no robot (a store planned before robots) takes the recorded one
    again = with_recorded_robot(RunTask(**{**task.__dict__, "robot": None, "trace_path": str(tmp_path / "b.mcap")}),
                                tmp_path / "a.mcap")
    assert robot_of(again.robot) == PROFILES["jackal"]
    execute(again)
    assert read_robot(tmp_path / "b.mcap") == PROFILES["jackal"]
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()
    # a task that names one keeps it
    assert with_recorded_robot(task, tmp_path / "a.mcap") is task
    # an old trace (no robot recorded) replays as the rmp400
    with TraceWriter(tmp_path / "old.mcap"):
        pass
    old = with_recorded_robot(RunTask(**{**task.__dict__, "robot": None}), tmp_path / "old.mcap")
    assert old.robot is None and robot_of(old.robot) == PROFILES["rmp400"]


def test_the_facade_takes_the_robot(tmp_path: Path) -> None:
    import navstress

    w = small_world(bumpy=False)
    navstress.run_mission(w, "reference-v1", seed=1, timeout_s=1.0, sim_config=CHEAP, robot="husky",
                          trace=tmp_path / "f.mcap")
    assert read_robot(tmp_path / "f.mcap") == PROFILES["husky"]
    with pytest.raises(SpecError, match="did you mean husky"):
        navstress.run_mission(w, "reference-v1", seed=1, timeout_s=1.0, robot="huskyy", trace=tmp_path / "g.mcap")
    assert not list(tmp_path.glob("*g.mcap*"))
