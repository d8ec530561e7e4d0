"""navstress: stress-test robot navigation software in generated virtual worlds.

The public facade, imported on first use (``import navstress`` stays cheap):
``navstress.run_mission(world, navigator, seed=...)`` runs one mission in this process, to
debug a navigator (see ``docs/plugins.md``).
"""

import hashlib
import os
from pathlib import Path
from typing import Any

__version__ = "0.1.0"
__all__ = ["__version__", "cache_dir", "run_mission"]


def __getattr__(name: str) -> Any:
    """The lazily imported part of the facade."""
    if name == "run_mission":
        from navstress._facade import run_mission

        return run_mission
    raise AttributeError(f"module 'navstress' has no attribute {name!r}")


def cache_dir() -> Path:
    """Where navstress keeps what it builds: ``$NAVSTRESS_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/navstress``, else ``~/.cache/navstress``."""
    if os.environ.get("NAVSTRESS_CACHE_DIR"):
        return Path(os.environ["NAVSTRESS_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "navstress"


def _numba_cache_dir() -> str | None:
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
    _dir = _numba_cache_dir()
    if _dir is not None:
        import numba  # (not through the environment: processes navstress starts for others keep theirs)

        numba.config.CACHE_DIR = _dir  # type: ignore[attr-defined]
