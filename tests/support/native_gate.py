"""Whether a test of the native (AVX-512) terrain walk runs, skips or fails.

Where the native walk cannot run (no AVX-512, no C compiler, ``NAVSTRESS_NATIVE=0``) its tests
skip, unless ``NAVSTRESS_REQUIRE_NATIVE=1``: then they fail. ``.ci/run`` sets it on every CI
machine whose CPU and compiler allow the walk, so a change to the numba walk that the C walk
does not mirror cannot pass CI there.
"""

from __future__ import annotations

import os

import pytest

from navstress.sim import native

REQUIRE = "NAVSTRESS_REQUIRE_NATIVE"


def required() -> bool:
    """Whether ``NAVSTRESS_REQUIRE_NATIVE`` asks for the native walk's tests to run."""
    return os.environ.get(REQUIRE, "").strip().lower() in ("1", "true", "yes", "on")


def need(ok: bool, why: str) -> None:
    """Go on if ``ok``; else skip the test, or fail it when the native walk is required."""
    if ok:
        return
    if required():
        pytest.fail(f"{REQUIRE}=1 but {why}", pytrace=False)
    pytest.skip(why)


def require_native() -> int:
    """The native walk's address; skips (or fails, see :func:`need`) where it cannot run."""
    need(native.available(), f"native walk {native.status()}")
    return native.load().address


def require_compiler() -> None:
    """Skips (or fails) where the C walk cannot be compiled (its CPU check aside)."""
    st = native.status()
    need(native.available() or st.startswith("off (this CPU"), f"no working C compiler here: {st}")
