"""The ``ros2`` navigator kind: a ROS 2 stack under test, reached over Zenoh as rmw_zenoh speaks
it (docs/ros2.md). ``config``: :class:`~navstress.nav.ros2.config.Ros2Config`.

Importing this package loads no Zenoh: the navigator's modules are imported when one is made.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from navstress.nav.ros2.config import Ros2Config, parse_config

__all__ = ["Ros2Config", "parse_config", "ros2_from_config"]


def ros2_from_config(*, config: Mapping[str, Any] | None = None) -> Any:
    """Registry factory (``ros2-v1``): a :class:`~navstress.nav.ros2.navigator.Ros2Navigator`."""
    from navstress.nav.ros2.navigator import Ros2Navigator  # local: Zenoh loaded only for a ros2 navigator

    return Ros2Navigator(parse_config(config))


def _validate(config: Mapping[str, Any]) -> None:
    parse_config(config)


ros2_from_config.validate_config = _validate  # type: ignore[attr-defined]
