"""Ready search specs, one per objective, as commented YAML (``navstress search init``).

Each searches 40 m maps (the demo campaign's size: runs of seconds) over tree and building
obstruction, the terrain's subdivisions and deformation, and the map seed, with 3 runs per
candidate and a budget of 1,920 runs: 40 generations of 16 candidates with the nominal stack
alone, 20 with the nominal and the faulty one. The ranges keep most worlds passable (on 40 m
maps, buildings above about 9 %, or trees and buildings together above about 20 %, or a
deformation above 1 m with many subdivisions, often leave no path from start to goal: such a
world fails every stack, gets no fitness and teaches nothing).

* ``failure``: where the reference stack fails (any class), MAP-Elites over the default map
  (obstruction x path ratio);
* ``fault-revealing``: where the small-footprint fault fails and the nominal stack succeeds, GA;
* ``boundary``: where the success probability is near 0.5, CMA-ME;
* ``illumination``: the map of failures over obstruction x terrain deformation, MAP-Elites.
"""

from __future__ import annotations

from navstress.errors import SpecError
from navstress.search.spec import OBJECTIVES

_HEAD = """\
# navstress search spec ({what}).
# Run it: navstress search THIS_FILE -o DIR (killed: the same command resumes). docs/search.md
# explains every field.
name: {name}
seed: 0                      # every map seed, run seed and algorithm draw derives from it

# The base world of every candidate (a WorldSpec mapping, docs/worlds.md).
world:
  size_m: [40.0, 40.0]
  cell_m: 0.4

# What the search varies: WorldSpec parameters within [low, high] (kind: float or int) and,
# with map_seed: true, the map seed (one of map_seeds seeds; false: one seed for every candidate).
space:
  parameters:
    - {{path: obstacles.obstruction.tree, low: 0, high: 16}}
    - {{path: obstacles.obstruction.building, low: 0, high: 8}}
    - {{path: ground.subdivisions, low: 0, high: 6, kind: int}}
    - {{path: ground.deformation, low: 0, high: 1.2}}
  map_seed: true
  map_seeds: 10000

# The stack under test (a registered navigator and its config) and the faults it runs with
# (null = nominal); every fault runs the same worlds with the same run seeds.
navigator: {{name: reference-v1, config: {{}}}}
faults: {faults}

"""

_TAIL = """
# How much to spend: runs of the search's generations (the elites' confirmation comes on top);
# optionally simulated hours and wall seconds (the search stops at the next generation's end).
budget:
  runs: 1920
  # sim_hours: 20
  # wall_s: 3600

# Runs per candidate and fault: a number, or {{adaptive: {{min: 2, max: 8, threshold: 0.5, confidence: 0.9}}}}
# (run again only while the candidate's verdict is undecided).
runs_per_candidate: 3

# The algorithm and its candidates per generation (batch):
#   random | map-elites (sigma, emitters) | cma-me (sigma0, emitters) | ga | nsga2 (crossover_prob,
#   crossover_eta, mutation_eta); map-elites and cma-me also take descriptors, when the objective has none.
algorithm:
{algorithm}

confirm_runs: {confirm_runs}             # fresh-seed runs per elite (and stack) before it is reported{confirm_why}
elites: 10                   # how many of the best worlds to report
timeout_s: 120.0             # per run (simulated seconds)
goal_tolerance_m: 2.0
sim: {{}}
"""

_OBJECTIVE = {
    "failure": """\
# The objective: worlds where the stack fails, of any class (or one: collision, timeout, error).
objective:
  name: failure
  outcome: any
""",
    "fault-revealing": """\
# The objective: worlds where the faulty stack fails and the nominal one succeeds, on the same
# world with the same run seeds (faults must hold null and this fault).
objective:
  name: fault-revealing
  fault: small-footprint
""",
    "boundary": """\
# The objective: worlds whose success probability is near the target (the most informative
# about difficulty).
objective:
  name: boundary
  target: 0.5
""",
    "illumination": """\
# The objective: a map over two descriptors (a world descriptor, or a path of the space), each
# cell keeping its most failing world (outcome: any, collision, timeout or error).
objective:
  name: illumination
  outcome: any
  descriptors:
    - {name: obstruction, low: 0, high: 24, cells: 8}
    - {name: ground.deformation, low: 0, high: 1.2, cells: 6}
""",
}

_ALGORITHM = {
    "failure": "  name: map-elites\n  batch: 16\n  sigma: 0.1",
    "fault-revealing": "  name: ga\n  batch: 16\n  crossover_prob: 0.9\n  crossover_eta: 15\n  mutation_eta: 20",
    "boundary": "  name: cma-me\n  batch: 16\n  sigma0: 0.2\n  emitters: 2",
    "illumination": "  name: map-elites\n  batch: 16\n  sigma: 0.1",
}

_WHAT = {
    "failure": "objective failure: the worlds where the stack fails",
    "fault-revealing": "objective fault-revealing: the worlds where a fault makes the stack fail",
    "boundary": "objective boundary: the worlds at the edge of the stack's ability",
    "illumination": "objective illumination: where the stack fails, mapped over two descriptors",
}


#: Each objective's confirmation runs and why (a comment after ``confirm_runs``); the others: 10.
_CONFIRM = {"fault-revealing": (20, "\n# (a revealing world needs at least 8 revealing pairs of the fresh ones, and one that reveals\n"
                                    "# half the time about 20: docs/search.md, \"Confirmation\")")}


def template_yaml(objective: str) -> str:
    """The ready spec of ``objective`` (SpecError naming ``--objective`` for an unknown one)."""
    if objective not in OBJECTIVES:
        raise SpecError("--objective", objective, f"one of {list(OBJECTIVES)}")
    faults = "[null, small-footprint]" if objective == "fault-revealing" else "[null]"
    confirm_runs, why = _CONFIRM.get(objective, (10, ""))
    return (_HEAD.format(what=_WHAT[objective], name=objective, faults=faults) + _OBJECTIVE[objective]
            + _TAIL.format(algorithm=_ALGORITHM[objective], confirm_runs=confirm_runs, confirm_why=why))
