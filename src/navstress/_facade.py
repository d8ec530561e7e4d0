"""``navstress.run_mission``: one mission from Python, to debug a navigator (imported lazily by
``navstress/__init__.py``, so that ``import navstress`` stays cheap)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstress.nav.api import Navigator
from navstress.nav.registry import make_navigator
from navstress.run.mission import RunResult
from navstress.run.mission import run_mission as loop
from navstress.run.robot import robot_of
from navstress.run.trace import TraceWriter
from navstress.world.world import World


def run_mission(world: World | str | os.PathLike[str], navigator: Navigator | str, *, seed: int = 0,
                timeout_s: float = 400.0, goal_tolerance_m: float = 2.0,
                navigator_config: Mapping[str, Any] | str | None = None, fault: str | None = None,
                trace: str | os.PathLike[str] | None = None, sim_config: Any = None, robot: Any = None) -> RunResult:
    """Run one mission in this process and return its :class:`~navstress.run.mission.RunResult`
    (classification, facts, true and perceived trajectories, events).

    ``world``: a :class:`~navstress.world.World` or a world directory. ``navigator``: an object
    with ``reset``/``step``/``close`` (your navigator, under a debugger if you like) or a
    registered name (built with ``navigator_config`` and ``fault``). ``seed``: the run seed
    (sensor noise, timing jitter, the navigator's seed): the same seed gives the same run.
    ``trace``: where to write the MCAP trace (none by default). ``robot``: the simulated robot, a
    :class:`~navstress.robot.RobotSpec`, a profile name (``"jackal"``), a robot file path or a
    mapping (default ``rmp400``, the paper's); the navigator is told it. The navigator runs in this
    process, unprotected: ``navstress run`` is the way to run one that may crash or hang.

        >>> import navstress
        >>> from navstress.world import Mission, World, WorldSpec
        >>> world = World.flat(WorldSpec(size_m=(20.0, 20.0)), mission=Mission((3.0, 3.0, 0.0), (15.0, 3.0), 1.0))
        >>> result = navstress.run_mission(world, "reference-v1", seed=1, timeout_s=60.0)
        >>> result.classification.outcome.label, result.facts.goal_distance_m < 2.0
        ('Success', True)
    """
    w = world if isinstance(world, World) else World.load(Path(world))
    robot_v = robot_of(robot)  # a bad robot: one line, before anything is built or written
    nav = make_navigator(navigator, navigator_config, fault=fault) if isinstance(navigator, str) else navigator
    tw = None
    if trace is not None:
        tw = TraceWriter(trace, {"run_seed": str(seed), "map_seed": str(w.seed), "world_seed": str(w.seed),
                                 "navigator": navigator if isinstance(navigator, str) else type(navigator).__name__,
                                 "fault": fault or "", "timeout_s": str(timeout_s),
                                 "goal_tolerance_m": str(goal_tolerance_m)})
    try:
        result = loop(w, nav, run_seed=seed, timeout_s=timeout_s, goal_tolerance_m=goal_tolerance_m,
                      sim_config=sim_config, trace=tw, robot=robot_v)
        if tw is not None:
            tw.close()
    except BaseException:
        if tw is not None:
            tw.abort()
        raise
    return result
