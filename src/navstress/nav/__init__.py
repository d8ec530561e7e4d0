"""Navigation under test: the Navigator contract and how any stack plugs into navstress.

The facade: the contract types (:mod:`navstress.nav.api`), the registry
(:func:`make_navigator`, :func:`register`, :func:`list_navigators`), and, imported on first use,
the conformance checker (:func:`check_navigator`), fault injection (:func:`apply_fault`,
:func:`list_faults`) and the out-of-process adapter (:class:`ExternalNavigator`).
See docs/plugins.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from navstress.nav.api import (
    Command,
    Imu,
    LidarScan,
    NavMission,
    Navigator,
    Observation,
    Odometry,
    PoseReading,
    Status,
)
from navstress.nav.registry import list_navigators, make_navigator, register, unregister

if TYPE_CHECKING:  # for the type checker only: __getattr__ imports these on first use
    from navstress.nav.check import CheckReport, check_navigator, format_report
    from navstress.nav.external import ExternalNavigator
    from navstress.nav.faults import FaultyNavigator, apply_fault, list_faults

__all__ = [
    "CheckReport", "Command", "ExternalNavigator", "FaultyNavigator", "Imu", "LidarScan",
    "NavMission", "Navigator", "Observation", "Odometry", "PoseReading", "Status", "apply_fault",
    "check_navigator", "format_report", "list_faults", "list_navigators", "make_navigator",
    "register", "unregister",
]

_LAZY = {
    "CheckReport": "navstress.nav.check", "check_navigator": "navstress.nav.check",
    "format_report": "navstress.nav.check", "ExternalNavigator": "navstress.nav.external",
    "FaultyNavigator": "navstress.nav.faults", "apply_fault": "navstress.nav.faults",
    "list_faults": "navstress.nav.faults",
}


def __getattr__(name: str) -> Any:
    """Import the checker, faults and external adapter only when first used (this package runs
    on `import navstress.nav.api`, the contract, which must stay cheap)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'navstress.nav' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
