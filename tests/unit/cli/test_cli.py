"""The navstress CLI, driven through typer's CliRunner and as a real subprocess."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image
from typer.testing import CliRunner

from tests.support.world_fixtures import small_world
from navstress import __version__
from navstress.cli import app
from navstress.world import World, parse_spec
from navstress.world.export.images import read_heightmap_png
from navstress.world.generate import generate

SMALL = ["--size", "20", "--cell", "0.5"]
NAVSTRESS = Path(sys.executable).parent / "navstress"


def run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(app, list(args))
    return r.exit_code, r.stdout, r.stderr


def snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else b"<dir>" for p in sorted(root.rglob("*"))}


def _prepare(tmp: Path) -> None:
    (tmp / "notaworld").mkdir()
    (tmp / "notaworld" / "keep.txt").write_text("mine")
    (tmp / "bad.yaml").write_text("ground: {subdivisions: -2}\n")
    (tmp / "broken.yaml").write_text("ground: [1, \n")
    (tmp / "typo.yaml").write_text("grund: {}\n")
    (tmp / "nonnum.json").write_text('{"cell_m": "fine"}')
    (tmp / "mover_speed.yaml").write_text("movers: {types: {pedestrian: {speed_min_m_s: -0.5}}}\n")
    (tmp / "mover_minmax.yaml").write_text("movers: {types: {vehicle: {speed_min_m_s: 6}}}\n")
    (tmp / "mover_kind.yaml").write_text("movers: {behaviour: {pedestrian: {kind: zigzag}}}\n")
    (tmp / "mover_type.yaml").write_text("movers: {count: {bicycle: 2}}\n")
    (tmp / "mover_param.yaml").write_text("movers: {behaviour: {pedestrian: {kind: patrol, trigger_m: 4}}}\n")
    (tmp / "mover_big.yaml").write_text("size_m: [20, 20]\nmovers: {types: {bus: {length_m: 12, width_m: 2.5, "
                                        "height_m: 3, speed_max_m_s: 4}}, count: {bus: 1}}\n")
    small_world().save(tmp / "w")


# (args; {tmp} is replaced by the test folder), field named in the message, value named in the message
BAD = [
    (["world", "generate", "--size", "-5", "-o", "{tmp}/out"], "--size", "-5"),
    (["world", "generate", "--size", "abc", "-o", "{tmp}/out"], "--size", "abc"),
    (["world", "generate", "--size", "20x5x5", "-o", "{tmp}/out"], "--size", "20x5x5"),
    (["world", "generate", "--cell", "xyz", "-o", "{tmp}/out"], "--cell", "xyz"),
    (["world", "generate", "--cell", "-0.4", "-o", "{tmp}/out"], "--cell", "-0.4"),
    (["world", "generate", "--trees", "100", "-o", "{tmp}/out"], "--trees", "100"),
    (["world", "generate", "--buildings", "-1", "-o", "{tmp}/out"], "--buildings", "-1"),
    (["world", "generate", "--trees", "ten", "-o", "{tmp}/out"], "--trees", "ten"),
    (["world", "generate", "--trees", "60", "--buildings", "45", "-o", "{tmp}/out"], "obstacles.obstruction", "105"),
    (["world", "generate", "--obstruction", "100", "--mix", "trees=1", "-o", "{tmp}/out"], "--obstruction", "100"),
    (["world", "generate", "--obstruction", "-2", "--mix", "trees=1", "-o", "{tmp}/out"], "--obstruction", "-2"),
    (["world", "generate", "--obstruction", "10", "-o", "{tmp}/out"], "--mix is missing", ""),
    (["world", "generate", "-s", "-1", "-o", "{tmp}/out"], "--subdivisions", "-1"),
    (["world", "generate", "--subdivisions", "2.5", "-o", "{tmp}/out"], "--subdivisions", "2.5"),
    (["world", "generate", "-d", "nan", "-o", "{tmp}/out"], "--deformation", "nan"),
    (["world", "generate", "--ground", "perlin", "-o", "{tmp}/out"], "--ground", "perlin"),
    (["world", "generate", "--obstruction", "10", "--mix", "rocks=1", "-o", "{tmp}/out"], "--mix", "rocks"),
    (["world", "generate", "--obstruction", "10", "--mix", "trees", "-o", "{tmp}/out"], "--mix", "trees"),
    (["world", "generate", "--obstruction", "10", "--mix", "trees=abc", "-o", "{tmp}/out"], "--mix", "trees=abc"),
    (["world", "generate", "--obstruction", "10", "--mix", "trees=1,,", "-o", "{tmp}/out"], "--mix", "trees=1,,"),
    (["world", "generate", "--mix", "trees=1", "-o", "{tmp}/out"], "--mix", "trees=1"),
    (["world", "generate", "--trees", "5", "--obstruction", "10", "-o", "{tmp}/out"], "--obstruction", "10"),
    (["world", "generate", "--seed", "-3", "-o", "{tmp}/out"], "--seed", "-3"),
    (["world", "generate", "--seed", "x1", "-o", "{tmp}/out"], "--seed", "x1"),
    (["world", "generate", "--spec", "{tmp}/missing.yaml", "-o", "{tmp}/out"], "spec", "missing.yaml"),
    (["world", "generate", "--spec", "{tmp}/bad.yaml", "-o", "{tmp}/out"], "ground.subdivisions", "-2"),
    (["world", "generate", "--spec", "{tmp}/broken.yaml", "-o", "{tmp}/out"], "spec", "broken.yaml"),
    (["world", "generate", "--spec", "{tmp}/typo.yaml", "-o", "{tmp}/out"], "grund", "{}"),
    (["world", "generate", "--spec", "{tmp}/nonnum.json", "-o", "{tmp}/out"], "cell_m", "fine"),
    (["world", "generate", "--spec", "{tmp}/mover_speed.yaml", "-o", "{tmp}/out"],
     "movers.types.pedestrian.speed_min_m_s", "-0.5"),
    (["world", "generate", "--spec", "{tmp}/mover_minmax.yaml", "-o", "{tmp}/out"],
     "movers.types.vehicle.speed_min_m_s", "6"),
    (["world", "generate", "--spec", "{tmp}/mover_kind.yaml", "-o", "{tmp}/out"], "movers.behaviour.pedestrian.kind",
     "zigzag"),
    (["world", "generate", "--spec", "{tmp}/mover_type.yaml", "-o", "{tmp}/out"], "movers.count.bicycle", "bicycle"),
    (["world", "generate", "--spec", "{tmp}/mover_param.yaml", "-o", "{tmp}/out"],
     "movers.behaviour.pedestrian.trigger_m", "4"),
    (["world", "generate", "--spec", "{tmp}/mover_big.yaml", "-o", "{tmp}/out"], "movers.types.bus", "12x2.5"),
    (["world", "generate", "--movers", "pedestrians=-2", "-o", "{tmp}/out"], "--movers", "pedestrians=-2"),
    (["world", "generate", "--movers", "pedestrians", "-o", "{tmp}/out"], "--movers", "pedestrians"),
    (["world", "generate", "--movers", "bicycles=2", "-o", "{tmp}/out"], "--movers", "bicycles"),
    (["world", "generate", "--movers", "pedestrian=1", "--mover-behaviour", "pedestrian=fly", "-o", "{tmp}/out"],
     "--mover-behaviour", "fly"),
    (["world", "generate", *SMALL, "-o", "{tmp}/notaworld"], "--output", "notaworld"),
    (["world", "generate", *SMALL, "-o", "{tmp}/bad.yaml"], "--output", "bad.yaml"),
    (["world", "generate", "--bogus", "1", "-o", "{tmp}/out"], "--bogus", ""),
    (["world", "generate", "--trees"], "--trees", ""),
    (["world", "show", "{tmp}/notaworld"], "world", "notaworld"),
    (["world", "show", "{tmp}/nothing-here"], "world", "nothing-here"),
    (["world", "export", "{tmp}/notaworld", "--format", "sdf", "-o", "{tmp}/x.sdf"], "world", "notaworld"),
    (["world", "export", "{tmp}/w", "--format", "xyz", "-o", "{tmp}/x.xyz"], "--format", "xyz"),
    (["world", "export", "{tmp}/w", "--format", "png", "-o", "{tmp}/w"], "--output", "w"),
    (["world", "export", "{tmp}/w", "-f", "sdf", "--heightmap-bits", "12", "-o", "{tmp}/x.sdf"], "--heightmap-bits", "12"),
    (["world", "export", "{tmp}/w", "-f", "png", "--heightmap-bits", "eight", "-o", "{tmp}/x.png"], "--heightmap-bits",
     "eight"),
    (["world", "export", "{tmp}/w", "-f", "obj", "--heightmap-bits", "8", "-o", "{tmp}/x.obj"], "--heightmap-bits", "8"),
    (["demo", "-o", "{tmp}/notaworld"], "--output", "notaworld"),
    (["nosuchcommand"], "nosuchcommand", ""),
]


@pytest.mark.parametrize("args,field,value", BAD, ids=[" ".join(b[0][:4]) + f" [{b[1]}]" for b in BAD])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path: Path, args: list[str], field: str, value: str) -> None:
    _prepare(tmp_path)
    before = snapshot(tmp_path)
    code, out, err = run(*(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith("error: "), line
    assert field in line and value in line, line
    if value:
        assert f"{field}=" in line or f"{field}'=" in line or "is not a world" in line, line
    assert snapshot(tmp_path) == before  # nothing written, nothing left behind


@pytest.mark.slow
def test_bad_input_in_a_real_subprocess(tmp_path: Path) -> None:
    r = subprocess.run([str(NAVSTRESS), "world", "generate", "--trees", "-3", "-o", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert r.stderr.strip() == "error: --trees=-3.0 is invalid: expected a percentage in [0, 100)"
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_version_and_generate_in_a_real_subprocess(tmp_path: Path) -> None:
    r = subprocess.run([str(NAVSTRESS), "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == f"navstress {__version__}"
    r = subprocess.run([str(NAVSTRESS), "world", "generate", *SMALL, "--trees", "3", "--seed", "4",
                        "-o", str(tmp_path / "w")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert World.load(tmp_path / "w").seed == 4


def test_generate_writes_the_world_of_spec_and_seed_with_a_preview(tmp_path: Path) -> None:
    code, out, err = run("world", "generate", *SMALL, "-s", "3", "-d", "0.5", "--trees", "4", "--seed", "9",
                         "-o", str(tmp_path / "w"))
    assert code == 0, err
    w = World.load(tmp_path / "w")
    spec = parse_spec({"size_m": [20, 20], "cell_m": 0.5, "ground": {"subdivisions": 3, "deformation": 0.5},
                       "obstacles": {"obstruction": {"tree": 4}}})
    assert w == generate(spec, 9)  # same spec and seed, same world
    assert (tmp_path / "w" / "preview.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "obstruction" in out and "seed" in out
    # generating again into the same world directory replaces it; another seed gives another world
    code, _, err = run("world", "generate", *SMALL, "-s", "3", "-d", "0.5", "--trees", "4", "--seed", "10",
                       "-o", str(tmp_path / "w"))
    assert code == 0, err
    w10 = World.load(tmp_path / "w")
    assert w10.seed == 10 and w10.terrain != w.terrain


def test_flags_override_the_spec_file_and_mix_accepts_both_spellings(tmp_path: Path) -> None:
    (tmp_path / "s.yaml").write_text("size_m: [30, 30]\ncell_m: 0.5\nground: {subdivisions: 2, deformation: 1}\n")
    code, _, err = run("world", "generate", "--spec", str(tmp_path / "s.yaml"), "--size", "20", "-d", "0",
                       "--obstruction", "8", "--mix", "trees=3,building=1", "-o", str(tmp_path / "w"))
    assert code == 0, err
    s = World.load(tmp_path / "w").spec
    assert s.size_m == (20.0, 20.0) and s.cell_m == 0.5
    assert (s.ground.subdivisions, s.ground.deformation) == (2, 0.0)
    assert s.obstacles.targets() == {"building": 2.0, "tree": 6.0}


def test_show_prints_descriptors_and_writes_the_preview(tmp_path: Path) -> None:
    small_world().save(tmp_path / "w")
    code, out, err = run("world", "show", str(tmp_path / "w"), "-o", str(tmp_path / "p.png"))
    assert code == 0, err
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    assert "20 m x 20 m" in out and "3 trees" not in out and "2 trees" in out and "1 building" in out


@pytest.mark.parametrize("fmt,name,bits,side_files", [
    ("sdf", "w.sdf", None, ["w_heightmap.png"]), ("sdf", "w.sdf", "16", ["w_heightmap.png"]),
    ("png", "h.png", None, []), ("png", "h.png", "8", []), ("obj", "w.obj", None, ["w_terrain.png", "w.mtl"]),
    ("gltf", "w.gltf", None, []), ("glb", "w.glb", None, [])])
def test_export_formats(tmp_path: Path, fmt: str, name: str, bits: str | None, side_files: list[str]) -> None:
    w = small_world()
    w.save(tmp_path / "w")
    extra = [] if bits is None else ["--heightmap-bits", bits]
    code, out, err = run("world", "export", str(tmp_path / "w"), "--format", fmt, *extra, "-o", str(tmp_path / name))
    assert code == 0, err
    data = (tmp_path / name).read_bytes()
    assert out.strip().splitlines()[-1] == "wrote " + ", ".join(str(tmp_path / f) for f in [name, *side_files])
    if fmt in ("sdf", "png"):
        with Image.open(tmp_path / (side_files[0] if fmt == "sdf" else name)) as img:
            expected_bits = int(bits) if bits else (8 if fmt == "sdf" else 16)
            assert img.mode == ("L" if expected_bits == 8 else "I;16")
    if fmt == "sdf":
        assert b"<sdf" in data and b'name="mission_goal"' in data and "65x65" in out
    elif fmt == "png":
        h, lo, hi = read_heightmap_png(tmp_path / name)
        assert h.shape == w.terrain.heights.shape and (lo, hi) == (float(w.terrain.heights.min()),
                                                                     float(w.terrain.heights.max()))
        assert f"0..{(1 << (int(bits) if bits else 16)) - 1} =" in out
    elif fmt == "gltf":
        assert json.loads(data)["asset"]["version"] == "2.0"
    elif fmt == "glb":
        assert data[:4] == b"glTF"
    else:
        assert data.count(b"\nf ") >= 2 * 40 * 40 + 12 * 3 and b"\no terrain\n" in data


def test_export_mjcf_uses_the_simulator_model_builder(tmp_path: Path) -> None:
    model = pytest.importorskip("navstress.sim.model")
    if not hasattr(model, "world_to_mjcf"):
        pytest.skip("navstress.sim.model.world_to_mjcf not written yet")
    small_world().save(tmp_path / "w")
    code, _, err = run("world", "export", str(tmp_path / "w"), "--format", "mjcf", "-o", str(tmp_path / "w.xml"))
    assert code == 0, err
    assert (tmp_path / "w.xml").read_text() == model.world_to_mjcf(World.load(tmp_path / "w"))


def _commands() -> list[list[str]]:
    return [[], ["world"], ["world", "generate"], ["world", "show"], ["world", "export"], ["demo"]]


@pytest.mark.parametrize("path", _commands(), ids=lambda p: " ".join(p) or "navstress")
def test_help_explains_every_flag(path: list[str]) -> None:
    import typer.main

    code, out, err = run(*path, "--help")
    assert code == 0, err
    cmd = typer.main.get_command(app)
    for name in path:
        cmd = cmd.commands[name]  # type: ignore[attr-defined]
    for param in cmd.params:
        for opt in param.opts:
            if opt.startswith("-"):
                assert opt in out, (opt, out)
        if param.param_type_name == "option" and not getattr(param, "hidden", False):
            assert param.help, f"{param.name} has no help"


def test_generate_with_movers_from_flags(tmp_path: Path) -> None:
    code, out, err = run("world", "generate", "--size", "30", "--movers", "pedestrians=3,vehicle=0",
                         "--mover-behaviour", "pedestrians=patrol", "--seed", "2", "-o", str(tmp_path / "w"))
    assert code == 0, err
    w = World.load(tmp_path / "w")
    assert [m.behaviour for m in w.movers] == ["patrol"] * 3
    assert w.descriptors["n_movers"] == {"pedestrian": 3, "vehicle": 0}
    assert "n_movers" in out
