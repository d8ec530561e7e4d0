"""Planning: a CampaignSpec becomes a deterministic list of maps and RunTasks.

Seeds (DESIGN invariant 2), for campaign seed ``S``:

- map seed = ``derive_seed(S, "map", experiment, config_key, map_index)``: one world per map,
  shared by every navigator and fault on it (nominal and faulty runs see the same maps);
- run seed = ``derive_seed(S, "run", experiment, config_key, map_index, run_index)``: the
  same for every navigator and fault, so the comparison is paired.

``run_id`` = ``f"{experiment}/{config_key}/m{map}/r{run}/{navigator}/{fault or 'nominal'}"``,
stable across plans of the same spec (the resume key).

    >>> from navstress.campaign.presets import demo
    >>> from navstress.campaign.spec import parse_campaign
    >>> p = plan(parse_campaign(demo()), "/tmp/c")
    >>> p.tasks[0].run_id
    'trees/tree=0/m0/r0/reference-v1/nominal'
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navstress.campaign.spec import CampaignSpec
from navstress.run.record import RunTask
from navstress.seeding import derive_seed

NOMINAL = "nominal"


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


@dataclass(frozen=True)
class Plan:
    """Every map and run of a campaign, in a deterministic order (map by map)."""

    maps: tuple[MapJob, ...]
    tasks: tuple[RunTask, ...]

    def tasks_by_map(self) -> dict[str, list[RunTask]]:
        out: dict[str, list[RunTask]] = {m.world_dir: [] for m in self.maps}
        for t in self.tasks:
            out[t.world_dir].append(t)
        return out


def run_id(experiment: str, config_key: str, map_index: int, run_index: int, navigator: str,
           fault: str | None) -> str:
    return f"{experiment}/{config_key}/m{map_index}/r{run_index}/{navigator}/{fault or NOMINAL}"


def map_seed(seed: int, experiment: str, config_key: str, map_index: int) -> int:
    return derive_seed(seed, "map", experiment, config_key, map_index)


def run_seed(seed: int, experiment: str, config_key: str, map_index: int, run_index: int) -> int:
    return derive_seed(seed, "run", experiment, config_key, map_index, run_index)


def plan(spec: CampaignSpec, root: str | Path) -> Plan:
    """The plan of ``spec`` for a campaign directory ``root`` (paths in tasks are absolute)."""
    base = Path(root).resolve()
    maps: list[MapJob] = []
    tasks: list[RunTask] = []
    for exp in spec.experiments:
        faults = spec.faults_of(exp)
        for cfg in exp.configurations(spec.world):
            for m in range(spec.maps_per_config):
                ms = map_seed(spec.seed, exp.name, cfg.key, m)
                wdir = base / "worlds" / exp.name / cfg.key / f"m{m}"
                maps.append(MapJob(key=f"{exp.name}/{cfg.key}/m{m}", experiment=exp.name, config_key=cfg.key,
                                   map_index=m, map_seed=ms, world=cfg.world, world_dir=str(wdir)))
                for r in range(spec.runs_per_map):
                    rs = run_seed(spec.seed, exp.name, cfg.key, m, r)
                    for nav in spec.navigators:
                        for fault in faults:
                            rid = run_id(exp.name, cfg.key, m, r, nav.name, fault)
                            trace = base / "traces" / exp.name / cfg.key / f"m{m}" / \
                                f"r{r}-{nav.name}-{fault or NOMINAL}.mcap"
                            tasks.append(RunTask(
                                run_id=rid, world_dir=str(wdir), run_seed=rs, trace_path=str(trace),
                                navigator=nav.name, navigator_config=dict(nav.config), fault=fault,
                                timeout_s=spec.timeout_s, goal_tolerance_m=spec.goal_tolerance_m,
                                record_lidar=spec.record_lidar, experiment=exp.name, config=dict(cfg.values),
                                map_index=m, run_index=r, map_seed=ms, sim_overrides=dict(spec.sim)))
    return Plan(maps=tuple(maps), tasks=tuple(tasks))
