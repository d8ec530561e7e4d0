"""Where navstress keeps what it builds (re-exported as ``navstress.cache_dir``)."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """Where navstress keeps what it builds: ``$NAVSTRESS_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/navstress``, else ``~/.cache/navstress``."""
    if os.environ.get("NAVSTRESS_CACHE_DIR"):
        return Path(os.environ["NAVSTRESS_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "navstress"
