"""Robot files: the user's own robot as data (docs/robots.md, "Your own robot").

A robot file (YAML or JSON) or the same mapping given inline (``robot:`` in a campaign spec) holds
the :class:`~navstress.robot.spec.RobotSpec`'s fields, with

- ``base: PROFILE``: a named profile to start from (optional). Without it the robot starts from
  the generic defaults (``RobotSpec()``'s figures) with the firmware figures that the drive model
  derives from the geometry (``track_multiplier``, ``wheel_torque_nm``, ``wheel_kv``,
  ``wheel_armature_kgm2``) left to it: the RMP 400's calibrated constants belong to ``base: rmp400``.
- ``urdf: FILE`` or ``mjcf: FILE`` with ``drive:`` and ``wheels:``: a body of its own, read by
  :mod:`navstress.robot.body` (paths relative to the robot file). Sensor mounts may name a link
  of the body: ``mounts: {lidar: {link: laser}}``.
- every other field overrides. **Merging:** a mapping merges key by key into the base's
  (``mounts: {lidar: {xyz: [0.1, 0, 0.3]}}`` moves the lidar and keeps its ``rpy``; another name
  adds a mount; ``mounts: {lidar: null}`` removes one), except ``footprint``, which replaces the
  base's whole (a circle's radius means nothing to a polygon). Lists replace.
- ``name``: default the file's stem; inline, the base's name when nothing else is given, else
  ``BASE-custom`` (name robots that a campaign compares).

Every bad input is one :class:`~navstress.errors.SpecError` line naming the field and the fix.

    >>> r = robot_from_mapping({"base": "jackal", "name": "our-jackal", "length_m": 0.62})
    >>> (r.name, r.length_m, r.mass_kg)
    ('our-jackal', 0.62, 17.0)
    >>> robot_from_mapping({"base": "jackal", "lenght_m": 0.62})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: robot.lenght_m=0.62 is invalid: expected a robot field; did you mean length_m?
"""

from __future__ import annotations

import copy
import difflib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from navstress._json import dumps
from navstress import specfile
from navstress._models import parse, spec_error
from navstress.errors import SpecError
from navstress.robot.profiles import PROFILES
from navstress.robot.spec import Footprint, Mount, RobotSpec, check_mount
from navstress.sensors import Sensor, default_suite, suite_from_list

#: Keys of a robot file besides the RobotSpec's fields.
FILE_KEYS = ("base", "urdf", "mjcf", "wheels")
#: RobotSpec fields a user does not write (navstress fills them in).
FILLED = ("body_source",)
#: The firmware figures the drive model derives when a robot has no base profile.
DERIVED = ("track_multiplier", "wheel_torque_nm", "wheel_kv", "wheel_armature_kgm2")
#: Suffixes of robot files.
SUFFIXES = (".yaml", ".yml", ".json")


def robot_fields() -> list[str]:
    """The keys a robot file or mapping may hold."""
    return [f for f in RobotSpec.model_fields if f not in FILLED] + list(FILE_KEYS)


def _unknown(path: str, key: Any, value: Any, allowed: list[str], what: str) -> SpecError:
    close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
    fix = f"did you mean {close[0]}?" if close else "one of " + ", ".join(allowed)
    return SpecError(f"{path}.{key}", value, what, fix)


def _check_keys(data: Mapping[str, Any], where: str) -> None:
    allowed = robot_fields()
    for k, v in data.items():
        if k not in allowed:
            raise _unknown(where, k, v, allowed, "a robot field")
    fp = data.get("footprint")
    if isinstance(fp, Mapping):
        for k, v in fp.items():
            if k not in Footprint.model_fields:
                raise _unknown(f"{where}.footprint", k, v, list(Footprint.model_fields), "a footprint field")
    mounts = data.get("mounts")
    if isinstance(mounts, Mapping):
        for name, m in mounts.items():
            if isinstance(m, Mapping):
                keys = [*Mount.model_fields, "link"]
                for k, v in m.items():
                    if k not in keys:
                        raise _unknown(f"{where}.mounts.{name}", k, v, keys, "a mount field")


def generic_start() -> dict[str, Any]:
    """The fields a robot without ``base:`` starts from."""
    d = RobotSpec().model_dump(mode="json")
    for f in (*DERIVED, *FILLED):
        d[f] = None
    d["name"] = "robot"
    return d


def _start(data: Mapping[str, Any], where: str) -> tuple[dict[str, Any], str | None]:
    base = data.get("base")
    if base is None:
        return generic_start(), None
    if not isinstance(base, str):
        raise SpecError(f"{where}.base", base, "a robot profile's name (one of " + ", ".join(sorted(PROFILES)) + ")")
    if base not in PROFILES:
        close = difflib.get_close_matches(base, list(PROFILES), n=1, cutoff=0.5)
        raise SpecError(f"{where}.base", base, "a robot profile (one of " + ", ".join(sorted(PROFILES)) + ")",
                        f"did you mean {close[0]}?" if close else "see `navstress robot list`")
    return PROFILES[base].model_dump(mode="json"), base


def merge(start: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``over`` merged into ``start`` (see the module's doc): mappings key by key, ``footprint``
    replaced whole, a mount set to null removed, anything else replaced."""
    out = copy.deepcopy(start)
    for k, v in over.items():
        if k == "mounts" and isinstance(v, Mapping) and isinstance(out.get("mounts"), dict):
            mounts = out["mounts"]
            for name, m in v.items():
                if m is None:
                    mounts.pop(name, None)
                elif isinstance(m, Mapping) and isinstance(mounts.get(name), dict):
                    mounts[name] = {**mounts[name], **copy.deepcopy(dict(m))}
                else:
                    mounts[name] = copy.deepcopy(m)
        elif k != "footprint" and isinstance(v, Mapping) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _body_path(data: Mapping[str, Any], kind: str, where: str, base_dir: Path | None) -> Path:
    raw = data[kind]
    if not isinstance(raw, str) or not raw:
        raise SpecError(f"{where}.{kind}", raw, f"the path of a {kind.upper()} file (relative to the robot file)")
    p = Path(raw)
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    if not p.is_file():
        rel = f" (relative to {base_dir})" if base_dir is not None and not Path(raw).is_absolute() else ""
        raise SpecError(f"{where}.{kind}", raw, f"a {kind.upper()} file that exists{rel}", "check the path")
    return p


def _with_body(data: Mapping[str, Any], start: dict[str, Any], where: str,
               base_dir: Path | None) -> tuple[dict[str, Any], dict[str, Any]]:
    """``start`` with the figures of the body file (if any), and the links' poses by name."""
    kinds = [k for k in ("urdf", "mjcf") if k in data]
    if len(kinds) == 2:
        raise SpecError(f"{where}.mjcf", data["mjcf"], "either urdf: or mjcf:, not both", "keep one")
    if not kinds:
        if "wheels" in data:
            raise SpecError(f"{where}.wheels", data["wheels"], "wheels: only with a body file (urdf: or mjcf:)",
                            "give the body's file, or the wheels' figures (wheel_radius_m, track_m, ...)")
        return start, {}
    kind = kinds[0]
    path = _body_path(data, kind, where, base_dir)
    drive = data.get("drive", start["drive"] if "base" in data else None)
    if drive is None:
        raise SpecError(f"{where}.drive", None, "the drive type of the body (skid-steer, differential or ackermann)",
                        "add drive: differential (or skid-steer, ackermann)")
    if drive not in ("skid-steer", "differential", "ackermann"):
        raise SpecError(f"{where}.drive", drive, "one of ['skid-steer', 'differential', 'ackermann']")
    if "wheels" not in data:
        shape = "{left: JOINT, right: JOINT}" if drive == "differential" else "{left: [JOINT, ...], right: [JOINT, ...]}"
        raise SpecError(f"{where}.wheels", None, f"the wheel joints of the body, wheels: {shape}",
                        "see docs/robots.md, 'Your own body'")
    from navstress.robot.body import import_body, sha256_file  # MuJoCo only for a robot with a body file

    body = import_body(path, kind, drive, data["wheels"], where)
    out = dict(start)
    out.update(copy.deepcopy(body.fields))
    if "base" not in data:  # the generic start's lidar may sit anywhere on this body: on top of it, centred
        top = out["ground_clearance_m"] + out["body_height_m"] - out["wheel_radius_m"]
        out["mounts"] = {"lidar": {"xyz": [0.0, 0.0, round(top + 0.05, 6)], "rpy": [0.0, 0.0, 0.0]}}
    out["body_source"] = {"kind": kind, "path": str(data[kind]), "sha256": sha256_file(path)}
    return out, dict(body.links)


def _resolve_links(mounts: Any, links: dict[str, Any], where: str) -> Any:
    if not isinstance(mounts, dict):
        return mounts
    out = {}
    for name, m in mounts.items():
        if isinstance(m, dict) and "link" in m:
            link = m["link"]
            if not links:
                raise SpecError(f"{where}.mounts.{name}.link", link, "a link of the body file",
                                "link: needs urdf: or mjcf:; give xyz: instead")
            if link not in links:
                close = difflib.get_close_matches(str(link), list(links), n=1, cutoff=0.5)
                raise SpecError(f"{where}.mounts.{name}.link", link, "a link of the body file (it has: "
                                + ", ".join(sorted(links)) + ")", f"did you mean {close[0]}?" if close else None)
            xyz, rpy = links[link]
            rest = {k: v for k, v in m.items() if k != "link"}
            out[name] = {"xyz": list(xyz), "rpy": list(rpy), **rest}
        else:
            out[name] = m
    return out


def check_physical(r: RobotSpec, where: str) -> None:
    """What the per-field bounds cannot see: an inertia no body has (each principal moment at most
    the sum of the other two)."""
    if r.inertia_kgm2 is not None:
        i = r.inertia_kgm2
        if min(i) <= 0:
            raise SpecError(f"{where}.inertia_kgm2", list(i), "three moments of inertia > 0 (kg m^2)")
        for k in range(3):
            if i[k] > i[(k + 1) % 3] + i[(k + 2) % 3] + 1e-12 * sum(i):
                raise SpecError(f"{where}.inertia_kgm2", list(i),
                                "principal moments each at most the sum of the other two (no body has others)",
                                "leave it out: a box of the footprint and the mass is used")


def robot_from_mapping(data: Any, *, where: str = "robot", base_dir: Path | None = None) -> RobotSpec:
    """The RobotSpec a robot mapping describes (a robot file's content, or ``robot:`` inline in a
    campaign spec). ``where`` names the mapping in error lines (``robots[1]``); ``base_dir`` is
    the folder relative paths (``urdf:``, ``mjcf:``) are taken from (default: the working one)."""
    if not isinstance(data, Mapping):
        raise SpecError(where, data, "a robot profile's name, a robot file, or a mapping of robot fields "
                        "(base:, name:, overrides)", "see `navstress robot list` and docs/robots.md")
    if not all(isinstance(k, str) for k in data):
        bad = next(k for k in data if not isinstance(k, str))
        raise SpecError(f"{where}.{bad}", data[bad], "a robot field (its name is a string)")
    if set(RobotSpec.model_fields) - {"sensors"} <= set(data) and "base" not in data:
        # a whole description, as navstress writes it (a store's spec, a search's spec, a trace):
        # taken as it is (JSON mode: its lists stand for the description's tuples)
        try:
            return RobotSpec.model_validate_json(dumps(dict(data)))
        except ValidationError as err:
            raise spec_error(err, dict(data), model=RobotSpec, prefix=where) from None
    _check_keys(data, where)
    start, base = _start(data, where)
    start, links = _with_body(data, start, where, base_dir)
    over = {k: v for k, v in data.items() if k not in FILE_KEYS}
    if "mounts" in over:
        over["mounts"] = _resolve_links(over["mounts"], links, where)
    merged = merge(start, over)
    shape = merged.get("footprint", {}).get("shape", "box") if isinstance(merged.get("footprint"), dict) else "box"
    for f in ("length_m", "width_m"):
        if f in over and shape != "box":
            raise SpecError(f"{where}.{f}", over[f], f"no {f} with a {shape} footprint (it follows the footprint)",
                            "change the footprint instead, or set footprint: {shape: box}")
    if "name" not in over:
        rest = [k for k in data if k not in ("base", "name")]
        merged["name"] = (base if not rest else f"{base or 'robot'}-custom") if base else "robot"
    if merged.get("sensors") is not None:
        mounts = {k: v if isinstance(v, Mount) else parse(Mount, v, prefix=f"{where}.mounts.{k}")
                  for k, v in (merged.get("mounts") or {"lidar": Mount(xyz=(0.35, 0.0, 0.75))}).items()}
        merged["sensors"] = suite_from_list(merged["sensors"], where=f"{where}.sensors", mounts=mounts)
    robot = parse(RobotSpec, merged, prefix=where)
    check_physical(robot, where)
    return robot


def with_sensors(robot: RobotSpec, *, sensors: Any = None, sensors_add: Any = None,
                 where: str = "") -> RobotSpec:
    """``robot`` with a spec's ``sensors:`` (replacing the robot's suite) and ``sensors_add:``
    (added to it; to its default suite when it has none) applied; unchanged when both are None.
    ``where`` prefixes the keys in error lines (``experiments[0].``)."""
    if sensors is None and sensors_add is None:
        return robot
    base: tuple[Sensor, ...] = robot.sensors if robot.sensors is not None else default_suite(robot.mounts)
    suite = base
    if sensors is not None:
        suite = suite_from_list(sensors, where=f"{where}sensors", mounts=robot.mounts)
        for i, s in enumerate(suite):
            check_mount(robot, f"{where}sensors[{i}].mount", s.mount)
    if sensors_add is not None:
        n0 = len(suite)
        suite = suite_from_list(sensors_add, where=f"{where}sensors_add", mounts=robot.mounts, base=suite)
        for i, s in enumerate(suite[n0:]):
            check_mount(robot, f"{where}sensors_add[{i}].mount", s.mount)
    data = robot.model_dump()
    data["sensors"] = suite
    data["mounts"] = robot.mounts
    try:
        return RobotSpec.model_validate(data, strict=False)
    except ValidationError as err:
        raise spec_error(err, data, model=RobotSpec, prefix=f"{where}robot") from None


def load_robot(ref: Any, *, where: str = "robot") -> RobotSpec:
    """The RobotSpec of ``ref``: a RobotSpec, a profile name, a mapping (:func:`robot_from_mapping`)
    or the path of a robot file (YAML or JSON; its ``name`` defaults to the file's stem)."""
    if isinstance(ref, RobotSpec):
        return ref
    if isinstance(ref, Mapping):
        return robot_from_mapping(ref, where=where)
    if isinstance(ref, str) and ref in PROFILES:
        return PROFILES[ref]
    if not isinstance(ref, (str, Path)):
        raise SpecError(where, ref, "a robot profile's name, a robot file, or a mapping of robot fields")
    p = Path(ref)
    if p.suffix.lower() in (".urdf", ".xml"):
        raise SpecError(where, str(ref), "a robot file (.yaml, .yml, .json) that names the body file",
                        f"write one: {{urdf: {p.name}, drive: differential, wheels: {{left: JOINT, right: JOINT}}}}"
                        if p.suffix.lower() == ".urdf" else
                        f"write one: {{mjcf: {p.name}, drive: differential, wheels: {{left: JOINT, right: JOINT}}}}")
    if p.suffix.lower() not in SUFFIXES:
        close = difflib.get_close_matches(str(ref), list(PROFILES), n=1, cutoff=0.5)
        raise SpecError(where, str(ref), "a robot profile (one of " + ", ".join(sorted(PROFILES))
                        + ") or a robot file (.yaml, .yml, .json)", f"did you mean {close[0]}?" if close else None)
    if not p.exists():
        raise SpecError(where, str(ref), "a robot file that exists", "check the path")
    data = specfile.load_file(p, field=where)
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise SpecError(where, str(ref), "a robot file holding a mapping of robot fields (base:, name:, overrides)")
    data = dict(data)
    data.setdefault("name", p.stem)
    return robot_from_mapping(data, where=f"{where}({p.name})", base_dir=p.parent)
