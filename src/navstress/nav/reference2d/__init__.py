"""``reference-2d-v1``: a reference stack for robots with a 2D scanner, with the architecture of
Nav2's defaults (costmap from the scans inflated by the footprint, A* global planner, DWB-style
local planner, recoveries). See docs/plugins.md ("reference-2d-v1")."""

from navstress.nav.reference2d.config import Reference2dConfig, parse_config
from navstress.nav.reference2d.navigator import NO_PATH, NO_TRAJECTORY, Reference2dNavigator

__all__ = ["NO_PATH", "NO_TRAJECTORY", "Reference2dConfig", "Reference2dNavigator", "parse_config"]
