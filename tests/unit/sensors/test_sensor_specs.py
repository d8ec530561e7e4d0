"""``sensors:`` / ``sensors_add:`` in campaign and search specs, sweepable ``sensors.<name>.<param>``
paths, and ``--sensor``: the robots the runs' tasks carry, the same from every entry point."""

from __future__ import annotations

import copy
from typing import Any

import pytest

from navstress.campaign.plan import plan
from navstress.errors import SpecError
from navstress.campaign.spec import parse_campaign
from navstress.robot import RobotSpec, profile
from navstress.robot.files import with_sensors
from navstress.run.sensors import apply_sensor_flags, apply_sensor_values
from navstress.search.spec import parse_search
from navstress.sensors import default_suite
from tests.support.cli_inputs import CAMPAIGN, SEARCH

LASER = {"name": "front_laser", "kind": "lidar2d", "profile": "ust10", "mount": {"xyz": [0.12, 0.0, 0.3]}}
CAM = {"name": "cam", "kind": "depth", "profile": "d435", "width": 160, "height": 120}
FLAGS = (["front_laser=lidar2d:ust10,mount=0.12:0:0.3"], ["cam=depth:d435,width=160,height=120"])


def _spec(**over: Any) -> dict[str, Any]:
    return {**copy.deepcopy(CAMPAIGN), "robot": "jackal", **over}


def _task_robots(spec: Any) -> dict[str, RobotSpec]:
    return {t.run_id: t.robot_spec() for t in plan(spec, "/tmp/sensor-plan").tasks}


def test_every_entry_point_gives_the_same_robot() -> None:
    want = with_sensors(profile("jackal"), sensors=[LASER], sensors_add=[CAM])
    assert apply_sensor_flags(profile("jackal"), *FLAGS) == want
    spec = parse_campaign(_spec(sensors=[LASER], sensors_add=[CAM]))
    assert spec.robot == want and all(r == want for r in _task_robots(spec).values())
    assert parse_search({**copy.deepcopy(SEARCH), "robot": "jackal", "sensors": [LASER],
                         "sensors_add": [CAM]}).robot == want


def test_sensors_add_to_the_default_suite_and_the_default_robot() -> None:
    spec = parse_campaign({**copy.deepcopy(CAMPAIGN), "sensors_add": [CAM]})
    assert spec.robot is not None and spec.robot.name == "rmp400"
    assert spec.robot.sensors == (*default_suite(RobotSpec().mounts), spec.robot.sensors[1])
    assert spec.digest() != parse_campaign(copy.deepcopy(CAMPAIGN)).digest()


def test_experiment_sensors_apply_after_the_campaigns() -> None:
    data = _spec(sensors=[LASER])
    data["experiments"] = [{**data["experiments"][0], "name": "a"},
                           {**data["experiments"][0], "name": "b", "sensors_add": [CAM]},
                           {**data["experiments"][0], "name": "c", "robots": ["husky", "jackal"]}]
    spec = parse_campaign(data)
    by_exp: dict[str, set[tuple[str, tuple[str, ...]]]] = {}
    for t in plan(spec, "/tmp/sensor-plan").tasks:
        r = t.robot_spec()
        by_exp.setdefault(t.experiment, set()).add((r.name, tuple(s.name for s in r.sensors or ())))
    assert by_exp == {"a": {("jackal", ("front_laser",))}, "b": {("jackal", ("front_laser", "cam"))},
                      "c": {("husky", ("front_laser",)), ("jackal", ("front_laser",))}}


@pytest.mark.parametrize("path,values,check", [
    ("sensors.front_laser.max_range_m", [5, 10, 30], lambda s, v: s.params["max_range_m"] == v),
    ("sensors.front_laser.profile", ["ust10", "tim571", "rplidar_a2"], lambda s, v: s.profile == v),
    ("sensors.front_laser.kind", ["lidar2d", "lidar3d"], lambda s, v: s.kind == v),
    ("sensors.front_laser.beams", [90, 360], lambda s, v: s.params["beams"] == v),
])
def test_a_sweep_over_a_sensor_sets_each_configurations_robot(path: str, values: list[Any], check: Any) -> None:
    data = _spec(sensors=[LASER])
    data["experiments"][0]["sweep"] = {path: {"values": values}, "obstacles.obstruction.tree": {"values": [0]}}
    spec = parse_campaign(data)
    tasks = plan(spec, "/tmp/sensor-plan").tasks
    seen = set()
    for t in tasks:
        v = t.config[path]
        (s,) = t.robot_spec().sensors or ()
        assert check(s, v) and s.name == "front_laser" and s.mount.xyz == (0.12, 0.0, 0.3), (v, s)
        assert "sensors" not in plan(spec, "/tmp/sensor-plan").maps[0].world  # never in the world
        seen.add(v)
    assert seen == set(values)


def test_sweeping_the_default_lidar() -> None:
    """A robot without its own suite: its default lidar (``lidar``) is swept."""
    data = {**copy.deepcopy(CAMPAIGN)}
    data["experiments"][0]["sweep"] = {"sensors.lidar.channels": {"values": [16, 32]}}
    spec = parse_campaign(data)
    chans = {t.config["sensors.lidar.channels"]: t.robot_spec().sensors[0].params["channels"]  # type: ignore[index]
             for t in plan(spec, "/tmp/sensor-plan").tasks}
    assert chans == {16: 16, 32: 32}


def test_a_profile_sweep_starts_from_the_profiles_figures() -> None:
    r = with_sensors(profile("jackal"), sensors=[{**LASER, "max_range_m": 6}])
    (s,) = apply_sensor_values(r, {"sensors.front_laser.profile": "tim571"}).sensors or ()
    assert s.params["max_range_m"] == 25.0 and s.params["beams"] == 811
    (s,) = apply_sensor_values(r, {"sensors.front_laser.beams": 100}).sensors or ()
    assert s.params["max_range_m"] == 6.0 and s.params["beams"] == 100  # the entry's override kept


def test_a_search_space_over_a_sensor() -> None:
    """A search space's ``sensors.<name>.<param>``: each candidate's robot (its campaign world
    entry's ``sensors``), never its world; the extremes checked when the spec is read."""
    from navstress.search.driver import _entry
    from navstress.search.space import Space

    data = {**copy.deepcopy(SEARCH), "robot": "jackal", "sensors": [LASER]}
    data["space"] = {"map_seed": False, "parameters": [
        {"path": "sensors.front_laser.max_range_m", "low": 2, "high": 20},
        {"path": "sensors.front_laser.beams", "low": 90, "high": 720, "kind": "int"}]}
    spec = parse_search(data)
    space = Space.from_spec(spec)
    c = space.decode([0.5, 0.0])
    assert c.world_overrides == {} and c.params == {"sensors.front_laser.max_range_m": 11.0,
                                                     "sensors.front_laser.beams": 90}
    cfg = parse_campaign({**spec.campaign_fields(), "robot": spec.robot,
                          "experiments": [{"name": "g0", "worlds": [_entry(c).model_dump()]}]})
    (task,) = [t for t in plan(cfg, "/tmp/sensor-plan").tasks][:1]
    (s,) = task.robot_spec().sensors or ()
    assert (s.params["max_range_m"], s.params["beams"]) == (11.0, 90)
    # an explicit world without sensor values keeps its digest (the text of before)
    plain = {**copy.deepcopy(CAMPAIGN), "experiments": [{"name": "e", "worlds": [{"key": "k", "map_seed": 1}]}]}
    assert "sensors" not in parse_campaign(plain).canonical_json()
    for bad, needle in ((("sensors.front_laser.rate_hz", 10, 500), "step rate"),
                        (("sensors.front_laser.profile", 0, 1), "numeric sensor parameter"),
                        (("sensors.back.max_range_m", 1, 2), "a sensor of the robot")):
        data["space"]["parameters"] = [{"path": bad[0], "low": bad[1], "high": bad[2]}]
        with pytest.raises(SpecError) as info:
            parse_search(data)
        assert needle in str(info.value), str(info.value)
