"""The colours of a world (ground, obstacle kinds, start and goal), shared by every picture and
model of it (no matplotlib needed).

Light sand (low) -> olive -> brown (high): quiet enough for the obstacles to stand out.
"""

from __future__ import annotations

import numpy as np

#: Fill colours per obstacle kind (unknown kinds cycle through EXTRA_KIND_COLOURS).
KIND_COLOURS: dict[str, str] = {"tree": "#1f6f3a", "building": "#3b4a63"}
EXTRA_KIND_COLOURS = ("#4b4f9c", "#b5651d", "#6a3d9a", "#2b8cbe", "#444444")
#: The mission's start and goal.
START_COLOUR, GOAL_COLOUR = "#1565c0", "#d62828"
#: Colour stops from the lowest to the highest ground, equally spaced.
TERRAIN_STOPS = ("#eef0e2", "#d9d3a8", "#c2a878", "#9b7a55", "#6e5440")


def kind_colour(kind: str, kinds: list[str]) -> str:
    """The fill colour of obstacle ``kind`` among the world's ``kinds`` (sorted)."""
    if kind in KIND_COLOURS:
        return KIND_COLOURS[kind]
    others = [k for k in kinds if k not in KIND_COLOURS]
    return EXTRA_KIND_COLOURS[others.index(kind) % len(EXTRA_KIND_COLOURS)] if kind in others \
        else EXTRA_KIND_COLOURS[0]


def rgb(hex_rgb: str) -> tuple[float, float, float]:
    """``#rrggbb`` as (r, g, b) in [0, 1]."""
    r, g, b = (int(hex_rgb[i:i + 2], 16) / 255 for i in (1, 3, 5))
    return r, g, b


def terrain_colours(t: np.ndarray) -> np.ndarray:
    """RGB in [0, 1], shape ``t.shape + (3,)``, for ``t`` in [0, 1] (clipped): linear between
    the stops, as ``matplotlib.colors.LinearSegmentedColormap.from_list(TERRAIN_STOPS)`` (without
    its 256-entry table)."""
    stops = np.array([rgb(h) for h in TERRAIN_STOPS])
    x = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
    at = np.linspace(0.0, 1.0, len(stops))
    return np.stack([np.interp(x, at, stops[:, c]) for c in range(3)], axis=-1)
