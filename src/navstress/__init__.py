"""navstress: stress-test robot navigation software in generated virtual worlds.

The public facade, imported on first use: ``navstress.run_mission(world, navigator, seed=...)``
runs one mission in this process, to debug a navigator (see ``docs/plugins.md``).
``import navstress`` does no work (no numba, no MuJoCo, no hashing): numba's cache directory is
set by :mod:`navstress._jit`, which every compiled module imports first.
"""

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
