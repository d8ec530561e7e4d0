"""Mesh export: files load back with trimesh, with the right counts, bounds and surface."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from world_fixtures import small_world
from navstress.world.export.mesh import MESH_FORMATS, Z_UP_TO_Y_UP, terrain_faces, write_mesh

W = small_world(7)


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
    loaded = trimesh.load(path, process=False)
    if isinstance(loaded, trimesh.Trimesh):  # OBJ: one merged mesh, world coordinates
        return {"all": loaded}
    out = {}
    inv = np.linalg.inv(Z_UP_TO_Y_UP)
    for node in loaded.graph.nodes_geometry:
        tf, geom = loaded.graph[node]
        m = loaded.geometry[geom].copy()
        m.apply_transform(inv @ tf)
        out[geom] = m
    return out


@pytest.mark.parametrize("fmt", MESH_FORMATS)
def test_mesh_round_trip_counts_and_bounds(tmp_path: Path, fmt: str) -> None:
    p = write_mesh(W, tmp_path / f"w.{fmt}")
    meshes = _load_world_coords(p)
    rows, cols = W.terrain.heights.shape
    n_vert = rows * cols + 8 * len(W.obstacles)
    assert sum(len(m.vertices) for m in meshes.values()) == n_vert
    assert sum(len(m.faces) for m in meshes.values()) == 2 * (rows - 1) * (cols - 1) + 12 * len(W.obstacles)
    allv = np.concatenate([m.vertices for m in meshes.values()])
    top = max(max(o.z + o.size[2] for o in W.obstacles), float(W.terrain.heights.max()))
    assert allv[:, 2].max() == pytest.approx(top, abs=1e-5)
    assert allv[:, :2].min() == pytest.approx(0.0, abs=1e-6) and allv[:, :2].max() == pytest.approx(20.0, abs=1e-5)
    if fmt != "obj":
        assert set(meshes) == {"terrain", "obstacles_tree", "obstacles_building"}
        box = meshes["obstacles_building"]
        o = next(o for o in W.obstacles if o.kind == "building")
        assert box.bounds[0, 2] == pytest.approx(o.z) and box.bounds[1, 2] == pytest.approx(o.z + o.size[2])
        assert box.volume == pytest.approx(o.size[0] * o.size[1] * o.size[2])


@pytest.fixture(scope="module")
def glb(tmp_path_factory: pytest.TempPathFactory) -> dict[str, trimesh.Trimesh]:
    return _load_world_coords(write_mesh(W, tmp_path_factory.mktemp("glb") / "w.glb"))


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
