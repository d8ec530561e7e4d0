"""The line protocol spoken by out-of-process navigators: one JSON object per line.

navstress (the host) writes one request per line on the navigator's stdin and reads exactly one
reply line from its stdout for every request except ``close``. The full schema with example
lines is in ``docs/plugins.md``; in short:

====================================================  =====================================================
host -> navigator                                      navigator -> host
====================================================  =====================================================
``{"type":"hello","protocol":1}``                      ``{"type":"hello","protocol":1,"name":"..."}``
``{"type":"reset","mission":{..},"robot":{..},         ``{"type":"ok"}``  (or a ``status`` error)
"seed":N}`` (mission: start, goal, goal_tolerance_m,
bounds: the geofence [xmin, ymin, xmax, ymax] or null)
``{"type":"step","obs":{..}}`` (``"debug":true``       ``{"type":"command","v":..,"omega":..}`` or
when the host records the navigator's drawings)        ``{"type":"status","kind":"arrived"|"error",
                                                       "message":".."}``, either with an optional
                                                       ``"debug":{..}`` (:func:`encode_debug`)
``{"type":"close"}``                                   (no reply; the process exits)
====================================================  =====================================================

Lidar points travel as base64 of little-endian float32 ``(N, 3)`` to keep lines compact.

**Versions.** The host's ``hello`` says ``"protocol":1`` (every host speaks it); the navigator's
reply names the version it speaks, 1 or 2 (:data:`PROTOCOLS`), and the host speaks that one from
then on. Version 1 is byte for byte what it was before sensors were declared (a robot's reset
carries no ``sensors`` field). Version 2 (docs/plugins.md, "Version 2: every sensor"):

- ``reset``'s robot holds ``sensors``: the resolved suite (name, kind, profile, mount, params);
- ``obs`` drops ``scans`` and adds ``readings``: by sensor name, the list of that sensor's
  readings since the previous step, each an object with ``kind`` and the kind's fields
  (``to_wire`` of its module under :mod:`navstress.sensors.kinds`); binary payloads (ranges,
  points, depth images) are base64 arrays ``{"dtype":"<f4","shape":[..],"data":".."}``
  (:func:`navstress.sensors.base.encode_array`) in the same line: one message per step, no
  side channel to order or lose. ``odom``, ``imu`` and ``pose`` stay as in version 1.

    >>> from navstress.nav.api import Odometry, Imu, Observation
    >>> obs = Observation(0.1, Odometry(0.1, 0, 0, 0, 0, 0), Imu(0.1, 0, 0, 0, (0, 0, 0)))
    >>> decode_observation(encode_observation(obs)).odom.t
    0.1
"""

from __future__ import annotations

import base64
import json
from typing import Any

import numpy as np

from navstress.nav.api import (
    Command,
    DebugDraw,
    DebugLine,
    DebugPoints,
    DebugText,
    Imu,
    InvalidAnswer,
    LidarScan,
    NavMission,
    Observation,
    Odometry,
    PoseReading,
    Status,
    check_answer,
    check_debug,
)
from navstress.robot import RobotSpec
from navstress.sensors import SensorKind, default_suite, kinds

__all__ = [
    "PROTOCOL_VERSION", "WireError", "decode_command_or_status", "decode_mission",
    "decode_debug", "decode_observation", "decode_points", "dumps", "encode_command_or_status", "encode_debug",
    "encode_mission", "encode_observation", "encode_points", "loads", "step_message",
    "reset_message", "hello_message", "close_message", "PROTOCOLS", "LATEST", "encode_readings", "decode_readings",
]

PROTOCOL_VERSION = 1
"""The version the host's ``hello`` names (the first; every host and navigator speaks it)."""
PROTOCOLS = (1, 2)
"""The versions navstress speaks; a navigator answers ``hello`` with one of them."""
LATEST = PROTOCOLS[-1]


class WireError(ValueError):
    """A line that is not a valid protocol message (the text says what is wrong)."""


# ---------------------------------------------------------------- low level

def dumps(msg: dict[str, Any]) -> bytes:
    """One message as one UTF-8 line, newline included (no NaN/inf allowed)."""
    return (json.dumps(msg, separators=(",", ":"), allow_nan=False) + "\n").encode("utf-8")


def _reject_constant(name: str) -> float:
    raise WireError(f"non-finite number {name} is not allowed")


def loads(line: bytes | str) -> dict[str, Any]:
    """Parse one line into a message object; :class:`WireError` says why it is not one."""
    if isinstance(line, bytes):
        try:
            line = line.decode("utf-8")
        except UnicodeDecodeError as e:
            raise WireError(f"not UTF-8 ({e.reason} at byte {e.start})") from None
    text = line.strip()
    if not text:
        raise WireError("empty line")
    try:
        msg = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as e:
        raise WireError(f"not JSON ({e.msg}): {_clip(text)}") from None
    if not isinstance(msg, dict):
        raise WireError(f"expected a JSON object, got {type(msg).__name__}: {_clip(text)}")
    kind = msg.get("type")
    if not isinstance(kind, str):
        raise WireError(f"missing string field 'type': {_clip(text)}")
    return msg


def _clip(text: str, n: int = 120) -> str:
    return repr(text if len(text) <= n else text[:n] + "...")


def encode_points(points: np.ndarray) -> str:
    """(N, 3) points as base64 of little-endian float32, row-major."""
    arr = np.ascontiguousarray(np.asarray(points, dtype="<f4").reshape(-1, 3))
    return base64.b64encode(arr.tobytes()).decode("ascii")


def decode_points(data: str, n: int | None = None) -> np.ndarray:
    """Inverse of :func:`encode_points`: an (N, 3) float32 array (native byte order)."""
    try:
        raw = base64.b64decode(data.encode("ascii"), validate=True)
    except (ValueError, UnicodeEncodeError) as e:
        raise WireError(f"points are not valid base64: {e}") from None
    if len(raw) % 12:
        raise WireError(f"points hold {len(raw)} bytes, not a multiple of 12 (3 x float32)")
    pts = np.frombuffer(raw, dtype="<f4").reshape(-1, 3).astype(np.float32)
    if n is not None and len(pts) != n:
        raise WireError(f"points field holds {len(pts)} points but n={n}")
    return pts


# ---------------------------------------------------------------- host -> navigator

def hello_message() -> dict[str, Any]:
    return {"type": "hello", "protocol": PROTOCOL_VERSION}


def close_message() -> dict[str, Any]:
    return {"type": "close"}


def encode_mission(mission: NavMission) -> dict[str, Any]:
    return {
        "start": [float(v) for v in mission.start],
        "goal": [float(v) for v in mission.goal],
        "goal_tolerance_m": float(mission.goal_tolerance_m),
        "bounds": None if mission.bounds is None else [float(v) for v in mission.bounds],
    }


def decode_mission(d: dict[str, Any]) -> NavMission:
    try:
        sx, sy, syaw = (float(v) for v in d["start"])
        gx, gy = (float(v) for v in d["goal"])
        b = d.get("bounds")
        bounds = None
        if b is not None:
            x0, y0, x1, y1 = (float(v) for v in b)
            bounds = (x0, y0, x1, y1)
        return NavMission((sx, sy, syaw), (gx, gy), float(d.get("goal_tolerance_m", 2.0)), bounds)
    except (KeyError, TypeError, ValueError) as e:
        raise WireError(f"invalid mission {d!r}: {e}") from None


def reset_message(mission: NavMission, robot: RobotSpec, seed: int, protocol: int = 1) -> dict[str, Any]:
    """A ``reset`` request. Version 1: the robot without ``sensors`` (as before they were
    declared); version 2: with its resolved suite (the default one when it lists none)."""
    data = robot.model_dump(mode="json")
    if protocol >= 2:
        if robot.sensors is None:
            data["sensors"] = [s.model_dump(mode="json") for s in default_suite(robot.mounts)]
    else:
        data.pop("sensors", None)
    return {
        "type": "reset",
        "mission": encode_mission(mission),
        "robot": data,
        "seed": int(seed),
    }


def _kind_of(reading: Any) -> SensorKind:
    for k in kinds().values():
        if isinstance(reading, k.reading):
            return k
    raise WireError(f"no sensor kind reads {type(reading).__name__}")


def encode_readings(readings: Any) -> dict[str, list[dict[str, Any]]]:
    """Version 2's ``readings``: every sensor's readings by name, each ``{"kind", ...}``."""
    out: dict[str, list[dict[str, Any]]] = {}
    for name, items in readings.items():
        enc = []
        for r in items:
            k = _kind_of(r)
            if k.to_wire is None:
                raise WireError(f"the {k.name} sensor kind has no line-protocol encoder")
            enc.append({"kind": k.name, **k.to_wire(r)})
        out[str(name)] = enc
    return out


def decode_readings(d: Any) -> dict[str, tuple[Any, ...]]:
    """Inverse of :func:`encode_readings`; :class:`WireError` says which reading is bad."""
    if not isinstance(d, dict):
        raise WireError(f"readings is a {type(d).__name__}, not an object")
    known = kinds()
    out: dict[str, tuple[Any, ...]] = {}
    for name, items in d.items():
        if not isinstance(items, list):
            raise WireError(f"readings.{name} is a {type(items).__name__}, not a list")
        dec = []
        for j, item in enumerate(items):
            kname = item.get("kind") if isinstance(item, dict) else None
            k = known.get(kname) if isinstance(kname, str) else None
            if k is None or k.from_wire is None:
                raise WireError(f"readings.{name}[{j}] has no known kind ({kname!r:.40}); kinds: "
                                + ", ".join(known))
            try:
                dec.append(k.from_wire({kk: v for kk, v in item.items() if kk != "kind"}))
            except (ValueError, TypeError, KeyError) as e:
                raise WireError(f"readings.{name}[{j}] is not a {k.name} reading: {e}") from None
        out[str(name)] = tuple(dec)
    return out


def encode_observation(obs: Observation, protocol: int = 1) -> dict[str, Any]:
    """The ``obs`` of a step request in version ``protocol`` (see the module's text)."""
    if protocol >= 2:
        out = _encode_v1(obs)
        del out["scans"]  # every lidar3d's scans are in readings
        out["readings"] = encode_readings(obs.readings)
        return out
    return _encode_v1(obs)


def _encode_v1(obs: Observation) -> dict[str, Any]:
    o, i = obs.odom, obs.imu
    out: dict[str, Any] = {
        "t": float(obs.t),
        "odom": {"t": o.t, "x": o.x, "y": o.y, "yaw": o.yaw, "v": o.v, "omega": o.omega},
        "imu": {"t": i.t, "roll": i.roll, "pitch": i.pitch, "yaw": i.yaw,
                "rates": [float(r) for r in i.rates]},
        "pose": None,
        "scans": [
            {"t": float(s.t), "mount": [float(m) for m in s.mount],
             "n": int(np.asarray(s.points).reshape(-1, 3).shape[0]),
             "points": encode_points(s.points)}
            for s in obs.scans
        ],
    }
    if obs.pose is not None:
        p = obs.pose
        out["pose"] = {"t": p.t, "x": p.x, "y": p.y, "z": p.z,
                       "yaw": p.yaw, "pitch": p.pitch, "roll": p.roll}
    # plain floats everywhere (numpy scalars are not JSON)
    for key in ("odom", "imu", "pose"):
        sub = out[key]
        if sub is not None:
            for k, v in sub.items():
                if k != "rates":
                    sub[k] = float(v)
    return out


def step_message(obs: Observation, *, debug: bool = False, protocol: int = 1) -> dict[str, Any]:
    """A ``step`` request; ``debug``: the host records the navigator's drawing (``"debug": true``),
    which the navigator may then add to its reply (:func:`encode_debug`)."""
    msg: dict[str, Any] = {"type": "step", "obs": encode_observation(obs, protocol)}
    if debug:
        msg["debug"] = True
    return msg


def encode_debug(draw: DebugDraw) -> dict[str, Any]:
    """A :class:`~navstress.nav.api.DebugDraw` as the optional ``"debug"`` field of a step reply
    (points as lists of [x, y, z]; docs/plugins.md)."""
    return {"lines": [{"points": ln.points.tolist(), "frame": ln.frame, "colour": list(ln.colour),
                       "width_m": ln.width_m} for ln in draw.lines],
            "points": [{"points": p.points.tolist(), "frame": p.frame, "colour": list(p.colour),
                        "size_m": p.size_m} for p in draw.points],
            "texts": [{"position": list(t.position), "text": t.text, "frame": t.frame, "colour": list(t.colour),
                       "size_m": t.size_m} for t in draw.texts]}


def decode_debug(d: object) -> DebugDraw:
    """Inverse of :func:`encode_debug`, checked by :func:`~navstress.nav.api.check_debug`; missing
    fields take the :class:`~navstress.nav.api.DebugDraw` defaults. :class:`InvalidAnswer` says
    what is wrong."""
    if not isinstance(d, dict):
        raise InvalidAnswer(f"debug is a {type(d).__name__}, not an object")
    unknown = sorted(set(d) - {"lines", "points", "texts"})
    if unknown:
        raise InvalidAnswer(f"debug has unknown field(s) {', '.join(map(repr, unknown))}")
    keys = {"lines": ("points", "frame", "colour", "width_m"), "points": ("points", "frame", "colour", "size_m"),
            "texts": ("position", "text", "frame", "colour", "size_m")}
    cls = {"lines": DebugLine, "points": DebugPoints, "texts": DebugText}
    parts: dict[str, list[Any]] = {}
    for kind in ("lines", "points", "texts"):
        items = d.get(kind, [])
        if not isinstance(items, list):
            raise InvalidAnswer(f"debug.{kind} is a {type(items).__name__}, not a list")
        parts[kind] = []
        for i, item in enumerate(items):
            if not isinstance(item, dict) or set(item) - set(keys[kind]):
                raise InvalidAnswer(f"debug.{kind}[{i}] is not an object with fields {', '.join(keys[kind])}")
            if keys[kind][0] not in item:
                raise InvalidAnswer(f"debug.{kind}[{i}] has no {keys[kind][0]!r}")
            args = {k: (tuple(v) if k in ("colour", "position") and isinstance(v, list) else v)
                    for k, v in item.items()}
            parts[kind].append(cls[kind](**args))
    return check_debug(DebugDraw(tuple(parts["lines"]), tuple(parts["points"]), tuple(parts["texts"])))


def decode_observation(d: dict[str, Any]) -> Observation:
    """Inverse of :func:`encode_observation` (for navigators written in Python), either version:
    with ``readings`` (version 2), ``scans`` are the lidar3d readings in the order taken."""
    if not isinstance(d, dict):
        raise WireError(f"invalid observation: a {type(d).__name__}, not an object")
    if "readings" in d:
        readings = decode_readings(d["readings"])
        v1 = _decode_v1({**d, "scans": []})
        scans = sorted((r for items in readings.values() for r in items if isinstance(r, LidarScan)),
                       key=lambda r: r.t)
        return Observation(v1.t, v1.odom, v1.imu, v1.pose, tuple(scans), readings)
    return _decode_v1(d)


def _decode_v1(d: dict[str, Any]) -> Observation:
    try:
        od, im = d["odom"], d["imu"]
        odom = Odometry(*(float(od[k]) for k in ("t", "x", "y", "yaw", "v", "omega")))
        r = [float(v) for v in im["rates"]]
        imu = Imu(float(im["t"]), float(im["roll"]), float(im["pitch"]), float(im["yaw"]),
                  (r[0], r[1], r[2]))
        pose = None
        if d.get("pose") is not None:
            pd = d["pose"]
            pose = PoseReading(*(float(pd[k]) for k in ("t", "x", "y", "z", "yaw", "pitch", "roll")))
        scans = tuple(
            LidarScan(float(s["t"]), decode_points(s["points"], s.get("n")),
                      tuple(float(m) for m in s["mount"]))  # type: ignore[arg-type]
            for s in d.get("scans", [])
        )
        return Observation(float(d["t"]), odom, imu, pose, scans)
    except (KeyError, TypeError, ValueError, IndexError) as e:
        if isinstance(e, WireError):
            raise
        raise WireError(f"invalid observation: {type(e).__name__}: {e}") from None


# ---------------------------------------------------------------- navigator -> host

def encode_command_or_status(out: Command | Status) -> dict[str, Any]:
    if isinstance(out, Command):
        return {"type": "command", "v": float(out.v), "omega": float(out.omega)}
    return {"type": "status", "kind": out.kind, "message": out.message}


def decode_command_or_status(msg: dict[str, Any]) -> Command | Status:
    """A navigator's answer to ``step``; :class:`WireError` for anything else.

    The decoded answer goes through :func:`navstress.nav.api.check_answer`, the validation
    the run loop applies to in-process navigators: one bad answer gets the same reason
    whichever way it came."""
    kind = msg.get("type")
    if kind == "command":
        answer: Command | Status = Command(msg.get("v"), msg.get("omega"))  # type: ignore[arg-type]
    elif kind == "status":
        answer = Status(msg.get("kind"), msg.get("message", ""))  # type: ignore[arg-type]
    else:
        raise WireError(f"expected a 'command' or 'status' message, got type {kind!r}")
    try:
        return check_answer(answer)
    except InvalidAnswer as e:
        raise WireError(str(e)) from None
