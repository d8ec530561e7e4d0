"""Ready campaign specs: ``paper`` (the paper's five classes, 5 maps x 5 runs), ``demo`` and
``dynamic`` (moving obstacles).

``paper`` (100 m maps, the paper's mission, timeout 400 s):

- ``buildings``: building obstruction 0..28 % step 2 (15 configs; the paper found no room
  for more 9 m buildings above about 28 %);
- ``trees``: tree obstruction 0..14 % step 1 (15 configs);
- ``smooth-s2``, ``smooth-s4``, ``smooth-s6``: no obstacles, the paper's ground
  (``ground.model: blender``: Blender's Subdivide with ``s`` = 2, 4, 6 cuts and its Fractal value
  ``d``) swept as in the paper's Table I: ``s = 2``: d 0..7, ``s = 4``: 0..5.5, ``s = 6``: 0..3.5,
  steps of 0.5 (15, 12 and 8 configurations: 375, 300 and 200 runs, the paper's counts).

65 configurations x 5 maps x 5 runs = 1,625 nominal runs, plus the ``small-footprint``
fault on the 30 obstacle configurations (750 runs, same maps and run seeds) = 2,375 runs,
against the paper's 2,345 (the paper lists its ground sweeps but not its obstruction increments:
it ran 900 building and 570 tree runs where this preset runs 375 + 375 nominal).

``demo``: 40 m maps (the mission scaled down: start and goal 5 m from the corners, 42 m
apart), 4 tree configurations (0-14 %: dense enough for the footprint fault to collide),
2 maps x 3 runs, nominal plus the fault (48 runs); 3 terrain configurations whose maps are
repeated adaptively (2 to 5 runs each, until the map is proven to pass, or to fail, at least
half the time with 75 % confidence: 4 runs when every run agrees; at most 30 runs, 25 on
the preset's seed); a ``movers`` class, 1 and 4 intercepting pedestrians on open ground
(:data:`DEMO_MOVERS`), 2 maps x 3 runs, nominal (12 runs); sized to finish in under a minute
on 2 cores and still feed every analysis (difficulty needs several configurations incl. the
flat empty one, indeterminism needs 2+ runs per map, fault power needs paired faulty runs).

``dynamic``: 40 m maps with 4 % trees and pedestrians steered online to cross ahead of the
robot (:data:`DEMO_MOVERS`); class ``count`` sweeps 0, 1, 2, 4, 8 pedestrians (clearance 2 m),
class ``aggressiveness`` sweeps the clearance they aim at, 6, 4, 2, 1, 0 m (0: a collision
course; 2 pedestrians); 3 maps x 3 runs, nominal (90 runs).
"""

from __future__ import annotations

import copy
from typing import Any

import yaml

from navstress.errors import SpecError

PRESETS = ("demo", "paper", "dynamic")
#: The demo's adaptive rule (its ``smooth-s4`` class): does a map pass at least half the time?
DEMO_RULE = {"min": 2, "max": 5, "threshold": 0.5, "confidence": 0.75}


#: The movers of the demo's ``movers`` class and of the ``dynamic`` preset: pedestrians steered
#: online to cross 2 m ahead of the robot (``aim: clearance``: a robot that stands still sees them
#: pass in front of it, not walk into it).
DEMO_MOVERS: dict[str, Any] = {"count": {"pedestrian": 2},
                               "behaviour": {"pedestrian": {"kind": "intercept", "aim": "clearance", "clearance_m": 2.0}}}


#: The paper's ground sweeps (Table I): cuts s -> the largest Fractal value d, from 0 in steps of 0.5.
PAPER_GROUND_SWEEPS = {2: 7.0, 4: 5.5, 6: 3.5}


def paper() -> dict[str, Any]:
    """The paper's design (see module doc)."""
    smooth = [
        {"name": f"smooth-s{s}", "overrides": {"ground": {"model": "blender", "subdivisions": s}},
         "sweep": {"ground.deformation": {"start": 0.0, "stop": stop, "step": 0.5}}, "faults": [None]}
        for s, stop in PAPER_GROUND_SWEEPS.items()
    ]
    return {
        "name": "paper",
        "seed": 2016,
        "world": {"size_m": [100.0, 100.0], "cell_m": 0.4},
        "experiments": [
            {"name": "buildings", "sweep": {"obstacles.obstruction.building": {"start": 0, "stop": 28, "step": 2}}},
            {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"start": 0, "stop": 14, "step": 1}}},
            *smooth,
        ],
        "maps_per_config": 5,
        "runs_per_map": 5,
        "navigators": [{"name": "reference-v1", "config": {}}],
        "faults": [None, "small-footprint"],
        "timeout_s": 400.0,
        "goal_tolerance_m": 2.0,
    }


def demo() -> dict[str, Any]:
    """A small campaign showing every analysis, and adaptive repetition, in about a minute on 2 cores."""
    return {
        "name": "demo",
        "seed": 7,
        "world": {"size_m": [40.0, 40.0], "cell_m": 0.4},
        "experiments": [
            {"name": "trees", "sweep": {"obstacles.obstruction.tree": {"values": [0, 6, 10, 14]}}},
            {"name": "smooth-s4", "overrides": {"ground": {"subdivisions": 4}},
             "sweep": {"ground.deformation": {"values": [0.5, 1.0, 1.5]}}, "faults": [None],
             "runs_per_map": {"adaptive": dict(DEMO_RULE)}},
            {"name": "movers", "overrides": {"movers": copy.deepcopy(DEMO_MOVERS)},
             "sweep": {"movers.count.pedestrian": {"values": [1, 4]}}, "faults": [None]},
        ],
        "maps_per_config": 2,
        "runs_per_map": 3,
        "navigators": [{"name": "reference-v1", "config": {}}],
        "faults": [None, "small-footprint"],
        "timeout_s": 120.0,
        "goal_tolerance_m": 2.0,
    }


def dynamic() -> dict[str, Any]:
    """Moving obstacles (see module doc): mover count, and how close ahead of the robot the
    intercepting pedestrians aim."""
    return {
        "name": "dynamic",
        "seed": 15,
        "world": {"size_m": [40.0, 40.0], "cell_m": 0.4, "obstacles": {"obstruction": {"tree": 4}},
                  "movers": copy.deepcopy(DEMO_MOVERS)},
        "experiments": [
            {"name": "count", "sweep": {"movers.count.pedestrian": {"values": [0, 1, 2, 4, 8]}}},
            {"name": "aggressiveness",
             "sweep": {"movers.behaviour.pedestrian.clearance_m": {"values": [6.0, 4.0, 2.0, 1.0, 0.0]}}},
        ],
        "maps_per_config": 3,
        "runs_per_map": 3,
        "navigators": [{"name": "reference-v1", "config": {}}],
        "faults": [None],
        "timeout_s": 120.0,
        "goal_tolerance_m": 2.0,
    }


def preset(name: str) -> dict[str, Any]:
    """The preset ``name`` as a spec mapping."""
    if name == "paper":
        return paper()
    if name == "demo":
        return demo()
    if name == "dynamic":
        return dynamic()
    raise SpecError("preset", name, f"one of {list(PRESETS)}")


def preset_yaml(name: str) -> str:
    """The preset as commented YAML, ready to edit."""
    data = preset(name)
    head = (f"# navstress campaign spec: preset '{name}'.\n"
            "# Run it with: navstress campaign run THIS_FILE -o DIR\n"
            "# Every map and run seed derives from `seed`; `faults: [null, ...]` (null = nominal).\n")
    return head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None)
