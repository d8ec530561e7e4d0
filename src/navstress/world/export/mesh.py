"""Triangle meshes of a world (trimesh): glTF (.glb/.gltf) and Wavefront OBJ (+ MTL + texture).

The terrain is triangulated exactly as the simulator and ``Terrain.height_at`` do: one
vertex per height sample, each cell split by the diagonal from vertex (i, j) to
(i+1, j+1), faces counter-clockwise seen from above (normals up). Each obstacle is a box
of its size (a wall: a long thin box), or a cylinder (a 32-sided prism on its circle), base at
``z``, rotated by ``yaw``, with its own vertices per face (flat normals).
The mission is two markers standing on the ground, as in the SDF export: ``mission_start`` (a
disc and an arrow along the start heading) and ``mission_goal`` (a disc and a pole).

Objects (glTF nodes and meshes; OBJ ``o`` and ``g`` of the same name): ``terrain``,
``obstacles_<kind>`` (all obstacles of a kind), ``mission_start``, ``mission_goal``. Every object
has vertex normals and a material: the terrain a texture coloured by height (one pixel per
height sample, north up; in an OBJ export ``<stem>_terrain.png`` beside the ``.obj``, in a
glTF embedded), the boxes a colour per kind, the markers green and red. OBJ materials are in
``<stem>.mtl`` beside the ``.obj``.

Axes: world coordinates are x east, y north, z up (meters). Both formats are written **y-up**
(file (x, y, z) = world (x, z, -y)): glTF is y-up by definition, and OBJ importers (Blender's
default, forward -Z up Y) expect it; viewers show the world upright. In glTF the rotation is a
root transform on every node (:data:`Z_UP_TO_Y_UP`), so loaders that apply the scene graph
(trimesh's ``Scene.to_geometry``) get it back after undoing that rotation; OBJ has no scene
graph, so its vertices are written rotated.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image
from trimesh.exchange.gltf import export_gltf
from trimesh.exchange.obj import export_obj
from trimesh.visual import TextureVisuals
from trimesh.visual.material import SimpleMaterial

from navstress._files import write_atomic_group
from navstress.world.export._grid import MARKER, MARKER_RGBA
from navstress.world.export.images import terrain_cmap
from navstress.world.world import Obstacle, Terrain, World, terrain_faces

#: The root transform of y-up exports (rotation of -90 degrees about x): (x, y, z) -> (x, z, -y).
Z_UP_TO_Y_UP: np.ndarray = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

MESH_FORMATS = ("glb", "gltf", "obj")
_KIND_RGBA = {"tree": (31, 111, 58, 255), "building": (59, 74, 99, 255), "wall": (140, 135, 128, 255)}


def _material(name: str, rgba: tuple[int, int, int, int], image: Any = None) -> Any:
    # ambient differs from diffuse: trimesh tells materials apart by a hash that XORs the two
    # (equal colours cancel, and the OBJ writer then merges every material into one)
    ambient = tuple(round(c * 0.4) for c in rgba[:3]) + (255,)
    return SimpleMaterial(  # type: ignore[no-untyped-call]
        name=name, diffuse=rgba, ambient=ambient, specular=(25, 25, 25, 255), glossiness=10.0, image=image)


def _solid(mesh: Any, name: str, rgba: tuple[int, int, int, int]) -> Any:
    """``mesh`` with its own vertices per face (flat normals) and one colour material."""
    m = trimesh.Trimesh(vertices=mesh.vertices[mesh.faces].reshape(-1, 3),
                        faces=np.arange(3 * len(mesh.faces)).reshape(-1, 3), process=False)
    m.visual = TextureVisuals(material=_material(name, rgba))  # type: ignore[no-untyped-call]
    return m


def terrain_texture(terrain: Terrain) -> Any:
    """The terrain's colours by height as an RGB image, one pixel per height sample, north up."""
    h = terrain.heights.astype(np.float64)
    span = float(h.max() - h.min())
    t = (h - h.min()) / span if span > 0 else np.full(h.shape, 0.3)
    rgb = (np.asarray(terrain_cmap()(t))[..., :3] * 255).round().astype(np.uint8)
    return Image.fromarray(np.ascontiguousarray(rgb[::-1]), mode="RGB")


def terrain_mesh(terrain: Terrain) -> Any:
    """The terrain as a ``trimesh.Trimesh`` (vertices in world coordinates, textured by height)."""
    h = terrain.heights.astype(np.float64)
    rows, cols = h.shape
    ys, xs = np.meshgrid(np.arange(rows) * terrain.cell_m, np.arange(cols) * terrain.cell_m, indexing="ij")
    verts = np.column_stack([xs.ravel(), ys.ravel(), h.ravel()])
    vi, uj = np.meshgrid(np.arange(rows) / max(rows - 1, 1), np.arange(cols) / max(cols - 1, 1), indexing="ij")
    m = trimesh.Trimesh(vertices=verts, faces=terrain_faces(rows, cols), process=False)
    m.visual = TextureVisuals(  # type: ignore[no-untyped-call]
        uv=np.column_stack([uj.ravel(), vi.ravel()]),
        material=_material("terrain", (255, 255, 255, 255), terrain_texture(terrain)))
    return m


def _box(size: tuple[float, float, float], x: float, y: float, z_base: float, yaw: float) -> Any:
    c, s = math.cos(yaw), math.sin(yaw)
    tf = np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z_base + size[2] / 2], [0.0, 0.0, 0.0, 1.0]])
    return trimesh.creation.box(extents=size, transform=tf)


#: The sides of the prism a cylinder obstacle is meshed as.
CYLINDER_SECTIONS = 32


def obstacle_mesh(o: Obstacle) -> Any:
    """One obstacle as a ``trimesh.Trimesh`` in world coordinates: a box (8 vertices, 12 faces),
    or a cylinder as a :data:`CYLINDER_SECTIONS`-sided prism whose vertices lie on its circle
    (base at ``z``, turned by its yaw)."""
    if o.is_cylinder:
        tf = trimesh.transformations.rotation_matrix(o.yaw, (0.0, 0.0, 1.0))  # type: ignore[no-untyped-call]
        tf[:3, 3] = (o.x, o.y, o.z + o.size[2] / 2)
        return trimesh.creation.cylinder(radius=o.size[0] / 2, height=o.size[2], sections=CYLINDER_SECTIONS,
                                         transform=tf)
    return _box(o.size, o.x, o.y, o.z, o.yaw)


def _disc(x: float, y: float, z: float, radius: float, height: float) -> Any:
    return trimesh.creation.cylinder(radius=radius, height=height, sections=32,
                                     transform=trimesh.transformations.translation_matrix(  # type: ignore[no-untyped-call]
                                         (x, y, z + height / 2)))


def marker_meshes(world: World) -> dict[str, Any]:
    """The mission markers (world coordinates): ``mission_start`` and ``mission_goal``."""
    ms, t = world.mission, world.terrain
    sx, sy, yaw = ms.start
    zs = t.height_at(sx, sy)
    r, th = MARKER["radius"], MARKER["thickness"]
    arrow_l = MARKER["arrow_length"]
    start = trimesh.util.concatenate([
        _disc(sx, sy, zs, r, th),
        _box((arrow_l, MARKER["arrow_width"], th), sx + math.cos(yaw) * arrow_l / 2,
             sy + math.sin(yaw) * arrow_l / 2, zs + th, yaw)])
    gx, gy = ms.goal
    zg = t.height_at(gx, gy)
    goal = trimesh.util.concatenate([_disc(gx, gy, zg, r, th), _disc(gx, gy, zg, 0.05, MARKER["pole_height"])])
    return {"mission_start": _solid(start, "start", MARKER_RGBA["start"]),
            "mission_goal": _solid(goal, "goal", MARKER_RGBA["goal"])}


def world_meshes(world: World) -> dict[str, Any]:
    """Named meshes in world coordinates: ``terrain``, ``obstacles_<kind>`` (all boxes of a kind
    concatenated), ``mission_start`` and ``mission_goal``."""
    out: dict[str, Any] = {"terrain": terrain_mesh(world.terrain)}
    for kind in sorted({o.kind for o in world.obstacles}):
        boxes = trimesh.util.concatenate([obstacle_mesh(o) for o in world.obstacles if o.kind == kind])
        out[f"obstacles_{kind}"] = _solid(boxes, kind, _KIND_RGBA.get(kind, (128, 128, 128, 255)))
    out.update(marker_meshes(world))
    return out


def world_scene(world: World, *, y_up: bool = False) -> Any:
    """A ``trimesh.Scene`` of the world; ``y_up`` adds the :data:`Z_UP_TO_Y_UP` transform."""
    scene = trimesh.Scene()
    tf = Z_UP_TO_Y_UP if y_up else np.eye(4)
    for name, mesh in world_meshes(world).items():
        scene.add_geometry(mesh, geom_name=name, node_name=name, transform=tf)
    return scene


def _obj_files(world: World, stem: str) -> dict[str, bytes]:
    """``{stem}.obj``, ``{stem}.mtl`` and ``{stem}_terrain.png``: y-up vertices, ``o`` and ``g``
    per object, vertex normals, one material per object."""
    text, files = export_obj(  # type: ignore[no-untyped-call]
        world_scene(world, y_up=True), include_normals=True, include_color=False, return_texture=True,
        mtl_name=f"{stem}.mtl", header="navstress world")
    texture = f"{stem}_terrain.png"
    out: dict[str, bytes] = {}
    for name, data in files.items():
        if name == "terrain.png":
            out[texture] = data
        elif name == f"{stem}.mtl":
            out[name] = data.replace(b"map_Kd terrain.png", f"map_Kd {texture}".encode())
        else:  # pragma: no cover - trimesh writes only the MTL and the one texture
            raise RuntimeError(f"unexpected OBJ side file {name!r}")
    lines = []
    for line in text.splitlines():
        lines.append(line)
        if line.startswith("o "):
            lines.append("g " + line[2:])
    out[f"{stem}.obj"] = ("\n".join(lines) + "\n").encode("utf-8")
    return out


def mesh_files(world: World, fmt: str, stem: str) -> dict[str, bytes]:
    """The files of the world encoded as ``fmt`` (``glb``, ``gltf`` with embedded buffers and
    textures, or ``obj`` with its MTL and texture), by file name; the main file is ``stem.fmt``."""
    if fmt not in MESH_FORMATS:
        raise ValueError(f"format={fmt!r}: expected one of {MESH_FORMATS}")
    if fmt == "obj":
        return _obj_files(world, stem)
    scene = world_scene(world, y_up=True)
    if fmt == "glb":
        return {f"{stem}.glb": bytes(scene.export(file_type="glb", include_normals=True))}
    files = export_gltf(scene, embed_buffers=True, include_normals=True)  # type: ignore[no-untyped-call]
    return {f"{stem}.gltf": bytes(files["model.gltf"])}


def write_mesh(world: World, path: str | Path, fmt: str | None = None) -> list[Path]:
    """Write the world mesh to ``path`` (and an OBJ's MTL and texture beside it, named after its
    stem); the format is ``fmt`` or the file suffix. Returns the files written, ``path`` first."""
    p = Path(path)
    f = (fmt or p.suffix.lstrip(".")).lower()
    files = mesh_files(world, f, p.stem)
    main = f"{p.stem}.{f}"
    out = {p: files[main], **{p.with_name(name): data for name, data in files.items() if name != main}}
    write_atomic_group(out)  # all of them or none
    return list(out)
