"""A robot's body from the user's URDF or MJCF: MuJoCo compiles the file, and the figures a
:class:`~navstress.robot.spec.RobotSpec` needs are read from the compiled model.

What is taken (docs/robots.md, "Your own body"):

- **mass** (the sum over the robot's bodies) and **inertia** (the whole robot's, about its centre of
  mass, the diagonal in base_link's axes);
- **wheels**: each declared wheel joint must be a hinge; its anchor is the wheel's position, its
  radius and width come from the wheel's collision geometry (the extent across and along the
  joint's axis); ``track_m``, ``wheelbase_m`` and ``wheels_per_side`` follow;
- **casters** (differential): the collision geometry, other than the wheels, that touches the
  ground plane the wheels stand on;
- **footprint**: the convex hull of the collision geometry other than the wheels, projected on
  the ground (a ``polygon``); **body height** and **ground clearance**: the vertical extent of that
  geometry, casters left out;
- **frames**: base_link is put at the centre of the driven wheels, at their axle height, with the
  axes of the file's root body (x forward, y left, z up): every position above is given in it.

navstress then simulates the robot with its own generated body (the footprint prism between the
ground clearance and the body's top), firmware, sensors and observer: the file's meshes, joints
other than the wheels, and its own controllers are not simulated.

    >>> from pathlib import Path
    >>> b = import_body(Path("examples/robots/small_diff.urdf"), "urdf", "differential",
    ...                 {"left": "left_wheel_joint", "right": "right_wheel_joint"}, "robot")
    >>> round(b.fields["mass_kg"], 3), round(b.fields["track_m"], 3), round(b.fields["wheel_radius_m"], 3)
    (6.7, 0.34, 0.05)
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navstress.errors import SpecError

#: The joint types of MuJoCo (mjtJoint): free, ball, slide, hinge.
_HINGE = 3
#: Geometry types (mjtGeom).
_PLANE, _HFIELD, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = 0, 1, 2, 3, 4, 5, 6, 7
#: How near the ground (m, or this fraction of the wheel radius, the larger) a non-wheel
#: geometry's lowest point must be to count as a caster.
CASTER_TOL_M = 0.005
CASTER_TOL_FRACTION = 0.1


@dataclass(frozen=True)
class Body:
    """What a URDF/MJCF gives a RobotSpec: ``fields`` (RobotSpec fields), and the poses of the
    file's bodies (links) in base_link, for sensor mounts given by ``link:``."""

    fields: dict[str, Any]
    links: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = field(default_factory=dict)
    joints: tuple[str, ...] = ()


def short_error(err: BaseException) -> str:
    """MuJoCo's message on one line, at most 200 characters."""
    text = " ".join(str(err).split())
    return text if len(text) <= 200 else text[:197] + "..."


def sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _compile(path: Path, kind: str, field_name: str) -> Any:
    import mujoco  # MuJoCo only for a robot with a body file (it takes ~0.2 s to import)

    try:
        spec = mujoco.MjSpec.from_file(str(path))
        spec.compiler.fusestatic = False  # keep every link: the root's mass and the links of mounts
        return spec.compile()
    except ValueError as err:
        raise SpecError(field_name, str(path), f"a {kind.upper()} file MuJoCo compiles",
                        f"MuJoCo says: {short_error(err)}") from None


def _side(wheels: Any, side: str, field_name: str, drive: str) -> list[str]:
    v = wheels.get(side) if isinstance(wheels, dict) else None
    if isinstance(v, str):
        return [v]
    if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
        return list(v)
    shape = ("a joint name" if drive == "differential" else "a list of joint names, front to rear")
    raise SpecError(f"{field_name}.{side}", v, f"{shape} (the {side} wheels' hinge joints in the body file)")


def wheel_names(wheels: Any, drive: str, field_name: str) -> tuple[list[str], list[str], list[str]]:
    """The declared joints: left wheels, right wheels, steering joints (ackermann)."""
    if not isinstance(wheels, dict):
        raise SpecError(field_name, wheels, "a mapping {left: JOINT, right: JOINT} naming the wheel joints",
                        "see docs/robots.md, 'Your own body'")
    allowed = {"left", "right"} | ({"steering"} if drive == "ackermann" else set())
    for k in wheels:
        if k not in allowed:
            raise SpecError(f"{field_name}.{k}", wheels[k], f"one of the keys {sorted(allowed)} for a {drive} drive")
    left, right = _side(wheels, "left", field_name, drive), _side(wheels, "right", field_name, drive)
    steering: list[str] = []
    if "steering" in wheels:
        s = wheels["steering"]
        steering = [s] if isinstance(s, str) else s if isinstance(s, list) else []
        if not steering or not all(isinstance(x, str) for x in steering):
            raise SpecError(f"{field_name}.steering", s, "a list of the steering joints' names (left, right)")
    if len(left) != len(right):
        raise SpecError(f"{field_name}.right", right, f"as many wheels as on the left ({len(left)})")
    if drive == "differential" and len(left) != 1:
        raise SpecError(f"{field_name}.left", left, "one wheel joint per side for a differential drive",
                        "set drive: skid-steer for more driven wheels")
    if drive == "ackermann" and len(left) != 2:
        raise SpecError(f"{field_name}.left", left, "two wheel joints per side (front, rear) for an ackermann drive")
    if drive == "skid-steer" and len(left) > 4:
        raise SpecError(f"{field_name}.left", left, "at most 4 wheels per side")
    return left, right, steering


def _geom_points(m: Any, d: Any, g: int) -> np.ndarray:
    """Points on the outline of geom ``g``, in world coordinates (n, 3)."""
    t = int(m.geom_type[g])
    s = m.geom_size[g]
    a = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    ring = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    if t == _SPHERE:
        local = np.vstack([ring * s[0], [[0, 0, s[0]], [0, 0, -s[0]]]])
    elif t == _ELLIPSOID:
        local = np.vstack([ring * s[:3], np.column_stack([ring[:, 0] * s[0], 0 * a, ring[:, 1] * s[2]]),
                           np.column_stack([0 * a, ring[:, 0] * s[1], ring[:, 1] * s[2]])])
    elif t in (_CYLINDER, _CAPSULE):
        r, h = s[0], s[1]
        local = np.vstack([ring * r + [0, 0, h], ring * r - [0, 0, h]])
        if t == _CAPSULE:
            local = np.vstack([local, [[0, 0, h + r], [0, 0, -h - r]],
                               np.column_stack([ring[:, 0] * r, 0 * a, ring[:, 1] * r + h]),
                               np.column_stack([ring[:, 0] * r, 0 * a, ring[:, 1] * r - h])])
    elif t == _MESH and int(m.geom_dataid[g]) >= 0:
        mid = int(m.geom_dataid[g])
        adr, n = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
        local = np.asarray(m.mesh_vert[adr:adr + n], np.float64)
    else:  # box, and any other shape: the corners of its bounding box
        c, h = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
        sgn = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], np.float64)
        local = c + sgn * h
    rot = np.asarray(d.geom_xmat[g], np.float64).reshape(3, 3)
    return np.asarray(local, np.float64) @ rot.T + np.asarray(d.geom_xpos[g], np.float64)


def _hull(pts: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise, no collinear points (monotone chain)."""
    p = sorted({(round(float(x), 6), round(float(y), 6)) for x, y in pts})
    if len(p) < 3:
        return np.array(p, np.float64)

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for q in p:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 1e-12:
            lower.pop()
        lower.append(q)
    upper: list[tuple[float, float]] = []
    for q in reversed(p):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 1e-12:
            upper.pop()
        upper.append(q)
    return np.array(lower[:-1] + upper[:-1], np.float64)


def _subtree(m: Any, root: int) -> set[int]:
    out = {root}
    for b in range(root + 1, m.nbody):
        if int(m.body_parentid[b]) in out:
            out.add(b)
    return out


def _rpy(r: np.ndarray) -> tuple[float, float, float]:
    """Roll, pitch, yaw (x-y-z fixed axes) of a rotation matrix."""
    pitch = math.asin(max(-1.0, min(1.0, -float(r[2, 0]))))
    roll = math.atan2(float(r[2, 1]), float(r[2, 2]))
    yaw = math.atan2(float(r[1, 0]), float(r[0, 0]))
    return (roll, pitch, yaw)


def _r(v: float) -> float:
    return round(float(v), 6) + 0.0  # 6 decimals (micrometres): stable digests; no -0.0


def import_body(path: Path, kind: str, drive: str, wheels: Any, field_name: str) -> Body:
    """The RobotSpec fields of the body in ``path`` (``kind``: ``urdf`` or ``mjcf``), with the
    wheel joints ``wheels`` of a ``drive`` drive; one-line SpecError naming ``field_name`` (the
    robot's path in the user's spec) for anything it lacks."""
    import mujoco  # see _compile

    fk = f"{field_name}.{kind}"
    fw = f"{field_name}.wheels"
    left, right, steering = wheel_names(wheels, drive, fw)
    m = _compile(path, kind, fk)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    names = {m.joint(j).name: j for j in range(m.njnt) if m.joint(j).name}

    def joint(name: str, where: str) -> int:
        if name not in names:
            have = ", ".join(sorted(names)) or "none"
            raise SpecError(where, name, f"a joint of {path.name} (it has: {have})", "check the joint's name")
        j = names[name]
        if int(m.jnt_type[j]) != _HINGE:
            raise SpecError(where, name, "a hinge joint (URDF continuous or revolute, MJCF hinge)",
                            "name the joint the wheel turns about")
        return j

    lj = [joint(n, f"{fw}.left") for n in left]
    rj = [joint(n, f"{fw}.right") for n in right]
    sj = [joint(n, f"{fw}.steering") for n in steering]
    wheel_bodies = {int(m.jnt_bodyid[j]) for j in lj + rj}
    if len(wheel_bodies) != len(lj) + len(rj):
        raise SpecError(fw, wheels, "one joint per wheel (each wheel joint on a body of its own)")
    # the robot's root body: the child of the world that holds the wheels
    b = int(m.jnt_bodyid[lj[0]])
    while int(m.body_parentid[b]) != 0:
        b = int(m.body_parentid[b])
    base = b
    robot_bodies = _subtree(m, base)
    if not wheel_bodies <= robot_bodies:
        raise SpecError(fw, wheels, "wheel joints on one robot (one root body holds them all)")
    wheel_tree: set[int] = set()
    for wb in wheel_bodies:
        wheel_tree |= _subtree(m, wb)
    rb = np.asarray(d.xmat[base], np.float64).reshape(3, 3)
    ob = np.asarray(d.xpos[base], np.float64)

    def in_base(p: np.ndarray) -> np.ndarray:
        return np.asarray((np.asarray(p, np.float64) - ob) @ rb, np.float64)

    collide = [g for g in range(m.ngeom) if int(m.geom_bodyid[g]) in robot_bodies
               and (int(m.geom_contype[g]) or int(m.geom_conaffinity[g])) and int(m.geom_type[g]) not in (_PLANE, _HFIELD)]
    if not collide:
        raise SpecError(fk, str(path), "a body with collision geometry (URDF <collision>, MJCF geoms that collide)")

    def wheel_figures(j: int, where: str) -> tuple[np.ndarray, float, float]:
        wb = int(m.jnt_bodyid[j])
        axis = np.asarray(d.xaxis[j], np.float64)
        radius = width = 0.0
        geoms = [g for g in collide if int(m.geom_bodyid[g]) in _subtree(m, wb)]
        if not geoms:
            raise SpecError(where, m.joint(j).name, "a wheel with collision geometry (its radius is read from it)")
        for g in geoms:
            rot = np.asarray(d.geom_xmat[g], np.float64).reshape(3, 3)
            ax = np.abs(rot.T @ axis)
            k = int(np.argmax(ax))
            half = m.geom_aabb[g][3:]
            radius = max(radius, float(max(half[i] for i in range(3) if i != k)))
            width = max(width, float(2 * half[k]))
        return in_base(d.xanchor[j]), radius, width

    wl = [wheel_figures(j, f"{fw}.left") for j in lj]
    wr = [wheel_figures(j, f"{fw}.right") for j in rj]
    allw = wl + wr
    centre = np.mean([w[0] for w in allw], axis=0)
    radius = float(np.mean([w[1] for w in allw]))
    width = float(np.mean([w[2] for w in allw]))
    yl = float(np.mean([w[0][1] for w in wl])) - centre[1]
    yr = float(np.mean([w[0][1] for w in wr])) - centre[1]
    if yl <= yr:
        raise SpecError(f"{fw}.left", left, "the wheels on the left (+y of the root body, x forward)",
                        "swap left and right")
    xs = [w[0][0] for w in wl]
    wheelbase = float(max(xs) - min(xs)) if len(xs) > 1 else 0.0
    if drive != "differential" and len(xs) > 1 and wheelbase < 1e-3:
        raise SpecError(f"{fw}.left", left, "wheels one behind the other (they are all on one axle)")
    ground = centre[2] - radius

    def shift(p: np.ndarray) -> np.ndarray:
        return np.asarray(p - centre, np.float64)

    body_pts: list[np.ndarray] = []
    chassis_pts: list[np.ndarray] = []
    casters: list[tuple[float, float, float]] = []
    tol = max(CASTER_TOL_M, CASTER_TOL_FRACTION * radius)
    for g in collide:
        if int(m.geom_bodyid[g]) in wheel_tree:
            continue
        pts = shift(in_base(_geom_points(m, d, g)))
        body_pts.append(pts)
        bottom = float(pts[:, 2].min())
        if bottom - (ground - centre[2]) <= tol:
            c = pts.mean(axis=0)
            casters.append((float(c[0]), float(c[1]), float((c[2] - bottom))))
        else:
            chassis_pts.append(pts)
    if not body_pts:
        raise SpecError(fk, str(path), "collision geometry on the body besides the wheels (the footprint is its outline)")
    if drive != "differential":
        chassis_pts = body_pts  # no casters: a low part of the body is body
        casters = []
    elif not casters:
        raise SpecError(fk, str(path), "a passive caster for a differential drive: collision geometry "
                        "besides the wheels that touches the ground the wheels stand on")
    if not chassis_pts:
        raise SpecError(fk, str(path), "a chassis: collision geometry above the ground besides the wheels and casters")
    allp = np.vstack(body_pts)
    chassis = np.vstack(chassis_pts)
    hull = _hull(allp[:, :2])
    if len(hull) < 3:
        raise SpecError(fk, str(path), "collision geometry with an outline of nonzero area seen from above")
    z0 = float(chassis[:, 2].min()) + radius  # above the ground (the ground is at z = -radius)
    z1 = float(chassis[:, 2].max()) + radius
    # mass and inertia of the whole robot
    mass = float(sum(m.body_mass[b] for b in robot_bodies))
    if mass <= 0:
        raise SpecError(fk, str(path), "a body with mass (URDF <inertial>, MJCF mass or density)")
    com = sum(m.body_mass[b] * np.asarray(d.xipos[b]) for b in robot_bodies) / mass
    inertia = np.zeros((3, 3))
    for b in robot_bodies:
        ri = np.asarray(d.ximat[b], np.float64).reshape(3, 3)
        inertia += ri @ np.diag(m.body_inertia[b]) @ ri.T
        r = np.asarray(d.xipos[b]) - com
        inertia += m.body_mass[b] * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    inertia = rb.T @ inertia @ rb
    fields: dict[str, Any] = {
        "drive": drive,
        "footprint": {"shape": "polygon", "points": [[_r(x), _r(y)] for x, y in hull]},
        "body_height_m": _r(max(z1 - z0, 1e-3)),
        "ground_clearance_m": _r(max(z0, 0.0)),
        "mass_kg": _r(mass),
        "inertia_kgm2": [_r(max(inertia[i, i], 1e-9)) for i in range(3)],
        "wheel_radius_m": _r(radius),
        "wheel_width_m": _r(width),
        "wheelbase_m": _r(wheelbase),
        "track_m": _r(yl - yr),
        "wheels_per_side": 1 if drive == "ackermann" else len(lj),
        "caster_positions": [[_r(c[0]), _r(c[1])] for c in casters],
        "caster_radius_m": _r(max(c[2] for c in casters)) if casters else None,
    }
    if drive == "ackermann" and sj:
        lims = []
        for j in sj:
            if m.jnt_limited[j]:
                lo, hi = (float(v) for v in m.jnt_range[j])
                lims.append(min(abs(lo), abs(hi)))
        if lims and min(lims) > 0:
            fields["max_steer_rad"] = _r(min(min(lims), math.pi / 2 - 1e-3))
    links: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {}
    for bb in sorted(robot_bodies):
        nm = m.body(bb).name
        if nm:
            p = shift(in_base(d.xpos[bb]))
            rot = rb.T @ np.asarray(d.xmat[bb], np.float64).reshape(3, 3)
            roll, pitch, yaw = _rpy(rot)
            links[nm] = ((_r(p[0]), _r(p[1]), _r(p[2])), (_r(roll), _r(pitch), _r(yaw)))
    return Body(fields=fields, links=links, joints=tuple(sorted(names)))
