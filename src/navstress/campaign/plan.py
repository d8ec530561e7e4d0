"""Planning: a CampaignSpec becomes a deterministic list of maps and RunTasks.

Seeds (DESIGN invariant 2), for campaign seed ``S``:

- map seed = ``derive_seed(S, "map", experiment, config_key, map_index)``: one world per map,
  shared by every navigator and fault on it (nominal and faulty runs see the same maps);
- run seed = ``derive_seed(S, "run", experiment, config_key, map_index, run_index)``: the
  same for every navigator and fault, so the comparison is paired.

An explicit world (``worlds:`` entry) is one configuration with one map, ``m0``, whose map seed
is the entry's own (not derived); its run seeds are derived as above (config_key = its key), so
another experiment listing the same world gets fresh run seeds.

``run_id`` = ``f"{experiment}/{config_key}/m{map}/r{run}/{navigator}/{fault or 'nominal'}"``,
stable across plans of the same spec (the resume key). A campaign of several robots (``robots:``)
runs every run on each robot, with the same seeds (paired), and names the robot in the navigator
part: ``.../r{run}/{navigator}@{robot}/{fault}``; a campaign of one robot keeps the form above
(its records name the robot: ``RunRecord.robot``, ``robot_digest``).

Adaptive repetition: the runs of one *stream* (experiment, configuration, map, navigator,
fault) are planned up to the rule's ``max``; which of them are *due* is a function of the
stream's recorded outcomes (:meth:`Stream.due`): runs ``0 .. min-1`` always, run ``n`` once runs
``0 .. n-1`` are all recorded and :func:`navstress.sequential.should_continue` holds for their
successes. The final set of runs therefore depends on the outcomes only (which the seeds fix),
never on the order runs complete in, the number of workers, or interruptions.

    >>> from navstress.campaign.presets import demo
    >>> from navstress.campaign.spec import parse_campaign
    >>> p = plan(parse_campaign(demo()), "/tmp/c")
    >>> p.tasks[0].run_id
    'trees/tree=0/m0/r0/reference-v1/nominal'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navstress._tables import NOMINAL as NOMINAL  # the fault of the nominal stack
from navstress._tables import config_key_of as config_key_of  # the configuration key of a run
from navstress.campaign.spec import CampaignSpec
from navstress.robot import RobotSpec
from navstress.run.record import RunTask
from navstress.seeding import derive_seed
from navstress.sequential import AdaptiveRule, should_continue


@dataclass(frozen=True)
class MapJob:
    """One world to generate: ``world`` is the WorldSpec mapping, saved at ``world_dir``."""

    key: str  # "experiment/config_key/m<k>"
    experiment: str
    config_key: str
    map_index: int
    map_seed: int
    world: dict[str, Any]
    world_dir: str
    #: the robot an imported world's drawn missions are sized for (the experiment's largest, its
    #: RobotSpec's JSON mapping); None for a generated world (sized by its spec alone)
    robot: dict[str, Any] | None = None


SUCCESS = "success"


@dataclass(frozen=True)
class Stream:
    """The runs of one (experiment, configuration, map, navigator, robot, fault), in run order, and
    the adaptive ``rule`` that decides how many of them run (None: all of them)."""

    run_ids: tuple[str, ...]
    rule: AdaptiveRule | None = None

    def state(self, outcomes: Mapping[str, str]) -> tuple[int, bool]:
        """(how many runs are due, whether the stream is finished: no further run can become due)
        given ``outcomes`` (run_id -> outcome of every recorded run)."""
        if self.rule is None:
            return len(self.run_ids), all(r in outcomes for r in self.run_ids)
        k = successes = 0
        for r in self.run_ids:  # the recorded prefix: what the rule has seen
            o = outcomes.get(r)
            if o is None:
                break
            k += 1
            successes += o == SUCCESS
        if k < self.rule.min_runs:
            return self.rule.min_runs, False
        if should_continue(successes, k, self.rule):
            return k + 1, False
        return k, True

    def due(self, outcomes: Mapping[str, str]) -> tuple[str, ...]:
        """The run_ids due (recorded or to run) given ``outcomes``."""
        return self.run_ids[:self.state(outcomes)[0]]

    def at_most(self, outcomes: Mapping[str, str]) -> int:
        """The most runs this stream will have: its final count once finished, else its max."""
        n, finished = self.state(outcomes)
        return n if finished else len(self.run_ids)


@dataclass(frozen=True)
class Plan:
    """Every map and run of a campaign, in a deterministic order (map by map); ``streams``
    groups the runs of each (experiment, config, map, navigator, fault). Adaptive streams plan
    their ``max`` runs, of which :meth:`due` tells which are scheduled."""

    maps: tuple[MapJob, ...]
    tasks: tuple[RunTask, ...]
    streams: tuple[Stream, ...] = ()
    #: the campaign directory (as followed once) every path of the plan is inside
    root: str = ""

    @property
    def adaptive(self) -> bool:
        return any(s.rule is not None for s in self.streams)

    def due(self, outcomes: Mapping[str, str]) -> set[str]:
        """The run_ids due given ``outcomes`` (every task when no stream is adaptive)."""
        if not self.adaptive:
            return {t.run_id for t in self.tasks}
        return {r for s in self.streams for r in s.due(outcomes)}

    def at_most(self, outcomes: Mapping[str, str]) -> int:
        """The most runs the campaign will have recorded (its planned runs when none is adaptive)."""
        if not self.adaptive:
            return len(self.tasks)
        return sum(s.at_most(outcomes) for s in self.streams)

    def tasks_by_map(self) -> dict[str, list[RunTask]]:
        out: dict[str, list[RunTask]] = {m.world_dir: [] for m in self.maps}
        for t in self.tasks:
            out[t.world_dir].append(t)
        return out


def run_id(experiment: str, config_key: str, map_index: int, run_index: int, navigator: str,
           fault: str | None) -> str:
    """The run id; ``navigator`` is :func:`variant` (``name@robot`` in a campaign of several robots)."""
    return f"{experiment}/{config_key}/m{map_index}/r{run_index}/{navigator}/{fault or NOMINAL}"


def variant(navigator: str, robot: str | None) -> str:
    """The navigator part of a run id and trace name: ``navigator``, or ``navigator@robot`` in a
    campaign of several robots (``robot`` given)."""
    return navigator if robot is None else f"{navigator}@{robot}"


def world_path(experiment: str, config_key: str, map_index: int) -> str:
    """Where a map's world lives, relative to the campaign directory."""
    return f"worlds/{experiment}/{config_key}/m{map_index}"


def variant_of(rid: str, navigator: str) -> str:
    """The navigator part of run id ``rid`` when it is ``navigator`` or ``navigator@robot`` (a
    campaign of several robots), else ``navigator``."""
    part = rid.split("/")[-2] if rid.count("/") >= 5 else navigator
    return part if part == navigator or part.startswith(navigator + "@") else navigator


def trace_path(experiment: str, config_key: str, map_index: int, run_index: int, navigator: str,
               fault: str | None) -> str:
    """Where a run's trace lives, relative to the campaign directory."""
    return f"traces/{experiment}/{config_key}/m{map_index}/r{run_index}-{navigator}-{fault or NOMINAL}.mcap"


def map_seed(seed: int, experiment: str, config_key: str, map_index: int) -> int:
    return derive_seed(seed, "map", experiment, config_key, map_index)


def run_seed(seed: int, experiment: str, config_key: str, map_index: int, run_index: int) -> int:
    return derive_seed(seed, "run", experiment, config_key, map_index, run_index)


def plan(spec: CampaignSpec, root: str | Path) -> Plan:
    """The plan of ``spec`` for a campaign directory ``root`` (paths in tasks are absolute)."""
    base = Path(root).resolve()
    maps: list[MapJob] = []
    tasks: list[RunTask] = []
    streams: list[Stream] = []
    several = spec.several_robots
    default_digest = RobotSpec().digest
    for exp in spec.experiments:
        faults = spec.faults_of(exp)
        robots = spec.robots_of(exp)
        # the default robot travels as None: its tasks are the tasks of before robots existed
        robots_json = [None if r.digest == default_digest else r.model_dump(mode="json") for r in robots]
        rule = spec.rule_of(exp)
        largest = max(robots, key=lambda r: r.half_diagonal_m).model_dump(mode="json")
        for cfg in exp.configurations(spec.world):
            if cfg.sensor_values:  # a sweep of the robots' sensors: each configuration's own suites
                swept = [cfg.robot(r) for r in robots]
                cfg_json: list[dict[str, Any] | None] = [r.model_dump(mode="json") for r in swept]
            else:
                cfg_json = robots_json
            for m in range(spec.maps_of(exp)):
                ms = cfg.map_seed if cfg.map_seed is not None else map_seed(spec.seed, exp.name, cfg.key, m)
                wdir = base / world_path(exp.name, cfg.key, m)
                maps.append(MapJob(key=f"{exp.name}/{cfg.key}/m{m}", experiment=exp.name, config_key=cfg.key,
                                   map_index=m, map_seed=ms, world=cfg.world, world_dir=str(wdir),
                                   robot=largest if isinstance(cfg.world.get("source"), dict) else None))
                ids: dict[tuple[str, str | None], list[str]] = {(variant(n.name, r.name if several else None), f): []
                                                                for n in spec.navigators for r in robots
                                                                for f in faults}
                for r in range(spec.max_runs_of(exp)):
                    rs = run_seed(spec.seed, exp.name, cfg.key, m, r)
                    for nav in spec.navigators:
                        for robot, robot_json in zip(robots, cfg_json):
                            name = variant(nav.name, robot.name if several else None)
                            for fault in faults:
                                rid = run_id(exp.name, cfg.key, m, r, name, fault)
                                ids[(name, fault)].append(rid)
                                trace = base / trace_path(exp.name, cfg.key, m, r, name, fault)
                                tasks.append(RunTask(
                                    run_id=rid, world_dir=str(wdir), run_seed=rs, trace_path=str(trace),
                                    navigator=nav.name, navigator_config=dict(nav.config), fault=fault,
                                    timeout_s=spec.timeout_s, goal_tolerance_m=spec.goal_tolerance_m,
                                    record_lidar=spec.record_lidar, record_navigator=spec.record_navigator,
                                    experiment=exp.name, config=dict(cfg.values),
                                    map_index=m, run_index=r, map_seed=ms, sim_overrides=dict(spec.sim),
                                    robot=robot_json))
                streams.extend(Stream(tuple(v), rule) for v in ids.values())
    return Plan(maps=tuple(maps), tasks=tuple(tasks), streams=tuple(streams), root=str(base))
