"""The ground's colours, shared by every picture and model of a world (no matplotlib needed).

Light sand (low) -> olive -> brown (high): quiet enough for the obstacles to stand out.
"""

from __future__ import annotations

import numpy as np

#: Colour stops from the lowest to the highest ground, equally spaced.
TERRAIN_STOPS = ("#eef0e2", "#d9d3a8", "#c2a878", "#9b7a55", "#6e5440")


def terrain_colours(t: np.ndarray) -> np.ndarray:
    """RGB in [0, 1], shape ``t.shape + (3,)``, for ``t`` in [0, 1] (clipped): linear between
    the stops, as ``matplotlib.colors.LinearSegmentedColormap.from_list(TERRAIN_STOPS)`` (without
    its 256-entry table)."""
    stops = np.array([[int(h[i:i + 2], 16) / 255 for i in (1, 3, 5)] for h in TERRAIN_STOPS])
    x = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
    at = np.linspace(0.0, 1.0, len(stops))
    return np.stack([np.interp(x, at, stops[:, c]) for c in range(3)], axis=-1)
