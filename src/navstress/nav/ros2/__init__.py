"""The ``ros2`` navigator kind: a ROS 2 stack under test, reached over Zenoh as rmw_zenoh speaks
it (docs/ros2.md). ``config``: :class:`~navstress.nav.ros2.config.Ros2Config`.

Importing this package loads no Zenoh: the navigator's modules are imported when one is made.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstress.errors import SpecError
from navstress.nav.ros2.config import Ros2Config, parse_config

__all__ = ["Ros2Config", "check_launchable", "parse_config", "ros2_from_config"]


def ros2_from_config(*, config: Mapping[str, Any] | None = None) -> Any:
    """Registry factory (``ros2-v1``): a :class:`~navstress.nav.ros2.navigator.Ros2Navigator`."""
    from navstress.nav.ros2.navigator import Ros2Navigator  # local: Zenoh loaded only for a ros2 navigator

    return Ros2Navigator(parse_config(config))


def _validate(config: Mapping[str, Any]) -> None:
    """Before a campaign or a run: the keys (:func:`parse_config`), and that the stack's launch
    command can be started here (its ``cwd`` a directory, its program found as the launch would
    find it, on the ``PATH`` it gets), so that a typo is one line, not a run per attempt."""
    cfg = parse_config(config)
    if cfg.launch is not None:
        check_launchable(cfg.launch)


def check_launchable(launch: Any) -> None:
    """:class:`SpecError` naming ``launch.cwd`` or ``launch.command`` when the command could not
    be started from here."""
    cwd = Path(launch.cwd) if launch.cwd is not None else Path.cwd()
    if not cwd.is_dir():
        raise SpecError("navigator-config.launch.cwd", launch.cwd, "a directory")
    prog = launch.command[0]
    path = launch.env.get("PATH", os.environ.get("PATH", os.defpath))
    if os.sep in prog:
        p = Path(prog) if Path(prog).is_absolute() else cwd / prog
        found = p.is_file() and os.access(p, os.X_OK)
    else:
        found = shutil.which(prog, path=path) is not None
    if not found:
        where = f"relative to {str(cwd)!r}" if os.sep in prog and not Path(prog).is_absolute() else "on the PATH"
        raise SpecError("navigator-config.launch.command", list(launch.command),
                        "a command whose program can be started", f"{prog!r} is not an executable file {where}")


ros2_from_config.validate_config = _validate  # type: ignore[attr-defined]
