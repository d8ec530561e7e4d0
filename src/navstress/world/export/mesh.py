"""Triangle meshes of a world (trimesh): glTF (.glb/.gltf) and Wavefront OBJ.

The terrain is triangulated exactly as the simulator and ``Terrain.height_at`` do: one
vertex per height sample, each cell split by the diagonal from vertex (i, j) to
(i+1, j+1), faces counter-clockwise seen from above (normals up). Each obstacle is a box
of its size, base at ``z``, rotated by ``yaw``. Vertex colours: terrain by height, boxes
by kind.

Axes: world coordinates are x east, y north, z up (meters). glTF is y-up by definition,
so :func:`write_mesh` puts the glTF scene under a root transform rotating z-up to y-up
(glTF (x, y, z) = world (x, z, -y)); viewers show it upright and loaders that apply the
scene graph (trimesh's ``Scene.to_geometry``) get it back after undoing that rotation
(:data:`Z_UP_TO_Y_UP`). OBJ has no axis convention: it is written in world coordinates.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from trimesh.exchange.gltf import export_gltf

from navstress.world.export._grid import write_atomic
from navstress.world.export.images import _terrain_cmap
from navstress.world.world import Obstacle, Terrain, World

#: The root transform of glTF exports (rotation of -90 degrees about x).
Z_UP_TO_Y_UP: np.ndarray = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

MESH_FORMATS = ("glb", "gltf", "obj")
_KIND_RGBA = {"tree": (31, 111, 58, 255), "building": (59, 74, 99, 255)}


def terrain_faces(rows: int, cols: int) -> np.ndarray:
    """Faces (2*(rows-1)*(cols-1), 3) of the grid; vertex index of (i, j) is i*cols + j."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    v00 = (i * cols + j).ravel()
    v01 = v00 + 1          # (i, j+1): +x
    v10 = v00 + cols       # (i+1, j): +y
    v11 = v10 + 1          # (i+1, j+1)
    lower = np.stack([v00, v01, v11], axis=1)  # u >= v half of the cell
    upper = np.stack([v00, v11, v10], axis=1)
    return np.concatenate([lower, upper]).astype(np.int64)


def terrain_mesh(terrain: Terrain) -> Any:
    """The terrain as a ``trimesh.Trimesh`` (vertices in world coordinates, coloured by height)."""
    h = terrain.heights.astype(np.float64)
    rows, cols = h.shape
    ys, xs = np.meshgrid(np.arange(rows) * terrain.cell_m, np.arange(cols) * terrain.cell_m, indexing="ij")
    verts = np.column_stack([xs.ravel(), ys.ravel(), h.ravel()])
    span = float(h.max() - h.min())
    t = (h.ravel() - h.min()) / span if span > 0 else np.full(h.size, 0.3)
    colours = (np.asarray(_terrain_cmap()(t)) * 255).astype(np.uint8)
    return trimesh.Trimesh(vertices=verts, faces=terrain_faces(rows, cols), vertex_colors=colours,
                           process=False)


def obstacle_mesh(o: Obstacle) -> Any:
    """One obstacle as a box ``trimesh.Trimesh`` (8 vertices, 12 faces)."""
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    tf = np.array([[c, -s, 0.0, o.x], [s, c, 0.0, o.y], [0.0, 0.0, 1.0, o.z + o.size[2] / 2],
                   [0.0, 0.0, 0.0, 1.0]])
    box = trimesh.creation.box(extents=o.size, transform=tf)
    box.visual.vertex_colors = np.tile(np.array(_KIND_RGBA.get(o.kind, (128, 128, 128, 255)), np.uint8),
                                       (len(box.vertices), 1))
    return box


def world_meshes(world: World) -> dict[str, Any]:
    """Named meshes: ``terrain`` and ``obstacles_<kind>`` (all boxes of a kind concatenated)."""
    out: dict[str, Any] = {"terrain": terrain_mesh(world.terrain)}
    for kind in sorted({o.kind for o in world.obstacles}):
        boxes = [obstacle_mesh(o) for o in world.obstacles if o.kind == kind]
        out[f"obstacles_{kind}"] = trimesh.util.concatenate(boxes)
    return out


def world_scene(world: World, *, y_up: bool = False) -> Any:
    """A ``trimesh.Scene`` of the world; ``y_up`` adds the :data:`Z_UP_TO_Y_UP` transform."""
    scene = trimesh.Scene()
    tf = Z_UP_TO_Y_UP if y_up else np.eye(4)
    for name, mesh in world_meshes(world).items():
        scene.add_geometry(mesh, geom_name=name, node_name=name, transform=tf)
    return scene


def mesh_bytes(world: World, fmt: str) -> bytes:
    """The world encoded as ``fmt`` (``glb``, ``gltf`` with embedded buffers, or ``obj``)."""
    if fmt not in MESH_FORMATS:
        raise ValueError(f"format={fmt!r}: expected one of {MESH_FORMATS}")
    if fmt == "obj":
        merged = trimesh.util.concatenate(list(world_meshes(world).values()))
        data = merged.export(file_type="obj", include_color=True, include_normals=False)  # type: ignore[no-untyped-call, call-arg]
        return data.encode("utf-8") if isinstance(data, str) else bytes(data)
    scene = world_scene(world, y_up=True)
    if fmt == "glb":
        return bytes(scene.export(file_type="glb"))
    files = export_gltf(scene, embed_buffers=True)  # type: ignore[no-untyped-call]
    return bytes(files["model.gltf"])


def write_mesh(world: World, path: str | Path, fmt: str | None = None) -> Path:
    """Write the world mesh to ``path``; the format is ``fmt`` or the file suffix."""
    p = Path(path)
    f = (fmt or p.suffix.lstrip(".")).lower()
    write_atomic(p, mesh_bytes(world, f))
    return p
