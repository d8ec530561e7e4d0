"""The reference navigation stack under test: the paper's POM + DTM + P3D, rebuilt.

``reference-v1`` is :class:`ReferenceNavigator` (local arc planner only, as in the paper);
``reference-global-v1`` is :class:`GlobalNavigator` (the same, guided by a global cost-to-go).
See docs/navigator.md.
"""

from navstress.nav.reference.config import GlobalConfig, ReferenceConfig, load_config, parse_config
from navstress.nav.reference.global_planner import GlobalNavigator
from navstress.nav.reference.navigator import NO_ARC, ReferenceNavigator

__all__ = ["NAVIGATORS", "NO_ARC", "GlobalConfig", "GlobalNavigator", "ReferenceConfig", "ReferenceNavigator",
           "load_config", "parse_config"]

#: navigator id -> class (for the registry's entry points)
NAVIGATORS = {"reference-v1": ReferenceNavigator, "reference-global-v1": GlobalNavigator}
