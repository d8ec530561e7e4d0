"""A Gazebo world (SDF 1.4 to 1.9) as a source (``kind: sdf``; docs/worlds.md, "Imported Gazebo
worlds (SDF)"). libsdformat's reading of the same file is the reference (the oracle
``tests/oracles/sdf_dump.cc``); what it imports:

- the first ``<world>``'s models (nested ones and ``<include>``\\ d ones too), their links'
  ``<collision>`` geometry at its world pose, composed model -> link -> collision with SDF's pose
  semantics: ``<pose>`` is ``x y z roll pitch yaw`` (1.9: ``rotation_format="quat_xyzw"`` and
  ``degrees``), relative to the parent's frame unless ``relative_to`` (1.7+) or ``frame`` (1.5,
  1.6: read as libsdformat reads it, as ``relative_to``) names another frame of the same scope:
  a link, a joint (its frame defaults to its child link's), a ``<frame>`` (defaults to its
  ``attached_to``), a nested model, or ``nested::name`` (1.8+); a model's ``placement_frame``
  (1.8+) places that frame at the model's pose;
- geometry: a box is a box; a cylinder an upright cylinder; a sphere an upright cylinder of its
  diameter and height (its bounding cylinder); a capsule likewise (height length + 2 radius); an
  ellipsoid its bounding box; a mesh, with ``meshes: bbox``, the box of its vertices (STL, OBJ,
  PLY, glTF) times its ``<scale>``; a horizontal ``<plane>`` is the flat ground; the first
  ``<heightmap>`` (a grey image) the terrain. Obstacles are upright: a box or cylinder turned
  so that one of its axes stays vertical (within :data:`UPRIGHT_TOL_RAD`) is exact; tilted
  geometry becomes its upright bounding box, and its model is listed in the warning;
- the world's ``<state>`` (Gazebo saves one in every world): as Gazebo classic's
  ``World::SetState`` applies it when it loads a world, its models' and links' poses (world
  frame) replace those of the world's body, ``<insertions>`` add models and ``<deletions>``
  remove them. (libsdformat's object model does not read ``<state>``: where a state moves
  something, Gazebo and libsdformat disagree, and navstress follows Gazebo.)

Every element it cannot import (meshes unless ``meshes: bbox``, actors, lights, plugins,
populations, roads, sensors, non-horizontal planes, other heightmaps, non-static models' dynamics:
their collisions are imported at their pose) is named in ONE :class:`SourceWarning` line, never
dropped silently. The world is shifted so that the content's lower-left corner minus
``margin_m`` is (0, 0) (``World.source.origin``), at least 10 m a side; its mission is a
placeholder (:func:`~navstress.world.sources.placeholder.placeholder_mission`).

Bad input (a file that is not XML, not SDF 1.4 to 1.9, without a ``<world>``, a pose or size
that is not numbers, an include whose model cannot be found, a frame that does not exist or a
cycle of frames): :class:`~navstress.errors.SpecError` naming the file and the fix."""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np

from navstress.errors import SpecError
from navstress.world.sources.digest import file_sha256
from navstress.world.sources.notes import warn
from navstress.world.sources.placeholder import placeholder_mission
from navstress.world.spec import SourceSpec, WorldSpec, check_memory
from navstress.world.world import Obstacle, Terrain, World, WorldSource

KIND = "sdf"

#: The SDF versions read (libsdformat 12 reads these; older ones are refused).
VERSIONS = ("1.4", "1.5", "1.6", "1.7", "1.8", "1.9")
#: A box or cylinder whose axis is this close to vertical is upright (radians; 1.57 for pi/2 is).
UPRIGHT_TOL_RAD = 2e-3
#: Largest SDF file read (bytes).
MAX_BYTES = 256 << 20
#: Deepest chain of ``<include>``s.
MAX_INCLUDE_DEPTH = 32
#: Smallest side of an imported world (m): WorldSpec's smallest map.
MIN_SIDE_M = 10.0
MAX_SIDE_M = 2000.0
#: Environment variables naming folders of models (``model://NAME``), searched in this order,
#: then the world file's folder and its ``models/`` subfolder.
MODEL_PATH_VARS = ("GAZEBO_MODEL_PATH", "SDF_PATH", "GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH")
#: Mesh files whose bounding box ``meshes: bbox`` reads (through trimesh).
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf")


def claims(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in (".world", ".sdf")


# ---- poses: position and unit quaternion (w, x, y, z), composed as libsdformat composes them ----

@dataclass(frozen=True, slots=True)
class Pose:
    p: tuple[float, float, float] = (0.0, 0.0, 0.0)
    q: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def __mul__(self, o: "Pose") -> "Pose":
        """``self * o``: the pose ``o`` (given in the frame ``self`` places) in ``self``'s parent."""
        rx, ry, rz = _rotate(self.q, o.p)
        w1, x1, y1, z1 = self.q
        w2, x2, y2, z2 = o.q
        return Pose((self.p[0] + rx, self.p[1] + ry, self.p[2] + rz),
                    (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2))

    def inverse(self) -> "Pose":
        w, x, y, z = self.q
        qi = (w, -x, -y, -z)
        px, py, pz = _rotate(qi, self.p)
        return Pose((-px, -py, -pz), qi)

    def matrix(self) -> tuple[tuple[float, float, float], ...]:
        """The rotation's rows (the columns are the frame's axes in the parent)."""
        w, x, y, z = self.q
        return ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
                (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
                (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))


IDENTITY = Pose()


def _rotate(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> tuple[float, float, float]:
    w, x, y, z = q
    vx, vy, vz = v
    # t = 2 q_vec x v; v' = v + w t + q_vec x t
    tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


def rpy_pose(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> Pose:
    """SDF's ``x y z roll pitch yaw`` (rotation Rz(yaw) Ry(pitch) Rx(roll), as ignition's Euler)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return Pose((x, y, z), (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy))


# ---- reading -----------------------------------------------------------------------------------

class _Bad(Exception):
    """Bad input met while reading ``path``; becomes a SpecError naming the world file."""

    def __init__(self, path: Path, expected: str, fix: str) -> None:
        super().__init__(expected)
        self.path, self.expected, self.fix = path, expected, fix


def _xml(path: Path) -> ET.Element:
    """The root element of ``path``: well-formed XML, no entity declarations (an SDF file never
    needs them and they can expand without bound), at most :data:`MAX_BYTES`."""
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise _Bad(path, f"an SDF file of at most {MAX_BYTES >> 20} MiB (this one has {size / (1 << 20):.0f} MiB)",
                       "split the world")
        data = path.read_bytes()
    except OSError as err:
        raise _Bad(path, f"a readable file ({err.strerror or err})", "check the path and its permissions") from None
    text = data
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        text = data.decode("utf-16").encode("utf-8")
    if b"<!ENTITY" in text:
        raise _Bad(path, "an SDF file without entity declarations (<!ENTITY ...>)", "remove the DOCTYPE and its entities")
    try:
        return ET.fromstring(data)
    except ET.ParseError as err:
        raise _Bad(path, f"well-formed XML ({err})", "fix the file's XML (an editor or `xmllint` shows where)") from None


def _version(root: ET.Element, path: Path) -> tuple[int, int]:
    if root.tag != "sdf":
        raise _Bad(path, f"an SDF file (its root element <sdf version=...>, not <{root.tag}>)",
                   "a Gazebo world file starts with <sdf version='1.x'>; convert an old one with `gz sdf -p FILE`")
    v = (root.get("version") or "").strip()
    if v not in VERSIONS:
        raise _Bad(path, f"an SDF version among {', '.join(VERSIONS)} (this file says version={v!r})",
                   "convert it (`gz sdf -p FILE` prints it in the newest version) or fix <sdf version=...>")
    major, minor = v.split(".")
    return (int(major), int(minor))


def _numbers(el: ET.Element | None, n: int, default: tuple[float, ...], path: Path, what: str) -> tuple[float, ...]:
    if el is None:
        return default
    words = (el.text or "").split()
    if not words:
        return default
    try:
        vals = tuple(float(w) for w in words)
    except ValueError:
        vals = ()
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise _Bad(path, f"<{what}> as {n} numbers (found {' '.join(words)[:80]!r})", f"fix <{what}>")
    return vals


def _pose(el: ET.Element | None, path: Path) -> Pose:
    if el is None or not (el.text or "").strip():
        return IDENTITY
    fmt = (el.get("rotation_format") or "euler_rpy").strip()
    if fmt == "quat_xyzw":
        x, y, z, qx, qy, qz, qw = _numbers(el, 7, (), path, "pose rotation_format='quat_xyzw'")
        n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        if n == 0:
            raise _Bad(path, "a <pose> quaternion that is not zero", "fix the <pose>")
        return Pose((x, y, z), (qw / n, qx / n, qy / n, qz / n))
    if fmt != "euler_rpy":
        raise _Bad(path, f"<pose rotation_format> euler_rpy or quat_xyzw (found {fmt!r})", "fix the <pose>")
    x, y, z, r, p, yw = _numbers(el, 6, (), path, "pose")
    if (el.get("degrees") or "").strip().lower() in ("true", "1"):
        r, p, yw = math.radians(r), math.radians(p), math.radians(yw)
    return rpy_pose(x, y, z, r, p, yw)


def _rel(el: ET.Element | None) -> str:
    """A pose's ``relative_to`` (1.7+) or ``frame`` (1.5, 1.6; libsdformat reads it the same way)."""
    if el is None:
        return ""
    return (el.get("relative_to") or el.get("frame") or "").strip()


def _bool(el: ET.Element | None) -> bool:
    return el is not None and (el.text or "").strip().lower() in ("1", "true")


def _text(el: ET.Element | None) -> str:
    return "" if el is None else (el.text or "").strip()


# ---- the model tree and its frames ----------------------------------------------------------------

@dataclass
class _Entry:
    pose: Pose
    rel: str  # the frame it is relative to (defaults filled in)
    model: "_Scope | None" = None  # a nested model's scope (its placement frame)


@dataclass
class _Collision:
    name: str
    pose: Pose
    rel: str
    geometry: ET.Element | None
    file: Path


@dataclass
class _Link:
    name: str
    collisions: list[_Collision] = field(default_factory=list)


@dataclass
class _Scope:
    """A model (or the world, ``root == "world"``): its frames and the poses resolved in its own frame."""

    name: str  # scoped name (a::b); "" for the world
    root: str  # "__model__" or "world"
    file: Path
    static: bool = True
    placement: str = ""
    entries: dict[str, _Entry] = field(default_factory=dict)
    links: list[_Link] = field(default_factory=list)
    models: dict[str, "_Scope"] = field(default_factory=dict)
    _done: dict[str, Pose] = field(default_factory=dict)

    def label(self, name: str) -> str:
        return f"{self.name}::{name}" if self.name else name

    def resolve(self, name: str, stack: tuple[str, ...] = ()) -> Pose:
        """The pose of frame ``name`` in this scope's frame."""
        if name == self.root or name == "":
            return IDENTITY
        done = self._done.get(name)
        if done is not None:
            return done
        if name in stack:
            raise _Bad(self.file, f"frames whose poses do not form a cycle ({' -> '.join(stack + (name,))} in "
                       f"{self.name or 'the world'})", "fix the relative_to / frame / attached_to attributes")
        if "::" in name and name not in self.entries:
            head, tail = name.split("::", 1)
            inner = self.models.get(head)
            if inner is None:
                raise self._unknown(name)
            pose = self.resolve(head, stack + (name,)) * inner.resolve(tail)
        else:
            e = self.entries.get(name)
            if e is None:
                raise self._unknown(name)
            pose = self.resolve(e.rel, stack + (name,)) * e.pose
            if e.model is not None and e.model.placement:
                pose = pose * e.model.resolve(e.model.placement).inverse()
        self._done[name] = pose
        return pose

    def _unknown(self, name: str) -> _Bad:
        known = sorted(self.entries)
        return _Bad(self.file, f"a frame named {name!r} in {('model ' + repr(self.name)) if self.name else 'the world'} "
                    f"(its frames: {', '.join([self.root] + known[:12])}{' ...' if len(known) > 12 else ''})",
                    "fix the relative_to / frame / attached_to / placement_frame name")


@dataclass
class _Reader:
    """Reads a world file and the models it includes."""

    world_file: Path
    options: SourceSpec
    notes: dict[str, list[str]]
    files: list[Path] = field(default_factory=list)  # every file read (digest)

    def add_file(self, p: Path) -> None:
        if p not in self.files:
            self.files.append(p)

    def note(self, group: str, name: str) -> None:
        self.notes.setdefault(group, []).append(name)

    # -- scope building --
    def world_scope(self, world: ET.Element, version: tuple[int, int]) -> _Scope:
        scope = _Scope(name="", root="world", file=self.world_file)
        for child in world:
            tag = child.tag
            if tag == "model":
                self._add_model(scope, child, self.world_file, version, depth=0)
            elif tag == "include":
                self._include(scope, child, self.world_file, depth=0)
            elif tag == "frame":
                self._add_frame(scope, child, self.world_file)
            elif tag in _LISTED:
                self.note(_LISTED[tag], _name_of(child, tag))
        return scope

    def _add_frame(self, scope: _Scope, el: ET.Element, file: Path) -> None:
        name = el.get("name") or ""
        pe = el.find("pose")
        rel = _rel(pe) or (el.get("attached_to") or "").strip() or scope.root
        scope.entries[name] = _Entry(_pose(pe, file), rel)

    def _add_model(self, parent: _Scope, el: ET.Element, file: Path, version: tuple[int, int], *, depth: int,
                   name: str | None = None, pose_el: ET.Element | None = None, static: bool | None = None,
                   placement: str | None = None) -> None:
        local = name or el.get("name") or ""
        pe = pose_el if pose_el is not None else el.find("pose")
        m = _Scope(name=parent.label(local), root="__model__", file=file,
                   static=(static if static is not None else _bool(el.find("static"))) or
                   (parent.root == "__model__" and parent.static),
                   placement=placement if placement is not None else (el.get("placement_frame") or "").strip())
        for child in el:
            tag = child.tag
            if tag == "link":
                self._add_link(m, child, file)
            elif tag == "frame":
                self._add_frame(m, child, file)
            elif tag == "joint":
                cpose = child.find("pose")
                child_link = _text(child.find("child"))
                m.entries[child.get("name") or ""] = _Entry(_pose(cpose, file), _rel(cpose) or child_link or m.root)
            elif tag == "model":
                self._add_model(m, child, file, version, depth=depth)
            elif tag == "include":
                self._include(m, child, file, depth=depth)
            elif tag in _LISTED:
                self.note(_LISTED[tag], f"{m.name}: {_name_of(child, tag)}")
        if not m.static:
            self.note("non-static models (their collisions imported at their pose; their dynamics are not "
                      "simulated)", m.name)
        parent.models[local] = m
        parent.entries[local] = _Entry(_pose(pe, file), _rel(pe) or parent.root, model=m)

    def _add_link(self, m: _Scope, el: ET.Element, file: Path) -> None:
        name = el.get("name") or ""
        pe = el.find("pose")
        m.entries[name] = _Entry(_pose(pe, file), _rel(pe) or m.root)
        link = _Link(name)
        for child in el:
            if child.tag == "collision":
                cp = child.find("pose")
                link.collisions.append(_Collision(child.get("name") or "", _pose(cp, file), _rel(cp) or name,
                                                  child.find("geometry"), file))
            elif child.tag == "sensor":
                self.note("sensors", f"{m.name}::{name}: {_name_of(child, 'sensor')}")
            elif child.tag in ("light", "projector", "particle_emitter"):
                self.note(_LISTED.get(child.tag, child.tag + "s"), f"{m.name}::{name}: {_name_of(child, child.tag)}")
        m.links.append(link)

    def _include(self, parent: _Scope, inc: ET.Element, file: Path, *, depth: int) -> None:
        uri = _text(inc.find("uri"))
        if depth >= MAX_INCLUDE_DEPTH:
            raise _Bad(file, f"includes nested at most {MAX_INCLUDE_DEPTH} deep (at {uri!r})", "remove the include cycle")
        model_file = self._find_model(uri, file)
        self.add_file(model_file)
        root = _xml(model_file)
        version = _version(root, model_file)
        for p in inc.findall("plugin"):
            self.note("plugins", f"{parent.label(_text(inc.find('name')) or uri)}: {_name_of(p, 'plugin')}")
        model = root.find("model")
        if model is None:
            for tag in ("actor", "light"):
                for el in root.findall(tag):
                    self.note(_LISTED[tag], f"{_name_of(el, tag)} (included from {uri})")
            if root.find("actor") is None and root.find("light") is None:
                raise _Bad(model_file, f"a model file (an <sdf> with a <model>; included as {uri!r} by {file})",
                           "include a model")
            return
        st = inc.find("static")
        pl = inc.find("placement_frame")
        self._add_model(parent, model, model_file, version, depth=depth + 1,
                        name=_text(inc.find("name")) or None,
                        pose_el=inc.find("pose"),
                        static=None if st is None else _bool(st),
                        placement=None if pl is None else _text(pl))

    def _find_model(self, uri: str, file: Path) -> Path:
        """The SDF file of the model ``uri`` (``model://NAME``, a path or ``file://``)."""
        if not uri:
            raise _Bad(file, "an <include> with a <uri>", "add <uri>model://NAME</uri>")
        searched: list[str] = []
        if uri.startswith("model://"):
            rest = uri[len("model://"):].strip("/")
            dirs = _model_dirs(self.world_file)
            for d in dirs:
                cand = d / rest
                if cand.is_dir() or cand.is_file():
                    return _model_sdf(cand, uri, file)
            searched = [str(d) for d in dirs]
        elif "://" not in uri or uri.startswith("file://"):
            p = Path(unquote(urlparse(uri).path) if uri.startswith("file://") else uri)
            cand = p if p.is_absolute() else file.parent / p
            if cand.exists():
                return _model_sdf(cand, uri, file)
            searched = [str(cand)]
        else:
            raise _Bad(file, f"an <include> navstress can read ({uri!r} is on the network)",
                       "download the model and include it as model://NAME with GAZEBO_MODEL_PATH set to its folder")
        raise _Bad(file, f"an included model that is found ({uri!r}: not in {', '.join(searched) or 'any folder'})",
                   f"set GAZEBO_MODEL_PATH (or SDF_PATH) to the folder that holds {uri.split('://')[-1].split('/')[0]}/, "
                   "or put it in a models/ folder beside the world")


def _model_dirs(world_file: Path) -> list[Path]:
    dirs: list[Path] = []
    for var in MODEL_PATH_VARS:
        for part in os.environ.get(var, "").split(os.pathsep):
            if part.strip():
                dirs.append(Path(part.strip()))
    dirs += [world_file.parent, world_file.parent / "models"]
    out: list[Path] = []
    for d in dirs:
        if d not in out:
            out.append(d)
    return out


def _model_sdf(cand: Path, uri: str, file: Path) -> Path:
    """A model folder's SDF (model.config's newest <sdf> navstress reads, else model.sdf), or the file itself."""
    if cand.is_file():
        return cand
    config = cand / "model.config"
    if config.is_file():
        try:
            root = ET.fromstring(config.read_bytes())
        except (ET.ParseError, OSError) as err:
            raise _Bad(config, f"a readable model.config ({err})", "fix the model's model.config") from None
        best: tuple[tuple[int, int], str] | None = None
        for s in root.findall("sdf"):
            v = (s.get("version") or "0.0").strip()
            try:
                key = (int(v.split(".")[0]), int(v.split(".")[1]))
            except (ValueError, IndexError):
                key = (0, 0)
            if key <= (1, 9) and (best is None or key > best[0]):
                best = (key, _text(s))
        if best is not None and (cand / best[1]).is_file():
            return cand / best[1]
    if (cand / "model.sdf").is_file():
        return cand / "model.sdf"
    raise _Bad(file, f"an included model with an SDF file ({uri!r}: {cand} has no model.config naming one, "
               "nor model.sdf)", "fix the model folder")


_LISTED = {"light": "lights", "actor": "actors", "plugin": "plugins", "population": "populations",
           "road": "roads", "projector": "projectors", "particle_emitter": "particle emitters",
           "gripper": "grippers"}


def _name_of(el: ET.Element, tag: str) -> str:
    name = el.get("name") or "(unnamed)"
    if tag == "plugin" and el.get("filename"):
        return f"{name} ({el.get('filename')})"
    return name


# ---- geometry -> obstacles ---------------------------------------------------------------------------

@dataclass
class _Out:
    obstacles: list[Obstacle] = field(default_factory=list)
    heightmaps: list[tuple[Pose, ET.Element, Path, str]] = field(default_factory=list)
    ground: list[float] = field(default_factory=list)  # z of each horizontal plane
    tilted: list[str] = field(default_factory=list)


def _vertical_axis(rows: tuple[tuple[float, float, float], ...]) -> int | None:
    """The body axis (0, 1, 2) that is vertical within the tolerance, if one is."""
    c = math.cos(UPRIGHT_TOL_RAD)
    for k in (2, 0, 1):
        if abs(rows[2][k]) >= c:
            return k
    return None


def _box(kind: str, pose: Pose, half: tuple[float, float, float]) -> tuple[Obstacle, bool]:
    """The upright box of a box of half sizes ``half`` at ``pose``: exact (True) when one of its
    axes is vertical, else its upright bounding box (False)."""
    rows = pose.matrix()
    cx, cy, cz = pose.p
    k = _vertical_axis(rows)
    if k is not None:
        i, j = [a for a in (0, 1, 2) if a != k]
        yaw = math.atan2(rows[1][i], rows[0][i])
        return Obstacle(kind=kind, x=cx, y=cy, yaw=yaw, size=(2 * half[i], 2 * half[j], 2 * half[k]),
                        z=cz - half[k]), True
    # the axis with the longest horizontal projection gives the yaw
    a = max((0, 1, 2), key=lambda n: rows[0][n] ** 2 + rows[1][n] ** 2)
    yaw = math.atan2(rows[1][a], rows[0][a])
    c, s = math.cos(yaw), math.sin(yaw)
    ex = sum(half[n] * abs(c * rows[0][n] + s * rows[1][n]) for n in range(3))
    ey = sum(half[n] * abs(-s * rows[0][n] + c * rows[1][n]) for n in range(3))
    ez = sum(half[n] * abs(rows[2][n]) for n in range(3))
    return Obstacle(kind=kind, x=cx, y=cy, yaw=yaw, size=(2 * ex, 2 * ey, 2 * ez), z=cz - ez), False


def _round(kind: str, pose: Pose, radius: float, half_len: float, cap: float) -> tuple[Obstacle, bool]:
    """An upright cylinder (exact when the axis is vertical) or the upright bounding box of a
    cylinder (``cap`` 0) or capsule (``cap`` = radius) with a tilted axis."""
    rows = pose.matrix()
    ax, ay, az = rows[0][2], rows[1][2], rows[2][2]
    cx, cy, cz = pose.p
    if abs(az) >= math.cos(UPRIGHT_TOL_RAD):
        h = half_len + cap
        return Obstacle(kind=kind, x=cx, y=cy, yaw=math.atan2(rows[1][0], rows[0][0]),
                        size=(2 * radius, 2 * radius, 2 * h), z=cz - h, shape="cylinder"), True
    yaw = math.atan2(ay, ax)
    along = math.hypot(ax, ay)

    def ext(d: float) -> float:
        return half_len * abs(d) + (cap if cap else radius * math.sqrt(max(0.0, 1 - d * d)))
    ex, ey, ez = ext(along), (cap if cap else radius), ext(az)
    return Obstacle(kind=kind, x=cx, y=cy, yaw=yaw, size=(2 * ex, 2 * ey, 2 * ez), z=cz - ez), False


class _Geometry:
    def __init__(self, reader: _Reader, out: _Out) -> None:
        self.reader, self.out = reader, out
        self._mesh_bounds: dict[Path, tuple[np.ndarray, np.ndarray] | str] = {}

    def add(self, label: str, model: str, col: _Collision, pose: Pose) -> None:
        g = col.geometry
        shape = None
        if g is not None:
            shape = next((c for c in g if c.tag in _SHAPES), None)
        if shape is None:
            if g is not None and next(iter(g), None) is not None and g[0].tag != "empty":
                self.reader.note("other geometry", f"{label} ({g[0].tag})")
            return
        tag, f = shape.tag, col.file
        if tag == "box":
            sx, sy, sz = _numbers(shape.find("size"), 3, (1.0, 1.0, 1.0), f, "box><size")
            self._put(model, *_box("box", pose, (sx / 2, sy / 2, sz / 2)))
        elif tag == "cylinder":
            (r,) = _numbers(shape.find("radius"), 1, (1.0,), f, "cylinder><radius")
            (ln,) = _numbers(shape.find("length"), 1, (1.0,), f, "cylinder><length")
            self._put(model, *_round("cylinder", pose, r, ln / 2, 0.0))
        elif tag == "sphere":
            (r,) = _numbers(shape.find("radius"), 1, (1.0,), f, "sphere><radius")
            cx, cy, cz = pose.p
            self.out.obstacles.append(Obstacle(kind="sphere", x=cx, y=cy, yaw=0.0, size=(2 * r, 2 * r, 2 * r),
                                               z=cz - r, shape="cylinder"))
        elif tag == "capsule":
            (r,) = _numbers(shape.find("radius"), 1, (0.5,), f, "capsule><radius")
            (ln,) = _numbers(shape.find("length"), 1, (1.0,), f, "capsule><length")
            self._put(model, *_round("capsule", pose, r, ln / 2, r))
        elif tag == "ellipsoid":
            rx, ry, rz = _numbers(shape.find("radii"), 3, (1.0, 1.0, 1.0), f, "ellipsoid><radii")
            self._put(model, *_box("ellipsoid", pose, (rx, ry, rz)))
            self.reader.note("ellipsoids (imported as their bounding boxes)", label)
        elif tag == "plane":
            nx, ny, nz = _numbers(shape.find("normal"), 3, (0.0, 0.0, 1.0), f, "plane><normal")
            n = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
            wx, wy, wz = _rotate(pose.q, (nx / n, ny / n, nz / n))
            if wz >= math.cos(UPRIGHT_TOL_RAD):
                self.out.ground.append(pose.p[2])
            else:
                self.reader.note("planes that are not horizontal ground", label)
        elif tag == "mesh":
            self._mesh(label, model, shape, col, pose)
        elif tag == "heightmap":
            self.out.heightmaps.append((pose, shape, f, label))
        else:  # polyline, image
            self.reader.note(f"{tag} geometry", label)

    def _put(self, model: str, o: Obstacle, exact: bool) -> None:
        self.out.obstacles.append(o)
        if not exact and model not in self.out.tilted:
            self.out.tilted.append(model)

    def _mesh(self, label: str, model: str, shape: ET.Element, col: _Collision, pose: Pose) -> None:
        uri = _text(shape.find("uri"))
        if self.reader.options.meshes != "bbox":
            self.reader.note("mesh collisions (`meshes: bbox` / --meshes bbox imports their bounding boxes)",
                             f"{label} ({uri})")
            return
        bounds = self._bounds(uri, col.file)
        if isinstance(bounds, str):
            self.reader.note("meshes whose bounding box could not be read", f"{label} ({uri}: {bounds})")
            return
        scale = _numbers(shape.find("scale"), 3, (1.0, 1.0, 1.0), col.file, "mesh><scale")
        lo, hi = bounds[0] * np.asarray(scale), bounds[1] * np.asarray(scale)
        lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
        centre = (lo + hi) / 2
        half = (hi - lo) / 2
        at = pose * Pose((float(centre[0]), float(centre[1]), float(centre[2])))
        self._put(model, *_box("mesh", at, (float(half[0]), float(half[1]), float(half[2]))))

    def _bounds(self, uri: str, file: Path) -> tuple[np.ndarray, np.ndarray] | str:
        path = _resource(uri, file, self.reader.world_file)
        if path is None:
            return "not found"
        if path in self._mesh_bounds:
            return self._mesh_bounds[path]
        result: tuple[np.ndarray, np.ndarray] | str
        if path.suffix.lower() not in MESH_SUFFIXES:
            result = f"navstress reads {', '.join(MESH_SUFFIXES)} meshes"
        else:
            import trimesh  # a mesh file's reader, loaded only when a world has meshes to read

            try:
                mesh = trimesh.load(str(path), force="mesh")
                b = np.asarray(mesh.bounds, np.float64)
                if b.shape != (2, 3) or not np.all(np.isfinite(b)):
                    raise ValueError("no vertices")
                result = (b[0], b[1])
                self.reader.add_file(path)
            except Exception as err:  # noqa: BLE001 - any unreadable mesh is listed, never fatal
                result = f"unreadable: {type(err).__name__}"
        self._mesh_bounds[path] = result
        return result


_SHAPES = ("box", "cylinder", "sphere", "capsule", "ellipsoid", "plane", "mesh", "heightmap", "polyline", "image")


def _resource(uri: str, file: Path, world_file: Path) -> Path | None:
    """The file a mesh or heightmap ``uri`` names (``model://``, ``file://``, or a path relative to the SDF file)."""
    if uri.startswith("model://"):
        rest = uri[len("model://"):].strip("/")
        for d in _model_dirs(world_file):
            if (d / rest).is_file():
                return d / rest
        return None
    if uri.startswith("file://"):
        p = Path(unquote(urlparse(uri).path))
    elif "://" in uri or not uri:
        return None
    else:
        p = Path(uri)
    cand = p if p.is_absolute() else file.parent / p
    return cand if cand.is_file() else None


# ---- the world's <state> ---------------------------------------------------------------------------

@dataclass
class _State:
    pose: Pose | None = None
    links: dict[str, Pose] = field(default_factory=dict)
    models: dict[str, "_State"] = field(default_factory=dict)


def _read_state(el: ET.Element, file: Path, reader: _Reader, prefix: str = "") -> dict[str, _State]:
    out: dict[str, _State] = {}
    for m in el.findall("model"):
        name = m.get("name") or ""
        st = _State()
        pe = m.find("pose")
        if pe is not None and (pe.text or "").strip():
            st.pose = _pose(pe, file)
        sc = m.find("scale")
        if sc is not None and _numbers(sc, 3, (1.0, 1.0, 1.0), file, "state><model><scale") != (1.0, 1.0, 1.0):
            reader.note("state scales (models kept at their own size)", prefix + name)
        for ln in m.findall("link"):
            lp = ln.find("pose")
            if lp is not None and (lp.text or "").strip():
                st.links[ln.get("name") or ""] = _pose(lp, file)
        st.models = _read_state(m, file, reader, prefix + name + "::")
        out[name] = st
    return out


# ---- the whole import --------------------------------------------------------------------------------

def _emit(scope: _Scope, X_WM: Pose, state: _State | None, geo: _Geometry) -> None:
    """The collisions of model ``scope`` (its frame at ``X_WM``) and of its nested models."""
    if state is not None and state.pose is not None:
        X_WM = state.pose
    for link in scope.links:
        X_ML = scope.resolve(link.name)
        X_WL = state.links.get(link.name) if state is not None else None
        for col in link.collisions:
            X_MC = scope.resolve(col.rel) * col.pose
            if X_WL is None:
                X_WC = X_WM * X_MC
            else:
                X_WC = X_WL * (X_ML.inverse() * X_MC)
            geo.add(f"{scope.name}::{link.name}::{col.name}", scope.name, col, X_WC)
    for local, inner in scope.models.items():
        _emit(inner, X_WM * scope.resolve(local), state.models.get(local) if state is not None else None, geo)


def read_sdf(path: Path, options: SourceSpec) -> tuple[_Out, _Reader]:
    """The obstacles of the world file ``path`` in its own frame and what else it holds; the
    reader's notes (groups of names for the warning) and the files it read."""
    notes: dict[str, list[str]] = {}
    reader = _Reader(path, options, notes, [path])
    root = _xml(path)
    version = _version(root, path)
    worlds = root.findall("world")
    if not worlds:
        held = ", ".join(sorted({c.tag for c in root})) or "nothing"
        raise _Bad(path, f"a world file (an <sdf> with a <world>; this one holds {held})",
                   "import a world; a model file is included in a world with <include>")
    world = worlds[0]
    for other in worlds[1:]:
        reader.note("other worlds of the file (the first is imported)", other.get("name") or "(unnamed)")
    scope = reader.world_scope(world, version)
    states: dict[str, _State] = {}
    st_el = world.find("state")
    if st_el is not None:
        ins = st_el.find("insertions")
        if ins is not None:
            for m in ins.findall("model"):
                reader._add_model(scope, m, path, version, depth=0)
        dels = st_el.find("deletions")
        if dels is not None:
            for n in dels.findall("name"):
                gone = _text(n)
                scope.models.pop(gone, None)
                scope.entries.pop(gone, None)
        states = _read_state(st_el, path, reader)
        for name in states:
            if name not in scope.models:
                reader.note("state entries of models the world does not have", name)
    out = _Out()
    geo = _Geometry(reader, out)
    for local, model in scope.models.items():
        _emit(model, scope.resolve(local), states.get(local), geo)
    if out.tilted:
        notes["tilted models (imported as upright bounding boxes)"] = out.tilted
    return out, reader


def _extent(obstacles: list[Obstacle]) -> tuple[float, float, float, float] | None:
    if not obstacles:
        return None
    xs, ys = [], []
    for o in obstacles:
        if o.is_cylinder:
            r = o.size[0] / 2
            xs += [o.x - r, o.x + r]
            ys += [o.y - r, o.y + r]
        else:
            c = o.corners()
            xs += [float(c[:, 0].min()), float(c[:, 0].max())]
            ys += [float(c[:, 1].min()), float(c[:, 1].max())]
    return min(xs), min(ys), max(xs), max(ys)


def _heightmap(out: _Out, reader: _Reader) -> tuple[np.ndarray, tuple[float, float, float, float], float] | None:
    """The first usable heightmap: its heights (rows along +y, from its south edge), its extent
    (x0, y0, x1, y1) in the source frame, and its base height; the others are listed."""
    got = None
    for pose, el, file, label in out.heightmaps:
        uri = _text(el.find("uri"))
        if got is not None:
            reader.note("heightmaps after the first (one terrain per world)", f"{label} ({uri})")
            continue
        rows = pose.matrix()
        if abs(rows[2][2]) < math.cos(UPRIGHT_TOL_RAD) or abs(math.atan2(rows[1][0], rows[0][0])) > UPRIGHT_TOL_RAD:
            reader.note("turned heightmaps", f"{label} ({uri})")
            continue
        src = _resource(uri, file, reader.world_file)
        if src is None:
            reader.note("heightmaps whose image was not found", f"{label} ({uri})")
            continue
        try:
            from PIL import Image  # the heightmap's image, read only for a world that has one

            with Image.open(src) as im:
                if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                    arr = np.asarray(im, np.float64)
                    top = 65535.0
                else:
                    arr = np.asarray(im.convert("RGB"), np.float64)[:, :, 0]
                    top = 255.0
        except Exception as err:  # noqa: BLE001 - an unreadable heightmap is listed, never fatal
            reader.note("heightmaps whose image could not be read", f"{label} ({uri}: {type(err).__name__})")
            continue
        reader.add_file(src)
        sx, sy, sz = _numbers(el.find("size"), 3, (1.0, 1.0, 1.0), file, "heightmap><size")
        px, py, pz = _numbers(el.find("pos"), 3, (0.0, 0.0, 0.0), file, "heightmap><pos")
        v = arr / top
        mx = float(v.max())
        heights = np.flipud(v) * (abs(sz) / mx if mx > 0 else abs(sz))
        cx, cy, cz = (pose * Pose((px, py, pz))).p
        got = (heights, (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2), cz)
    return got


def _sample(heights: np.ndarray, extent: tuple[float, float, float, float], base: float, xs: np.ndarray,
            ys: np.ndarray) -> np.ndarray:
    """Bilinear heights at the points (xs x ys grid) of the source frame, clamped to the edges."""
    n_r, n_c = heights.shape
    x0, y0, x1, y1 = extent
    u = np.clip((xs - x0) / max(x1 - x0, 1e-12) * (n_c - 1), 0, n_c - 1)
    v = np.clip((ys - y0) / max(y1 - y0, 1e-12) * (n_r - 1), 0, n_r - 1)
    j0 = np.minimum(np.floor(u).astype(int), max(n_c - 2, 0))
    i0 = np.minimum(np.floor(v).astype(int), max(n_r - 2, 0))
    fu, fv = u - j0, v - i0
    j1, i1 = np.minimum(j0 + 1, n_c - 1), np.minimum(i0 + 1, n_r - 1)
    h = heights
    top = h[i0[:, None], j0[None, :]] * (1 - fu[None, :]) + h[i0[:, None], j1[None, :]] * fu[None, :]
    bot = h[i1[:, None], j0[None, :]] * (1 - fu[None, :]) + h[i1[:, None], j1[None, :]] * fu[None, :]
    out: np.ndarray = base + top * (1 - fv[:, None]) + bot * fv[:, None]
    return out


def load(path: Path, options: SourceSpec) -> World:
    """The Gazebo world ``path`` as a navstress world (module docstring)."""
    path = Path(path)
    try:
        return _load(path, options)
    except _Bad as bad:
        where = "" if bad.path == path else f" (in {bad.path})"
        raise SpecError("source.path", str(path), bad.expected + where, bad.fix) from None


def _load(path: Path, options: SourceSpec) -> World:
    out, reader = read_sdf(path, options)
    obstacles, reader_notes = out.obstacles, reader.notes
    hm = _heightmap(out, reader)
    if not out.ground and hm is None:
        reader_notes.setdefault("notes", []).append("no ground plane: navstress puts the world on flat ground at z = 0")
    box = _extent(obstacles)
    if hm is not None:
        e = hm[1]
        box = e if box is None else (min(box[0], e[0]), min(box[1], e[1]), max(box[2], e[2]), max(box[3], e[3]))
    if box is None:
        box = (0.0, 0.0, 0.0, 0.0)
    margin = options.margin_m
    cell = WorldSpec.model_fields["cell_m"].default
    if hm is not None:
        heights = hm[0]
        spacing = (hm[1][2] - hm[1][0]) / max(heights.shape[1] - 1, 1)
        cell = float(min(2.0, max(0.05, round(spacing, 3))))
    sizes = []
    for lo, hi in ((box[0], box[2]), (box[1], box[3])):
        span = hi - lo + 2 * margin
        if span > MAX_SIDE_M:
            raise SpecError("source.path", str(path), f"a Gazebo world whose content fits a {MAX_SIDE_M:g} m square "
                            f"(this one spans {box[2] - box[0]:.0f} x {box[3] - box[1]:.0f} m with the margin)",
                            "remove far-away models, or lower margin_m")
        n = max(math.ceil(MIN_SIDE_M / cell - 1e-9), math.ceil(span / cell - 1e-9))
        sizes.append(round(n * cell, 9))
    origin = (box[0] - margin, box[1] - margin)
    spec = check_memory(WorldSpec(size_m=(sizes[0], sizes[1]), cell_m=cell, source=options))
    rows, cols = spec.grid_shape
    if hm is None:
        grid = np.zeros((rows, cols), np.float32)
    else:
        xs = origin[0] + np.arange(cols) * cell
        ys = origin[1] + np.arange(rows) * cell
        grid = _sample(hm[0], hm[1], hm[2], xs, ys).astype(np.float32)
    shifted = tuple(Obstacle(kind=o.kind, x=o.x - origin[0], y=o.y - origin[1], yaw=o.yaw, size=o.size, z=o.z,
                             shape=o.shape) for o in obstacles)
    mission = placeholder_mission(spec.size_m, shifted)
    source = WorldSource(kind=KIND, path=str(path.resolve()), sha256=file_sha256(*reader.files), origin=origin)
    world = World(spec=spec, seed=0, terrain=Terrain(grid, cell), obstacles=shifted, mission=mission,
                  source=source)
    warn(path, reader_notes)
    return world
