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

``barn`` (``navstress campaign init --preset barn --barn DIR [--all]``, :func:`barn`): the BARN
benchmark's protocol (docs/worlds.md, "The BARN benchmark") on the BARN worlds in ``DIR``, a folder
laid out as in the BARN repository (``world_N.world``, ``path_files/path_N.npy``): the Jackal with
a UST-10-class scanner at BARN's mount, ``reference-2d-v1``, each world imported from its Gazebo
file with BARN's mission in the file's frame, success within 1 m, 100 s, a collision ends the run
(every navstress run stops at its first collision); the test set (worlds 0, 6, ..., 294) or all
300 worlds, 10 runs each.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import yaml

from navstress.errors import MISSING, SpecError

PRESETS = ("demo", "paper", "dynamic")
#: The presets made from a folder of worlds the user names (``--barn DIR``), after :data:`PRESETS`.
FOLDER_PRESETS = ("barn",)
#: Every preset ``campaign init`` writes.
ALL_PRESETS = PRESETS + FOLDER_PRESETS
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


# ---- BARN -------------------------------------------------------------------------------------

#: BARN's mission in its worlds' frame (the BARN repository's run.py, static worlds 0-299): start
#: (-2.25, 3) m facing +y (its 1.57 rad written as pi/2 to 4 decimals), the goal 10 m ahead.
BARN_START = (-2.25, 3.0, 1.5708)
BARN_GOAL = (-2.25, 13.0)
#: The BARN test set: the 50 worlds 0, 6, ..., 294 (its test.sh), each run 10 times.
BARN_TEST_WORLDS = tuple(range(0, 300, 6))
BARN_ALL_WORLDS = tuple(range(300))
BARN_RUNS = 10
#: The scanner of BARN's Jackal, as its run.py sets it (JACKAL_LASER_MODEL=ust10,
#: JACKAL_LASER_OFFSET="-0.065 0 0.01" on the front mount) and jackal_description (melodic-devel)
#: places it: front_mount (0.12, 0, 0.184) in base_link, the bracket -0.065 m back and 0.01 m up,
#: the focal point 0.0474 m above the bracket; base_link is 0.0345 m below the axles, so in
#: navstress's base_link (at the axle height) x = 0.055, z = 0.184 + 0.01 + 0.0474 - 0.0345 =
#: 0.2069. The figures are those of the Gazebo sensor of jackal_description's hokuyo_ust10 macro
#: (what BARN's stacks see: 50 Hz, 0.1-30 m, Gaussian noise 0.001 m, 270 degrees), except its 720
#: samples 0.3755 degrees apart: 721 beams 0.375 degrees apart, a step that divides the circle, so
#: the simulation casts the fan at once (docs/simulation.md) instead of ray by ray (ten times slower).
BARN_SCANNER: dict[str, Any] = {
    "name": "front_laser", "kind": "lidar2d", "profile": "ust10",
    "mount": {"xyz": [0.055, 0.0, 0.2069], "rpy": [0.0, 0.0, 0.0]},
    "fov_deg": 270.0, "beams": 721, "rate_hz": 50.0, "min_range_m": 0.1, "max_range_m": 30.0,
    "range_noise_std_m": 0.001,
}
#: Free ground kept around a BARN world's cylinders when it is imported (``source.margin_m``):
#: the cylinders span y in [0, 9.6] m of the file's frame, BARN's goal is at y = 13 on Gazebo's
#: open 100 m ground plane; 5 m puts the map's edge 1.6 m beyond the goal (the simulation stops a
#: robot 0.7 m from an edge) and leaves room around the corridor, as Gazebo's open ground does.
BARN_MARGIN_M = 5.0
#: What a BARN folder holds (errors).
BARN_LAYOUT = ("a BARN worlds folder laid out as in the BARN repository (jackal_helper/worlds/BARN: "
               "world_N.world and path_files/path_N.npy)")


def barn_world_file(folder: str | Path, n: int) -> Path:
    """World ``n``'s Gazebo file in a BARN folder."""
    return Path(folder) / f"world_{n}.world"


def barn_path_file(folder: str | Path, n: int) -> Path:
    """World ``n``'s path file (its shortest path in lattice cells) in a BARN folder."""
    return Path(folder) / "path_files" / f"path_{n}.npy"


def check_barn_folder(folder: str | Path, worlds: tuple[int, ...] = BARN_TEST_WORLDS, field: str = "--barn") -> Path:
    """``folder`` resolved, when it holds the world file and the path file of each of ``worlds``;
    else a SpecError naming the folder (or its first missing file) and the fix."""
    d = Path(folder)
    if not d.is_dir():
        raise SpecError(field, str(folder), BARN_LAYOUT, ("it does not exist" if not d.exists() else "it is not a folder")
                        + ": name the folder that holds world_N.world and path_files/ (tar -xJf BARN.tar.xz gives BARN/)")
    if not (d / "path_files").is_dir():
        raise SpecError(field, str(folder), BARN_LAYOUT, f"it has no path_files folder ({d / 'path_files'}): "
                        "use the whole BARN folder (tar -xJf BARN.tar.xz gives BARN/ with path_files/)")
    for n in worlds:
        for f, what in ((barn_world_file(d, n), "world"), (barn_path_file(d, n), "path")):
            if not f.is_file():
                raise SpecError(field, str(folder), BARN_LAYOUT, f"it lacks the {what} file {f}: use a complete BARN "
                                "folder (its 300 world files and 300 path files)")
    return d.resolve()


def barn(folder: str | Path, *, all_worlds: bool = False) -> dict[str, Any]:
    """BARN's protocol on the BARN worlds in ``folder`` (see module doc): the 50 test worlds, or all
    300 with ``all_worlds``; SpecError (:func:`check_barn_folder`) when the folder lacks a file."""
    worlds = BARN_ALL_WORLDS if all_worlds else BARN_TEST_WORLDS
    d = check_barn_folder(folder, worlds)
    entries = [{"key": f"world_{n}", "map_seed": n,
                "world": {"source": {"path": str(barn_world_file(d, n)), "margin_m": BARN_MARGIN_M},
                          "mission": {"start": list(BARN_START), "goal": list(BARN_GOAL)}}}
               for n in worlds]
    return {
        "name": "barn-all" if all_worlds else "barn",
        "seed": 2020,
        "robot": "jackal",
        "sensors": [copy.deepcopy(BARN_SCANNER)],
        "experiments": [{"name": "barn", "worlds": entries}],
        "runs_per_map": BARN_RUNS,
        "navigators": [{"name": "reference-2d-v1", "config": {}}],
        "faults": [None],
        "timeout_s": 100.0,
        "goal_tolerance_m": 1.0,
    }


def preset(name: str, *, folder: str | Path | None = None, all_worlds: bool = False) -> dict[str, Any]:
    """The preset ``name`` as a spec mapping (``folder``, ``all_worlds``: the ``barn`` preset's
    BARN folder and world set)."""
    if name == "barn":
        if folder is None:
            raise SpecError("--barn", MISSING, BARN_LAYOUT + ", with --preset barn")
        return barn(folder, all_worlds=all_worlds)
    if name == "paper":
        return paper()
    if name == "demo":
        return demo()
    if name == "dynamic":
        return dynamic()
    raise SpecError("preset", name, f"one of {list(ALL_PRESETS)}")


def preset_yaml(name: str, *, folder: str | Path | None = None, all_worlds: bool = False) -> str:
    """The preset as commented YAML, ready to edit (``folder``, ``all_worlds``: see :func:`preset`)."""
    data = preset(name, folder=folder, all_worlds=all_worlds)
    head = (f"# navstress campaign spec: preset '{name}'.\n"
            "# Run it with: navstress campaign run THIS_FILE -o DIR\n"
            "# Every map and run seed derives from `seed`; `faults: [null, ...]` (null = nominal).\n")
    if name == "barn":
        head += ("# BARN's protocol (docs/worlds.md, \"The BARN benchmark\"): a Jackal with a UST-10-class scanner at\n"
                 "# BARN's mount, each world imported from its Gazebo file, BARN's mission in the file's frame,\n"
                 "# success within 1 m, 100 s, a collision ends the run; `navstress report` adds BARN's score.\n")
        exps = data.pop("experiments")
        lines = [f"  - name: {exps[0]['name']}", "    worlds:"]  # one line per world
        lines += ["      - " + yaml.safe_dump(w, sort_keys=False, default_flow_style=True, width=10**6).strip()
                  for w in exps[0]["worlds"]]
        return (head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None) + "experiments:\n"
                + "\n".join(lines) + "\n")
    return head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None)
