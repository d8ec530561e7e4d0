"""WorldSpec: the genotype of a world, validated.

A WorldSpec says *what kind* of world to make; :func:`navstress.world.generate`
turns it plus a seed into a concrete :class:`~navstress.world.world.World`.

    >>> spec = WorldSpec.model_validate({"obstacles": {"obstruction": {"tree": 6}}})
    >>> spec.size_m, spec.cell_m, spec.obstacles.targets()
    ((100.0, 100.0), 0.4, {'tree': 6.0})

Load from a file with :func:`load_spec` (YAML or JSON). Invalid input raises
:class:`~navstress.errors.SpecError` naming ``field=value``, the allowed range and a fix.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, Field, SerializerFunctionWrapHandler, Strict, model_serializer, model_validator

from navstress._models import LIST, SPEC_CONFIG, parse
from navstress.errors import MISSING, SpecError
from navstress.specfile import load_file

_STRICT = SPEC_CONFIG


class GroundSpec(BaseModel):
    """The ground surface.

    ``model="blender"`` (the paper's tool, reproduced): Blender's Subdivide operator with its
    Fractal option on a plane of side ``plane_m`` (Blender's default plane: 2 m) cut
    ``subdivisions`` times per edge (``s + 1`` flat-faced segments per side), each vertex moved
    along z by Blender's fractal rule scaled by ``deformation`` (the operator's Fractal value),
    then scaled to the map in x and y only (see ``navstress.world.blender``).

    ``model="subdivide"``: a plane subdivided ``subdivisions`` times (``2**s + 1`` control
    vertices per side), each control vertex displaced along z by ``deformation * U(-1/2, 1/2)``
    meters, the surface between them a smooth interpolation (``navstress.world.terrain``). The
    default, so that every spec written before the ``blender`` model keeps its worlds.

    ``model="fractal"``: multi-octave fractal noise (``octaves``, ``persistence``,
    ``wavelength_m`` of the first octave, ``amplitude_m`` of the first octave).
    """

    model_config = _STRICT
    model: Literal["subdivide", "blender", "fractal"] = "subdivide"
    subdivisions: int = Field(0, ge=0, le=100, description=(
        "s: subdivisions (subdivide: 0..10, 2**s segments per side; blender: cuts per edge, "
        "s + 1 segments per side)"))
    deformation: float = Field(0.0, ge=0.0, le=50.0, description=(
        "d: displacement scale (subdivide: meters, peak to peak; blender: the Fractal value)"))
    plane_m: float = Field(2.0, gt=0.0, le=1000.0, description=(
        "blender: the plane's side in meters when it is subdivided (Blender's default plane: 2 m)"))
    octaves: int = Field(5, ge=1, le=12)
    persistence: float = Field(0.5, gt=0.0, le=1.0)
    wavelength_m: float = Field(40.0, gt=0.0)
    amplitude_m: float = Field(1.0, ge=0.0, le=50.0)

    @model_validator(mode="after")
    def _check_model(self) -> "GroundSpec":
        if self.model == "subdivide" and self.subdivisions > 10:
            raise SpecError("ground.subdivisions", self.subdivisions,
                            "an integer in [0, 10] for model subdivide (2**s segments per side)",
                            "model blender takes up to 100 cuts")
        if self.model == "blender" and self.subdivisions == 0 and self.deformation > 0:
            raise SpecError("ground.subdivisions", self.subdivisions,
                            "at least 1 cut for model blender with deformation > 0 (Blender's Subdivide "
                            "makes 1 to 100 cuts)", "set subdivisions >= 1, or deformation 0 for flat ground")
        return self

    def label(self) -> str:
        """One line naming the model and its parameters."""
        if self.model == "fractal":
            return (f"fractal amp={self.amplitude_m:g} m wavelength={self.wavelength_m:g} m "
                    f"octaves={self.octaves}")
        if self.model == "blender":
            return f"blender s={self.subdivisions} d={self.deformation:g} plane={self.plane_m:g} m"
        return f"subdivide s={self.subdivisions} d={self.deformation:g} m"

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        """``plane_m`` only for the blender model: the files of every other world keep their bytes."""
        data = handler(self)
        if isinstance(data, dict) and self.model != "blender":
            data.pop("plane_m", None)
        return data


class ObstacleType(BaseModel):
    """A kind of obstacle: a box with a base (sx, sy), a height, and a size-variability envelope.

    ``variability`` v draws each footprint side uniformly in ``[base*(1-v), base*(1+v)]``
    and the height in ``[height*(1-v), height*(1+v)]``.
    """

    model_config = _STRICT
    base_m: tuple[float, float] = Field(description="footprint sides (sx, sy) in meters", strict=LIST)
    height_m: float = Field(gt=0.0)
    variability: float = Field(0.0, ge=0.0, lt=1.0)

    @model_validator(mode="after")
    def _positive_base(self) -> "ObstacleType":
        if self.base_m[0] <= 0 or self.base_m[1] <= 0:
            raise SpecError("base_m", list(self.base_m), "two footprint sides > 0 (meters)")
        return self


BUILTIN_TYPES: dict[str, ObstacleType] = {
    "tree": ObstacleType(base_m=(1.0, 1.0), height_m=5.0),
    "building": ObstacleType(base_m=(9.0, 9.0), height_m=8.0),
}


#: At most this many obstacle moves in a spec.
MAX_MOVES = 256


class ObstacleMove(BaseModel):
    """A local move of one generated obstacle: the obstacle whose centre is nearest ``at``
    (x, y in meters; the first placed on a tie) is translated by ``by`` (dx, dy in meters).

    Moves apply in order after placement, before the ground is levelled. A move that would put
    its obstacle outside the map, over another obstacle or into the start or goal free disc is
    not applied (the world's ``moves_applied`` descriptor counts the applied ones)."""

    model_config = _STRICT
    at: tuple[float, float] = Field(strict=LIST)
    by: tuple[float, float] = Field(strict=LIST)


#: A point [x, y] inside a list (a list stands for the tuple; its numbers stay strict).
_Point = Annotated[tuple[Annotated[float, Strict()], Annotated[float, Strict()]], Strict(False)]
#: At most this many points in one wall polyline, and this many wall segments in a spec.
MAX_WALL_POINTS = 1000
MAX_WALL_SEGMENTS = 10_000


class WallSpec(BaseModel):
    """A wall: a polyline of ``points`` (x, y in meters, at least 2, consecutive points distinct)
    of ``thickness_m`` and ``height_m``; one box of kind ``wall`` per segment, each extended by
    half the thickness at both ends so that joints close (:mod:`navstress.world.shapes`). The
    whole footprint must lie inside the map and keep out of the mission's start and goal free
    discs; random obstacles are placed around the walls."""

    model_config = _STRICT
    points: tuple[_Point, ...] = Field(strict=LIST)
    thickness_m: float = Field(0.2, gt=0.0, le=10.0)
    height_m: float = Field(2.5, gt=0.0, le=100.0)


def wall_segment(a: tuple[float, float], b: tuple[float, float], thickness_m: float) -> tuple[float, float, float, float]:
    """(x, y, yaw, length) of the box of the wall segment from ``a`` to ``b``: centred on the
    segment's midpoint, turned along it, extended by half the thickness at both ends
    (:mod:`navstress.world.shapes` makes the wall's boxes from it)."""
    (ax, ay), (bx, by) = a, b
    return (ax + bx) / 2, (ay + by) / 2, math.atan2(by - ay, bx - ax), math.hypot(bx - ax, by - ay) + thickness_m


def _box_corners(x: float, y: float, yaw: float, sx: float, sy: float) -> np.ndarray:
    """The corners of a turned box's footprint, as ``Obstacle.corners`` computes them."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[sx / 2, sy / 2], [-sx / 2, sy / 2], [-sx / 2, -sy / 2], [sx / 2, -sy / 2]])
    out: np.ndarray = local @ np.array([[c, -s], [s, c]]).T + np.array([x, y])
    return out


def _box_distance(x: float, y: float, yaw: float, sx: float, sy: float, px: float, py: float) -> float:
    """The distance from (px, py) to a turned box's footprint (0 inside)."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = px - x, py - y
    ex = max(abs(c * dx + s * dy) - sx / 2, 0.0)
    ey = max(abs(-s * dx + c * dy) - sy / 2, 0.0)
    return math.hypot(ex, ey)


class ObstaclesSpec(BaseModel):
    """Obstacle types and how much of the map they cover.

    Either give per-type targets in ``obstruction`` (percent of map area), or a ``total``
    percentage with ``mix`` weights that split it between types. Types default to the
    built-ins (``tree`` 1 m x 1 m, ``building`` 9 m x 9 m); ``types`` adds or overrides.
    """

    model_config = _STRICT
    types: dict[str, ObstacleType] = Field(default_factory=dict)
    obstruction: dict[str, float] = Field(default_factory=dict)
    total: float | None = Field(None, ge=0.0, lt=100.0)
    mix: dict[str, float] | None = None
    moves: tuple[ObstacleMove, ...] = Field((), strict=LIST)
    walls: tuple[WallSpec, ...] = Field((), strict=LIST)

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        """Without moves (walls), no ``moves`` (``walls``) key: the files of every world without
        them keep their bytes."""
        data = handler(self)
        if isinstance(data, dict):
            if not self.moves:
                data.pop("moves", None)
            if not self.walls:
                data.pop("walls", None)
        return data

    def all_types(self) -> dict[str, ObstacleType]:
        return {**BUILTIN_TYPES, **self.types}

    def targets(self) -> dict[str, float]:
        """Resolved per-type obstruction targets in percent (types with 0 omitted)."""
        if self.total is not None:
            mix = self.mix or {}
            wsum = sum(mix.values())
            out = {k: self.total * w / wsum for k, w in mix.items() if w > 0} if wsum > 0 else {}
        else:
            out = {k: float(v) for k, v in self.obstruction.items() if v > 0}
        return dict(sorted(out.items()))

    @model_validator(mode="after")
    def _check(self) -> "ObstaclesSpec":
        known = self.all_types()
        for name, pct in self.obstruction.items():
            if name not in known:
                raise _unknown_type(f"obstruction.{name}", name, known)
            if not (0.0 <= pct < 100.0) or math.isnan(pct):
                raise SpecError(f"obstacles.obstruction.{name}", pct, "a percentage in [0, 100)")
        if self.total is not None:
            if self.obstruction:
                raise SpecError("obstacles.total", self.total, "either total+mix or obstruction, not both",
                                "remove one of them")
            if not self.mix:
                raise SpecError("obstacles.mix", self.mix if self.mix is not None else MISSING,
                                "weights per type when total is given",
                                "e.g. --mix trees=1,buildings=1")
        for name, w in (self.mix or {}).items():
            if name not in known:
                raise _unknown_type(f"mix.{name}", name, known)
            if not (w >= 0.0) or math.isinf(w):
                raise SpecError(f"obstacles.mix.{name}", w, "a weight >= 0")
        if self.total is not None and self.total > 0 and sum((self.mix or {}).values()) <= 0:
            raise SpecError("obstacles.mix", self.mix, "at least one weight > 0")
        if len(self.moves) > MAX_MOVES:
            raise SpecError("obstacles.moves", f"{len(self.moves)} moves", f"at most {MAX_MOVES} moves")
        for i, mv in enumerate(self.moves):
            for name, pair in (("at", mv.at), ("by", mv.by)):
                if not all(math.isfinite(v) for v in pair):
                    raise SpecError(f"obstacles.moves[{i}].{name}", list(pair), "two finite numbers (meters)")
        self._check_walls()
        s = sum(self.targets().values())
        if s >= 100.0:
            raise SpecError("obstacles.obstruction", round(s, 3), "a total below 100 percent")
        return self


    def _check_walls(self) -> None:
        segments = 0
        for i, wall in enumerate(self.walls):
            at = f"obstacles.walls[{i}]"
            if not 2 <= len(wall.points) <= MAX_WALL_POINTS:
                raise SpecError(f"{at}.points", f"{len(wall.points)} points",
                                f"a polyline of 2 to {MAX_WALL_POINTS} points [x, y] (meters)",
                                "give at least a start and an end point" if len(wall.points) < 2 else "split the wall")
            for j, (p, q) in enumerate(zip(wall.points, wall.points[1:]), start=1):
                if p == q:
                    raise SpecError(f"{at}.points[{j}]", list(q), f"a point other than points[{j - 1}] (a segment of "
                                    "length 0)", "remove the repeated point")
            segments += len(wall.points) - 1
        if segments > MAX_WALL_SEGMENTS:
            raise SpecError("obstacles.walls", f"{segments} segments", f"at most {MAX_WALL_SEGMENTS} wall segments",
                            "merge straight runs into one segment")


def _unknown_type(field: str, name: str, known: dict[str, ObstacleType]) -> SpecError:
    return SpecError(f"obstacles.{field}", name, f"one of the obstacle types {sorted(known)}",
                     "add it under obstacles.types or fix the spelling")


class MissionSpec(BaseModel):
    """Where the robot starts and where it must go.

    ``mode="paper"``: start near the bottom-left corner facing the goal near the top-right
    corner, each ``inset_m`` from both edges (100 m map: (5, 5) -> (95, 95), 127 m apart).
    Explicit ``start`` (x, y, yaw) / ``goal`` (x, y) override. ``mode="random"``: a start/goal
    pair drawn from the map seed, at least ``min_distance_m`` apart, satisfying the same
    constraints. ``free_radius_m`` is kept free of obstacles around start and goal, and the ground
    there is levelled (``navstress.world.freearea``): 5 m = the robot's initial scanning manoeuvre
    (turn on the spot, ~3 m forward) plus its half-diagonal (0.66 m) plus a margin of about 1 m.
    Both free discs lie inside the map in every mode (the world spec refuses an ``inset_m``, a
    ``start`` or ``goal`` closer than ``free_radius_m`` to an edge, and a radius over half the
    map's shorter side).
    """

    model_config = _STRICT
    mode: Literal["paper", "random"] = "paper"
    start: tuple[float, float, float] | None = Field(None, strict=LIST)
    goal: tuple[float, float] | None = Field(None, strict=LIST)
    inset_m: float = Field(5.0, ge=0.0)
    free_radius_m: float = Field(5.0, ge=0.0, le=50.0)
    min_distance_m: float = Field(50.0, ge=0.0)


#: The behaviours a mover type may have (docs/worlds.md, "Movers").
BEHAVIOURS = ("crossing", "patrol", "intercept", "still-then-move")
#: Most movers a world may have (all types together).
MAX_MOVERS = 1000


class MoverType(BaseModel):
    """A kind of mover (an obstacle that moves during a run).

    ``shape="disc"``: an upright cylinder of diameter ``length_m`` (``width_m`` must equal it);
    ``shape="box"``: a box ``length_m`` (along its heading) x ``width_m`` x ``height_m``. Each
    mover's cruise speed is drawn in ``[speed_min_m_s, speed_max_m_s]`` (from the map seed) and
    its speed never exceeds ``speed_max_m_s``; ``accel_m_s2`` bounds the change of its velocity
    vector. ``variability`` v draws each size in ``[size*(1-v), size*(1+v)]`` (a disc: one draw
    for its diameter), as for static obstacle types.
    """

    model_config = _STRICT
    shape: Literal["disc", "box"] = "box"
    length_m: float = Field(gt=0.0, le=50.0)
    width_m: float = Field(gt=0.0, le=50.0)
    height_m: float = Field(gt=0.0, le=50.0)
    speed_min_m_s: float = Field(0.0, ge=0.0, le=50.0)
    speed_max_m_s: float = Field(gt=0.0, le=50.0)
    accel_m_s2: float = Field(1.0, gt=0.0, le=50.0)
    variability: float = Field(0.0, ge=0.0, lt=1.0)

    @property
    def radius_m(self) -> float:
        """The largest radius of this type's footprint (at the top of its size envelope): the disc's
        radius, a box's half diagonal."""
        f = 1.0 + self.variability
        if self.shape == "disc":
            return self.length_m * f / 2
        return math.hypot(self.length_m, self.width_m) * f / 2


BUILTIN_MOVER_TYPES: dict[str, MoverType] = {
    # a pedestrian: a 0.5 m disc (an upright cylinder), 1.8 m tall, 0.5-1.5 m/s
    "pedestrian": MoverType(shape="disc", length_m=0.5, width_m=0.5, height_m=1.8, speed_min_m_s=0.5,
                            speed_max_m_s=1.5, accel_m_s2=1.0),
    # a car: a 4.5 x 1.8 x 1.5 m box, up to 5 m/s
    "vehicle": MoverType(shape="box", length_m=4.5, width_m=1.8, height_m=1.5, speed_min_m_s=2.0,
                         speed_max_m_s=5.0, accel_m_s2=2.0),
}

#: The behaviour parameters each behaviour uses (the others must keep their defaults).
BEHAVIOUR_PARAMS: dict[str, tuple[str, ...]] = {
    "crossing": ("waypoints", "pause_max_s"),
    "patrol": ("waypoints", "pause_max_s"),
    "intercept": ("waypoints", "pause_max_s", "aim", "ttc_s", "clearance_m", "reaction_s", "engage_m",
                  "cross_m", "speed_m_s", "accel_m_s2"),
    "still-then-move": ("trigger_m", "reaction_s", "aim", "ttc_s", "clearance_m", "cross_m", "speed_m_s",
                        "accel_m_s2"),
}


class BehaviourSpec(BaseModel):
    """How the movers of one type move (docs/worlds.md, "Movers", states the controller's rules).

    * ``crossing``: straight free segments between ``waypoints`` random points of the free space
      (drawn from the map seed), walked there and back; a pause of ``U(0, pause_max_s)`` (run
      seed) at each point.
    * ``patrol``: a closed loop of ``waypoints`` (>= 3) points, walked round and round.
    * ``intercept``: wanders as ``crossing`` until the robot is within ``engage_m``; then every
      ``reaction_s`` seconds it aims, from the robot's true pose and velocity (constant-velocity
      prediction), at the point of the robot's predicted path that it reaches ``lead`` ahead of
      the robot (``aim: ttc``: lead = ``ttc_s`` x the robot's speed; ``aim: clearance``: lead =
      ``clearance_m``; 0: a collision course), and walks on ``cross_m`` past it; at
      ``speed_m_s``/``accel_m_s2`` (default: the type's limits).
    * ``still-then-move``: parked until the robot comes within ``trigger_m``; ``reaction_s``
      later it aims once as ``intercept`` does and crosses (``cross_m`` past the aim point), then
      parks again.
    """

    model_config = _STRICT
    kind: Literal["crossing", "patrol", "intercept", "still-then-move"] = "crossing"
    waypoints: int = Field(4, ge=1, le=64)
    pause_max_s: float = Field(0.0, ge=0.0, le=600.0)
    aim: Literal["ttc", "clearance"] = "ttc"
    ttc_s: float = Field(2.0, ge=0.0, le=60.0)
    clearance_m: float = Field(2.0, ge=0.0, le=100.0)
    reaction_s: float = Field(0.5, ge=0.0, le=60.0)
    engage_m: float = Field(30.0, gt=0.0, le=10_000.0)
    cross_m: float = Field(3.0, ge=0.0, le=100.0)
    speed_m_s: float | None = Field(None, gt=0.0, le=50.0)
    accel_m_s2: float | None = Field(None, gt=0.0, le=50.0)
    trigger_m: float = Field(10.0, gt=0.0, le=10_000.0)


_BEHAVIOUR_DEFAULTS = BehaviourSpec()


class MoversSpec(BaseModel):
    """Obstacles that move during a run (none by default).

    ``types`` adds mover types or overrides fields of the built-ins (``pedestrian``, ``vehicle``:
    the fields given replace the built-in's, the others are kept). How many of each type: either
    ``count`` (movers) or ``density_per_ha`` (movers per hectare of the map, rounded to the
    nearest whole number, halves up), not both for one type. ``behaviour`` gives each type its
    :class:`BehaviourSpec` (default: ``crossing``).

        >>> m = MoversSpec.model_validate({"count": {"pedestrian": 3}, "density_per_ha": {"vehicle": 0.5}})
        >>> m.counts((40.0, 50.0))
        {'pedestrian': 3, 'vehicle': 0}
    """

    model_config = _STRICT
    types: dict[str, MoverType] = Field(default_factory=dict)
    count: dict[str, int] = Field(default_factory=dict)
    density_per_ha: dict[str, float] = Field(default_factory=dict)
    behaviour: dict[str, BehaviourSpec] = Field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _over_builtins(cls, data: Any) -> Any:
        """A built-in type's fields given under ``types`` replace only those fields."""
        if isinstance(data, dict) and isinstance(data.get("types"), dict):
            types = {}
            for name, t in data["types"].items():
                if name in BUILTIN_MOVER_TYPES and isinstance(t, dict):
                    t = {**BUILTIN_MOVER_TYPES[name].model_dump(), **t}
                types[name] = t
            data = {**data, "types": types}
        return data

    def all_types(self) -> dict[str, MoverType]:
        return {**BUILTIN_MOVER_TYPES, **self.types}

    def behaviour_of(self, name: str) -> BehaviourSpec:
        return self.behaviour.get(name, _BEHAVIOUR_DEFAULTS)

    def counts(self, size_m: tuple[float, float]) -> dict[str, int]:
        """Movers per type named in ``count`` or ``density_per_ha``: the ``count``, or
        ``density_per_ha`` x the map's hectares rounded half up."""
        ha = size_m[0] * size_m[1] / 10_000.0
        out = {k: int(v) for k, v in self.count.items()}
        out.update({k: int(math.floor(d * ha + 0.5)) for k, d in self.density_per_ha.items()})
        return dict(sorted(out.items()))

    @property
    def empty(self) -> bool:
        """Whether this is the default (no movers field at all): such a spec's dump leaves it out."""
        return self == _NO_MOVERS

    @model_validator(mode="after")
    def _check(self) -> "MoversSpec":
        known = self.all_types()
        for name, t in self.types.items():
            at = f"movers.types.{name}"
            if t.speed_min_m_s > t.speed_max_m_s:
                raise SpecError(f"{at}.speed_min_m_s", t.speed_min_m_s, f"a speed <= speed_max_m_s={t.speed_max_m_s:g}",
                                "lower speed_min_m_s or raise speed_max_m_s")
            if t.shape == "disc" and t.width_m != t.length_m:
                raise SpecError(f"{at}.width_m", t.width_m, f"the disc's diameter length_m={t.length_m:g} (a disc "
                                "has one size)", "set width_m equal to length_m, or shape: box")
        for field, table in (("count", self.count), ("density_per_ha", self.density_per_ha),
                             ("behaviour", self.behaviour)):
            for name in table:
                if name not in known:
                    raise SpecError(f"movers.{field}.{name}", name, f"one of the mover types {sorted(known)}",
                                    "add it under movers.types or fix the spelling")
        for name, n in self.count.items():
            if not 0 <= n <= MAX_MOVERS:
                raise SpecError(f"movers.count.{name}", n, f"a number of movers in [0, {MAX_MOVERS}]")
        for name, d in self.density_per_ha.items():
            if not (0.0 <= d <= 10_000.0):
                raise SpecError(f"movers.density_per_ha.{name}", d, "movers per hectare in [0, 10000]")
            if name in self.count:
                raise SpecError(f"movers.density_per_ha.{name}", d, f"either count.{name} or density_per_ha.{name}, "
                                "not both", "remove one of them")
        for name, b in self.behaviour.items():
            used = BEHAVIOUR_PARAMS[b.kind]
            for p in BehaviourSpec.model_fields:
                if p != "kind" and p not in used and getattr(b, p) != getattr(_BEHAVIOUR_DEFAULTS, p):
                    raise SpecError(f"movers.behaviour.{name}.{p}", getattr(b, p),
                                    f"no {p} for kind {b.kind} (it takes {', '.join(used)})",
                                    "remove it or change the kind")
            if b.kind == "patrol" and b.waypoints < 3:
                raise SpecError(f"movers.behaviour.{name}.waypoints", b.waypoints, "at least 3 waypoints for a patrol loop")
        return self


_NO_MOVERS = MoversSpec()


#: The world generators (:mod:`navstress.world.generators`), the default first.
GENERATORS = ("outdoor", "rooms", "clutter")
#: The kinds of imported world (:mod:`navstress.world.sources`); ``auto``: by the file.
SOURCE_KINDS = ("auto", "map", "sdf", "dir")


class SourceSpec(BaseModel):
    """An imported world (docs/worlds.md, "Imported worlds"): ``path`` names a ROS ``map_server``
    YAML (with its PGM or PNG image), a Gazebo world (SDF), or a navstress world directory;
    ``kind`` says which (``auto``: by the file). A relative path is relative to the spec file
    that names it (the spec readers make it absolute). The other fields are import options:
    ``wall_height_m`` (a map's occupied cells become walls this high), ``unknown`` (a map's
    unknown cells: ``wall`` or ``free`` ground), ``meshes`` (an SDF's mesh collisions: ``skip``,
    listed in the warning, or ``bbox``, their bounding boxes), ``margin_m`` (free ground kept
    around an SDF world's content), ``sha256`` (the source's digest, pinned by a campaign's plan:
    a source file that changed since is refused, never silently mixed)."""

    model_config = _STRICT
    path: str = Field(min_length=1)
    kind: Literal["auto", "map", "sdf", "dir"] = "auto"
    wall_height_m: float = Field(2.0, gt=0.0, le=100.0)
    unknown: Literal["wall", "free"] = "wall"
    meshes: Literal["skip", "bbox"] = "skip"
    margin_m: float = Field(1.0, ge=0.0, le=100.0)
    sha256: str | None = Field(None, pattern=r"^[0-9a-f]{64}$")


#: The free gap (m) a passage must leave beside a robot of its width: a door or corridor at least
#: this much wider than the robot (the ``rooms`` generator's check, with the robot it is made for).
PASSAGE_MARGIN_M = 0.1


class RoomsSpec(BaseModel):
    """The ``rooms`` generator's parameters (docs/worlds.md, "Generators: rooms and clutter").

    A floor plan filling the map: room bands along horizontal corridors and one vertical corridor
    (the spine) joining them. Room sides (between wall centre lines) are drawn in
    ``[room_min_m, room_max_m]``; ``corridor_width_m`` and ``door_width_m`` are clear widths;
    each room has ``doors_min`` to ``doors_max`` doors (the first onto its corridor, the others onto
    a corridor or a neighbouring room); ``furniture_pct`` percent of the rooms' floor is covered by
    box furniture (a few sizes, kept off doorways and the mission's free discs, every room staying
    reachable). Walls are boxes of kind ``wall``, ``wall_thickness_m`` thick and ``wall_height_m``
    high, one per straight run between doors and junctions.

        >>> RoomsSpec(room_min_m=3.0, room_max_m=5.0).room_max_m
        5.0
    """

    model_config = _STRICT
    room_min_m: float = Field(3.0, ge=1.0, le=100.0, description="smallest room side, between wall centre lines (m)")
    room_max_m: float = Field(6.0, ge=1.0, le=100.0, description="largest room side, between wall centre lines (m)")
    corridor_width_m: float = Field(2.0, gt=0.0, le=20.0, description="clear corridor width (m)")
    door_width_m: float = Field(1.0, gt=0.0, le=10.0, description="clear door width (m)")
    doors_min: int = Field(1, ge=1, le=8, description="fewest doors of a room")
    doors_max: int = Field(2, ge=1, le=8, description="most doors of a room")
    wall_thickness_m: float = Field(0.15, ge=0.02, le=1.0)
    wall_height_m: float = Field(2.5, gt=0.0, le=20.0)
    furniture_pct: float = Field(0.0, ge=0.0, le=30.0, description="percent of the rooms' floor covered by furniture")

    @model_validator(mode="after")
    def _check(self) -> "RoomsSpec":
        t = self.wall_thickness_m
        if self.room_min_m > self.room_max_m:
            raise SpecError("rooms.room_min_m", self.room_min_m, f"a side <= rooms.room_max_m={self.room_max_m:g}",
                            "lower room_min_m or raise room_max_m")
        if self.doors_min > self.doors_max:
            raise SpecError("rooms.doors_min", self.doors_min, f"at most rooms.doors_max={self.doors_max}",
                            "lower doors_min or raise doors_max")
        clear = self.room_min_m - t
        need = self.doors_min * self.door_width_m + (self.doors_min + 1) * t
        if need > clear + 1e-9:
            raise SpecError("rooms.door_width_m", self.door_width_m,
                            f"{self.doors_min} door(s) that fit the smallest room's side (clear {clear:.3g} m, "
                            f"with a wall of {t:g} m beside each door: at most "
                            f"{(clear - (self.doors_min + 1) * t) / self.doors_min:.3g} m)",
                            "narrow the doors, lower doors_min or raise room_min_m")
        if self.corridor_width_m < 2 * t:
            raise SpecError("rooms.corridor_width_m", self.corridor_width_m,
                            f"a corridor at least twice the wall thickness ({2 * t:g} m)")
        return self

    def check_fits(self, size_m: tuple[float, float]) -> None:
        """SpecError when the map cannot hold one room beside a corridor (the smallest floor plan)."""
        t, pitch = self.wall_thickness_m, self.corridor_width_m + self.wall_thickness_m
        for axis, size in zip("xy", size_m):
            need = self.room_min_m + pitch + t
            if size + 1e-9 < need:
                raise SpecError("rooms.room_min_m", self.room_min_m,
                                f"rooms that fit the {size_m[0]:g}x{size_m[1]:g} m map (one room and a corridor "
                                f"take {need:.3g} m along {axis}, walls included)",
                                "enlarge the map (size_m) or make rooms and corridors smaller")

    def check_robot(self, width_m: float, name: str) -> None:
        """SpecError when a robot ``width_m`` wide cannot pass the corridors or the doors."""
        for field, w, what in (("corridor_width_m", self.corridor_width_m, "corridor"),
                               ("door_width_m", self.door_width_m, "door")):
            if w < width_m + PASSAGE_MARGIN_M - 1e-9:
                raise SpecError(f"rooms.{field}", w, f"a {what} wider than the robot {name!r} ({width_m:.3g} m wide) "
                                f"by at least {PASSAGE_MARGIN_M:g} m", f"widen the {what}s or choose a smaller robot")


class ClutterSpec(BaseModel):
    """The ``clutter`` generator's parameters: BARN's worlds (Perille et al. 2020, "Benchmarking
    Metric Ground Navigation"; its generator ``gen_world_ca.py`` in github.com/dperille/jackal-map-creation),
    docs/worlds.md, "Generators: rooms and clutter".

    A lattice of ``lattice_m`` cells: an obstacle field of ``cells_x`` x ``cells_y`` cells made by
    BARN's cellular automaton (each cell filled with probability ``fill_pct`` percent, then
    ``smooth_iterations`` rounds of its rule), its two side columns walls, behind it a start
    corridor of ``corridor_cells`` rows closed by a back wall; an upright cylinder of radius
    ``radius_m`` and height ``height_m`` at each occupied cell. The robot starts ``start_m`` above
    the lattice's lower edge facing +y, the goal ``goal_m`` ahead (BARN: 3 m and 10 m).

        >>> ClutterSpec().cells_x, ClutterSpec().lattice_m
        (30, 0.15)
    """

    model_config = _STRICT
    fill_pct: float = Field(20.0, ge=0.0, le=100.0, description="initial fill of the field, percent of its cells")
    smooth_iterations: int = Field(4, ge=0, le=50, description="rounds of the cellular automaton's smoothing rule")
    cells_x: int = Field(30, ge=5, le=1000, description="field width in lattice cells (side walls included)")
    cells_y: int = Field(30, ge=1, le=1000, description="field length in lattice cells (along the travel, +y)")
    corridor_cells: int = Field(34, ge=2, le=1000, description="rows from the lattice's lower edge to the field (back wall included)")
    lattice_m: float = Field(0.15, gt=0.0, le=5.0, description="lattice cell side (m)")
    radius_m: float = Field(0.075, gt=0.0, le=2.5, description="cylinder radius (m)")
    height_m: float = Field(1.0, gt=0.0, le=20.0, description="cylinder height (m)")
    start_m: float = Field(3.0, gt=0.0, le=1000.0, description="start's distance above the lattice's lower edge (m)")
    goal_m: float = Field(10.0, gt=0.0, le=2000.0, description="goal's distance ahead of the start, along +y (m)")

    @model_validator(mode="after")
    def _check(self) -> "ClutterSpec":
        if 2 * self.radius_m > self.lattice_m + 1e-12:
            raise SpecError("clutter.radius_m", self.radius_m, f"a radius <= half the lattice cell "
                            f"(clutter.lattice_m={self.lattice_m:g} m): cylinders must not overlap",
                            "lower radius_m or raise lattice_m")
        if self.start_m >= self.corridor_cells * self.lattice_m:
            raise SpecError("clutter.start_m", self.start_m, f"a start inside the corridor, below the field "
                            f"(< corridor_cells x lattice_m = {self.corridor_cells * self.lattice_m:g} m)",
                            "lower start_m or raise corridor_cells")
        if self.start_m <= self.lattice_m:
            raise SpecError("clutter.start_m", self.start_m, f"a start above the back wall (> lattice_m={self.lattice_m:g} m)")
        return self

    @property
    def width_m(self) -> float:
        """The lattice's width (the field's, walls included)."""
        return self.cells_x * self.lattice_m

    @property
    def span_m(self) -> float:
        """The layout's length along y: the lattice (corridor and field) or the goal, whichever reaches farther, plus 1 m."""
        return max((self.corridor_cells + self.cells_y) * self.lattice_m, self.start_m + self.goal_m) + 1.0

    def check_fits(self, size_m: tuple[float, float]) -> None:
        """SpecError when the map cannot hold the layout (lattice and goal)."""
        sx, sy = size_m
        if self.width_m > sx + 1e-9:
            raise SpecError("clutter.cells_x", self.cells_x, f"a field that fits the map's width {sx:g} m "
                            f"(cells_x x lattice_m = {self.width_m:g} m)", "enlarge size_m or lower cells_x")
        if self.span_m > sy + 1e-9:
            raise SpecError("clutter.cells_y", self.cells_y, f"a layout that fits the map's height {sy:g} m (corridor, "
                            f"field and goal take {self.span_m:g} m, a 1 m margin included)",
                            "enlarge size_m or shorten the field, corridor or goal_m")


class WorldSpec(BaseModel):
    """Everything that defines a family of worlds; with a seed, one world."""

    model_config = _STRICT
    size_m: tuple[float, float] = Field((100.0, 100.0), strict=LIST)
    cell_m: float = Field(0.4, ge=0.05, le=2.0, description="terrain grid cell size in meters")
    ground: GroundSpec = GroundSpec()
    obstacles: ObstaclesSpec = ObstaclesSpec()
    mission: MissionSpec = MissionSpec()
    movers: MoversSpec = MoversSpec()
    source: SourceSpec | None = None
    generator: Literal["outdoor", "rooms", "clutter"] = "outdoor"
    rooms: RoomsSpec = RoomsSpec()
    clutter: ClutterSpec = ClutterSpec()

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        """A spec without movers dumps as before movers existed (no ``movers`` key), so the
        files of every world without movers keep their bytes; likewise without a ``source``,
        with the ``outdoor`` generator, and without the parameters of a generator it does not use."""
        data = handler(self)
        if isinstance(data, dict):
            if self.movers.empty:
                data.pop("movers", None)
            if self.source is None:
                data.pop("source", None)
            if self.generator == "outdoor":
                data.pop("generator", None)
            for name in ("rooms", "clutter"):
                if self.generator != name:
                    data.pop(name, None)
        return data

    @model_validator(mode="after")
    def _check(self) -> "WorldSpec":
        for name in ("rooms", "clutter"):
            if name in self.model_fields_set and self.generator != name:
                raise SpecError(name, "set", f"parameters of the generator in use ({self.generator!r})",
                                f"set generator: {name}, or remove {name}")
        for axis, size in zip("xy", self.size_m):
            if not (size > 0) or math.isinf(size):
                raise SpecError(f"size_m.{axis}", size, "a map size in meters > 0")
            if size < 10 or size > 2000:
                raise SpecError(f"size_m.{axis}", size, "a map size in [10, 2000] meters")
            n = size / self.cell_m
            if abs(n - round(n)) > 1e-6:
                raise SpecError(f"size_m.{axis}", size, f"a whole multiple of cell_m={self.cell_m}",
                                f"use size {round(n) * self.cell_m:g} or another cell_m")
        if self.source is not None:  # the mission and the moves are in the source's frame: checked on import
            if self.generator != "outdoor":
                raise SpecError("generator", self.generator, "no generator with a source (the world is imported)",
                                "remove generator, or remove source")
            if self.ground != GroundSpec():
                raise SpecError("ground", self.ground.label(), "the source's own ground (a world with a source keeps "
                                "its terrain)", "remove ground, or remove source")
            return self._check_movers()
        m = self.mission
        for name, pt in (("start", m.start), ("goal", m.goal)):
            if pt is not None and not (0 <= pt[0] <= self.size_m[0] and 0 <= pt[1] <= self.size_m[1]):
                raise SpecError(f"mission.{name}", list(pt), f"a point inside the map [0, {self.size_m[0]:g}] x [0, {self.size_m[1]:g}]")
        if self.generator == "rooms":  # (free discs on flat floors: the generator keeps furniture out of them)
            self.rooms.check_fits(self.size_m)
        elif self.generator == "clutter":
            self.clutter.check_fits(self.size_m)
        else:
            self._check_free_discs()
        self._check_walls_in_map()
        for i, mv in enumerate(self.obstacles.moves):
            if not (0 <= mv.at[0] <= self.size_m[0] and 0 <= mv.at[1] <= self.size_m[1]):
                raise SpecError(f"obstacles.moves[{i}].at", list(mv.at),
                                f"a point inside the map [0, {self.size_m[0]:g}] x [0, {self.size_m[1]:g}]")
        return self._check_movers()

    def _check_movers(self) -> "WorldSpec":
        counts = self.movers.counts(self.size_m)
        total = sum(counts.values())
        if total > MAX_MOVERS:
            raise SpecError("movers", f"{total} movers", f"at most {MAX_MOVERS} movers in a world",
                            "lower movers.count or movers.density_per_ha")
        types = self.movers.all_types()
        side = min(self.size_m)
        for name, n in counts.items():
            t = types[name]
            diameter = 2 * t.radius_m
            if n > 0 and diameter >= side / 2:
                raise SpecError(f"movers.types.{name}", f"{t.length_m:g}x{t.width_m:g} m (variability {t.variability:g})",
                                f"a mover that fits the {self.size_m[0]:g}x{self.size_m[1]:g} m map (its largest "
                                f"footprint, {diameter:.3g} m across, must be under half the map's side)",
                                "use a smaller type or a larger map")
        return self

    def _check_walls_in_map(self) -> None:
        """Every wall's footprint lies inside the map and, for a mission whose start and goal the
        spec fixes (not ``random``), keeps out of their free discs."""

        sx, sy = self.size_m
        m = self.mission
        discs: list[tuple[str, tuple[float, float]]] = []
        if m.mode == "paper":
            start = m.start[:2] if m.start is not None else (m.inset_m, m.inset_m)
            goal = m.goal if m.goal is not None else (sx - m.inset_m, sy - m.inset_m)
            discs = [("start", (start[0], start[1])), ("goal", (goal[0], goal[1]))]
        for i, wall in enumerate(self.obstacles.walls):
            for j, (x, y) in enumerate(wall.points):
                if not (0 <= x <= sx and 0 <= y <= sy):
                    raise SpecError(f"obstacles.walls[{i}].points[{j}]", [x, y],
                                    f"a point inside the map [0, {sx:g}] x [0, {sy:g}]")
            for j, (a, b) in enumerate(zip(wall.points, wall.points[1:])):
                cx, cy, yaw, length = wall_segment(a, b, wall.thickness_m)
                corners = _box_corners(cx, cy, yaw, length, wall.thickness_m)
                if not (corners[:, 0].min() >= 0 and corners[:, 1].min() >= 0 and corners[:, 0].max() <= sx
                        and corners[:, 1].max() <= sy):
                    raise SpecError(f"obstacles.walls[{i}].points[{j + 1}]", list(wall.points[j + 1]),
                                    f"a wall inside the map: the segment from points[{j}] of thickness "
                                    f"{wall.thickness_m:g} m (and half of it past each end) leaves [0, {sx:g}] x "
                                    f"[0, {sy:g}]", "move the wall at least half its thickness from the map's edge")
                for name, (px, py) in discs:
                    if m.free_radius_m > 0 and _box_distance(cx, cy, yaw, length, wall.thickness_m, px, py) < \
                            m.free_radius_m:
                        raise SpecError(f"obstacles.walls[{i}].points[{j + 1}]", list(wall.points[j + 1]),
                                        f"a wall clear of the mission's {name} free disc (radius "
                                        f"mission.free_radius_m={m.free_radius_m:g} m around ({px:g}, {py:g})): "
                                        f"the segment from points[{j}] crosses it",
                                        f"move the wall or the {name}, or lower mission.free_radius_m")

    def _check_free_discs(self) -> None:
        """The start and goal free discs (radius ``mission.free_radius_m``) lie inside the map, in
        every mission mode: a drivable area the generator can level (navstress.world.freearea)."""
        m, (sx, sy) = self.mission, self.size_m
        r = m.free_radius_m
        inside = f"the start and goal free discs of mission.free_radius_m={r:g} must lie inside the {sx:g}x{sy:g} m map"
        if 2 * r > min(sx, sy):
            raise SpecError("mission.free_radius_m", r, f"a radius <= {min(sx, sy) / 2:g} m, half the map's shorter side "
                            f"({inside})", "lower free_radius_m or enlarge the map")
        if m.mode == "random":  # drawn in the map shrunk by the radius: inside
            return
        if m.start is None or m.goal is None:  # (inset, inset) and (sx - inset, sy - inset)
            hi = min(sx, sy) - r
            if not (r <= m.inset_m <= hi):
                raise SpecError("mission.inset_m", m.inset_m, f"an inset in [{r:g}, {hi:g}] m ({inside})",
                                "raise inset_m or lower free_radius_m" if m.inset_m < r else "lower inset_m")
        for name, pt in (("start", m.start), ("goal", m.goal)):
            if pt is not None and not (r <= pt[0] <= sx - r and r <= pt[1] <= sy - r):
                raise SpecError(f"mission.{name}", list(pt), f"a point at least mission.free_radius_m={r:g} m from every "
                                f"edge, in [{r:g}, {sx - r:g}] x [{r:g}, {sy - r:g}] ({inside})",
                                f"move the {name} or lower free_radius_m")

    @property
    def grid_shape(self) -> tuple[int, int]:
        """(rows, cols) of the height grid: rows along y, cols along x, vertices at cell corners."""
        return (round(self.size_m[1] / self.cell_m) + 1, round(self.size_m[0] / self.cell_m) + 1)

    @property
    def memory_estimate_bytes(self) -> int:
        """Peak memory that generating, saving, previewing and simulating a world of this spec
        needs, estimated from its grid: :data:`BYTES_PER_VERTEX` per terrain grid vertex (the
        height grid and every array sized by it: generation fields, pads, descriptors, the
        preview, the simulator's heightfield and lidar height pyramids) plus a fixed base."""
        rows, cols = self.grid_shape
        return rows * cols * BYTES_PER_VERTEX + BASE_BYTES


#: Measured peak bytes per terrain grid vertex of generate + save + preview + simulation, with a margin.
BYTES_PER_VERTEX = 200
#: Memory of a world that does not scale with its grid (interpreter, MuJoCo, obstacles).
BASE_BYTES = 256 << 20
#: Default largest memory estimate a WorldSpec may have (GiB); override with NAVSTRESS_MAX_WORLD_GIB.
DEFAULT_MAX_WORLD_GIB = 8.0
MAX_WORLD_GIB_ENV = "NAVSTRESS_MAX_WORLD_GIB"


def max_world_bytes() -> int:
    """The memory limit of one world: ``NAVSTRESS_MAX_WORLD_GIB`` GiB, default 8."""
    raw = os.environ.get(MAX_WORLD_GIB_ENV)
    if raw is None or not raw.strip():
        return int(DEFAULT_MAX_WORLD_GIB * (1 << 30))
    try:
        gib = float(raw)
    except ValueError:
        gib = math.nan
    if not (gib > 0) or math.isinf(gib):
        raise SpecError(MAX_WORLD_GIB_ENV, raw, "a number of GiB > 0", f"unset it for the default {DEFAULT_MAX_WORLD_GIB:g}")
    return int(gib * (1 << 30))


def check_memory(spec: WorldSpec) -> WorldSpec:
    """Refuse (SpecError) a spec whose world would need more than :func:`max_world_bytes`."""
    need, limit = spec.memory_estimate_bytes, max_world_bytes()
    if need > limit:
        rows, cols = spec.grid_shape
        sx, sy = spec.size_m
        raise SpecError("size_m", f"{sx:g}x{sy:g} m at cell_m={spec.cell_m:g}",
                        f"a world needing at most {limit / (1 << 30):.3g} GiB of memory (this grid of "
                        f"{cols}x{rows} vertices needs about {need / (1 << 30):.3g} GiB)",
                        f"use a larger cell_m or a smaller map, or raise {MAX_WORLD_GIB_ENV}")
    return spec


def parse_spec(data: dict[str, Any]) -> WorldSpec:
    """Validate a mapping into a WorldSpec, raising :class:`SpecError` on bad input (including a
    world too large for memory, see :func:`check_memory`)."""
    return check_memory(parse(WorldSpec, data))


def load_spec(path: str | Path) -> WorldSpec:
    """Read a WorldSpec from a YAML or JSON file (through :mod:`navstress.specfile`: bounded size,
    nesting and alias expansion; UTF-8 text only)."""
    p = Path(path)
    data = load_file(p, field="spec")
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SpecError("spec", str(p), "a mapping of fields at the top level")
    return parse_spec(resolve_source(data, p.parent))


def resolve_source(world: Any, base_dir: str | Path | None) -> Any:
    """A WorldSpec mapping with its ``source`` made absolute: a relative ``source.path`` (or a
    ``source`` given as a bare path, ``source: office.yaml``) is taken relative to ``base_dir``
    (the folder of the spec file that names it; None: the working directory), so that workers
    in other processes or on other machines (Ray) find it whatever their working directory.
    Anything else is returned as it is (the spec's validation names it)."""
    if not isinstance(world, dict) or "source" not in world:
        return world
    src = world["source"]
    if isinstance(src, str):
        src = {"path": src}
    if not isinstance(src, dict) or not isinstance(src.get("path"), str) or not src["path"]:
        return world
    p = Path(os.path.expanduser(src["path"]))
    if not p.is_absolute():
        p = Path(base_dir if base_dir is not None else os.getcwd()) / p
    return {**world, "source": {**src, "path": os.path.normpath(str(p.absolute()))}}
