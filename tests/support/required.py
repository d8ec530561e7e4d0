"""Tools a test reads navstress's files with (a browser, Gazebo's libraries): where one is
missing the test is skipped, and under CI (``CI=true``) it fails instead, since ``make test``
installs them."""

from __future__ import annotations

import os

import pytest


def need(ok: bool, why: str) -> None:
    """Go on if ``ok``; else skip with ``why``, or fail under CI."""
    if ok:
        return
    if os.environ.get("CI", "").lower() in ("true", "1", "yes"):
        pytest.fail(f"{why} (required under CI; `make test` installs it)")
    pytest.skip(why)
