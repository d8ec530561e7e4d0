"""`navstress robot list/show/check` through the real CLI: the profiles' table, a robot's figures,
digest and drawing (the SVG parses and holds the footprint, every wheel, caster and mount), the
JSON documents, and the one-line refusals."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from navstress.robot import PROFILES, resolve_robot
from navstress.robot.describe import wheel_layout
from tests.support.cli_run import cli

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "robots"
REFS = [*sorted(PROFILES), str(EXAMPLES / "our_jackal.yaml"), str(EXAMPLES / "small_diff.yaml")]


def test_list_shows_every_profile_with_its_figures() -> None:
    code, out, _err = cli("robot", "list")
    assert code == 0
    for name, r in PROFILES.items():
        line = next(ln for ln in out.splitlines() if f" {name} " in ln)
        assert r.drive in line and f"{r.mass_kg:g}" in line and f"{r.max_speed_mps:g}" in line and r.digest in line


def _ids(svg: Path) -> set[str]:
    root = ET.fromstring(svg.read_text(encoding="utf-8"))  # parses: well-formed XML
    assert root.tag.endswith("svg")
    return {el.get("id", "") for el in root.iter()}


@pytest.mark.parametrize("ref", REFS, ids=[Path(r).name for r in REFS])
def test_show_draws_footprint_wheels_casters_and_mounts(ref: str, tmp_path: Path) -> None:
    robot = resolve_robot(ref)
    out_svg = tmp_path / "robot.svg"
    code, out, err = cli("robot", "show", ref, "-o", str(out_svg))
    assert code == 0, err
    assert robot.digest in out and f"wrote {out_svg}" in out
    ids = _ids(out_svg)
    assert "footprint" in ids and "base_link" in ids
    assert {f"wheel-{i}" for i in range(len(wheel_layout(robot)))} <= ids
    assert {f"caster-{i}" for i in range(len(robot.caster_positions))} <= ids
    assert {f"mount-{m}" for m in robot.mounts} <= ids
    png = tmp_path / "robot.png"
    assert cli("robot", "show", ref, "-o", str(png))[0] == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("ref", REFS, ids=[Path(r).name for r in REFS])
def test_show_json_is_the_description_and_every_figure(ref: str) -> None:
    code, out, _err = cli("robot", "show", ref, "--json")
    assert code == 0
    doc = json.loads(out)
    robot = resolve_robot(ref)
    assert doc["digest"] == robot.digest and doc["name"] == robot.name
    assert doc["description"] == robot.model_dump(mode="json")
    assert doc["figures"]["mass_kg"] == robot.mass_kg
    assert len(doc["wheels"]) == len(wheel_layout(robot))


def test_wheel_layouts_follow_the_drive() -> None:
    assert len(wheel_layout(PROFILES["rmp400"])) == 4
    assert len(wheel_layout(PROFILES["turtlebot4"])) == 2
    f1 = wheel_layout(PROFILES["f1tenth"])
    assert len(f1) == 4 and sorted({x for x, _y, _s in f1}) == pytest.approx([-0.1651, 0.1651])


@pytest.mark.parametrize(("argv", "field"), [
    (["robot", "show", "jackall"], "robot='jackall'"),
    (["robot", "show", "nope.yaml"], "robot='nope.yaml'"),
    (["robot", "show", "jackal", "-o", "x.pdf"], "--output='x.pdf'"),
    (["robot", "check", "jackall"], "robot='jackall'"),
    (["robot", "show", str(EXAMPLES / "small_diff.urdf")], "robot="),
])
def test_bad_input_is_one_line_exit_2(argv: list[str], field: str, tmp_path: Path) -> None:
    code, out, err = cli(*argv)
    assert code == 2, (out, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {field}"), err
    assert not (tmp_path / "x.pdf").exists()


@pytest.mark.parametrize("ref", [*sorted(PROFILES), str(EXAMPLES / "small_diff.yaml")])
def test_check_passes_the_shipped_robots(ref: str) -> None:
    code, out, err = cli("robot", "check", ref, "--quick", "--json")
    doc = json.loads(out)
    assert code == (0 if doc["passed"] else 1), err
    assert doc["digest"] == resolve_robot(ref).digest and doc["legs"]
    assert doc["passed"], doc["problems"]
    code, text, _err = cli("robot", "check", ref, "--quick")
    assert code == 0 and text.rstrip().endswith("PASS")


def test_check_fails_with_exit_1_on_a_robot_it_cannot_hold(tmp_path: Path) -> None:
    bad = tmp_path / "tippy.yaml"  # a tall, narrow, light base at a high speed with a huge torque
    bad.write_text("base: jackal\nwidth_m: 0.12\ntrack_m: 0.1\nbody_height_m: 0.9\nmass_kg: 2.0\n"
                   "max_speed_mps: 5.0\nmax_accel_mps2: 20.0\nwheel_torque_nm: 200.0\n"
                   "mounts: {lidar: {xyz: [0.0, 0.0, 1.2]}}\n", encoding="utf-8")
    code, out, _err = cli("robot", "check", str(bad), "--quick")
    assert code == 1 and "FAIL" in out


@pytest.mark.parametrize("dest", ["{tmp}/afile/robot.svg", "/proc/navstress-no-such-dir/robot.png", "/sys/navstress.svg"])
def test_an_unwritable_picture_is_one_line_naming_its_path(dest: str, tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("a file", encoding="utf-8")
    out = dest.replace("{tmp}", str(tmp_path))
    code, _out, err = cli("robot", "show", "jackal", "-o", out)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: path="), err
    assert f"path='{out}'" in lines[0] or f"path='{Path(out).parent}'" in lines[0], err  # the file or its folder
    assert not Path(out).exists()
