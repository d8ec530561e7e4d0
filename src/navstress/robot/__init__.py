"""The robot: its description as validated data (:class:`RobotSpec`), the named profiles, and
:func:`resolve_robot` (a profile name, a robot file, a mapping, or a RobotSpec -> a RobotSpec).

    >>> resolve_robot("jackal").name
    'jackal'
    >>> resolve_robot(None) == RobotSpec()
    True
"""

from __future__ import annotations

from typing import Any

from navstress.robot.profiles import PROFILES, profile
from navstress.robot.spec import DRIVES, Footprint, LidarMount, Mount, RobotSpec

__all__ = ["DRIVES", "PROFILES", "Footprint", "LidarMount", "Mount", "RobotSpec", "profile", "resolve_robot"]


def resolve_robot(ref: Any) -> RobotSpec:
    """A RobotSpec from what a user wrote: None (the default, ``rmp400``), a RobotSpec, a profile
    name, or (see :mod:`navstress.robot.files`) a robot file path or a mapping with an optional
    ``base:`` profile and overrides."""
    if ref is None:
        return PROFILES["rmp400"]
    if isinstance(ref, RobotSpec):
        return ref
    if isinstance(ref, str) and ref in PROFILES:
        return PROFILES[ref]
    if isinstance(ref, str) and not ref.lower().endswith((".yaml", ".yml", ".json", ".urdf", ".xml")):
        return profile(ref)  # unknown profile: SpecError with a "did you mean"
    from navstress.robot.files import load_robot  # files (and MuJoCo for URDF/MJCF) only when asked for

    return load_robot(ref)
