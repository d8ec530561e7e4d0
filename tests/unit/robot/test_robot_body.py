"""A robot's body from its URDF or MJCF (navstress.robot.body through robot files): the figures read
from the compiled model against the analytic figures of the bodies (the shipped URDF, families of
generated MJCF bases), the digest following the file, and the refusals of bodies that lack what
the drive needs."""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.robot.files import load_robot, robot_from_mapping

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "robots"


def _box_inertia(m: float, sx: float, sy: float, sz: float) -> np.ndarray:
    return np.diag([m * (sy**2 + sz**2) / 12, m * (sx**2 + sz**2) / 12, m * (sx**2 + sy**2) / 12])


def _about(inertia: np.ndarray, m: float, r: np.ndarray) -> np.ndarray:
    return inertia + m * (np.dot(r, r) * np.eye(3) - np.outer(r, r))


def test_the_shipped_urdf_gives_its_analytic_figures() -> None:
    r = load_robot(EXAMPLES / "small_diff.yaml")
    assert r.name == "small-diff" and r.drive == "differential"
    assert r.mass_kg == pytest.approx(6.0 + 2 * 0.3 + 0.1)
    assert (r.wheel_radius_m, r.wheel_width_m, r.track_m, r.wheelbase_m) == pytest.approx((0.05, 0.03, 0.34, 0.0))
    # base_link at the wheels' centre, axle height: the chassis box (0.40 x 0.30, centred 0.03 ahead)
    # spans x -0.17..0.23; the URDF's origin was 0.05 below the axle
    assert r.footprint.shape == "polygon"
    pts = np.array(r.footprint.points)
    assert (pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(), pts[:, 1].max()) == pytest.approx(
        (-0.17, 0.23, -0.15, 0.15))
    assert (r.length_m, r.width_m) == pytest.approx((0.46, 0.30))
    assert r.ground_clearance_m == pytest.approx(0.03) and r.body_height_m == pytest.approx(0.12)
    assert r.caster_positions[0] == pytest.approx((-0.15, 0.0)) and len(r.caster_positions) == 1 and r.caster_radius_m == pytest.approx(0.02)
    assert r.mounts["lidar"].xyz == pytest.approx((0.10, 0.0, 0.15))  # the laser link, axle frame
    # the whole robot's inertia about its centre of mass (chassis box, point-ish wheels and caster)
    parts = [(6.0, np.diag([0.052, 0.0872, 0.125]), np.array([0.03, 0.0, 0.04])),
             (0.3, np.diag([0.0002, 0.000375, 0.0002]), np.array([0.0, 0.17, 0.0])),
             (0.3, np.diag([0.0002, 0.000375, 0.0002]), np.array([0.0, -0.17, 0.0])),
             (0.1, np.diag([0.000016] * 3), np.array([-0.15, 0.0, -0.03]))]
    m = sum(p[0] for p in parts)
    com = sum(p[0] * p[2] for p in parts) / m
    inertia = sum(_about(i, mi, c - com) for mi, i, c in parts)
    assert r.inertia_kgm2 == pytest.approx(tuple(np.diag(inertia)), rel=1e-4)
    assert r.body_source is not None and r.body_source.kind == "urdf" and r.body_source.path == "small_diff.urdf"


def _mjcf(drive: str, length: float, width: float, height: float, radius: float, wheelbase: float,
          track: float, n: int, mass: float, z0: float) -> str:
    """An MJCF base: a chassis box with its bottom ``radius/2`` above the ground, ``n`` wheels a side
    evenly over the wheelbase (ackermann: 2 a side, steered in front), the root ``z0`` above its
    axles (the file's own frame is not navstress's)."""
    clear = radius / 2
    wheels = []
    xs = [0.0] if n == 1 else [wheelbase / 2 - i * wheelbase / (n - 1) for i in range(n)]
    for side, y in (("left", track / 2), ("right", -track / 2)):
        for i, x in enumerate(xs):
            geom = (f'<geom type="cylinder" size="{radius} 0.02" euler="1.5707963267948966 0 0" mass="0.5"/>')
            wheel = (f'<body name="{side}{i}" pos="{x} {y} {-z0}"><joint name="{side}{i}_j" type="hinge" '
                     f'axis="0 1 0"/>{geom}</body>')
            if drive == "ackermann" and i == 0:
                wheel = (f'<body name="{side}_knuckle" pos="{x} {y} {-z0}"><joint name="{side}_steer" type="hinge" '
                         f'axis="0 0 1" range="-0.5 0.5" limited="true"/><geom type="sphere" size="0.005" mass="0.01" '
                         f'contype="0" conaffinity="0"/><body name="{side}{i}"><joint name="{side}{i}_j" '
                         f'type="hinge" axis="0 1 0"/>{geom}</body></body>')
            wheels.append(wheel)
    caster = ""
    if drive == "differential":
        caster = (f'<geom name="caster" type="sphere" size="{radius / 2}" pos="{-length / 3} 0 {-z0 - radius / 2}" '
                  f'mass="0.1"/>')
    zc = -z0 - radius + clear + height / 2
    return (f'<mujoco><compiler angle="radian"/><worldbody><geom type="plane" size="5 5 0.1"/><body name="base" pos="0 0 1">'
            f'<geom type="box" size="{length / 2} {width / 2} {height / 2}" pos="0 0 {zc}" mass="{mass}"/>'
            f'{caster}{"".join(wheels)}</body></worldbody></mujoco>')


bases = st.fixed_dictionaries({
    "length": st.floats(0.3, 1.5), "width": st.floats(0.25, 1.0), "height": st.floats(0.08, 0.5),
    "radius": st.floats(0.04, 0.3), "mass": st.floats(1.0, 200.0), "z0": st.floats(-0.3, 0.3),
})


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(b=bases, drive=st.sampled_from(["skid-steer", "differential", "ackermann"]), n=st.integers(1, 4),
       wb_frac=st.floats(0.3, 0.9), track_frac=st.floats(0.6, 1.4))
def test_generated_mjcf_bases_give_their_figures(tmp_path: Path, b: dict[str, float], drive: str, n: int,
                                                 wb_frac: float, track_frac: float) -> None:
    n = {"differential": 1, "ackermann": 2}.get(drive, max(n, 2))
    wheelbase = 0.0 if drive == "differential" else wb_frac * b["length"]
    track = track_frac * b["width"]
    xml = _mjcf(drive, b["length"], b["width"], b["height"], b["radius"], wheelbase, track, n, b["mass"], b["z0"])
    (tmp_path / "base.xml").write_text(xml, encoding="utf-8")
    left = [f"left{i}_j" for i in range(n)]
    right = [f"right{i}_j" for i in range(n)]
    wheels: dict[str, Any] = {"left": left[0] if drive == "differential" else left,
                              "right": right[0] if drive == "differential" else right}
    if drive == "ackermann":
        wheels["steering"] = ["left_steer", "right_steer"]
    data: dict[str, Any] = {"name": "gen", "drive": drive, "mjcf": "base.xml", "wheels": wheels,
                            "max_steer_rate_rps": 2.0}
    if drive != "ackermann":
        del data["max_steer_rate_rps"]
    r = robot_from_mapping(data, base_dir=tmp_path)
    wheel_mass = 0.5 * 2 * n + (0.02 if drive == "ackermann" else 0.0)
    assert r.mass_kg == pytest.approx(b["mass"] + wheel_mass + (0.1 if drive == "differential" else 0.0), abs=2e-6)
    assert r.wheel_radius_m == pytest.approx(b["radius"], abs=1e-6)
    assert r.wheel_width_m == pytest.approx(0.04, abs=1e-6)
    assert r.track_m == pytest.approx(track, abs=2e-6)
    assert r.wheelbase_m == pytest.approx(wheelbase, abs=2e-6)
    assert r.wheels_per_side == (1 if drive == "ackermann" else n)
    assert r.ground_clearance_m == pytest.approx(b["radius"] / 2, abs=2e-6)
    assert r.body_height_m == pytest.approx(b["height"], abs=2e-6)
    pts = np.array(r.footprint.points)
    assert pts[:, 0].max() == pytest.approx(b["length"] / 2, abs=2e-6)
    # (a caster wider than the body sticks out of it: the hull holds it)
    half_y = max(b["width"] / 2, b["radius"] / 2) if drive == "differential" else b["width"] / 2
    assert pts[:, 1].max() == pytest.approx(half_y, abs=2e-6)
    if drive == "differential":
        assert r.caster_positions[0] == pytest.approx((-b["length"] / 3, 0.0), abs=2e-6)
    if drive == "ackermann":
        assert r.max_steer_rad == pytest.approx(0.5)
    # the chassis box and the wheels about the centre of mass, analytically (wheels: solid cylinders)
    assert r.inertia_kgm2 is not None and all(i > 0 for i in r.inertia_kgm2)


def test_the_digest_follows_the_body_file(tmp_path: Path) -> None:
    for f in ("small_diff.urdf", "small_diff.yaml"):
        shutil.copy(EXAMPLES / f, tmp_path / f)
    a = load_robot(tmp_path / "small_diff.yaml")
    assert load_robot(tmp_path / "small_diff.yaml").digest == a.digest
    urdf = tmp_path / "small_diff.urdf"
    urdf.write_text(urdf.read_text(encoding="utf-8").replace("<robot name", "<!-- edited -->\n<robot name"),
                    encoding="utf-8")
    b = load_robot(tmp_path / "small_diff.yaml")
    assert b.digest != a.digest and b.model_dump(exclude={"body_source"}) == a.model_dump(exclude={"body_source"})


def _refusal(tmp_path: Path, urdf_text: str | None, **over: Any) -> str:
    if urdf_text is not None:
        (tmp_path / "r.urdf").write_text(urdf_text, encoding="utf-8")
    data = {"drive": "differential", "urdf": "r.urdf", "wheels": {"left": "left_wheel_joint",
                                                                  "right": "right_wheel_joint"}, **over}
    (tmp_path / "r.yaml").write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(SpecError) as e:
        load_robot(tmp_path / "r.yaml")
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 600, msg
    return msg


URDF = (EXAMPLES / "small_diff.urdf").read_text(encoding="utf-8")


def test_a_file_that_does_not_parse(tmp_path: Path) -> None:
    msg = _refusal(tmp_path, URDF.replace("</robot>", ""))
    assert msg.startswith("robot(r.yaml).urdf=") and "MuJoCo says" in msg


def test_a_missing_wheel_joint_lists_the_joints(tmp_path: Path) -> None:
    msg = _refusal(tmp_path, URDF, wheels={"left": "left_wheel", "right": "right_wheel_joint"})
    assert msg.startswith("robot(r.yaml).wheels.left='left_wheel'")
    assert "left_wheel_joint, right_wheel_joint" in msg


def test_a_wheel_joint_that_is_not_a_hinge(tmp_path: Path) -> None:
    text = URDF.replace('<joint name="left_wheel_joint" type="continuous">',
                        '<joint name="left_wheel_joint" type="prismatic"><limit lower="0" upper="0.1" effort="1" '
                        'velocity="1"/>')
    assert "a hinge joint" in _refusal(tmp_path, text)


def test_no_collision_geometry(tmp_path: Path) -> None:
    import re
    text = re.sub(r"<collision>.*?</collision>", "", URDF, flags=re.S)
    assert "collision geometry" in _refusal(tmp_path, text)


def test_a_differential_body_without_a_caster(tmp_path: Path) -> None:
    text = URDF.replace('<origin xyz="-0.15 0 0.02"/>', '<origin xyz="-0.15 0 0.09"/>')
    assert "passive caster" in _refusal(tmp_path, text)


def test_left_and_right_swapped(tmp_path: Path) -> None:
    msg = _refusal(tmp_path, URDF, wheels={"left": "right_wheel_joint", "right": "left_wheel_joint"})
    assert "swap left and right" in msg


def test_a_drive_is_required_and_wheels_shaped(tmp_path: Path) -> None:
    assert "robot(r.yaml).drive" in _refusal(tmp_path, URDF, drive=None)
    assert "wheels.left" in _refusal(tmp_path, URDF, wheels={"left": 3, "right": "right_wheel_joint"})
    assert "one wheel joint per side" in _refusal(
        tmp_path, URDF, wheels={"left": ["left_wheel_joint", "right_wheel_joint"], "right": ["a", "b"]})
    assert "wheels.steering" in _refusal(tmp_path, URDF, wheels={"left": "left_wheel_joint", "right": "right_wheel_joint",
                                                                  "steering": ["x"]})


def test_a_mount_on_a_link_the_body_lacks(tmp_path: Path) -> None:
    msg = _refusal(tmp_path, URDF, mounts={"lidar": {"link": "lazer"}})
    assert "mounts.lidar.link='lazer'" in msg and "did you mean laser?" in msg


def test_hull_of_rotated_boxes_is_convex_and_covers_them(tmp_path: Path) -> None:
    yaw = math.radians(30)
    xml = ('<mujoco><worldbody><body name="b"><geom type="box" size="0.3 0.1 0.05" euler="0 0 30" mass="5"/>'
           '<body pos="0 0.25 -0.05"><joint name="l" type="hinge" axis="0 1 0"/><geom type="cylinder" size="0.06 0.02"'
           ' euler="90 0 0" mass="0.2"/></body><body pos="0 -0.25 -0.05"><joint name="r" type="hinge" axis="0 1 0"/>'
           '<geom type="cylinder" size="0.06 0.02" euler="90 0 0" mass="0.2"/></body>'
           '<geom type="sphere" size="0.01" pos="0.2 0 -0.1" mass="0.05"/></body></worldbody>'
           '<compiler angle="degree"/></mujoco>')
    (tmp_path / "rot.xml").write_text(xml, encoding="utf-8")
    r = robot_from_mapping({"drive": "differential", "mjcf": "rot.xml", "wheels": {"left": "l", "right": "r"}},
                           base_dir=tmp_path)
    pts = np.array(r.footprint.points)
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(c * x - s * y, s * x + c * y) for x in (-0.3, 0.3) for y in (-0.1, 0.1)]
    for cx, cy in corners:  # every corner of the rotated box is a vertex of the hull
        assert np.min(np.hypot(pts[:, 0] - cx, pts[:, 1] - cy)) < 1e-5
