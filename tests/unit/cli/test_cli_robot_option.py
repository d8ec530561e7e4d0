"""``--robot NAME|FILE`` on every command that takes it (world generate, world drive, run, nav
check): bad input is one line naming --robot, exit 2, nothing written; a robot that does not fit
the world's free discs likewise; a good one is used."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from navstress.robot import PROFILES
from navstress.run.trace import read_robot
from navstress.world import World, generate, parse_spec
from tests.support.cli_run import cli

COMMANDS = {
    "world generate": ["world", "generate", "-o", "{root}/out", "--size", "20"],
    "world drive": ["world", "drive", "{root}/world", "-o", "{root}/out.png", "--course", "0.5,0,1"],
    "run": ["run", "{root}/world", "-o", "{root}/out", "--timeout", "1"],
    "nav check": ["nav", "check", "reference-v1"],
}
BAD = {"jackall": "did you mean jackal", "RMP400": "did you mean rmp400", "": "", "  ": "",
       "missing-robot.yaml": ""}


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("robotcli")
    generate(parse_spec({"size_m": [20, 20]}), 3).save(r / "world")
    spec = {"size_m": [20, 20], "ground": {"subdivisions": 2, "deformation": 0.3},
            "mission": {"free_radius_m": 0.4}}
    (r / "tight.yaml").write_text(yaml.safe_dump(spec))
    generate(parse_spec(spec), 3).save(r / "tight")
    return r


def _argv(argv: list[str], root: Path) -> list[str]:
    return [a.replace("{root}", str(root)) for a in argv]


def _written(root: Path) -> set[str]:
    return {p.name for p in root.iterdir()} - {"world", "tight", "tight.yaml"}


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("bad", sorted(BAD))
def test_a_bad_robot_is_one_line_exit_2_nothing_written(root: Path, command: str, bad: str) -> None:
    code, out, err = cli(*_argv(COMMANDS[command], root), "--robot", bad)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "robot" in lines[0].lower()
    if BAD[bad]:
        assert lines[0].startswith("error: --robot=") and BAD[bad] in lines[0], lines[0]
    assert not _written(root) and not (root / "world" / "out.png").exists()


@pytest.mark.parametrize("command", ["world drive", "run"])
def test_a_robot_that_does_not_fit_the_worlds_free_discs_is_refused(root: Path, command: str) -> None:
    argv = [a.replace("{root}/world", "{root}/tight") for a in COMMANDS[command]]
    for name, robot in PROFILES.items():
        if robot.half_diagonal_m <= 0.4:
            continue
        code, _out, err = cli(*_argv(argv, root), "--robot", name)
        assert code == 2 and err.startswith("error: --robot=") and "free_radius_m=0.4" in err, err
        assert len(err.strip().splitlines()) == 1
        assert not _written(root)


def test_world_generate_refuses_a_robot_that_does_not_fit_and_writes_nothing(root: Path) -> None:
    code, _out, err = cli("world", "generate", "-o", str(root / "out"), "--spec", str(root / "tight.yaml"),
                          "--robot", "husky")
    assert code == 2 and err.startswith("error: --robot='husky'") and len(err.strip().splitlines()) == 1, err
    assert not _written(root)
    code, _out, err = cli("world", "generate", "-o", str(root / "out"), "--spec", str(root / "tight.yaml"),
                          "--robot", "turtlebot4")  # 0.171 m: it fits
    assert code == 0, err
    assert World.load(root / "out").mission.free_radius_m == 0.4


def test_world_generate_sizes_the_free_discs_to_the_robot(tmp_path: Path) -> None:
    args = ["world", "generate", "--size", "30", "-d", "0.5", "-s", "3", "--seed", "2"]
    assert cli(*args, "-o", str(tmp_path / "rmp"))[0] == 0
    assert cli(*args, "-o", str(tmp_path / "rmp2"), "--robot", "rmp400")[0] == 0
    assert cli(*args, "-o", str(tmp_path / "jackal"), "--robot", "jackal")[0] == 0
    assert (tmp_path / "rmp" / "world.json").read_bytes() == (tmp_path / "rmp2" / "world.json").read_bytes()
    rmp, jackal = World.load(tmp_path / "rmp"), World.load(tmp_path / "jackal")
    assert jackal.mission.free_radius_m < rmp.mission.free_radius_m == 5.0
    assert jackal.descriptors["traversability"]["robot"] == "jackal"


def test_run_with_a_robot_records_it(root: Path, tmp_path: Path) -> None:
    code, out, err = cli("run", str(root / "world"), "-o", str(tmp_path / "o"), "--timeout", "1", "--robot",
                         "turtlebot4", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["robot"] == {"name": "turtlebot4", "digest": PROFILES["turtlebot4"].digest}
    assert read_robot(tmp_path / "o" / "run-000.mcap") == PROFILES["turtlebot4"]


def test_world_drive_drives_the_robot_given(root: Path, tmp_path: Path) -> None:
    code, out, err = cli("world", "drive", str(root / "world"), "-o", str(tmp_path / "d.png"), "--course", "0.3,0,1",
                         "--robot", "jackal")
    assert code == 0, err
    assert out.startswith("drove ") and (tmp_path / "d.png").stat().st_size > 0


def test_nav_check_with_a_robot_passes_for_the_reference_stack() -> None:
    code, out, err = cli("nav", "check", "reference-v1", "--robot", "turtlebot4")
    assert code == 0, (out, err)
    assert "reference-v1: PASS" in out
