"""numba's on-disk cache for this exact source tree, set up by the first kernel module imported.

Every module that compiles with ``@njit(cache=True)`` imports this module before its first
decorator runs (numba reads ``numba.config.CACHE_DIR`` when a dispatcher enables caching, at
decoration time); ``import navstress`` does none of this work. A test checks that every such
module imports it.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

from navstress._paths import cache_dir


def numba_cache_dir() -> str | None:
    """numba's on-disk cache for this exact source tree: ``<cache>/numba/<hash of the sources>``.

    numba keys a cached function by its own file's time stamp only, while the compiled code also
    holds every ``@njit`` function it calls from other files: after an update that touches only a
    callee's file, a caller would keep running the old callee (or crash on a changed signature).
    One cache directory per source tree avoids that. None when the directory cannot be created
    (numba then caches next to the sources, as by default)."""
    h = hashlib.sha256()
    root = Path(__file__).parent
    for p in sorted(root.rglob("*")):
        if p.suffix in (".py", ".c") and p.is_file():
            h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    d = cache_dir() / "numba" / h.hexdigest()[:16]
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return str(d) if os.access(d, os.W_OK) else None


if not os.environ.get("NUMBA_CACHE_DIR"):  # a directory chosen by the user wins
    _dir = numba_cache_dir()
    if _dir is not None:  # (not through the environment: processes navstress starts for others keep theirs)
        numba.config.CACHE_DIR = _dir  # type: ignore[attr-defined]
