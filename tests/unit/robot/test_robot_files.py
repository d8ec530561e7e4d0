"""Robot files and inline robot mappings (navstress.robot.files): families of valid files load with
their overrides applied and stable, distinct digests; every family of bad input is refused with one
line naming the field and the fix."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec, resolve_robot
from navstress.robot.files import DERIVED, load_robot, merge, robot_from_mapping

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "robots"
BOX_PROFILES = sorted(n for n, p in PROFILES.items() if p.footprint.shape == "box")


def _write(path: Path, data: dict[str, Any]) -> Path:
    path.write_text(json.dumps(data) if path.suffix == ".json" else yaml.safe_dump(data), encoding="utf-8")
    return path


# ---- valid families ---------------------------------------------------------------------------

overrides = st.fixed_dictionaries({}, optional={
    "mass_kg": st.floats(0.5, 500.0),
    "max_speed_mps": st.floats(0.1, 5.0),
    "max_yaw_rate_rps": st.floats(0.1, 5.0),
    "body_height_m": st.floats(0.05, 0.1),  # below every profile's scanner
    "wheel_torque_nm": st.floats(0.5, 200.0),
})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(base=st.sampled_from(sorted(PROFILES)), over=overrides, fmt=st.sampled_from([".yaml", ".yml", ".json"]),
       stem=st.from_regex(r"[a-z][a-z0-9_-]{0,12}", fullmatch=True))
def test_files_load_with_the_overrides_applied(tmp_path: Path, base: str, over: dict[str, float], fmt: str,
                                               stem: str) -> None:
    path = _write(tmp_path / f"{stem}{fmt}", {"base": base, **over})
    r = load_robot(path)
    assert r.name == stem  # a file without a name: its stem
    for k, v in over.items():
        assert getattr(r, k) == v
    for k in RobotSpec.model_fields:  # everything else is the base's
        if k not in over and k != "name":
            assert getattr(r, k) == getattr(PROFILES[base], k), k
    assert load_robot(path).digest == r.digest  # stable
    assert resolve_robot(str(path)) == r
    inline = robot_from_mapping({"base": base, "name": stem, **over})
    assert inline == r and inline.digest == r.digest  # a file and the same mapping inline


@settings(max_examples=30, deadline=None)
@given(base=st.sampled_from(BOX_PROFILES), a=st.floats(0.2, 3.0), b=st.floats(0.2, 3.0))
def test_digests_differ_when_the_description_does(base: str, a: float, b: float) -> None:
    ra = robot_from_mapping({"base": base, "name": "x", "length_m": a})
    rb = robot_from_mapping({"base": base, "name": "x", "length_m": b})
    assert (ra.digest == rb.digest) == (a == b)
    assert ra.length_m == a


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_a_base_alone_is_the_profile(name: str) -> None:
    r = robot_from_mapping({"base": name})
    assert r == PROFILES[name] and r.digest == PROFILES[name].digest


def test_no_base_leaves_the_firmware_figures_to_the_drive_model() -> None:
    r = robot_from_mapping({"name": "mine", "length_m": 0.6, "width_m": 0.4, "mass_kg": 20.0})
    assert all(getattr(r, f) is None for f in DERIVED)
    assert r.name == "mine" and r.mass_kg == 20.0
    assert robot_from_mapping({"length_m": 0.6}).name == "robot"
    assert robot_from_mapping({"base": "jackal", "mass_kg": 18.0}).name == "jackal-custom"


def test_mounts_merge_and_footprint_replaces() -> None:
    r = robot_from_mapping({"base": "jackal", "mounts": {"lidar": {"xyz": [0.1, 0.0, 0.3]},
                                                         "camera": {"xyz": [0.2, 0.0, 0.25], "rpy": [0, 0.1, 0]}}})
    assert r.mounts["lidar"].xyz == (0.1, 0.0, 0.3) and r.mounts["lidar"].rpy == PROFILES["jackal"].mounts["lidar"].rpy
    assert r.mounts["camera"].rpy == (0.0, 0.1, 0.0)
    gone = robot_from_mapping({"base": "jackal", "mounts": {"lidar": None}})
    assert "lidar" not in gone.mounts
    circle = robot_from_mapping({"base": "jackal", "footprint": {"shape": "circle", "radius_m": 0.3}})
    assert circle.footprint.shape == "circle" and circle.length_m == 0.6
    box = robot_from_mapping({"base": "turtlebot4", "footprint": {"shape": "box"}})
    assert box.footprint.radius_m is None and box.length_m == PROFILES["turtlebot4"].length_m
    assert merge({"a": {"b": 1, "c": 2}}, {"a": {"b": 3}}) == {"a": {"b": 3, "c": 2}}


def test_the_shipped_example_file() -> None:
    r = load_robot(EXAMPLES / "our_jackal.yaml")
    assert (r.name, r.length_m, r.max_speed_mps) == ("our-jackal", 0.62, 1.5)
    assert r.mounts["lidar"].xyz == (0.2, 0.0, 0.25)
    assert r.mass_kg == PROFILES["jackal"].mass_kg


def test_a_polygon_footprint_and_casters_are_yaml_lists(tmp_path: Path) -> None:
    path = _write(tmp_path / "poly.yaml", {"base": "turtlebot4", "footprint": {"shape": "polygon", "points": [
        [0.2, 0.15], [-0.2, 0.15], [-0.2, -0.15], [0.2, -0.15]]}, "caster_positions": [[0.15, 0.0]]})
    r = load_robot(path)
    assert r.footprint.points == ((0.2, 0.15), (-0.2, 0.15), (-0.2, -0.15), (0.2, -0.15))
    assert r.caster_positions == ((0.15, 0.0),)


# ---- bad input: one line naming the field and the fix ----------------------------------------

BAD: list[tuple[str, dict[str, Any], str, str]] = [
    ("unknown profile", {"base": "jackall"}, "robot.base='jackall'", "did you mean jackal?"),
    ("base not a string", {"base": 3}, "robot.base=3", "robot profile"),
    ("unknown field", {"base": "jackal", "lenght_m": 0.6}, "robot.lenght_m", "did you mean length_m?"),
    ("unknown footprint field", {"footprint": {"shap": "box"}}, "robot.footprint.shap", "did you mean shape?"),
    ("unknown mount field", {"mounts": {"lidar": {"xzy": [0, 0, 1]}}}, "robot.mounts.lidar.xzy", "did you mean xyz?"),
    ("zero mass", {"base": "jackal", "mass_kg": 0}, "robot.mass_kg=0", "> 0"),
    ("negative mass", {"mass_kg": -3.0}, "robot.mass_kg=-3.0", "> 0"),
    ("negative speed", {"base": "husky", "max_speed_mps": -1.0}, "robot.max_speed_mps", "> 0"),
    ("zero wheel", {"wheel_radius_m": 0.0}, "robot.wheel_radius_m", "> 0"),
    ("a mass as text", {"mass_kg": "17"}, "robot.mass_kg='17'", "without quotes"),
    ("impossible inertia", {"inertia_kgm2": [1.0, 1.0, 5.0]}, "robot.inertia_kgm2", "sum of the other two"),
    ("non-convex footprint", {"footprint": {"shape": "polygon", "points": [[1, 1], [0, 0.2], [-1, 1], [-1, -1],
                                                                         [1, -1]]}},
     "robot.footprint.points", "convex"),
    ("zero-area footprint", {"footprint": {"shape": "polygon", "points": [[0, 0], [1, 0], [2, 0]]}},
     "robot.footprint.points", "nonzero area"),
    ("mount inside the body", {"base": "jackal", "mounts": {"lidar": {"xyz": [0.0, 0.0, 0.05]}}},
     "robot.mounts.lidar.xyz", "inside it"),
    ("mount below the ground", {"base": "jackal", "mounts": {"lidar": {"xyz": [0.0, 0.0, -0.5]}}},
     "robot.mounts.lidar.xyz", "above the ground"),
    ("length of a circle", {"base": "turtlebot4", "length_m": 0.5}, "robot.length_m", "follows the footprint"),
    ("wheels without a body", {"wheels": {"left": "a", "right": "b"}}, "robot.wheels", "urdf: or mjcf:"),
    ("both body files", {"urdf": "a.urdf", "mjcf": "b.xml"}, "robot.mjcf", "not both"),
    ("missing body file", {"drive": "differential", "urdf": "nope.urdf", "wheels": {"left": "a", "right": "b"}},
     "robot.urdf='nope.urdf'", "exists"),
    ("differential with four wheels", {"drive": "differential", "wheels_per_side": 2,
                                       "caster_positions": [[0.3, 0.0]]}, "robot.wheels_per_side", "skid-steer"),
    ("not a mapping", [1, 2], "robot=[1, 2]", "mapping of robot fields"),  # type: ignore[list-item]
]


@pytest.mark.parametrize(("data", "field", "fix"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_mappings_are_one_line_naming_the_field(data: Any, field: str, fix: str) -> None:
    with pytest.raises(SpecError) as e:
        robot_from_mapping(data)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(field), msg
    assert fix in msg, msg


@pytest.mark.parametrize(("data", "field", "fix"), [b[1:] for b in BAD if isinstance(b[1], dict)],
                         ids=[b[0] for b in BAD if isinstance(b[1], dict)])
def test_bad_files_name_the_file_and_the_field(tmp_path: Path, data: dict[str, Any], field: str, fix: str) -> None:
    path = _write(tmp_path / "ours.yaml", data)
    with pytest.raises(SpecError) as e:
        load_robot(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(field.replace("robot", "robot(ours.yaml)", 1)), msg
    assert fix in msg


@settings(max_examples=30, deadline=None)
@given(field=st.sampled_from(["mass_kg", "length_m", "width_m", "body_height_m", "wheel_radius_m", "track_m",
                              "max_speed_mps", "max_yaw_rate_rps", "max_accel_mps2", "max_yaw_accel_rps2"]),
       value=st.floats(-1e6, 0.0))
def test_non_physical_figures_are_refused(field: str, value: float) -> None:
    with pytest.raises(SpecError) as e:
        robot_from_mapping({"base": "husky", field: value})
    assert str(e.value).startswith(f"robot.{field}=")


@pytest.mark.parametrize(("name", "text", "where"), [
    ("bad.yaml", "base: jackal\nlength_m: [0.5\n", "line"),
    ("bad.json", '{"base": "jackal",\n "length_m": }', "line 2"),
])
def test_a_file_that_does_not_parse_names_the_line(tmp_path: Path, name: str, text: str, where: str) -> None:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    with pytest.raises(SpecError) as e:
        load_robot(p)
    assert where in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize(("ref", "expect"), [
    ("nope.yaml", "a robot file that exists"),
    ("our_robot.urdf", "write one: {urdf: our_robot.urdf"),
    ("our_robot.xml", "write one: {mjcf: our_robot.xml"),
    ("jackall", "did you mean jackal?"),
])
def test_refs_that_are_not_robot_files(tmp_path: Path, ref: str, expect: str) -> None:
    with pytest.raises(SpecError) as e:
        resolve_robot(str(tmp_path / ref) if ref.endswith(".yaml") else ref)
    assert expect in str(e.value)


def test_a_file_holding_a_list_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "list.yaml"
    p.write_text("- base: jackal\n", encoding="utf-8")
    with pytest.raises(SpecError, match="a mapping of robot fields"):
        load_robot(p)
