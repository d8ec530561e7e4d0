"""``navstress world import map.yaml``: bad input is one line naming the file and the fix, exit 2,
nothing written (the folder snapshot before and after); a map too large is refused from its
header, before its pixels are read; an office imported through the CLI (a real subprocess) and
a mission run in it with the Jackal and its 2D scanner."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.support.cli_inputs import assert_one_line_error, invoke, snapshot
from tests.support.maps import write_pgm, write_png, write_yaml

ROOT = Path(__file__).resolve().parents[3]


def office(h: int = 160, w: int = 240) -> np.ndarray:
    """A 12 x 8 m office at 0.05 m: an unknown border, the outer walls, a wall with a door between
    two rooms, a pillar."""
    img = np.full((h, w), 205, np.uint8)
    img[6:h - 6, 6:w - 6] = 254
    img[6:10, 6:w - 6] = img[h - 10:h - 6, 6:w - 6] = 0
    img[6:h - 6, 6:10] = img[6:h - 6, w - 10:w - 6] = 0
    img[6:70, 120:123] = 0
    img[90:h - 6, 120:123] = 0  # a 1 m door at rows 70..90
    img[40:46, 60:66] = 0
    return img


def make_office(d: Path) -> Path:
    write_pgm(d / "office.pgm", office())
    return write_yaml(d / "office.yaml", "office.pgm", resolution=0.05, origin=[-2.0, -1.0, 0.0])


def _bad(tmp_path: Path, case: str) -> tuple[Path, str]:
    """(the YAML, a piece of the expected message) for each bad input."""
    pgm = write_pgm(tmp_path / "o.pgm", office())
    y = tmp_path / "m.yaml"
    if case == "missing image":
        write_yaml(y, "nope.pgm")
        return y, "m.yaml image="
    if case == "not pgm/png":
        (tmp_path / "o.jpg").write_bytes(b"\xff\xd8\xff\xe0" + b"\0" * 100)
        write_yaml(y, "o.jpg")
        return y, "PGM (P2 or P5) or PNG"
    if case == "ppm colour":
        (tmp_path / "c.ppm").write_bytes(b"P6\n2 2\n255\n" + b"\0" * 12)
        write_yaml(y, "c.ppm")
        return y, "PGM (P2 or P5) or PNG"
    if case == "truncated pgm":
        (tmp_path / "t.pgm").write_bytes(pgm.read_bytes()[:500])
        write_yaml(y, "t.pgm")
        return y, "cut short"
    if case == "occupied above 1":
        write_yaml(y, pgm.name, occupied_thresh=1.2)
        return y, "m.yaml occupied_thresh=1.2"
    if case == "free below 0":
        write_yaml(y, pgm.name, free_thresh=-0.5)
        return y, "m.yaml free_thresh=-0.5"
    if case == "reversed":
        write_yaml(y, pgm.name, occupied_thresh=0.2, free_thresh=0.6)
        return y, "below occupied_thresh"
    if case == "equal":
        write_yaml(y, pgm.name, occupied_thresh=0.5, free_thresh=0.5)
        return y, "below occupied_thresh"
    if case == "no resolution":
        write_yaml(y, pgm.name, resolution=None)
        return y, "m.yaml resolution"
    if case == "negative resolution":
        write_yaml(y, pgm.name, resolution=-0.05)
        return y, "m.yaml resolution=-0.05"
    if case == "text resolution":
        write_yaml(y, pgm.name, resolution="fine")
        return y, "m.yaml resolution='fine'"
    if case == "map too wide":
        write_yaml(y, pgm.name, resolution=10.0)
        return y, "at most 2000 m a side"
    if case == "no room for the robot":
        img = np.zeros((100, 100), np.uint8)
        img[40:50, 40:50] = 254  # a 0.5 m free square
        write_pgm(tmp_path / "tight.pgm", img)
        write_yaml(y, "tight.pgm")
        return y, "stand and turn"
    if case == "all walls":
        write_pgm(tmp_path / "black.pgm", np.zeros((50, 50), np.uint8))
        write_yaml(y, "black.pgm")
        return y, "stand and turn"
    if case == "not a map yaml":
        y.write_text("name: a campaign\n")
        return y, "map_server map YAML"
    if case == "corrupt png":
        (tmp_path / "b.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0\0\0\rIHDR" + b"\0\0\0\x10\0\0\0\x10\x08\0\0\0\0" + b"junk")
        write_yaml(y, "b.png")
        return y, "readable PNG"
    raise AssertionError(case)


CASES = ["missing image", "not pgm/png", "ppm colour", "truncated pgm", "occupied above 1", "free below 0", "reversed",
         "equal", "no resolution", "negative resolution", "text resolution", "map too wide", "no room for the robot",
         "all walls", "not a map yaml", "corrupt png"]


@pytest.mark.parametrize("case", CASES)
def test_bad_map_is_one_line_exit_2_nothing_written(tmp_path: Path, case: str) -> None:
    y, piece = _bad(tmp_path, case)
    before = snapshot(tmp_path)
    argv = ["world", "import", str(y), "-o", str(tmp_path / "out")]
    code, out, err = invoke(argv)
    line = assert_one_line_error(code, out, err, argv)
    assert piece in line, line
    assert str(y.parent) in line  # names the file
    assert snapshot(tmp_path) == before


def test_map_too_large_is_refused_from_its_header_with_the_estimate(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A PGM whose header says 30000 x 30000 cells and that holds no pixels at all: refused with
    the memory estimate, so the pixels were never read (they would be 'cut short' otherwise)."""
    (tmp_path / "huge.pgm").write_bytes(b"P5\n30000 30000\n255\n")
    y = write_yaml(tmp_path / "huge.yaml", "huge.pgm", resolution=0.05)
    monkeypatch.setenv("NAVSTRESS_MAX_WORLD_GIB", "8")
    before = snapshot(tmp_path)
    argv = ["world", "import", str(y), "-o", str(tmp_path / "out")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "30000x30000 cells need about 54.1 GiB" in line and "NAVSTRESS_MAX_WORLD_GIB" in line, line
    assert snapshot(tmp_path) == before
    # a PNG's header likewise (IHDR: 40000 x 40000, no image data)
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", 40000, 40000, 8, 0, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    (tmp_path / "huge.png").write_bytes(png)
    y2 = write_yaml(tmp_path / "hugepng.yaml", "huge.png", resolution=0.04)
    before = snapshot(tmp_path)
    argv = ["world", "import", str(y2), "-o", str(tmp_path / "out")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "40000x40000 cells need about" in line, line
    assert snapshot(tmp_path) == before
    # a lower limit refuses a map that the default takes
    write_pgm(tmp_path / "mid.pgm", np.full((3000, 3000), 254, np.uint8))
    y3 = write_yaml(tmp_path / "mid.yaml", "mid.pgm")
    monkeypatch.setenv("NAVSTRESS_MAX_WORLD_GIB", "0.5")
    argv = ["world", "import", str(y3), "-o", str(tmp_path / "out")]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "3000x3000 cells need about" in line and "at most 0.5 GiB" in line, line


def test_given_start_in_a_wall_or_outside_is_refused(tmp_path: Path) -> None:
    y = make_office(tmp_path)
    before = snapshot(tmp_path)
    for start, goal, flag in (("-2,-1,0", "5,3", "--start"), ("1,1,0", "100,3", "--goal"), ("1,1,0", "4.05,5", "--goal")):
        argv = ["world", "import", str(y), "-o", str(tmp_path / "out"), "--start", start, "--goal", goal,
                "--robot", "jackal"]
        line = assert_one_line_error(*invoke(argv), argv)
        assert line.startswith(f"error: {flag}="), line
    assert snapshot(tmp_path) == before


def test_import_in_process_writes_the_map_frame_and_a_drawn_mission(tmp_path: Path) -> None:
    y = make_office(tmp_path)
    code, out, err = invoke(["world", "import", str(y), "-o", str(tmp_path / "w"), "--robot", "jackal",
                             "--wall-height", "1.5", "--unknown", "wall"])
    assert code == 0, err
    assert "warning: " in err and "unknown" in err
    d = json.loads((tmp_path / "w" / "world.json").read_text())
    assert d["source"]["kind"] == "map" and d["source"]["origin"] == [-2.0, -1.0]
    assert d["source"]["path"] == str(y.resolve())
    assert all(o["size"][2] == 1.5 and o["kind"] == "wall" for o in d["obstacles"])
    s, g = d["mission"]["start"], d["mission"]["goal"]
    # drawn inside the office's walls (x in 0.5 .. 11.5, y in 0.5 .. 7.5 in the world), far apart: the two rooms
    for x, yy in (s[:2], g):
        assert 0.5 < x < 11.5 and 0.5 < yy < 7.5
    assert abs(s[0] - g[0]) > 6.0
    # given in the map's frame: stored in the world's
    code, out, err = invoke(["world", "import", str(y), "-o", str(tmp_path / "w2"), "--start", "-1,0,0.5",
                             "--goal", "8,5"])
    assert code == 0, err
    m = json.loads((tmp_path / "w2" / "world.json").read_text())["mission"]
    assert m["start"] == [1.0, 1.0, 0.5] and m["goal"] == [10.0, 6.0]


@pytest.mark.slow
def test_office_imported_by_the_cli_and_a_jackal_mission_run_in_it(tmp_path: Path) -> None:
    """End to end through real processes: `navstress world import office.yaml -o DIR`, then
    `navstress run DIR` with the Jackal, its UST-10 scanner and reference-2d-v1 (examples/jackal_2d.yaml's set)."""
    y = make_office(tmp_path)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    w = tmp_path / "office-world"
    r = subprocess.run([sys.executable, "-m", "navstress.cli", "world", "import", str(y), "-o", str(w),
                        "--robot", "jackal"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (w / "world.json").is_file() and (w / "preview.png").is_file()
    out = tmp_path / "runs"
    r = subprocess.run([sys.executable, "-m", "navstress.cli", "run", str(w), "-o", str(out), "--robot", "jackal",
                        "--sensor", "front_laser=lidar2d:ust10,mount=0.12:0:0.3", "--navigator", "reference-2d-v1",
                        "--timeout", "60", "--goal-tolerance", "1"], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    rec = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines() if line.strip()]
    assert len(rec) == 1
    assert rec[0]["outcome"] == "success", rec[0]


def test_png_office_imports_like_its_pgm(tmp_path: Path) -> None:
    img = office()
    write_pgm(tmp_path / "o.pgm", img)
    write_png(tmp_path / "o.png", img)
    a = write_yaml(tmp_path / "a.yaml", "o.pgm")
    b = write_yaml(tmp_path / "b.yaml", "o.png")
    for y, d in ((a, "wa"), (b, "wb")):
        code, _, err = invoke(["world", "import", str(y), "-o", str(tmp_path / d), "--robot", "jackal"])
        assert code == 0, err
    ja, jb = (json.loads((tmp_path / d / "world.json").read_text()) for d in ("wa", "wb"))
    assert ja["obstacles"] == jb["obstacles"] and ja["mission"] == jb["mission"]


@pytest.mark.parametrize("flags, piece", [
    (["--unknown", "bogus"], "error: --unknown='bogus'"),
    (["--wall-height", "-1"], "error: --wall-height='-1' is invalid: expected a height in (0, 100] m"),
    (["--wall-height", "101"], "error: --wall-height='101'"),
    (["--wall-height", "nan"], "error: --wall-height="),
    (["--kind", "png"], "error: --kind='png'"),
    (["--start", "1,2,0"], "error: --goal is missing"),
    (["--start", "1,2", "--goal", "3,4"], "error: --start='1,2'"),
])
def test_import_flags_are_checked_by_name(tmp_path: Path, flags: list[str], piece: str) -> None:
    y = make_office(tmp_path)
    before = snapshot(tmp_path)
    argv = ["world", "import", str(y), "-o", str(tmp_path / "out"), *flags]
    line = assert_one_line_error(*invoke(argv), argv)
    assert line.startswith(piece), line
    assert snapshot(tmp_path) == before
