"""RobotSpec: the physical robot the simulator simulates (its truth), as validated data.

A navigator is told a RobotSpec too; usually the same one. Telling it another one (a smaller
footprint) is how the paper's footprint fault is injected.

The defaults are the paper's robot, a Segway RMP 400 class platform (Mana): four-wheel skid steer,
footprint 1.14 m x 0.67 m. The named profiles (``rmp400``, ``husky``, ``jackal``, ``turtlebot4``,
``f1tenth``) are in :mod:`navstress.robot.profiles`, their sources in docs/robots.md.

**Frames.** The robot frame ``base_link`` has x forward, y left, z up; its origin is the centre of
the footprint at the height of the wheel axles (the chassis body's origin in the simulation).
Footprint points, wheel and caster positions and sensor mounts are in this frame.

    >>> r = RobotSpec()
    >>> (r.length_m, r.width_m, r.drive)
    (1.14, 0.67, 'skid-steer')
    >>> from navstress._models import parse
    >>> parse(RobotSpec, {"drive": "differential", "wheels_per_side": 2}, prefix="robot")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: robot.wheels_per_side=2 is invalid: expected 1 for a differential drive (two driven wheels and passive casters); set drive: skid-steer for a base with more driven wheels
"""

from __future__ import annotations

import hashlib
import math
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, Field, model_validator

from navstress._json import dumps
from navstress._models import LIST, SPEC_CONFIG
from navstress.errors import SpecError
from navstress.sensors import Mount as Mount, Sensor

#: The drive types the simulation knows (one module each under ``navstress.sim.drives``).
DRIVES = ("skid-steer", "differential", "ackermann")
Drive = Literal["skid-steer", "differential", "ackermann"]
Vec3 = tuple[float, float, float]
#: (x, y); a YAML/JSON list is taken for it (inside a list of points too), its items stay strict
Point = Annotated[tuple[float, float], Field(strict=LIST)]


class LidarMount(BaseModel):
    """The lidar's position as the simulation reads it (``RobotSpec.lidar``: ``mounts['lidar']``)."""

    model_config = SPEC_CONFIG
    x_m: float = 0.35
    y_m: float = 0.0
    z_m: float = 0.75  # above the chassis origin (the axle height)


class Footprint(BaseModel):
    """The robot's shape seen from above: what the planner inflates and the simulation collides.

    ``box``: the rectangle ``length_m`` x ``width_m`` of the RobotSpec, centred on the origin;
    ``circle``: a disc of ``radius_m`` centred on the origin; ``polygon``: a convex polygon, its
    ``points`` (x, y) counter-clockwise or clockwise, at least 3, nonzero area."""

    model_config = SPEC_CONFIG
    shape: Literal["box", "circle", "polygon"] = "box"
    radius_m: float | None = Field(None, gt=0)
    points: tuple[Point, ...] | None = Field(None, strict=LIST)


class BodySource(BaseModel):
    """The URDF/MJCF file a robot's body was read from (:mod:`navstress.robot.body`): its kind, its
    path as the robot file wrote it, and the sha256 of its text (so that the robot's digest changes
    when the file does)."""

    model_config = SPEC_CONFIG
    kind: Literal["urdf", "mjcf"]
    path: str
    sha256: str = Field(pattern=r"^[0-9a-f]{64}$")


class RobotSpec(BaseModel):
    """Geometry, mass, drive and limits of the robot. All lengths in meters, SI units throughout.

    Fields left ``None`` are derived from the others by the drive model (documented with each
    drive in docs/robots.md)."""

    model_config = SPEC_CONFIG

    name: str = "rmp400"
    drive: Drive = "skid-steer"
    # --- body
    length_m: float = Field(1.14, gt=0, description="footprint length (x); for a circle or polygon footprint: its extent")
    width_m: float = Field(0.67, gt=0, description="footprint width (y); for a circle or polygon footprint: its extent")
    footprint: Footprint = Footprint()
    body_height_m: float = Field(0.45, gt=0, description="chassis box height")
    ground_clearance_m: float = Field(0.12, ge=0, description="belly height above the ground")
    mass_kg: float = Field(110.0, gt=0, description="total mass (RMP 400: ~110 kg)")
    inertia_kgm2: Vec3 | None = Field(None, strict=LIST,
                                      description="chassis principal moments (ixx, iyy, izz); None: a box of the footprint")
    # --- wheels
    wheel_radius_m: float = Field(0.265, gt=0, description="wheel radius (21 in tyres)")
    wheel_width_m: float = Field(0.15, gt=0)
    wheelbase_m: float = Field(0.62, ge=0, description="front-rear axle distance (0: one axle)")
    track_m: float = Field(0.55, gt=0, description="left-right wheel centre distance")
    wheels_per_side: int = Field(2, ge=1, le=4, description="driven wheels per side (skid-steer)")
    caster_positions: tuple[Point, ...] = Field((), strict=LIST,
                                                description="passive casters (x, y) of a differential base")
    caster_radius_m: float | None = Field(None, gt=0)
    max_steer_rad: float | None = Field(None, gt=0, lt=math.pi / 2, description="steering limit (ackermann)")
    max_steer_rate_rps: float | None = Field(None, gt=0, description="steering rate limit (ackermann)")
    drive_wheels: Literal["rear", "all"] = Field("rear", description="driven axles (ackermann)")
    # --- motors and firmware
    wheel_torque_nm: float | None = Field(60.0, gt=0, description="per-wheel motor torque limit; None: from mass")
    wheel_kv: float | None = Field(100.0, gt=0, description="wheel velocity-servo gain, N m per rad/s; None: from mass")
    wheel_armature_kgm2: float | None = Field(0.1, ge=0, description="reflected rotor inertia; None: from mass")
    wheel_hold_gain: float = Field(5.0, ge=0, description="wheel-angle hold, (rad/s) per rad of lag")
    gyro: bool = Field(True, description="the firmware closes a yaw-rate loop on a gyro")
    yaw_kp: float = Field(1.0, ge=0)
    yaw_ki: float = Field(4.0, ge=0)
    track_multiplier: float | None = Field(
        3.4, gt=0, description=("skid steer: effective track / track, in the firmware and the odometry; None: the "
                                "simulator's calibration for the geometry (docs/simulation.md, Drive types)"))
    odom_heading: Literal["wheels", "gyro"] = Field("wheels", description="odometry heading from the wheels or the gyro")
    # --- limits
    max_speed_mps: float = Field(1.2, gt=0, description="top linear speed used by navigation")
    max_yaw_rate_rps: float = Field(1.0, gt=0, description="top turn rate")
    max_accel_mps2: float = Field(1.0, gt=0, description="linear acceleration limit")
    max_yaw_accel_rps2: float = Field(2.0, gt=0, description="angular acceleration limit")
    # --- sensors
    mounts: dict[str, Mount] = Field(default_factory=lambda: {"lidar": Mount(xyz=(0.35, 0.0, 0.75))})
    #: the sensors the robot carries (navstress.sensors); None: its default suite, one ``lidar3d``
    #: named ``lidar`` on the ``lidar`` mount with the figures of ``sim.lidar`` (the paper's unit).
    #: Odometry, IMU and pose are built in. Left out of the digest when None.
    sensors: tuple[Sensor, ...] | None = Field(None, strict=LIST)
    # --- the body file the figures were read from (None: none; left out of the digest then)
    body_source: BodySource | None = None

    @model_validator(mode="after")
    def _check(self) -> "RobotSpec":
        check_robot_spec(self)
        return self

    # ---- derived figures ----------------------------------------------------------------
    @property
    def lidar(self) -> LidarMount:
        """The ``lidar`` mount (x, y, z in base_link); the default's when the robot has none."""
        m = self.mounts.get("lidar")
        if m is None:
            return LidarMount()
        return LidarMount(x_m=m.xyz[0], y_m=m.xyz[1], z_m=m.xyz[2])

    def footprint_points(self, segments: int = 32) -> np.ndarray:
        """The footprint as a counter-clockwise polygon, (n, 2) in base_link (a circle: ``segments``
        vertices on it)."""
        fp = self.footprint
        if fp.shape == "box":
            hx, hy = self.length_m / 2, self.width_m / 2
            return np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]], np.float64)
        if fp.shape == "circle":
            assert fp.radius_m is not None
            a = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
            return np.column_stack([fp.radius_m * np.cos(a), fp.radius_m * np.sin(a)])
        assert fp.points is not None
        pts = np.array(fp.points, np.float64)
        return pts if _signed_area(pts) > 0 else pts[::-1].copy()

    @property
    def half_diagonal_m(self) -> float:
        """Radius of the smallest origin-centred circle around the footprint."""
        if self.footprint.shape == "box":
            return float(0.5 * (self.length_m**2 + self.width_m**2) ** 0.5)
        if self.footprint.shape == "circle":
            assert self.footprint.radius_m is not None
            return float(self.footprint.radius_m)
        return float(np.max(np.hypot(*self.footprint_points().T)))

    @property
    def digest(self) -> str:
        """First 16 hex digits of the sha256 of the description (canonical JSON): two robots with
        the same digest are simulated the same."""
        data = self.model_dump(mode="json")
        for key in ("body_source", "sensors"):
            if data.get(key) is None:
                data.pop(key, None)  # the digests of robots without a body file stay as they were
        text = dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def description(self) -> str:
        """The robot as canonical JSON (what a task and a trace carry of it). A robot with its
        default suite (``sensors`` None) leaves ``sensors`` out: its text is the one of before
        sensors were declared (so are its tasks and traces, byte for byte)."""
        data = self.model_dump(mode="json")
        if data.get("sensors") is None:
            data.pop("sensors", None)
        return dumps(data, sort_keys=True, separators=(",", ":"))

    @classmethod
    def footprint_fault(cls) -> "RobotSpec":
        """The paper's faulty belief about its RMP 400: the robot is 0.84 m x 0.45 m."""
        return cls(name="rmp400-small-belief", length_m=0.84, width_m=0.45)


def _signed_area(pts: np.ndarray) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


#: How far beyond its footprint and above its body a sensor mount may be (a mast, an arm).
REACH_M = 1.5


def _refuse(field: str, value: object, expected: str, fix: str | None = None) -> None:
    raise SpecError(field, value, expected, fix)


def check_robot_spec(r: RobotSpec) -> None:
    """The checks across fields (one-line :class:`SpecError` naming the field, relative to the robot,
    and the fix; :func:`navstress._models.parse` with ``prefix="robot"`` names it from the root)."""
    fp = r.footprint
    if fp.shape == "circle":
        if fp.radius_m is None:
            _refuse("footprint.radius_m", None, "a radius > 0 for a circle footprint")
        assert fp.radius_m is not None
        ext = 2 * fp.radius_m
        if not (math.isclose(r.length_m, ext) and math.isclose(r.width_m, ext)):
            # length and width follow the shape: set through object.__setattr__ (frozen model)
            object.__setattr__(r, "length_m", ext)
            object.__setattr__(r, "width_m", ext)
    elif fp.shape == "polygon":
        if fp.points is None or len(fp.points) < 3:
            _refuse("footprint.points", fp.points, "at least 3 points (x, y) of a convex polygon")
        pts = np.array(fp.points, np.float64)
        area = _signed_area(pts)
        if abs(area) < 1e-6:
            _refuse("footprint.points", fp.points, "a polygon of nonzero area")
        if not _convex(pts):
            _refuse("footprint.points", fp.points, "a convex polygon, its points in order around it",
                    "use the convex hull of the body's outline")
        if not _contains(pts if area > 0 else pts[::-1], 0.0, 0.0):
            _refuse("footprint.points", fp.points, "a polygon around base_link's origin (0, 0)")
        lx = float(2 * np.max(np.abs(pts[:, 0])))
        ly = float(2 * np.max(np.abs(pts[:, 1])))
        object.__setattr__(r, "length_m", lx)
        object.__setattr__(r, "width_m", ly)
    elif fp.radius_m is not None or fp.points is not None:
        _refuse("footprint", fp.model_dump(exclude_none=True), "no radius_m or points for a box footprint",
                "set shape: circle or shape: polygon")
    if r.drive == "differential":
        if r.wheels_per_side != 1:
            _refuse("wheels_per_side", r.wheels_per_side,
                    "1 for a differential drive (two driven wheels and passive casters)",
                    "set drive: skid-steer for a base with more driven wheels")
        if not r.caster_positions:
            _refuse("caster_positions", [], "at least one passive caster (x, y) for a differential drive")
    elif r.caster_positions:
        _refuse("caster_positions", [list(c) for c in r.caster_positions],
                f"no casters for a {r.drive} drive", "set drive: differential")
    if r.wheelbase_m == 0 and (r.drive == "ackermann" or (r.drive == "skid-steer" and r.wheels_per_side > 1)):
        _refuse("wheelbase_m", 0.0, f"a distance > 0 between the axles of a {r.drive} drive")
    if r.drive == "ackermann":
        for f in ("max_steer_rad", "max_steer_rate_rps"):
            if getattr(r, f) is None:
                _refuse(f, None, "a number > 0 for an ackermann drive (its steering limit and rate)")
    where_mounts = [(f"mounts.{n}", m) for n, m in r.mounts.items()]
    where_mounts += [(f"sensors[{i}].mount", s.mount) for i, s in enumerate(r.sensors or ())]
    names = [s.name for s in r.sensors or ()]
    for i, n in enumerate(names):
        if n in names[:i]:
            _refuse(f"sensors[{i}].name", n, "a name no other sensor of the robot has", "name each sensor once")
    for where, m in where_mounts:
        check_mount(r, where, m)

def check_mount(r: RobotSpec, where: str, m: Mount) -> None:
    """A mount of ``r`` (a sensor's or a named one) above the ground, not inside the body, within
    :data:`REACH_M` of the body; SpecError naming ``where.xyz`` otherwise."""
    x, y, z = m.xyz
    reach = REACH_M
    top = r.ground_clearance_m - r.wheel_radius_m + r.body_height_m
    if abs(x) > r.length_m / 2 + reach or abs(y) > r.width_m / 2 + reach or z > top + reach:
        _refuse(f"{where}.xyz", list(m.xyz),
                f"a mount within the robot's reach: at most {reach:g} m beyond its footprint "
                f"(|x| <= {r.length_m / 2 + reach:g}, |y| <= {r.width_m / 2 + reach:g}) and {reach:g} m above "
                f"its body (z <= {top + reach:g})", "check the units (meters) and the axes (x forward, z up)")
    if z + r.wheel_radius_m < 0:
        _refuse(f"{where}.xyz", list(m.xyz),
                f"a mount above the ground (z >= -{r.wheel_radius_m:g}, the axle height is z = 0)")
    zb0 = r.ground_clearance_m - r.wheel_radius_m
    zb1 = zb0 + r.body_height_m
    pts = r.footprint_points()
    if zb0 < z < zb1 and _contains(pts, x, y, margin=1e-3):
        _refuse(f"{where}.xyz", list(m.xyz), "a mount on or outside the body, not inside it",
                f"raise z to the top of the body ({zb1:g}) or move it to the footprint's edge")


def _convex(pts: np.ndarray) -> bool:
    n = len(pts)
    sign = 0.0
    for i in range(n):
        a, b, c = pts[i], pts[(i + 1) % n], pts[(i + 2) % n]
        cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        if abs(cross) < 1e-12:
            continue
        if sign == 0.0:
            sign = cross
        elif cross * sign < 0:
            return False
    return sign != 0.0


def _contains(ccw: np.ndarray, x: float, y: float, margin: float = 0.0) -> bool:
    """(x, y) strictly inside the counter-clockwise convex polygon, by more than ``margin``."""
    n = len(ccw)
    for i in range(n):
        a, b = ccw[i], ccw[(i + 1) % n]
        ex, ey = b[0] - a[0], b[1] - a[1]
        cross = ex * (y - a[1]) - ey * (x - a[0])
        if cross <= margin * math.hypot(ex, ey):
            return False
    return True
