"""navstress: stress-test robot navigation software in generated virtual worlds.

The public facade, imported on first use: ``navstress.run_mission(world, navigator, seed=...)``
runs one mission in this process, to debug a navigator (see ``docs/plugins.md``).
``import navstress`` does no work (no numba, no MuJoCo, no hashing): numba's cache directory is
set by :mod:`navstress._jit`, which every compiled module imports first.
"""

from typing import Any

from navstress._paths import cache_dir

__version__ = "0.1.0"
__all__ = ["__version__", "cache_dir", "run_mission"]


def __getattr__(name: str) -> Any:
    """The lazily imported part of the facade."""
    if name == "run_mission":
        from navstress._facade import run_mission  # local: the facade runs missions (numba, MuJoCo)

        return run_mission
    raise AttributeError(f"module 'navstress' has no attribute {name!r}")
