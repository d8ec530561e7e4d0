"""Robot files: YAML or JSON with the RobotSpec's fields, a ``base:`` profile to start from and
overrides; or a body of its own (``urdf:`` / ``mjcf:`` with ``drive:`` and ``wheels:``).
(Files to be written: see issue 35, part 3. :func:`robot_from_mapping` is what campaign and
search specs use for a ``robot:`` written inline.)

    >>> robot_from_mapping({"base": "jackal", "name": "our-jackal", "length_m": 0.62}).length_m
    0.62
    >>> robot_from_mapping({"base": "jackal", "mass_kg": -1}, field="robots[1]")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: robots[1].mass_kg=-1 is invalid: expected a value > 0.0
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import ValidationError

from navstress._models import parse, spec_error
from navstress.errors import SpecError
from navstress.robot.profiles import profile
from navstress.robot.spec import RobotSpec


def load_robot(ref: Any) -> RobotSpec:
    if isinstance(ref, dict):
        return robot_from_mapping(ref)
    raise SpecError("robot", ref, "a robot profile (robot files are not supported yet)")


def robot_from_mapping(data: Any, field: str = "robot") -> RobotSpec:
    """A RobotSpec from a mapping: an optional ``base:`` profile (default ``rmp400``) and
    RobotSpec fields that replace the base's (top-level fields replace whole). SpecError naming
    ``field.KEY`` for a bad value, an unknown key or an unknown base (with a "did you mean")."""
    if not isinstance(data, dict):
        raise SpecError(field, data, "a robot profile name, a robot file, or a mapping of RobotSpec fields "
                        "with an optional base: profile")
    over = dict(data)
    base_name = over.pop("base", "rmp400")
    if not isinstance(base_name, str):
        raise SpecError(f"{field}.base", base_name, "a robot profile name")
    try:
        base = profile(base_name)
    except SpecError as err:
        raise SpecError(f"{field}.base", base_name, err.expected, err.fix) from None
    merged = {**base.model_dump(mode="json"), **over}
    try:  # JSON mode: a list stands for a tuple at every depth (caster_positions, footprint.points)
        text = json.dumps(merged, allow_nan=False)
    except (TypeError, ValueError):
        return parse(RobotSpec, merged, prefix=field)  # (names the field that is not JSON data)
    try:
        return RobotSpec.model_validate_json(text)
    except ValidationError as err:
        raise spec_error(err, merged, model=RobotSpec, prefix=field) from None
