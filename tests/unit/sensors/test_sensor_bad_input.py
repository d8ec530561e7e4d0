"""Every bad sensor input of issue 36 ("Bad input") from every entry point: one line, exit 2 on
the command line, nothing written.

The cases (:data:`CASES`) are written once, as a spec entry and as the ``--sensor`` text; the
entry points are a campaign spec (``sensors:`` and ``sensors_add:`` at the top level and in an
experiment, and a sweep value), a search spec, a robot file, and ``navstress run``, ``world
drive``, ``nav check`` (``--sensor`` and ``--sensor-add``), ``campaign run`` and ``search`` with a
spec file. Hypothesis draws further bad values of the same kinds (a field of view over 360, a
rate above the step rate, a maximum range below the minimum) through the campaign spec.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.campaign.spec import parse_campaign
from navstress.errors import SpecError
from navstress.robot.files import load_robot
from navstress.search.spec import parse_search
from tests.support.cli_inputs import CAMPAIGN, SEARCH, assert_one_line_error, invoke, snapshot
from tests.support.world_fixtures import small_world

LASER = {"name": "front_laser", "kind": "lidar2d", "profile": "ust10", "mount": {"xyz": [0.12, 0.0, 0.3]}}


def _laser(**over: Any) -> list[dict[str, Any]]:
    return [{**LASER, **over}]


#: name -> (the sensors: list, the --sensor values, what the line must hold)
CASES: dict[str, tuple[list[dict[str, Any]], list[str], tuple[str, ...]]] = {
    "unknown kind": ([{**LASER, "kind": "lidar2", "profile": None}], ["front_laser=lidar2"],
                     ("kind='lidar2'", "did you mean lidar2d?")),
    "unknown profile": (_laser(profile="ust1"), ["front_laser=lidar2d:ust1"], ("profile='ust1'", "did you mean ust10")),
    "unknown parameter": (_laser(max_rnge_m=5), ["front_laser=lidar2d,max_rnge_m=5"],
                          ("max_rnge_m=5", "did you mean max_range_m")),
    "fov over 360": (_laser(fov_deg=400), ["front_laser=lidar2d,fov_deg=400"], ("fov_deg=400", "<= 360")),
    "zero beams": (_laser(beams=0), ["front_laser=lidar2d,beams=0"], ("beams=0", ">= 1")),
    "zero channels": ([{"name": "top", "kind": "lidar3d", "channels": 0}], ["top=lidar3d,channels=0"],
                      ("channels=0", ">= 1")),
    "range below minimum": (_laser(max_range_m=0.01), ["front_laser=lidar2d,max_range_m=0.01"],
                            ("max_range_m=0.01", "min_range_m=0.06")),
    "depth range below minimum": ([{"name": "cam", "kind": "depth", "max_range_m": 0.05}],
                                  ["cam=depth:d435,max_range_m=0.05"], ("max_range_m=0.05", "min_range_m")),
    "mount out of reach": (_laser(mount={"xyz": [5.0, 0.0, 0.3]}), ["front_laser=lidar2d,mount=5:0:0.3"],
                           ("mount.xyz=[5.0, 0.0, 0.3]", "reach")),
    "mount under ground": (_laser(mount={"xyz": [0.1, 0.0, -2.0]}), ["front_laser=lidar2d,mount=0.1:0:-2"],
                           ("mount.xyz", "above the ground")),
    "rate above step rate": (_laser(rate_hz=1000), ["front_laser=lidar2d,rate_hz=1000"],
                             ("front_laser.rate_hz=1000", "step rate")),
    "name used twice": ([LASER, {**LASER, "kind": "depth", "profile": "d435"}],
                        ["front_laser=lidar2d", "front_laser=depth"], ("name='front_laser'", "no other sensor")),
    "reserved name": ([{**LASER, "name": "imu"}], ["imu=lidar2d"], ("name='imu'", "built-in")),
}
IDS = list(CASES)


def _check(err: SpecError | str, needles: tuple[str, ...]) -> None:
    text = str(err)
    assert "\n" not in text
    for n in needles:
        assert n in text, (n, text)


def _raises(fn: Any, needles: tuple[str, ...]) -> str:
    with pytest.raises(SpecError) as info:
        fn()
    _check(info.value, needles)
    return info.value.field


# ---- specs ----------------------------------------------------------------------------------


@pytest.mark.parametrize("case", IDS)
@pytest.mark.parametrize("where", ["top", "top-add", "experiment", "experiment-add", "experiment-robot"])
def test_campaign_spec(case: str, where: str) -> None:
    sensors, _flags, needles = CASES[case]
    spec = copy.deepcopy(CAMPAIGN)
    spec["robot"] = "jackal"
    key = "sensors_add" if where.endswith("-add") else "sensors"
    if where.startswith("top"):
        spec[key] = sensors
        prefix = ""
    else:
        spec["experiments"][0][key] = sensors
        if where == "experiment-robot":
            spec["experiments"][0]["robot"] = "husky"
            del spec["robot"]
        prefix = "experiments[0]." if "rate_hz" not in needles[0] else ""
    field = _raises(lambda: parse_campaign(spec), needles)
    assert field.startswith(prefix), field
    if "rate_hz" not in needles[0]:
        assert field.startswith(f"{prefix}{key}["), field


@pytest.mark.parametrize("case", IDS)
def test_search_spec(case: str) -> None:
    sensors, _flags, needles = CASES[case]
    for key in ("sensors", "sensors_add"):
        spec = {**copy.deepcopy(SEARCH), "robot": "jackal", key: sensors}
        _raises(lambda: parse_search(spec), needles)


@pytest.mark.parametrize("case", [c for c in IDS if "rate" not in c])
def test_robot_file(case: str, tmp_path: Path) -> None:
    sensors, _flags, needles = CASES[case]
    f = tmp_path / "bot.yaml"
    f.write_text(yaml.safe_dump({"base": "jackal", "sensors": sensors}), encoding="utf-8")
    field = _raises(lambda: load_robot(str(f)), needles if "mount" not in case else needles[:1])
    assert field.startswith("robot(bot.yaml).sensors["), field


def test_robot_file_rate_is_checked_where_it_runs(tmp_path: Path) -> None:
    """A robot file has no time step: its sensors' rates are checked by the command that runs it."""
    sensors, _flags, needles = CASES["rate above step rate"]
    f = tmp_path / "bot.yaml"
    f.write_text(yaml.safe_dump({"base": "jackal", "sensors": sensors}), encoding="utf-8")
    load_robot(str(f))
    code, out, err = invoke(["run", str(tmp_path / "w"), "-o", str(tmp_path / "o"), "--robot", str(f)])
    line = assert_one_line_error(code, out, err, ["run"])
    assert line.startswith("error: --robot sensors.front_laser.rate_hz=1000") and "step rate" in line, line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("case", ["fov over 360", "unknown kind", "rate above step rate"])
def test_campaign_sweep_value(case: str) -> None:
    """A swept sensor value is checked in every configuration when the spec is read."""
    bad = {"fov over 360": ("fov_deg", 400), "unknown kind": ("kind", "lidar2"),
           "rate above step rate": ("rate_hz", 1000)}[case]
    spec = copy.deepcopy(CAMPAIGN)
    spec.update(robot="jackal", sensors=[LASER])
    spec["experiments"][0]["sweep"] = {f"sensors.front_laser.{bad[0]}": {"values": [20 if bad[0] != "kind" else "lidar2d",
                                                                                    bad[1]]}}
    with pytest.raises(SpecError) as info:
        parse_campaign(spec)
    assert info.value.field.startswith(f"experiments[0].sweep[{bad[0]}="), info.value.field


@pytest.mark.parametrize("path,needle", [("sensors.back_laser.max_range_m", "did you mean front_laser"),
                                         ("sensors.front_laser.max_rnge_m", "did you mean max_range_m"),
                                         ("sensors.front_laser", "sensors.<name>.<param>")])
def test_campaign_sweep_path(path: str, needle: str) -> None:
    spec = copy.deepcopy(CAMPAIGN)
    spec.update(robot="jackal", sensors=[LASER])
    spec["experiments"][0]["sweep"] = {path: {"values": [5]}}
    with pytest.raises(SpecError) as info:
        parse_campaign(spec)
    assert info.value.field == f"experiments[0].sweep.{path}" and needle in str(info.value), str(info.value)


# ---- the command line -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("sensors-cli")
    small_world().save(r / "w")
    return r


def _commands(root: Path) -> dict[str, list[str]]:
    return {"run": ["run", str(root / "w"), "-o", str(root / "out")],
            "world drive": ["world", "drive", str(root / "w"), "-o", str(root / "out.png")],
            "nav check": ["nav", "check", "straightline-v1"]}


@pytest.mark.parametrize("case", IDS)
@pytest.mark.parametrize("command", ["run", "world drive", "nav check"])
@pytest.mark.parametrize("flag", ["--sensor", "--sensor-add"])
def test_command_line(root: Path, case: str, command: str, flag: str) -> None:
    _sensors, values, needles = CASES[case]
    argv = [*_commands(root)[command], "--robot", "jackal"]
    for v in values:
        argv += [flag, v]
    before = snapshot(root)
    line = assert_one_line_error(*invoke(argv), argv)
    _check(line, needles[1:] if "rate" not in case else needles[1:])
    assert line.startswith(f"error: {flag}"), line
    assert snapshot(root) == before  # nothing written


@pytest.mark.parametrize("case", IDS)
@pytest.mark.parametrize("command", ["campaign run", "search"])
def test_spec_files_on_the_command_line(root: Path, tmp_path: Path, case: str, command: str) -> None:
    sensors, _flags, needles = CASES[case]
    data = {**copy.deepcopy(CAMPAIGN if command == "campaign run" else SEARCH), "robot": "jackal", "sensors": sensors}
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(data), encoding="utf-8")
    out = tmp_path / "out"
    argv = [*command.split(), str(spec), "-o", str(out)]
    before = snapshot(tmp_path)
    line = assert_one_line_error(*invoke(argv), argv)
    _check(line, needles)
    assert snapshot(tmp_path) == before


def test_a_sensor_file_on_the_command_line(root: Path, tmp_path: Path) -> None:
    """--sensor FILE: a list of entries, read as a spec's sensors: (its errors name the flag)."""
    f = tmp_path / "sensors.yaml"
    f.write_text(yaml.safe_dump([LASER, {"name": "cam", "kind": "depht"}]), encoding="utf-8")
    argv = [*_commands(root)["run"], "--robot", "jackal", "--sensor", str(f)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith("error: --sensor[1].kind='depht'") and "did you mean depth?" in line, line
    f.write_text(yaml.safe_dump({"sensors": "front_laser"}), encoding="utf-8")
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith("error: --sensor=") and "list of sensor entries" in line, line


@pytest.mark.parametrize("text", ["front_laser", "=lidar2d", "front_laser=", "a=lidar2d,mount=1:2",
                                  "a=lidar2d,rpy=0:0:1", "a=lidar2d,beams", "a=lidar2d:ust10,profile=tim571",
                                  "a=lidar2d,mount=1:x:2", "missing.yaml"])
def test_malformed_sensor_text(root: Path, text: str) -> None:
    argv = [*_commands(root)["run"], "--robot", "jackal", "--sensor", text]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith("error: --sensor"), line


# ---- further bad values, drawn --------------------------------------------------------------


BAD_VALUES = st.one_of(
    st.tuples(st.just("fov_deg"), st.floats(360.001, 1e9)),
    st.tuples(st.just("beams"), st.integers(-10**9, 0)),
    st.tuples(st.just("rate_hz"), st.floats(200.001, 1e9)),  # the Jackal's step: 0.005 s
    st.tuples(st.just("max_range_m"), st.floats(1e-9, 0.06)),
    st.tuples(st.just("min_range_m"), st.floats(10.0, 1e6)),
)


@settings(max_examples=60, deadline=None)
@given(BAD_VALUES, st.sampled_from(["sensors", "sensors_add"]))
def test_drawn_bad_values_are_one_line_naming_the_field(bad: tuple[str, float], key: str) -> None:
    field, value = bad
    spec = {**copy.deepcopy(CAMPAIGN), "robot": "jackal", key: _laser(**{field: value})}
    with pytest.raises(SpecError) as info:
        parse_campaign(spec)
    text = str(info.value)
    assert "\n" not in text
    named = {"min_range_m": "max_range_m"}.get(field, field)  # min above max: the max is named
    assert info.value.field.endswith(named), text
