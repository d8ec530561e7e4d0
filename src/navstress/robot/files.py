"""Robot files: YAML or JSON with the RobotSpec's fields, a ``base:`` profile to start from and
overrides; or a body of its own (``urdf:`` / ``mjcf:`` with ``drive:`` and ``wheels:``).
(To be written: see issue 35, part 3.)"""

from __future__ import annotations

from typing import Any

from navstress.errors import SpecError
from navstress.robot.spec import RobotSpec


def load_robot(ref: Any) -> RobotSpec:
    raise SpecError("robot", ref, "a robot profile (robot files are not supported yet)")
