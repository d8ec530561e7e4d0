"""`navstress world drive` and `navstress run` as a user calls them (real subprocesses, real simulation)."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from navstress.world import Mission, Obstacle, World, WorldSpec

pytestmark = pytest.mark.slow
NAVSTRESS = [sys.executable, "-m", "navstress.cli"]


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*NAVSTRESS, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def box_ahead(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A flat 30 m world with a box 8 m straight ahead of the start."""
    spec = WorldSpec(size_m=(30.0, 30.0))
    w = World.flat(spec, obstacles=(Obstacle("building", 14.0, 5.0, 0.0, (2.0, 6.0, 3.0), 0.0),),
                   mission=Mission((5.0, 5.0, 0.0), (25.0, 25.0), 3.0))
    d = tmp_path_factory.mktemp("w") / "box"
    w.save(d)
    return d


def test_drive_into_a_box_shows_the_collision(box_ahead: Path, tmp_path: Path) -> None:
    pic = tmp_path / "drive.png"
    r = cli("world", "drive", str(box_ahead), "--course", "1,0,12", "-o", str(pic))
    assert r.returncode == 0, r.stderr
    assert "collisions: 1" in r.stdout
    assert pic.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_drive_straight_in_the_open(box_ahead: Path, tmp_path: Path) -> None:
    r = cli("world", "drive", str(box_ahead), "--course", "0,0.5,3.1416; 1,0,8", "-o", str(tmp_path / "d.png"))
    assert r.returncode == 0, r.stderr
    assert "collisions: 0" in r.stdout
    dist = float(r.stdout.split("drove ")[1].split(" m")[0])
    assert 7.0 < dist < 9.0  # 8 m commanded (plus a little creep during the turn on the spot)


@pytest.mark.parametrize("args,needle", [
    (("--course", "1,0"), "--course[0]='1,0' is invalid"),
    (("--course", "1,0,-3"), "--course[0]='1,0,-3' is invalid"),
    (("--seed", "x"), "--seed='x' is invalid"),
])
def test_drive_bad_input(box_ahead: Path, tmp_path: Path, args: tuple[str, ...], needle: str) -> None:
    r = cli("world", "drive", str(box_ahead), *args, "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and needle in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_run_writes_traces_records_and_picture(box_ahead: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = cli("run", str(box_ahead), "--runs", "2", "--timeout", "15", "--seed", "3", "-o", str(out))
    assert r.returncode == 0, r.stderr
    lines = (out / "runs.jsonl").read_text().splitlines()
    recs = [json.loads(x) for x in lines]
    assert [x["run_id"] for x in recs] == ["run-000", "run-001"]
    assert all(x["outcome"] in {"success", "fail-collision", "fail-error", "fail-timeout", "fail-other"} for x in recs)
    assert recs[0]["run_seed"] != recs[1]["run_seed"]
    assert all(Path(x["trace"]).exists() for x in recs)
    assert (out / "trajectories.png").stat().st_size > 10_000
    from navstress.run.trace import read_debug, read_grids
    assert read_debug(recs[0]["trace"]) == [] and len(read_grids(recs[0]["trace"])) == 1
    # --navigator-view: the same run, with what the navigator drew and its map each second
    r = cli("run", str(box_ahead), "--timeout", "15", "--seed", "3", "--navigator-view", "-o", str(tmp_path / "v"))
    assert r.returncode == 0, r.stderr
    (rec,) = [json.loads(x) for x in (tmp_path / "v" / "runs.jsonl").read_text().splitlines()]
    assert {k: rec[k] for k in ("outcome", "duration_s", "run_seed")} == \
        {k: recs[0][k] for k in ("outcome", "duration_s", "run_seed")}
    assert len(read_debug(rec["trace"])) > 100 and len(read_grids(rec["trace"])) >= 14


@pytest.mark.parametrize("args,needle", [
    (("--navigator", "nope-v1"), "unknown navigator 'nope-v1'"),
    (("--fault", "nope"), "unknown fault 'nope'"),
    (("--runs", "0"), "--runs='0' is invalid"),
    (("--timeout", "-1"), "--timeout='-1' is invalid"),
    (("--wall-limit", "0"), "--wall-limit='0' is invalid"),
    (("--wall-limit", "nan"), "--wall-limit='nan' is invalid"),
])
def test_run_bad_input_writes_nothing(box_ahead: Path, tmp_path: Path, args: tuple[str, ...], needle: str) -> None:
    out = tmp_path / "out"
    r = cli("run", str(box_ahead), *args, "-o", str(out))
    assert r.returncode == 2
    assert needle in r.stderr and r.stderr.strip().count("\n") == 0
    assert not out.exists()


def test_run_on_a_non_world(tmp_path: Path) -> None:
    r = cli("run", str(tmp_path), "-o", str(tmp_path / "out"))
    assert r.returncode == 2 and "not a world directory" in r.stderr


@pytest.mark.parametrize("value", ["0", "-3", "inf", "soon"])
def test_nav_check_bad_wall_limit_is_one_line_exit_2(value: str) -> None:
    r = cli("nav", "check", "reference-v1", "--wall-limit", value)
    assert r.returncode == 2
    assert f"--wall-limit={value!r} is invalid" in r.stderr and r.stderr.strip().count("\n") == 0
