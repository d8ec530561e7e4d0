"""Mesh export: files load back with trimesh (the files' reader here), y-up, one named object per
part with normals and a material, the terrain on the simulator's surface."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from tests.support.world_fixtures import small_world
from navstress.world.export._grid import MARKER
from navstress.world.export.mesh import MESH_FORMATS, Z_UP_TO_Y_UP, terrain_faces, write_mesh

W = small_world(7)
OBJECTS = {"terrain", "obstacles_tree", "obstacles_building", "mission_start", "mission_goal"}
#: The material of each object (the OBJ loader groups by material).
MATERIAL = {"terrain": "terrain", "obstacles_tree": "tree", "obstacles_building": "building",
            "mission_start": "start", "mission_goal": "goal"}
INV = np.linalg.inv(Z_UP_TO_Y_UP)


def _surface_z(verts: np.ndarray, faces: np.ndarray, x: float, y: float) -> float:
    """Brute force: the z of the (unique up to shared edges) triangle containing (x, y)."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    d = (b[:, 1] - c[:, 1]) * (a[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (a[:, 1] - c[:, 1])
    l1 = ((b[:, 1] - c[:, 1]) * (x - c[:, 0]) + (c[:, 0] - b[:, 0]) * (y - c[:, 1])) / d
    l2 = ((c[:, 1] - a[:, 1]) * (x - c[:, 0]) + (a[:, 0] - c[:, 0]) * (y - c[:, 1])) / d
    l3 = 1 - l1 - l2
    inside = np.nonzero((l1 >= -1e-9) & (l2 >= -1e-9) & (l3 >= -1e-9))[0]
    assert len(inside) >= 1
    k = inside[0]
    return float(l1[k] * a[k, 2] + l2[k] * b[k, 2] + l3[k] * c[k, 2])


def _load_world_coords(path: Path) -> dict[str, trimesh.Trimesh]:
    """Every object of the file in world coordinates (z up), by object name."""
    loaded = trimesh.load(path, process=False)
    assert isinstance(loaded, trimesh.Scene)
    by_material = {v: k for k, v in MATERIAL.items()}
    out = {}
    for node in loaded.graph.nodes_geometry:
        tf, geom = loaded.graph[node]
        m = loaded.geometry[geom].copy()
        m.apply_transform(INV @ tf)  # the file is y-up: undo it
        name = by_material[m.visual.material.name] if path.suffix == ".obj" else geom
        out[name] = m
    return out


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Path]]:
    d = tmp_path_factory.mktemp("mesh")
    return {fmt: write_mesh(W, d / f"w.{fmt}") for fmt in MESH_FORMATS}


@pytest.mark.parametrize("fmt", MESH_FORMATS)
def test_mesh_round_trip_objects_counts_and_bounds(exported: dict[str, list[Path]], fmt: str) -> None:
    meshes = _load_world_coords(exported[fmt][0])
    assert set(meshes) == OBJECTS
    rows, cols = W.terrain.heights.shape
    t = meshes["terrain"]
    assert (len(t.vertices), len(t.faces)) == (rows * cols, 2 * (rows - 1) * (cols - 1))
    assert t.vertices[:, :2].min() == pytest.approx(0.0, abs=1e-6)
    assert t.vertices[:, :2].max() == pytest.approx(20.0, abs=1e-5)
    assert t.vertices[:, 2].max() == pytest.approx(float(W.terrain.heights.max()), abs=1e-5)
    for kind in ("tree", "building"):
        obs = [o for o in W.obstacles if o.kind == kind]
        m = meshes[f"obstacles_{kind}"]
        assert len(m.faces) == 12 * len(obs)
        assert m.vertices[:, 2].max() == pytest.approx(max(o.z + o.size[2] for o in obs), abs=1e-5)
    box = meshes["obstacles_building"]
    o = next(o for o in W.obstacles if o.kind == "building")
    assert box.bounds[0, 2] == pytest.approx(o.z, abs=1e-5)
    assert box.bounds[1, 2] == pytest.approx(o.z + o.size[2], abs=1e-5)
    assert box.volume == pytest.approx(o.size[0] * o.size[1] * o.size[2], rel=1e-5)


@pytest.mark.parametrize("fmt", MESH_FORMATS)
def test_mission_markers_stand_on_the_ground_at_start_and_goal(exported: dict[str, list[Path]], fmt: str) -> None:
    meshes = _load_world_coords(exported[fmt][0])
    ms = W.mission
    for name, (x, y), top in (("mission_start", ms.start[:2], 2 * MARKER["thickness"]),
                              ("mission_goal", ms.goal, MARKER["pole_height"])):
        b = meshes[name].bounds
        ground = W.terrain.height_at(x, y)
        assert b[0, 2] == pytest.approx(ground, abs=1e-5) and b[1, 2] == pytest.approx(ground + top, abs=1e-5)
        disc = meshes[name].vertices[np.abs(meshes[name].vertices[:, 2] - ground) < 1e-6]
        assert disc[:, :2].mean(axis=0) == pytest.approx((x, y), abs=0.02)
    # the arrow points along the start heading
    start = meshes["mission_start"]
    tip = start.vertices[np.argmax(start.vertices[:, :2] @ np.array([np.cos(ms.start[2]), np.sin(ms.start[2])]))]
    assert np.hypot(*(tip[:2] - np.array(ms.start[:2]))) == pytest.approx(MARKER["arrow_length"], abs=0.1)


@pytest.mark.parametrize("fmt", MESH_FORMATS)
def test_normals_point_out_of_every_object(exported: dict[str, list[Path]], fmt: str) -> None:
    meshes = _load_world_coords(exported[fmt][0])
    for name, m in meshes.items():
        n = m.vertex_normals  # the file's normals where it has them (checked below), rotated back
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-4), name
    assert (meshes["terrain"].vertex_normals[:, 2] > 0).all()
    boxes = meshes["obstacles_building"]
    # flat faces: each face's three vertex normals equal its face normal
    assert np.allclose(boxes.vertex_normals[boxes.faces].mean(axis=1), boxes.face_normals, atol=1e-5)


def test_obj_file_has_groups_normals_and_its_material_library(exported: dict[str, list[Path]]) -> None:
    obj, *side = exported["obj"]
    assert {p.name for p in side} == {"w.mtl", "w_terrain.png"}
    text = obj.read_text()
    objects = re.findall(r"^o (\S+)$", text, re.M)
    assert set(objects) == OBJECTS and re.findall(r"^g (\S+)$", text, re.M) == objects
    assert text.count("\nvn ") == text.count("\nv ") > 0
    assert re.search(r"^f \d+/\d+/\d+ ", text, re.M) and re.search(r"^f \d+//\d+ ", text, re.M)
    mtl = (obj.parent / "w.mtl").read_text()
    assert re.findall(r"^mtllib (\S+)$", text, re.M) == ["w.mtl"]
    assert set(re.findall(r"^usemtl (\S+)$", text, re.M)) == set(re.findall(r"^newmtl (\S+)$", mtl, re.M))
    assert re.findall(r"^map_Kd (\S+)$", mtl, re.M) == ["w_terrain.png"]
    with Image.open(obj.parent / "w_terrain.png") as img:
        assert img.size == W.terrain.heights.shape[::-1] and img.mode == "RGB"
    # y-up in the file itself: the second coordinate of a terrain vertex is its height
    first = np.array([float(v) for v in re.search(r"^v (.+)$", text, re.M).group(1).split()])  # type: ignore[union-attr]
    assert first == pytest.approx([0.0, float(W.terrain.heights[0, 0]), 0.0], abs=1e-6)


def test_two_obj_exports_in_one_folder_keep_their_own_side_files(tmp_path: Path) -> None:
    a = write_mesh(W, tmp_path / "a.obj")
    b = write_mesh(small_world(3), tmp_path / "b.obj")
    assert not {p.name for p in a} & {p.name for p in b}
    assert "map_Kd b_terrain.png" in (tmp_path / "b.mtl").read_text()


@pytest.mark.parametrize("fmt", ["gltf", "glb"])
def test_gltf_primitives_have_normals_and_materials(exported: dict[str, list[Path]], fmt: str) -> None:
    path = exported[fmt][0]
    if fmt == "gltf":
        doc = json.loads(path.read_text())
    else:
        data = path.read_bytes()
        length = int.from_bytes(data[12:16], "little")
        assert data[16:20] == b"JSON"
        doc = json.loads(data[20:20 + length])
    names = {m["name"] for m in doc["meshes"]}
    assert names == OBJECTS
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            assert "NORMAL" in prim["attributes"] and "material" in prim, mesh["name"]
    terrain = next(m for m in doc["meshes"] if m["name"] == "terrain")["primitives"][0]
    assert "TEXCOORD_0" in terrain["attributes"]
    assert "baseColorTexture" in doc["materials"][terrain["material"]]["pbrMetallicRoughness"]
    colours = {tuple(doc["materials"][p["material"]]["pbrMetallicRoughness"].get("baseColorFactor", ()))
               for m in doc["meshes"] if m["name"] != "terrain" for p in m["primitives"]}
    assert len(colours) == 4  # tree, building, start, goal: each its own colour


@pytest.fixture(scope="module")
def glb(exported: dict[str, list[Path]]) -> dict[str, trimesh.Trimesh]:
    return _load_world_coords(exported["glb"][0])


@settings(max_examples=30, deadline=None)
@given(x=st.floats(0, 20), y=st.floats(0, 20))
def test_glb_terrain_surface_equals_height_at(glb: dict[str, trimesh.Trimesh], x: float, y: float) -> None:
    t = glb["terrain"]
    assert _surface_z(t.vertices, t.faces, x, y) == pytest.approx(W.terrain.height_at(x, y), abs=1e-4)


def test_terrain_faces_point_up_and_split_along_the_i_j_diagonal(glb: dict[str, trimesh.Trimesh]) -> None:
    f = terrain_faces(2, 2)  # one cell: vertices 0=(0,0) 1=(0,1) 2=(1,0) 3=(1,1)
    assert sorted(map(sorted, f.tolist())) == [[0, 1, 3], [0, 2, 3]]
    m = glb["terrain"]
    assert (m.face_normals[:, 2] > 0).all()
