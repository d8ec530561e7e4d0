"""Heightmap PNG round trip and the top-down preview."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from tests.support.world_fixtures import small_world
from navstress.world import Terrain, World, WorldSpec
from navstress.world.export.images import (draw_world, heightmap_png_bytes, read_heightmap_png,
                                           world_title, write_heightmap_png, write_preview)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(arrays(np.float32, st.tuples(st.integers(2, 9), st.integers(2, 9)),
              elements=st.floats(-30, 30, width=32)), st.sampled_from([8, 16]))
def test_heightmap_round_trip_within_quantisation(tmp_path: Path, h: np.ndarray, bits: int) -> None:
    info = write_heightmap_png(Terrain(h, 0.5), tmp_path / "h.png", bits=bits)
    back, z_min, z_max = read_heightmap_png(info.path)
    assert (z_min, z_max) == (float(h.min()), float(h.max())) == (info.z_min, info.z_max)
    assert back.shape == h.shape
    with Image.open(info.path) as img:
        assert img.mode == ("L" if bits == 8 else "I;16")
    step = (z_max - z_min) / ((1 << bits) - 1)
    assert np.max(np.abs(back - h)) <= step / 2 + 1e-9 * max(1.0, abs(z_max))


def test_heightmap_is_16_bit_north_up_and_uses_full_range(tmp_path: Path) -> None:
    h = np.zeros((3, 4), np.float32)
    h[2, 0] = 7.5  # north-west corner (row 2 = largest y) is the highest
    h[0, 3] = -2.5  # south-east corner the lowest
    write_heightmap_png(Terrain(h, 1.0), tmp_path / "h.png")
    with Image.open(tmp_path / "h.png") as img:
        assert img.mode in ("I;16", "I;16B", "I")
        assert img.size == (4, 3)
        px = np.array(img)
        assert img.text["navstress:z_min"] == "-2.5" and img.text["navstress:z_max"] == "7.5"
    assert px[0, 0] == 65535 and px[2, 3] == 0  # image row 0 = north edge
    assert px[1, 1] == round(2.5 / 10 * 65535)


@pytest.mark.parametrize("bits", [0, 1, 12, 32, "8"])
def test_heightmap_bits_other_than_8_or_16_are_refused(bits: object) -> None:
    with pytest.raises(ValueError, match="bits"):
        heightmap_png_bytes(np.zeros((2, 2)), 0.5, bits=bits)  # type: ignore[arg-type]


def test_flat_heightmap_is_zero_with_degenerate_range() -> None:
    png, z_min, z_max = heightmap_png_bytes(np.full((3, 3), 1.25), 0.4)
    assert (z_min, z_max) == (1.25, 1.25)
    import io
    assert not np.array(Image.open(io.BytesIO(png))).any()


def test_preview_writes_a_png_for_a_world(tmp_path: Path) -> None:
    p = write_preview(small_world(), tmp_path / "sub" / "p.png")
    with Image.open(p) as img:
        assert img.format == "PNG" and img.size[0] > 600 and img.size[1] > 400
        rgb = np.array(img.convert("RGB"), dtype=np.int32)
    assert rgb.std() > 10  # not a blank canvas
    assert not list(tmp_path.glob("sub/.*"))  # no temp file left behind


def test_draw_world_draws_every_obstacle_with_its_corners() -> None:
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    w = small_world()
    ax = Figure().add_subplot()
    mappable = draw_world(ax, w)
    polys = [p for c in ax.collections if isinstance(c, PolyCollection) for p in c.get_paths()]
    assert len(polys) == len(w.obstacles)
    drawn = sorted(tuple(np.round(p.vertices[:4].mean(axis=0), 6)) for p in polys)
    assert drawn == sorted((round(o.x, 6), round(o.y, 6)) for o in w.obstacles)
    lo, hi = mappable.get_clim()
    assert lo == pytest.approx(float(w.terrain.heights.min())) and hi == pytest.approx(float(w.terrain.heights.max()))
    assert ax.get_xlim() == (0.0, 20.0) and ax.get_ylim() == (0.0, 20.0)


def test_title_names_the_key_descriptors() -> None:
    w = World.flat(WorldSpec(size_m=(20.0, 20.0), ground={"subdivisions": 4, "deformation": 2.0}), seed=17)
    t = world_title(w)
    assert "obstruction 0.0 %" in t and "s = 4" in t and "d = 2 m" in t and "seed 17" in t
