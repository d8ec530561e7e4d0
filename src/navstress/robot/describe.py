"""What ``navstress robot show`` prints and draws: a robot's derived figures, its wheel layout, and
its top view (footprint, wheels, casters, sensor mounts, base_link's axes) as SVG or PNG.

The picture is drawn on an Agg canvas of its own (no pyplot, no global backend), like the other
pictures of navstress; its parts carry ids in the SVG (``footprint``, ``wheel-0``, ``caster-0``,
``mount-lidar``, ``base_link``) so that tools and tests can find them.

    >>> from navstress.robot.profiles import profile
    >>> [(round(x, 3), round(y, 3)) for x, y, _side in wheel_layout(profile("jackal"))]
    [(0.131, 0.188), (-0.131, 0.188), (0.131, -0.188), (-0.131, -0.188)]
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from navstress import _files
from navstress.errors import SpecError
from navstress.robot.spec import RobotSpec
from navstress.sensors import Sensor, default_suite

#: Picture formats of ``robot show -o`` (by the file's suffix).
FORMATS = (".svg", ".png")


def wheel_layout(r: RobotSpec) -> list[tuple[float, float, str]]:
    """The wheels' centres (x, y) in base_link and their side (``left``/``right``), left first,
    front to rear: skid-steer ``wheels_per_side`` evenly over the wheelbase, differential one on
    each side at x = 0, ackermann a front and a rear axle."""
    n = 2 if r.drive == "ackermann" else r.wheels_per_side
    xs = [0.0] if n == 1 else list(np.linspace(r.wheelbase_m / 2, -r.wheelbase_m / 2, n))
    return [(float(x), s * r.track_m / 2, side) for s, side in ((1, "left"), (-1, "right")) for x in xs]


def _area(pts: np.ndarray) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _inscribed(pts: np.ndarray) -> float:
    """Distance from the origin to the nearest edge of the convex polygon."""
    out = math.inf
    for a, b in zip(pts, np.roll(pts, -1, axis=0)):
        e = b - a
        out = min(out, abs(float(e[0] * a[1] - e[1] * a[0])) / float(np.hypot(*e)))
    return out


def inertia(r: RobotSpec) -> tuple[float, float, float]:
    """The chassis' principal moments: the given ones, or those of a box of the footprint's
    length and width, the body's height and the whole mass."""
    if r.inertia_kgm2 is not None:
        return r.inertia_kgm2
    m, lx, ly, lz = r.mass_kg, r.length_m, r.width_m, r.body_height_m
    return (m * (ly**2 + lz**2) / 12, m * (lx**2 + lz**2) / 12, m * (lx**2 + ly**2) / 12)


def figures(r: RobotSpec) -> dict[str, Any]:
    """Every figure of ``r`` a person checks, derived ones included (numbers in SI units; None
    for a firmware figure the drive model derives)."""
    pts = r.footprint_points()
    out: dict[str, Any] = {
        "drive": r.drive,
        "footprint": r.footprint.shape,
        "length_m": r.length_m,
        "width_m": r.width_m,
        "footprint_area_m2": _area(pts),
        "circumscribed_radius_m": r.half_diagonal_m,
        "inscribed_radius_m": _inscribed(pts),
        "body_height_m": r.body_height_m,
        "ground_clearance_m": r.ground_clearance_m,
        "top_above_ground_m": r.ground_clearance_m + r.body_height_m,
        "mass_kg": r.mass_kg,
        "inertia_kgm2": list(inertia(r)),
        "inertia_from": "given" if r.inertia_kgm2 is not None else "a box of the footprint",
        "wheel_radius_m": r.wheel_radius_m,
        "wheel_width_m": r.wheel_width_m,
        "wheelbase_m": r.wheelbase_m,
        "track_m": r.track_m,
        "wheels": len(wheel_layout(r)),
        "wheels_per_side": r.wheels_per_side,
        "casters": [list(c) for c in r.caster_positions],
        "max_speed_mps": r.max_speed_mps,
        "max_yaw_rate_rps": r.max_yaw_rate_rps,
        "max_accel_mps2": r.max_accel_mps2,
        "max_yaw_accel_rps2": r.max_yaw_accel_rps2,
        "top_wheel_speed_rps": r.max_speed_mps / r.wheel_radius_m,
    }
    if r.drive == "ackermann":
        assert r.max_steer_rad is not None
        out["max_steer_rad"] = r.max_steer_rad
        out["max_steer_rate_rps"] = r.max_steer_rate_rps
        out["min_turn_radius_m"] = r.wheelbase_m / math.tan(r.max_steer_rad)
        out["drive_wheels"] = r.drive_wheels
    for f in ("track_multiplier", "wheel_torque_nm", "wheel_kv", "wheel_armature_kgm2"):
        out[f] = getattr(r, f)
    out["gyro"] = r.gyro
    out["odom_heading"] = r.odom_heading
    out["mounts"] = {k: {"xyz": list(m.xyz), "rpy": list(m.rpy),
                         "height_above_ground_m": m.xyz[2] + r.wheel_radius_m} for k, m in r.mounts.items()}
    out["sensors"] = [sensor_figures(x, r) for x in sensor_suite(r)]
    if r.body_source is not None:
        out["body_source"] = r.body_source.model_dump(mode="json")
    return out


def sensor_suite(r: RobotSpec) -> tuple[Sensor, ...]:
    """The sensors ``r`` carries: its own, or its default suite."""
    return r.sensors if r.sensors is not None else default_suite(r.mounts)


def sensor_summary(kind: str, p: dict[str, Any]) -> str:
    """A sensor's main figures in a few words (``navstress robot show``, ``navstress sensor list``)."""
    if kind == "lidar3d":
        return (f"{p['channels']} ch {p['min_elevation_deg']:g}..{p['max_elevation_deg']:g} deg x "
                f"{p['azimuth_steps']} steps, {p['min_range_m']:g}-{p['max_range_m']:g} m, {p['rate_hz']:g} Hz")
    if kind == "lidar2d":
        return (f"{p['fov_deg']:g} deg, {p['beams']} beams, {p['min_range_m']:g}-{p['max_range_m']:g} m, "
                f"{p['rate_hz']:g} Hz")
    if kind == "depth":
        return (f"{p['width']} x {p['height']} px, {p['hfov_deg']:g} deg wide, {p['min_range_m']:g}-"
                f"{p['max_range_m']:g} m, {p['rate_hz']:g} Hz")
    return ", ".join(f"{k} {v}" for k, v in p.items())


def sensor_figures(x: Sensor, r: RobotSpec) -> dict[str, Any]:
    """One sensor of ``navstress robot show --json``."""
    return {"name": x.name, "kind": x.kind, "profile": x.profile, "xyz": list(x.mount.xyz),
            "rpy": list(x.mount.rpy), "height_above_ground_m": x.mount.xyz[2] + r.wheel_radius_m,
            "default": r.sensors is None, "params": dict(x.params), "summary": sensor_summary(x.kind, x.params)}


def describe(r: RobotSpec) -> dict[str, Any]:
    """The JSON object of ``navstress robot show --json``."""
    return {"name": r.name, "digest": r.digest, "description": r.model_dump(mode="json"),
            "figures": figures(r),
            "wheels": [{"x_m": x, "y_m": y, "side": s} for x, y, s in wheel_layout(r)]}


def _text(v: Any) -> str:
    if v is None:
        return "(derived by the drive model)"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(_text(x) for x in v) + "]" if v else "none"
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_text(x)}" for k, x in v.items())
    return str(v)


def rows(r: RobotSpec) -> list[tuple[str, str]]:
    """The terminal table of ``navstress robot show``: (figure, value) rows."""
    out = [("name", r.name), ("digest", r.digest)]
    for k, v in figures(r).items():
        if k == "mounts":
            for name, m in v.items():
                out.append((f"mount {name}", f"xyz {_text(m['xyz'])}, rpy {_text(m['rpy'])}, "
                                             f"{m['height_above_ground_m']:.3g} m above the ground"))
        elif k == "sensors":
            for x in v:
                out.append((f"sensor {x['name']}" + (" (default)" if x["default"] else ""),
                            f"{x['kind']} {x['profile']}: {x['summary']}; xyz {_text(x['xyz'])}, rpy {_text(x['rpy'])}"))
        else:
            out.append((k, _text(v)))
    for i, (x, y, s) in enumerate(wheel_layout(r)):
        out.append((f"wheel {i} ({s})", f"x {x:+.3f} m, y {y:+.3f} m"))
    return out


def draw(r: RobotSpec) -> Any:
    """The top view of ``r`` on a matplotlib Figure of its own."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, FancyArrow, Polygon, Rectangle, Wedge

    fig = Figure(figsize=(6.4, 5.6), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    pts = r.footprint_points()
    fp = Polygon(pts, closed=True, facecolor="#dfe7f2", edgecolor="#2c5fd6", linewidth=1.6, label="footprint")
    fp.set_gid("footprint")
    ax.add_patch(fp)
    for i, (x, y, _s) in enumerate(wheel_layout(r)):
        w = Rectangle((x - r.wheel_radius_m, y - r.wheel_width_m / 2), 2 * r.wheel_radius_m, r.wheel_width_m,
                      facecolor="#333333", edgecolor="black", label="wheels" if i == 0 else None)
        w.set_gid(f"wheel-{i}")
        ax.add_patch(w)
    for i, (x, y) in enumerate(r.caster_positions):
        c = Circle((x, y), r.caster_radius_m or 0.02, facecolor="#8c8c8c", edgecolor="black",
                   label="casters" if i == 0 else None)
        c.set_gid(f"caster-{i}")
        ax.add_patch(c)
    scale = max(r.length_m, r.width_m, r.track_m + r.wheel_width_m)
    for name, m in r.mounts.items():
        (x, y, _z), yaw = m.xyz, m.rpy[2]
        (mk,) = ax.plot([x], [y], marker="D", color="#d7191c", markersize=7, linestyle="none")
        mk.set_gid(f"mount-{name}")
        ax.add_patch(FancyArrow(x, y, 0.12 * scale * math.cos(yaw), 0.12 * scale * math.sin(yaw),
                                width=0.006 * scale, color="#d7191c", length_includes_head=True))
        ax.annotate(f"{name} (z {m.xyz[2] + r.wheel_radius_m:.2f} m)", (x, y), xytext=(6, 6),
                    textcoords="offset points", fontsize=8, color="#d7191c")
    for i, sn in enumerate(sensor_suite(r)):
        fov = float({"lidar2d": sn.params.get("fov_deg"), "depth": sn.params.get("hfov_deg")}.get(sn.kind) or 360.0)
        (sx, sy, _z), yaw = sn.mount.xyz, math.degrees(sn.mount.rpy[2])
        wedge = Wedge((sx, sy), 0.25 * scale, yaw - fov / 2, yaw + fov / 2, facecolor="#fdae61", alpha=0.25,
                      edgecolor="#e66101", linewidth=0.8, label="sensor fields of view" if i == 0 else None)
        wedge.set_gid(f"sensor-{sn.name}")
        ax.add_patch(wedge)
        ax.annotate(f"{sn.name}: {sn.kind}", (sx, sy), xytext=(6, -12 - 10 * i), textcoords="offset points", fontsize=7.5,
                    color="#a6400a")
    a = 0.18 * scale
    ax.add_patch(FancyArrow(0, 0, a, 0, width=0.008 * scale, color="#c0392b", length_includes_head=True, gid="base_link"))
    ax.add_patch(FancyArrow(0, 0, 0, a, width=0.008 * scale, color="#1a9641", length_includes_head=True))
    ax.annotate("base_link", (0, 0), xytext=(-8, -14), textcoords="offset points", fontsize=8)
    half = 0.6 * scale + 0.05
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [m] (forward)")
    ax.set_ylabel("y [m] (left)")
    ax.set_title(f"{r.name}: {r.drive}, {r.length_m:.3g} m x {r.width_m:.3g} m, {r.mass_kg:.3g} kg "
                 f"(digest {r.digest})", fontsize=9.5, loc="left")
    ax.legend(loc="lower right", fontsize=8)
    return fig


def write_picture(r: RobotSpec, path: str | Path) -> Path:
    """Write the top view of ``r`` to ``path`` (PNG for ``.png``, else SVG: ``.svg`` or no suffix),
    atomically."""
    p = Path(path)
    fmt = p.suffix.lower() or ".svg"
    if fmt not in FORMATS:
        raise SpecError("--output", str(p), "a picture file ending in .svg or .png (no suffix: SVG)")
    fig = draw(r)
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt[1:])
    _files.write_atomic(p, buf.getvalue())
    return p
