"""World: the phenotype. A value object that round-trips exactly through a directory.

A world directory holds ``world.json`` (spec, seed, descriptors, obstacles, mission, and its
movers when it has any: a world without movers has no ``movers`` key, as before movers existed; an
imported world's ``source``, see :class:`WorldSource`) and
``terrain.npz`` (``heights``: 2-D float32 meters, rows along +y, columns along +x, vertex
(i, j) at (x, y) = (j*cell_m, i*cell_m); plus ``cell_m``).

    >>> import numpy as np, tempfile
    >>> w = World.flat(WorldSpec(size_m=(20.0, 20.0)), seed=1)
    >>> d = tempfile.mkdtemp() + "/w"
    >>> w.save(d)
    >>> World.load(d) == w
    True
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from navstress import _files
from navstress.errors import WorldFileError
from navstress.world.spec import BEHAVIOURS as MOVER_BEHAVIOURS
from navstress.world.spec import WorldSpec

MOVER_SHAPES = ("disc", "box")

FORMAT_VERSION = 1
WORLD_JSON = "world.json"
TERRAIN_NPZ = "terrain.npz"


#: The obstacle shapes (docs/worlds.md, "Obstacle shapes"): ``box`` (an upright box turned by
#: its yaw; a wall is a long thin box of kind ``wall``) and ``cylinder`` (an upright cylinder).
OBSTACLE_SHAPES = ("box", "cylinder")


@dataclass(frozen=True, repr=False)
class Obstacle:
    """A static obstacle standing on the ground. (x, y) is the footprint centre, ``z`` the height
    of its base (the ground under it is levelled to ``z``). ``shape="box"`` (the default):
    ``size`` = (sx, sy, sz) with sx along the box's own x axis rotated by ``yaw`` (radians,
    counter-clockwise). ``shape="cylinder"``: an upright cylinder, ``size`` = (diameter,
    diameter, height), ``yaw`` kept as given and without effect on its geometry.

    A box's text (``repr``, which :meth:`World.digest` hashes, and :meth:`to_json`) is what it was
    before shapes existed: no ``shape``."""

    kind: str
    x: float
    y: float
    yaw: float
    size: tuple[float, float, float]
    z: float = 0.0
    shape: str = "box"

    def __post_init__(self) -> None:
        if self.shape not in OBSTACLE_SHAPES:
            raise ValueError(f"obstacle shape {self.shape!r} is unknown (one of {list(OBSTACLE_SHAPES)})")

    def __repr__(self) -> str:
        tail = "" if self.shape == "box" else f", shape={self.shape!r}"
        return (f"Obstacle(kind={self.kind!r}, x={self.x!r}, y={self.y!r}, yaw={self.yaw!r}, "
                f"size={self.size!r}, z={self.z!r}{tail})")

    @property
    def is_cylinder(self) -> bool:
        return self.shape == "cylinder"

    @property
    def radius_xy(self) -> float:
        """The radius of the footprint's circumscribed circle (centre (x, y))."""
        if self.shape == "cylinder":
            return self.size[0] / 2
        return math.hypot(self.size[0], self.size[1]) / 2

    def corners(self) -> np.ndarray:
        """The 4 footprint corners, shape (4, 2), counter-clockwise (a cylinder: those of its
        footprint's bounding square, turned by its yaw)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        hx, hy = self.size[0] / 2, self.size[1] / 2
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        rot = np.array([[c, -s], [s, c]])
        out: np.ndarray = local @ rot.T + np.array([self.x, self.y])
        return out

    def outline(self, segments: int = 24) -> np.ndarray:
        """The footprint as a counter-clockwise polygon, shape (n, 2): a box's 4 corners, a
        cylinder's circle as a regular ``segments``-gon inscribed in it."""
        if self.shape == "box":
            return self.corners()
        a = np.arange(segments) * (2 * math.pi / segments)
        r = self.size[0] / 2
        out: np.ndarray = np.stack([self.x + r * np.cos(a), self.y + r * np.sin(a)], axis=1)
        return out

    @property
    def area(self) -> float:
        if self.shape == "cylinder":
            return math.pi * (self.size[0] / 2) ** 2
        return self.size[0] * self.size[1]

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "x": self.x, "y": self.y, "yaw": self.yaw,
                               "size": list(self.size), "z": self.z}
        if self.shape != "box":
            out["shape"] = self.shape
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "Obstacle":
        return cls(kind=str(d["kind"]), x=float(d["x"]), y=float(d["y"]), yaw=float(d["yaw"]),
                   size=(float(d["size"][0]), float(d["size"][1]), float(d["size"][2])),
                   z=float(d.get("z", 0.0)), shape=str(d.get("shape", "box")))


@dataclass(frozen=True)
class WorldSource:
    """Where an imported world came from (:mod:`navstress.world.sources`): the source's ``kind``
    (``map``, ``sdf``, ``dir``), its ``path`` (absolute) and ``sha256`` (of the file, or for a map
    of the YAML and its image together), and ``origin``: the point of the source's own frame at
    navstress's (0, 0). A world's frame starts at its lower-left corner; an imported one is
    shifted there, and a point p of the world is p + origin in the source's frame."""

    kind: str
    path: str
    sha256: str
    origin: tuple[float, float] = (0.0, 0.0)

    def to_source(self, x: float, y: float) -> tuple[float, float]:
        return (x + self.origin[0], y + self.origin[1])

    def from_source(self, x: float, y: float) -> tuple[float, float]:
        return (x - self.origin[0], y - self.origin[1])

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "path": self.path, "sha256": self.sha256, "origin": list(self.origin)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "WorldSource":
        o = d.get("origin", [0.0, 0.0])
        return cls(kind=str(d["kind"]), path=str(d["path"]), sha256=str(d["sha256"]),
                   origin=(float(o[0]), float(o[1])))


@dataclass(frozen=True)
class Mission:
    """Start pose (x, y, yaw) and goal (x, y), with the obstacle-free radius around each."""

    start: tuple[float, float, float]
    goal: tuple[float, float]
    free_radius_m: float

    @property
    def straight_distance_m(self) -> float:
        return math.hypot(self.goal[0] - self.start[0], self.goal[1] - self.start[1])

    def to_json(self) -> dict[str, Any]:
        return {"start": list(self.start), "goal": list(self.goal), "free_radius_m": self.free_radius_m}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "Mission":
        s, g = d["start"], d["goal"]
        return cls(start=(float(s[0]), float(s[1]), float(s[2])), goal=(float(g[0]), float(g[1])),
                   free_radius_m=float(d["free_radius_m"]))


@dataclass(frozen=True)
class Mover:
    """An obstacle that moves during a run (its plan, drawn from the map seed; the controller,
    :mod:`navstress.sim.movers`, moves it).

    ``id``: its index in ``World.movers``; ``kind``: its mover type; ``shape``: ``"disc"`` (an
    upright cylinder of diameter ``size[0]``) or ``"box"``; ``size`` = (length along its heading,
    width, height); ``start`` = (x, y, yaw) of its centre at time 0; ``speed_m_s`` its cruise
    speed, ``speed_max_m_s`` and ``accel_m_s2`` its limits (for ``intercept`` and
    ``still-then-move``, the behaviour's own when it sets them); ``behaviour`` its behaviour's
    kind and ``params`` that behaviour's parameters (name, value) in name order; ``waypoints`` the
    points of its path (``crossing``, ``patrol``, ``intercept`` while it wanders: each segment
    from the start through the waypoints, and for a patrol back to the start, is free of static
    obstacles by ``radius_m`` plus a margin); ``radius_m`` the radius of its footprint's
    circumscribed circle (what the controller keeps clear of obstacles and other movers)."""

    id: int
    kind: str
    shape: str
    size: tuple[float, float, float]
    start: tuple[float, float, float]
    speed_m_s: float
    speed_max_m_s: float
    accel_m_s2: float
    behaviour: str
    params: tuple[tuple[str, float | str], ...] = ()
    waypoints: tuple[tuple[float, float], ...] = ()

    @property
    def radius_m(self) -> float:
        if self.shape == "disc":
            return self.size[0] / 2
        return math.hypot(self.size[0], self.size[1]) / 2

    def param(self, name: str) -> float | str:
        """The value of behaviour parameter ``name`` (KeyError when the behaviour has none)."""
        for k, v in self.params:
            if k == name:
                return v
        raise KeyError(name)

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "shape": self.shape, "size": list(self.size),
                "start": list(self.start), "speed_m_s": self.speed_m_s, "speed_max_m_s": self.speed_max_m_s,
                "accel_m_s2": self.accel_m_s2, "behaviour": self.behaviour, "params": dict(self.params),
                "waypoints": [list(w) for w in self.waypoints]}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "Mover":
        sz, st = d["size"], d["start"]
        params = d.get("params", {})
        if not isinstance(params, dict):
            raise TypeError("mover params must be a mapping")
        if d["shape"] not in MOVER_SHAPES or d["behaviour"] not in MOVER_BEHAVIOURS:
            raise ValueError(f"mover shape {d['shape']!r} or behaviour {d['behaviour']!r} is unknown")
        return cls(id=int(d["id"]), kind=str(d["kind"]), shape=str(d["shape"]),
                   size=(float(sz[0]), float(sz[1]), float(sz[2])), start=(float(st[0]), float(st[1]), float(st[2])),
                   speed_m_s=float(d["speed_m_s"]), speed_max_m_s=float(d["speed_max_m_s"]),
                   accel_m_s2=float(d["accel_m_s2"]), behaviour=str(d["behaviour"]),
                   params=tuple(sorted((str(k), v if isinstance(v, str) else float(v)) for k, v in params.items())),
                   waypoints=tuple((float(w[0]), float(w[1])) for w in d.get("waypoints", [])))


@dataclass(frozen=True, eq=False)
class Terrain:
    """Height grid in meters. ``heights[i, j]`` is the ground at (x, y) = (j*cell_m, i*cell_m)."""

    heights: np.ndarray
    cell_m: float

    def __post_init__(self) -> None:
        h = np.ascontiguousarray(self.heights, dtype=np.float32)
        h.setflags(write=False)
        object.__setattr__(self, "heights", h)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Terrain) and self.cell_m == other.cell_m
                and self.heights.shape == other.heights.shape
                and bool(np.array_equal(self.heights, other.heights)))

    __hash__ = None  # type: ignore[assignment]

    @property
    def size_m(self) -> tuple[float, float]:
        rows, cols = self.heights.shape
        return ((cols - 1) * self.cell_m, (rows - 1) * self.cell_m)

    def height_at(self, x: float, y: float) -> float:
        """Ground height at (x, y) on the triangulated surface (clamped to the map).

        Each cell is split into two triangles by the diagonal from vertex (i, j) to
        (i+1, j+1), the triangulation the simulator uses (see ``navstress.sim``).
        """
        rows, cols = self.heights.shape
        fx = float(min(max(x / self.cell_m, 0.0), cols - 1.000001))
        fy = float(min(max(y / self.cell_m, 0.0), rows - 1.000001))
        j, i = int(fx), int(fy)
        u, v = fx - j, fy - i
        h = self.heights
        h00, h10, h01, h11 = float(h[i, j]), float(h[i, j + 1]), float(h[i + 1, j]), float(h[i + 1, j + 1])
        if u >= v:  # lower-right triangle (i,j) (i,j+1) (i+1,j+1)
            return h00 + u * (h10 - h00) + v * (h11 - h10)
        return h00 + v * (h01 - h00) + u * (h11 - h01)  # upper-left (i,j) (i+1,j) (i+1,j+1)


def terrain_faces(rows: int, cols: int) -> np.ndarray:
    """Faces (2*(rows-1)*(cols-1), 3) of a height grid of ``rows`` x ``cols`` vertices, split as
    :meth:`Terrain.height_at` splits each cell; vertex index of (i, j) is i*cols + j (the meshes the
    exports write and the traces draw)."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    v00 = (i * cols + j).ravel()
    v01 = v00 + 1          # (i, j+1): +x
    v10 = v00 + cols       # (i+1, j): +y
    v11 = v10 + 1          # (i+1, j+1)
    lower = np.stack([v00, v01, v11], axis=1)  # u >= v half of the cell
    upper = np.stack([v00, v11, v10], axis=1)
    return np.concatenate([lower, upper]).astype(np.int64)


@dataclass(frozen=True, eq=False)
class World:
    """A generated world: terrain, obstacles, mission, movers (none by default), and where it came from."""

    spec: WorldSpec
    seed: int
    terrain: Terrain
    obstacles: tuple[Obstacle, ...]
    mission: Mission
    descriptors: dict[str, Any] = field(default_factory=dict)
    movers: tuple[Mover, ...] = ()
    source: WorldSource | None = None  # an imported world's source (None: generated)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, World) and self.spec == other.spec and self.seed == other.seed
                and self.terrain == other.terrain and self.obstacles == other.obstacles
                and self.mission == other.mission and self.descriptors == other.descriptors
                and self.movers == other.movers and self.source == other.source)

    __hash__ = None  # type: ignore[assignment]

    @property
    def size_m(self) -> tuple[float, float]:
        return self.spec.size_m

    def digest(self) -> str:
        """A hex digest of what was generated: the terrain grid, the obstacles, the mission and the
        movers (not the spec, seed or descriptors). Two worlds a robot cannot tell apart have the
        same digest, whatever specs made them (e.g. obstacle moves that were not applied)."""
        h = hashlib.sha256()
        h.update(repr((self.terrain.heights.shape, self.terrain.cell_m)).encode())
        h.update(self.terrain.heights.tobytes())
        h.update(repr((self.obstacles, self.mission, self.movers)).encode())
        if self.source is not None:  # (a generated world: the digest of before sources existed)
            h.update(repr(self.source.origin).encode())
        return h.hexdigest()

    @classmethod
    def flat(cls, spec: WorldSpec, seed: int = 0, obstacles: tuple[Obstacle, ...] = (),
             mission: Mission | None = None, movers: tuple[Mover, ...] = ()) -> "World":
        """A flat world with given obstacles and movers (for tests and hand-made scenes)."""
        rows, cols = spec.grid_shape
        sx, sy = spec.size_m
        m = mission or Mission(start=(5.0, 5.0, math.atan2(sy - 10, sx - 10)),
                               goal=(sx - 5.0, sy - 5.0), free_radius_m=spec.mission.free_radius_m)
        return cls(spec=spec, seed=seed, terrain=Terrain(np.zeros((rows, cols), np.float32), spec.cell_m),
                   obstacles=tuple(obstacles), mission=m, movers=tuple(movers))

    # ---- persistence -------------------------------------------------------------------
    def to_json(self) -> dict[str, Any]:
        out = {
            "format": "navstress-world", "version": FORMAT_VERSION,
            "seed": self.seed,
            "spec": self.spec.model_dump(mode="json"),
            "mission": self.mission.to_json(),
            "obstacles": [o.to_json() for o in self.obstacles],
            "descriptors": self.descriptors,
        }
        if self.movers:  # a world without movers: the text of before movers existed
            out["movers"] = [m.to_json() for m in self.movers]
        if self.source is not None:  # a generated world: the text of before sources existed
            out["source"] = self.source.to_json()
        return out

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the world directory atomically (a temp dir renamed into place).

        ``path`` must not exist, or must be an existing world directory (replaced). What is
        written or removed is ``path`` and, beside it, ``.NAME.XXXXXXXX`` (the new directory
        before its rename) and ``.NAME.old`` (the directory it replaces, then removed)."""
        dest = Path(path)
        if dest.exists() and not is_world_dir(dest):
            raise WorldFileError(f"output={str(dest)!r} exists and is not a world directory; "
                                 "choose a new path or remove it")
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = _files.temp_dir_beside(dest)  # with the umask's mode: other users may read worlds
        try:
            with open(tmp / WORLD_JSON, "w", encoding="utf-8") as f:
                json.dump(self.to_json(), f, indent=1, sort_keys=True, allow_nan=False)
                f.write("\n")
            with open(tmp / TERRAIN_NPZ, "wb") as f:
                np.savez_compressed(f, heights=self.terrain.heights, cell_m=np.float64(self.terrain.cell_m))
            _files.replace_dir(tmp, dest)  # the world it replaces via .NAME.old (a link there refused)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "World":
        d = Path(path)
        if not is_world_dir(d):
            raise WorldFileError(f"world={str(d)!r} is not a world directory "
                                 f"(expected {WORLD_JSON} and {TERRAIN_NPZ}); create one with `navstress world generate`")
        try:
            meta = json.loads((d / WORLD_JSON).read_text(encoding="utf-8"))
            with np.load(d / TERRAIN_NPZ) as z:
                heights = np.array(z["heights"], dtype=np.float32)
                cell = float(z["cell_m"])
            spec = WorldSpec.model_validate(meta["spec"])
            return cls(spec=spec, seed=int(meta["seed"]), terrain=Terrain(heights, cell),
                       obstacles=tuple(Obstacle.from_json(o) for o in meta["obstacles"]),
                       mission=Mission.from_json(meta["mission"]), descriptors=dict(meta.get("descriptors", {})),
                       movers=tuple(Mover.from_json(m) for m in meta.get("movers", [])),
                       source=WorldSource.from_json(meta["source"]) if meta.get("source") else None)
        except (KeyError, ValueError, TypeError, OSError, ValidationError, RecursionError, EOFError,
                zipfile.BadZipFile) as err:
            raise WorldFileError(f"world={str(d)!r} is corrupt: {type(err).__name__}: {err}".splitlines()[0]) from None


def is_world_dir(path: str | os.PathLike[str]) -> bool:
    p = Path(path)
    return p.is_dir() and (p / WORLD_JSON).is_file() and (p / TERRAIN_NPZ).is_file()


# ---- descriptors of a saved world (read by analyses and exports) ------------------------------

#: Bookkeeping entries of World.descriptors that say nothing about difficulty.
SKIP_PREFIXES = ("placement_", "traversability.", "obstruction_target_pct", "infeasible_reason")


def flatten(d: dict[str, Any], prefix: str = "") -> dict[str, float]:
    """Numeric leaves of a nested mapping as ``{"a.b": value}`` (bools as 0/1, others dropped)."""
    out: dict[str, float] = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, name + "."))
        elif isinstance(v, bool):
            out[name] = float(v)
        elif isinstance(v, (int, float)) and math.isfinite(float(v)):
            out[name] = float(v)
    return out


def world_descriptors(world_dir: str | Path) -> dict[str, float] | None:
    """The flattened numeric descriptors of a saved world (reads only ``world.json``), None if absent."""
    p = Path(world_dir) / "world.json"
    try:
        meta = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    flat = flatten(dict(meta.get("descriptors", {})))
    return {k: v for k, v in flat.items() if not k.startswith(SKIP_PREFIXES)}
