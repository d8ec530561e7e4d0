"""Occupancy-grid map import (navstress.world.sources.occupancy): hand-made images with known
walls, every mode and image kind as nav2_map_server reads them, the map's frame kept through
World.source.origin, the walls' rectangles against the cells (exact cover, no overlap, by
hypothesis over random grids), the free space and its default mission, and bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from navstress.errors import SpecError
from navstress.world._gridkernels import edt_squared
from navstress.world.freespace import farthest_mission, free_space, free_space_of_grid, rasterise
from navstress.world.generate import generate
from navstress.world.sources import module_for
from navstress.world.sources import occupancy as oc
from navstress.world.spec import SourceSpec, WorldSpec
from navstress.world.world import Obstacle
from tests.support.maps import walls_to_cells, write_pgm, write_png, write_yaml

FREE_V, WALL_V, UNK_V = 254, 0, 205  # map_saver's grey values


def load(yaml_path: Path, **opts: object) -> oc.World:
    return oc.load(yaml_path, SourceSpec(path=str(yaml_path), **opts))  # type: ignore[arg-type]


def room(h: int = 60, w: int = 80, t: int = 3) -> np.ndarray:
    img = np.full((h, w), FREE_V, np.uint8)
    img[:t, :] = img[-t:, :] = WALL_V
    img[:, :t] = img[:, -t:] = WALL_V
    return img


# ---- hand-made maps with known walls ---------------------------------------------------------


def test_room_outline_is_four_walls_covering_exactly_its_cells(tmp_path: Path) -> None:
    img = room()
    write_pgm(tmp_path / "room.pgm", img)
    w = load(write_yaml(tmp_path / "room.yaml", "room.pgm", resolution=0.05))
    assert len(w.obstacles) == 4
    cover = walls_to_cells(w, img.shape, 0.05, (0.0, 0.0))
    assert np.array_equal(cover, (img == WALL_V).astype(np.int64))
    assert all(o.size[2] == 2.0 and o.kind == "wall" and o.yaw == 0.0 for o in w.obstacles)
    assert w.spec.size_m == (10.0, 10.0) and w.spec.cell_m == 0.1  # 4 x 3 m padded to 10 m
    assert w.source is not None and w.source.kind == "map" and w.source.origin == (0.0, 0.0)
    assert np.all(w.terrain.heights == 0)


def test_single_pillar_lands_where_the_map_says(tmp_path: Path) -> None:
    """A 4 x 2 cell pillar whose top-left pixel is at image (row 10, col 30) of a 40-row map at 0.1
    m, origin (12.5, -7.25): in the map frame x in [12.5 + 3.0, 12.5 + 3.4], y in [-7.25 + (40 -
    12) 0.1, -7.25 + (40 - 10) 0.1]."""
    img = np.full((40, 50), FREE_V, np.uint8)
    img[10:12, 30:34] = WALL_V
    write_pgm(tmp_path / "p.pgm", img)
    w = load(write_yaml(tmp_path / "p.yaml", "p.pgm", resolution=0.1, origin=[12.5, -7.25, 0.0]), wall_height_m=3.5)
    assert len(w.obstacles) == 1
    o = w.obstacles[0]
    assert w.source is not None and w.source.origin == (12.5, -7.25)
    mx, my = w.source.to_source(o.x, o.y)
    assert mx == pytest.approx(12.5 + 3.2) and my == pytest.approx(-7.25 + 2.9)
    assert o.size == pytest.approx((0.4, 0.2, 3.5))
    # the world's own frame: the map's lower-left corner at (0, 0)
    assert (o.x, o.y) == pytest.approx((3.2, 2.9))


@pytest.mark.parametrize("negate", [0, 1])
def test_negate_swaps_black_and_white(tmp_path: Path, negate: int) -> None:
    img = room()
    img[20:25, 40:45] = WALL_V
    shown = img if not negate else (255 - img).astype(np.uint8)  # negated: white is occupied
    write_pgm(tmp_path / "n.pgm", shown)
    w = load(write_yaml(tmp_path / "n.yaml", "n.pgm", negate=negate))
    assert np.array_equal(walls_to_cells(w, img.shape, 0.05, (0.0, 0.0)), (img == WALL_V).astype(np.int64))


#: grey values and the cell nav2_map_server + Nav2's costmap make of them (thresholds 0.65 / 0.196)
#: trinary: occ = 1 - v/255; > 0.65 occupied (v < 89.25), < 0.196 free (v > 204.99), else unknown.
#: scale: the same ends, between them a partial value (free unless it rounds to 100).
#: raw: round(v) itself: 100 occupied, 0..99 free, above 100 unknown.
GREYS = [0, 89, 90, 150, 204, 205, 206, 254, 255, 100, 50, 99, 101]
EXPECTED = {
    "trinary": ["O", "O", "U", "U", "U", "U", "F", "F", "F", "U", "O", "U", "U"],
    "scale":   ["O", "O", "F", "F", "F", "F", "F", "F", "F", "F", "O", "F", "F"],
    "raw":     ["F", "F", "F", "U", "U", "U", "U", "U", "U", "O", "F", "F", "U"],
}
CODE = {"F": oc.FREE, "O": oc.OCCUPIED, "U": oc.UNKNOWN}


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
def test_each_mode_classifies_as_nav2_map_server(tmp_path: Path, mode: str) -> None:
    img = np.array([GREYS], np.uint8)
    write_pgm(tmp_path / "m.pgm", img)
    m = oc.read_yaml(write_yaml(tmp_path / "m.yaml", "m.pgm", mode=mode))
    codes = oc.classify(m, oc.read_pixels(m, oc.image_info(m)))
    assert codes[0].tolist() == [CODE[c] for c in EXPECTED[mode]]


def test_scale_mode_partial_values_round_as_rint(tmp_path: Path) -> None:
    """Between the thresholds, scale gives rint((occ - free) / (occ_t - free) * 100): 100 (a wall)
    only when occ reaches occupied_thresh after rounding."""
    m = oc.read_yaml(write_yaml(tmp_path / "s.yaml", "s.pgm", mode="scale", occupied_thresh=0.6, free_thresh=0.2))
    v = np.arange(256, dtype=np.uint8)
    write_pgm(tmp_path / "s.pgm", v[None, :])
    codes = oc.classify(m, oc.read_pixels(m, oc.image_info(m)))[0]
    occ = 1 - v / 255.0
    want = np.where(occ > 0.6, oc.OCCUPIED, oc.FREE)
    mid = (occ >= 0.2) & (occ <= 0.6)
    want[mid & (np.rint((occ - 0.2) / 0.4 * 100) >= 100)] = oc.OCCUPIED
    assert codes.tolist() == want.tolist()


@pytest.mark.parametrize("unknown", ["wall", "free"])
def test_unknown_cells_become_walls_or_free_ground(tmp_path: Path, unknown: str) -> None:
    img = np.full((50, 70), UNK_V, np.uint8)
    img[5:45, 5:65] = FREE_V
    img[20:23, 20:50] = WALL_V
    write_pgm(tmp_path / "u.pgm", img)
    w = load(write_yaml(tmp_path / "u.yaml", "u.pgm"), unknown=unknown)
    want = (img == WALL_V) | ((img == UNK_V) if unknown == "wall" else False)
    assert np.array_equal(walls_to_cells(w, img.shape, 0.05, (0.0, 0.0)), want.astype(np.int64))
    notes = w.descriptors.get("import_notes", [])
    assert any("unknown" in n for n in notes) == (unknown == "wall")


@pytest.mark.parametrize("yaw", [0.3, math.pi / 2, -2.0])
def test_origin_yaw_turns_the_walls_in_the_maps_frame(tmp_path: Path, yaw: float) -> None:
    img = room(40, 60)
    img[10:14, 20:30] = WALL_V
    write_pgm(tmp_path / "y.pgm", img)
    ox, oy = 4.0, -3.0
    w = load(write_yaml(tmp_path / "y.yaml", "y.pgm", resolution=0.1, origin=[ox, oy, yaw]))
    assert np.array_equal(walls_to_cells(w, img.shape, 0.1, (ox, oy), yaw), (img == WALL_V).astype(np.int64))
    # the world holds the turned map: every wall corner inside, the bounding box touching (0, 0)
    corners = np.concatenate([o.corners() for o in w.obstacles])
    assert corners.min(axis=0) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert np.all(corners.max(axis=0) <= np.array(w.size_m) + 1e-9)
    assert any("yaw" in n for n in w.descriptors["import_notes"])


def test_origin_offset_and_a_given_mission_in_the_maps_frame(tmp_path: Path) -> None:
    img = room(100, 100)
    write_pgm(tmp_path / "o.pgm", img)
    y = write_yaml(tmp_path / "o.yaml", "o.pgm", resolution=0.1, origin=[-20.0, 30.0, 0.0])
    spec = WorldSpec.model_validate({"source": {"path": str(y)}, "mission": {"start": [-18.0, 32.0, 0.5],
                                                                              "goal": [-12.0, 38.0]}})
    w = generate(spec, seed=0)
    assert w.mission.start == pytest.approx((2.0, 2.0, 0.5)) and w.mission.goal == pytest.approx((8.0, 8.0))


# ---- image kinds: PGM P2/P5, 8/16 bits; PNG grey, 16-bit, RGB, RGBA, grey+alpha, palette ----


def _codes(tmp_path: Path, name: str, mode: str = "trinary") -> np.ndarray:
    m = oc.read_yaml(write_yaml(tmp_path / f"{name}.yaml", name, mode=mode))
    return oc.classify(m, oc.read_pixels(m, oc.image_info(m)))


@pytest.mark.parametrize("kind", ["p5", "p2", "p5-16", "p2-16", "png-L", "png-16", "png-RGB", "png-RGBA-opaque",
                                  "png-LA-opaque", "png-P", "png-1"])
def test_every_image_kind_reads_as_its_grey_pgm(tmp_path: Path, kind: str) -> None:
    rng = np.random.default_rng(3)
    grey = rng.choice(np.array([0, 40, 120, 205, 230, 254, 255], np.uint8), size=(23, 31))
    if kind == "png-1":
        grey = np.where(grey > 128, 255, 0).astype(np.uint8)
    want = _codes(tmp_path, write_pgm(tmp_path / "ref.pgm", grey).name)
    name = f"img.{'pgm' if kind.startswith('p') and not kind.startswith('png') else 'png'}"
    p = tmp_path / name
    if kind == "p5":
        write_pgm(p, grey)
    elif kind == "p2":
        write_pgm(p, grey, plain=True)
    elif kind in ("p5-16", "p2-16"):
        write_pgm(p, grey.astype(np.uint16) * 257, maxval=65535, plain=kind == "p2-16")
    elif kind == "png-L":
        write_png(p, grey)
    elif kind == "png-16":
        write_png(p, grey.astype(np.uint16) * 257)
    elif kind == "png-RGB":
        write_png(p, np.repeat(grey[:, :, None], 3, axis=2))
    elif kind == "png-RGBA-opaque":
        write_png(p, np.concatenate([np.repeat(grey[:, :, None], 3, axis=2), np.full(grey.shape + (1,), 255, np.uint8)], 2))
    elif kind == "png-LA-opaque":
        write_png(p, np.stack([grey, np.full(grey.shape, 255, np.uint8)], axis=2), mode="LA")
    elif kind == "png-P":
        from PIL import Image

        Image.fromarray(grey).convert("P").save(p)
    elif kind == "png-1":
        from PIL import Image

        Image.fromarray(grey).convert("1").save(p)
    if "A-opaque" in kind:  # trinary averages alpha in as a 4th channel (nav2_map_server): scale reads the grey
        want = _codes(tmp_path, "ref.pgm", mode="scale")
        assert np.array_equal(_codes(tmp_path, name, mode="scale"), want)
        m = oc.read_yaml(write_yaml(tmp_path / "tri.yaml", name, mode="trinary"))
        tri = oc.classify(m, oc.read_pixels(m, oc.image_info(m)))
        occ = 1 - (3 * grey.astype(np.float64) + 255) / 4 / 255
        assert np.array_equal(tri == oc.OCCUPIED, occ > 0.65) and np.array_equal(tri == oc.FREE, occ < 0.196)
        return
    got = _codes(tmp_path, name)
    assert np.array_equal(got, want)


def test_rgb_is_the_mean_of_its_channels_and_alpha_counts_in_trinary_only(tmp_path: Path) -> None:
    """nav2_map_server: shade = mean(r, g, b) (with alpha as a 4th channel in trinary); scale:
    a pixel not opaque is unknown."""
    px = np.array([[[255, 0, 0, 255], [255, 255, 255, 0], [255, 255, 255, 255], [0, 0, 0, 255]]], np.uint8)
    write_png(tmp_path / "c.png", px)
    tri = _codes(tmp_path, "c.png")[0].tolist()
    # trinary, alpha averaged in: opaque red (255+0+0+255)/4 -> occ 0.5 unknown; transparent white 3/4 -> occ
    # 0.25 unknown; opaque white free; opaque black 1/4 -> occ 0.75 occupied
    assert tri == [oc.UNKNOWN, oc.UNKNOWN, oc.FREE, oc.OCCUPIED]
    # scale: red 1/3 -> occ 0.667 occupied; the transparent pixel unknown
    sc = _codes(tmp_path, "c.png", mode="scale")[0].tolist()
    assert sc == [oc.OCCUPIED, oc.UNKNOWN, oc.FREE, oc.OCCUPIED]


# ---- rectangles: exact cover, no overlap ---------------------------------------------------------


def _paint(rects: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    out = np.zeros(shape, np.int64)
    for i0, j0, i1, j1 in rects:
        assert 0 <= i0 < i1 <= shape[0] and 0 <= j0 < j1 <= shape[1]
        out[i0:i1, j0:j1] += 1
    return out


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1, 40), st.integers(1, 40), st.floats(0.0, 1.0), st.integers(0, 2**32 - 1), st.booleans())
def test_rectangles_cover_exactly_without_overlap(h: int, w: int, p: float, seed: int, blocky: bool) -> None:
    rng = np.random.default_rng(seed)
    if blocky:  # walls and blocks, as maps have
        mask = np.zeros((h, w), bool)
        for _ in range(rng.integers(0, 8)):
            i, j = rng.integers(0, h), rng.integers(0, w)
            mask[i:i + rng.integers(1, h + 1), j:j + rng.integers(1, 4)] = True
            mask[i:i + rng.integers(1, 4), j:j + rng.integers(1, w + 1)] = True
    else:
        mask = rng.random((h, w)) < p
    rects = oc.rectangles(mask)
    assert np.array_equal(_paint(rects, mask.shape), mask.astype(np.int64))
    # never more rectangles than the row runs (a box per cell only on a checkerboard)
    runs = int(np.sum(np.diff(np.pad(mask.astype(np.int8), ((0, 0), (1, 0))), axis=1) == 1))
    assert len(rects) <= runs


def test_rectangles_merge_walls_into_few_boxes() -> None:
    mask = np.zeros((500, 700), bool)
    mask[:4, :] = mask[-4:, :] = mask[:, :4] = mask[:, -4:] = True  # the outline
    mask[100:400, 300:303] = True  # a wall
    mask[200:260, 100:160] = True  # a block
    assert len(oc.rectangles(mask)) == 6


# ---- the free space and the default mission --------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 30), st.integers(1, 30), st.floats(0.0, 1.0), st.integers(0, 2**32 - 1))
def test_distance_transform_is_scipys(h: int, w: int, p: float, seed: int) -> None:
    b = np.random.default_rng(seed).random((h, w)) < p
    pad = np.zeros((h + 2, w + 2), bool)
    pad[1:-1, 1:-1] = ~b
    assert np.allclose(edt_squared(b), ndimage.distance_transform_edt(pad)[1:-1, 1:-1] ** 2)


def test_rasterise_is_exact_on_aligned_boxes_and_conservative_on_turned_ones() -> None:
    obs = (Obstacle("wall", 1.05, 2.0, 0.0, (0.3, 1.0, 2.0)), Obstacle("wall", 5.0, 5.0, math.pi / 2, (2.0, 0.2, 2.0)),
           Obstacle("wall", 8.0, 2.0, 0.4, (1.0, 1.0, 2.0)), Obstacle("p", 2.0, 7.0, 0.0, (1.0, 1.0, 1.0), shape="cylinder"))
    g = rasterise(obs, (10.0, 10.0), 0.1)
    want = np.zeros_like(g)
    want[15:25, 9:12] = True
    want[40:60, 49:51] = True
    assert np.array_equal(g[:30, :40], want[:30, :40])  # only the first box there
    assert np.array_equal(g[30:70, 40:60], want[30:70, 40:60])  # only the second (turned a quarter: aligned)
    # every cell centre inside a turned box or the cylinder is blocked
    yy, xx = np.mgrid[0:100, 0:100]
    cx, cy = (xx + 0.5) * 0.1, (yy + 0.5) * 0.1
    u = math.cos(0.4) * (cx - 8) + math.sin(0.4) * (cy - 2)
    v = -math.sin(0.4) * (cx - 8) + math.cos(0.4) * (cy - 2)
    assert np.all(g[(np.abs(u) <= 0.5) & (np.abs(v) <= 0.5)])
    assert np.all(g[np.hypot(cx - 2, cy - 7) <= 0.5])


def test_default_mission_spans_the_largest_free_part_with_clearance(tmp_path: Path) -> None:
    img = room(100, 160)  # 8 x 5 m at 0.05, in a 10 x 10 m world: the padding is outside the map, never free space
    img[3:97, 80:83] = WALL_V  # walls splitting it in three: the left part (0.15 .. 4.0 m) the largest
    img[3:97, 120:123] = WALL_V
    write_pgm(tmp_path / "d.pgm", img)
    w = load(write_yaml(tmp_path / "d.yaml", "d.pgm"))
    fs = free_space(w)
    m = farthest_mission(fs, pass_m=0.3, turn_m=0.45)
    assert m is not None
    for x, y in (m.start[:2], m.goal):
        assert 0.15 + 0.45 <= x <= 4.0 - 0.45 and 0.15 + 0.45 <= y <= 5 - 0.15 - 0.45 + 1e-9
    assert m.straight_distance_m > 4.0  # across the diagonal of the left room
    assert m.start[2] == pytest.approx(math.atan2(m.goal[1] - m.start[1], m.goal[0] - m.start[0]))


def test_free_space_of_a_grid_counts_its_edge_as_blocked() -> None:
    fs = free_space_of_grid(np.zeros((10, 10), bool), 0.1)
    assert fs.clearance.max() == pytest.approx((5 - math.sqrt(0.5)) * 0.1, rel=1e-6)  # a centre cell: 5 cells from the edge
    assert farthest_mission(fs, pass_m=0.5, turn_m=0.5) is None


def test_kind_auto_claims_a_map_yaml(tmp_path: Path) -> None:
    write_pgm(tmp_path / "a.pgm", room())
    y = write_yaml(tmp_path / "a.yaml", "a.pgm")
    assert module_for(SourceSpec(path=str(y))) is oc


def test_large_map_is_fast_and_few_walls(tmp_path: Path) -> None:
    """A 1000 x 1000 cell office of 10 x 10 rooms: about one wall per wall segment, in well under a second."""
    import time

    img = np.full((1000, 1000), FREE_V, np.uint8)
    for k in range(0, 1000, 100):
        img[k:k + 3, :] = WALL_V
        img[:, k:k + 3] = WALL_V
    img[-3:, :] = img[:, -3:] = WALL_V
    write_pgm(tmp_path / "big.pgm", img)
    y = write_yaml(tmp_path / "big.yaml", "big.pgm")
    load(y)  # compiled kernels warm
    t = time.perf_counter()
    w = load(y)
    assert time.perf_counter() - t < 3.0
    assert np.array_equal(walls_to_cells(w, img.shape, 0.05, (0.0, 0.0)), (img == WALL_V).astype(np.int64))
    assert len(w.obstacles) <= 2 * 11 * 10 + 2


# ---- bad input: one SpecError naming the file and the fix --------------------------------------


def test_thresholds_and_fields_are_checked(tmp_path: Path) -> None:
    write_pgm(tmp_path / "r.pgm", room())
    cases = {
        "occupied_thresh": dict(occupied_thresh=1.5),
        "free_thresh": dict(free_thresh=-0.1),
        "free_thresh ": dict(free_thresh=0.7, occupied_thresh=0.6),
        "resolution": dict(resolution=0),
        "resolution ": dict(resolution="abc"),
        "origin": dict(origin=[1, 2]),
        "negate": dict(negate=3),
        "mode": dict(mode="ternary"),
    }
    for key, fields in cases.items():
        y = write_yaml(tmp_path / "bad.yaml", "r.pgm", **fields)  # type: ignore[arg-type]
        with pytest.raises(SpecError) as e:
            load(y)
        assert f"bad.yaml {key.strip()}=" in str(e.value) and "\n" not in str(e.value), str(e.value)
    y = write_yaml(tmp_path / "nores.yaml", "r.pgm", resolution=None)
    with pytest.raises(SpecError, match="nores.yaml resolution"):
        load(y)
