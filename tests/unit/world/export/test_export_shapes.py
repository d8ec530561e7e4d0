"""Cylinders and walls in every output outside the simulator, read back with the real readers:
glTF/OBJ (trimesh, the mesh tests' reader), the trace's scene (the MCAP reader and Foxglove's
protobuf schemas), its ROS 2 export's markers (rosbags), the preview PNG (its pixels) and the report's SVG
map (its path data)."""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from PIL import Image

from tests.support.world_fixtures import shapes_world
from navstress.world import World
from navstress.world.colours import kind_colour
from navstress.world.export.images import draw_world, preview_png_bytes
from navstress.world.export.mesh import CYLINDER_SECTIONS, Z_UP_TO_Y_UP, write_mesh

W = shapes_world(3, bumpy=False)
INV = np.linalg.inv(Z_UP_TO_Y_UP)


@pytest.mark.parametrize("fmt", ["glb", "gltf", "obj"])
def test_mesh_export_has_each_cylinder_on_its_circle_and_each_wall_box(tmp_path: Path, fmt: str) -> None:
    path = write_mesh(W, tmp_path / f"w.{fmt}")[0]
    scene = trimesh.load(path, process=False)
    meshes = {}
    for node in scene.graph.nodes_geometry:
        tf, geom = scene.graph[node]
        m = scene.geometry[geom].copy()
        m.apply_transform(INV @ tf)
        name = geom if fmt != "obj" else m.visual.material.name
        meshes[name.removeprefix("obstacles_")] = m
    trees = meshes["tree"].vertices
    cyls = [o for o in W.obstacles if o.is_cylinder]
    for o in cyls:  # each cylinder: its vertices lie on its circle, from its base to its top
        r = o.size[0] / 2
        d = np.hypot(trees[:, 0] - o.x, trees[:, 1] - o.y)
        mine = trees[np.abs(d - r) < 1e-4]
        assert len(mine) >= 2 * CYLINDER_SECTIONS
        assert mine[:, 2].min() == pytest.approx(o.z, abs=1e-5)
        assert mine[:, 2].max() == pytest.approx(o.z + o.size[2], abs=1e-5)
    # every tree vertex belongs to one of the cylinders (on its circle or its axis)
    d = np.min([np.abs(np.hypot(trees[:, 0] - o.x, trees[:, 1] - o.y) - o.size[0] / 2)
                * (np.hypot(trees[:, 0] - o.x, trees[:, 1] - o.y) > 1e-6) for o in cyls], axis=0)
    assert np.all(d < 1e-4)
    walls = [o for o in W.obstacles if o.kind == "wall"]
    wall_verts = meshes["wall"].vertices
    assert len(meshes["wall"].faces) == 12 * len(walls)
    for o in walls:  # the box's 8 corners are there
        for cx, cy in o.corners():
            assert np.any(np.hypot(wall_verts[:, 0] - cx, wall_verts[:, 1] - cy) < 1e-4)


def test_the_trace_scene_has_a_cylinder_primitive_of_each_cylinder(tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    from navstress.run.mission import world_messages
    from navstress.run.trace import TraceWriter, euler

    with TraceWriter(tmp_path / "s.mcap") as tw:
        world_messages(tw, W)
    with open(tmp_path / "s.mcap", "rb") as f:
        [(_, _, _, scene)] = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
            topics=["/world/scene"]))
    [ent] = scene.entities
    cyls = [o for o in W.obstacles if o.is_cylinder]
    boxes = [o for o in W.obstacles if not o.is_cylinder]
    assert len(ent.cylinders) == len(cyls) and len(ent.cubes) == len(boxes)
    kinds = sorted({o.kind for o in W.obstacles})
    for o, prim in zip(cyls, ent.cylinders):
        p = prim.pose.position
        assert (p.x, p.y, p.z) == pytest.approx((o.x, o.y, o.z + o.size[2] / 2))
        assert (prim.size.x, prim.size.y, prim.size.z) == pytest.approx((o.size[0], o.size[0], o.size[2]))
        assert prim.bottom_scale == prim.top_scale == 1.0
        c = prim.color
        assert (c.r, c.g, c.b) == pytest.approx(to_rgb(kind_colour(o.kind, kinds)), abs=1 / 255)
    for o, prim in zip(boxes, ent.cubes):
        assert (prim.size.x, prim.size.y, prim.size.z) == pytest.approx(o.size)
        assert euler(prim.pose.orientation)[0] == pytest.approx(o.yaw, abs=1e-9)


def test_the_ros2_export_draws_cylinders_as_cylinder_markers(tmp_path: Path) -> None:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    from navstress.run.mission import world_messages
    from navstress.run.ros2 import export_ros2
    from navstress.run.trace import TraceWriter

    with TraceWriter(tmp_path / "s.mcap") as tw:
        world_messages(tw, W)
    export_ros2(tmp_path / "s.mcap", tmp_path / "bag")
    ts = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(tmp_path / "bag") as reader:
        arrays = [ts.deserialize_cdr(raw, conn.msgtype) for conn, _t, raw in reader.messages()
                  if conn.topic == "/world/markers"]
    (arr,) = arrays
    cyl_markers = [mk for mk in arr.markers if mk.type == mk.CYLINDER]
    cyls = [o for o in W.obstacles if o.is_cylinder]
    assert len(cyl_markers) == len(cyls)
    for o, mk in zip(cyls, cyl_markers):
        assert (mk.pose.position.x, mk.pose.position.y, mk.pose.position.z) == pytest.approx(
            (o.x, o.y, o.z + o.size[2] / 2))
        assert (mk.scale.x, mk.scale.y, mk.scale.z) == pytest.approx((o.size[0], o.size[0], o.size[2]))
    assert len([mk for mk in arr.markers if mk.type == mk.CUBE]) == len(W.obstacles) - len(cyls)


def _pixels(world: World, dpi: int = 50) -> tuple[np.ndarray, float]:
    """``world`` drawn by :func:`draw_world` alone on a figure it fills: (RGB pixels, pixels per meter)."""
    sx, sy = world.size_m
    fig = Figure(figsize=(sx / 2, sy / 2), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    draw_world(ax, world, legend=False, hillshade=False)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    img = np.asarray(Image.open(buf).convert("RGB"), np.float64) / 255
    return img, img.shape[1] / sx


def test_preview_pixels_are_obstacle_coloured_inside_each_cylinder_and_not_outside() -> None:
    img, ppm = _pixels(W)
    h = img.shape[0]
    kinds = sorted({o.kind for o in W.obstacles})
    for o in W.obstacles:
        if not o.is_cylinder or o.size[0] < 0.8:
            continue
        colour = np.array(to_rgb(kind_colour(o.kind, kinds)))
        r = o.size[0] / 2

        def at(x: float, y: float) -> np.ndarray:
            return img[int(h - y * ppm), int(x * ppm)]

        assert np.abs(at(o.x, o.y) - colour).max() < 0.08  # the centre: the kind's colour (alpha 0.95)
        for a in np.linspace(0, 2 * math.pi, 8, endpoint=False):
            inside = at(o.x + 0.6 * r * math.cos(a), o.y + 0.6 * r * math.sin(a))
            outside = at(o.x + (r + 0.3) * math.cos(a), o.y + (r + 0.3) * math.sin(a))
            assert np.abs(inside - colour).max() < 0.08
            assert np.abs(outside - colour).max() > 0.2  # the ground, not the obstacle
    assert preview_png_bytes(W).startswith(b"\x89PNG")


def test_the_report_map_draws_each_cylinder_as_its_circle() -> None:
    from navstress.analysis.svgmap import world_defs

    svg = world_defs(W, "g")
    sy = W.size_m[1]
    ds = {title: d for _, d, title in re.findall(r'<path class="obs" fill="([^"]+)" d="([^"]+)"><title>([^<]+)</title>',
                                                   svg)}
    tree_d = ds["tree"]
    # every cylinder: a subpath "M x-r y a r r 0 1 0 2r 0 a r r 0 1 0 -2r 0 z" (5 cm grid)
    subpaths = re.findall(r"M([-\d.]+) ([-\d.]+)a([-\d.]+) ([-\d.]+) 0 1 0 ([-\d.]+) 0a[-\d.]+ [-\d.]+ 0 1 0 "
                          r"([-\d.]+) 0z", tree_d)
    cyls = [o for o in W.obstacles if o.is_cylinder]
    assert len(subpaths) == len(cyls)
    for o, (mx, my, rx, ry, dx, back) in zip(cyls, subpaths):
        r = o.size[0] / 2
        assert float(rx) == float(ry) == pytest.approx(r, abs=0.026)
        assert float(mx) + float(rx) == pytest.approx(o.x, abs=0.051) and float(my) == pytest.approx(sy - o.y, abs=0.026)
        assert float(dx) == -float(back) == pytest.approx(2 * r, abs=0.051)
    # walls and boxes stay polygons of their corners: a move and three relative lines each
    walls = [o for o in W.obstacles if o.kind == "wall"]
    assert re.fullmatch(r"(M[-\d.]+ [-\d.]+(l[-\d.]+ [-\d.]+){3}z)+", ds["wall"])
    assert ds["wall"].count("M") == len(walls)
