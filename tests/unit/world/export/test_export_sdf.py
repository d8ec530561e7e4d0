"""Gazebo SDF export: valid XML, one model per obstacle at the right pose, a 2^n+1 heightmap."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.support.world_fixtures import small_world
from navstress.world.export._grid import next_pow2_plus1, surface_heights
from navstress.world.export.images import read_heightmap_png
from navstress.world.export.sdf import write_sdf


def _floats(text: str | None) -> list[float]:
    assert text is not None
    return [float(v) for v in text.split()]


def test_sdf_models_and_poses_match_the_world(tmp_path: Path) -> None:
    w = small_world(3)
    r = write_sdf(w, tmp_path / "w.sdf")
    root = ET.parse(r.sdf_path).getroot()
    assert root.tag == "sdf" and float(root.get("version", "0")) >= 1.7
    world = root.find("world")
    assert world is not None
    assert world.find("physics/max_step_size") is not None
    assert world.find("light[@type='directional']") is not None
    boxes = [m for m in world.findall("model") if m.find("link/collision/geometry/box") is not None]
    assert len(boxes) == len(w.obstacles)
    for m, o in zip(boxes, w.obstacles):
        assert m.findtext("static") == "true"
        x, y, z, roll, pitch, yaw = _floats(m.findtext("pose"))
        assert (x, y, roll, pitch) == pytest.approx((o.x, o.y, 0.0, 0.0), abs=1e-6)
        assert z == pytest.approx(o.z + o.size[2] / 2, abs=1e-6)
        assert math.remainder(yaw - o.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
        assert _floats(m.findtext("link/collision/geometry/box/size")) == pytest.approx(list(o.size))


@pytest.mark.parametrize("bits,mode", [(8, "L"), (16, "I;16")])
def test_sdf_heightmap_is_square_2n_plus_1_and_matches_the_terrain(tmp_path: Path, bits: int, mode: str) -> None:
    w = small_world(5)  # 41 x 41 vertices -> resampled to 65 x 65
    r = write_sdf(w, tmp_path / "w.sdf", **({} if bits == 8 else {"heightmap_bits": bits}))  # 8: the default
    hm = ET.parse(r.sdf_path).getroot().find("world/model[@name='ground']/link/collision/geometry/heightmap")
    assert hm is not None
    assert hm.findtext("uri") == "w_heightmap.png" and (tmp_path / "w_heightmap.png").is_file()
    with Image.open(r.heightmap_path) as img:
        assert img.size == (65, 65) == (r.heightmap_side, r.heightmap_side) and img.mode == mode
    sx, sy, sz = _floats(hm.findtext("size"))
    px, py, pz = _floats(hm.findtext("pos"))
    assert (sx, sy) == w.terrain.size_m and (px, py) == (sx / 2, sy / 2)
    grid, z_min, z_max = read_heightmap_png(r.heightmap_path)
    assert pz == pytest.approx(z_min) and sz == pytest.approx(z_max - z_min)
    # every resampled vertex lies on the simulator's triangulated surface (within half a quantisation step)
    xs = np.linspace(0, sx, 65)
    ys = np.linspace(0, sy, 65)
    expected = surface_heights(w.terrain, xs[None, :], ys[:, None])
    step = (z_max - z_min) / ((1 << bits) - 1)
    assert np.max(np.abs(grid - expected)) <= step / 2 + 1e-9
    # spot-check against the scalar reference
    assert grid[64, 0] == pytest.approx(w.terrain.height_at(0.0, sy), abs=step / 2 + 1e-6)


@pytest.mark.parametrize("n,expected", [(2, 3), (3, 3), (4, 5), (41, 65), (251, 257), (257, 257), (258, 513)])
def test_next_pow2_plus1(n: int, expected: int) -> None:
    assert next_pow2_plus1(n) == expected
