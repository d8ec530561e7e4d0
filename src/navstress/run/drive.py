"""Drive a scripted course in a world: see the simulation work (``navstress world drive``).

A course is a list of segments ``(v m/s, omega rad/s, duration s)`` played open loop from the
mission start. The picture shows the real path (ground truth) and the wheel-odometry path
placed at the start pose, so slip, skid and collisions are visible.

    >>> parse_course("1.0,0,5; 0.5,0.4,4")
    [(1.0, 0.0, 5.0), (0.5, 0.4, 4.0)]
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navstress.errors import SpecError
from navstress.nav.api import Command
from navstress.robot import RobotSpec
from navstress.run.figures import draw_footprint, legend, save_png, world_axes
from navstress.run.robot import robot_of
from navstress.sim.config import SimConfig
from navstress.sim.simulation import Simulation
from navstress.world.export.images import draw_world
from navstress.world.world import World

#: 20 m straight, a left quarter turn, 12 m straight, a right half turn on the move, 15 m straight.
DEFAULT_COURSE: list[tuple[float, float, float]] = [
    (1.0, 0.0, 20.0), (0.0, 0.5, math.pi), (1.0, 0.0, 12.0), (0.8, -0.4, math.pi / 0.4 / 2), (1.0, 0.0, 15.0),
]


def parse_course(text: str) -> list[tuple[float, float, float]]:
    """``"v,omega,duration; ..."`` into segments; SpecError naming the bad segment."""
    segs: list[tuple[float, float, float]] = []
    for i, part in enumerate(p for p in text.split(";") if p.strip()):
        try:
            v, w, d = (float(x) for x in part.split(","))
        except ValueError:
            raise SpecError(f"--course[{i}]", part.strip(), "three numbers 'v,omega,duration'",
                            "e.g. --course '1,0,10; 0,0.5,3'") from None
        if not all(math.isfinite(x) for x in (v, w, d)) or d <= 0:
            raise SpecError(f"--course[{i}]", part.strip(), "finite v and omega and a duration > 0")
        segs.append((v, w, d))
    if not segs:
        raise SpecError("--course", text, "at least one segment 'v,omega,duration'")
    return segs


@dataclass
class DriveResult:
    truth: np.ndarray  # (N, 7)
    odometry: np.ndarray  # (M, 3) x, y, yaw placed in the map frame at the start pose
    collisions: list[tuple[float, float, float, int]]  # t, x, y, obstacle
    stopped: str | None
    sim_s: float
    wall_s: float

    @property
    def real_time_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else float("inf")


def drive(world: World, course: list[tuple[float, float, float]], *, seed: int = 0, lidar: bool = True,
          robot: Any = None) -> DriveResult:
    """Play ``course`` open loop from the mission start in the real simulation, with ``robot``
    (a RobotSpec, a profile name or a robot file; default the paper's rmp400)."""
    sim = Simulation(world, robot_of(robot), config=SimConfig(lidar_enabled=lidar), seed=seed)
    x0, y0, yaw0 = world.mission.start
    c, s = math.cos(yaw0), math.sin(yaw0)
    odo: list[tuple[float, float, float]] = []
    wall0 = time.perf_counter()
    for v, w, dur in course:
        sim.command(Command(v, w))
        end = sim.t + dur
        half_step = sim.config.timestep_s / 2
        while sim.t < end - half_step and sim.stopped is None:
            t0 = sim.t
            sim.advance(max(min(0.1, end - sim.t), 2 * half_step))
            if sim.t == t0:  # stopped (flipped, left the map): no further progress
                break
            o = sim.observe().odom
            odo.append((x0 + c * o.x - s * o.y, y0 + s * o.x + c * o.y, yaw0 + o.yaw))
        if sim.stopped is not None:
            break
    sim.command(Command(0.0, 0.0))
    sim.advance(1.0)
    wall = time.perf_counter() - wall0
    return DriveResult(truth=np.array(sim.observer.poses), odometry=np.array(odo).reshape(-1, 3),
                       collisions=[(e.t, e.x, e.y, e.obstacle) for e in sim.observer.collisions],
                       stopped=sim.stopped.reason if sim.stopped is not None else None, sim_s=sim.t, wall_s=wall)


def drive_picture(world: World, res: DriveResult, path: str | Path, title: str, robot: RobotSpec | None = None) -> Path:
    """Write a PNG of the real path and the odometry path over ``world``, with ``robot``'s
    footprint (its true shape) where it started and where it ended."""
    fig, ax = world_axes(figsize=(8.2, 7.2), dpi=110)
    draw_world(ax, world, legend=False)
    if len(res.truth):
        ax.plot(res.truth[:, 1], res.truth[:, 2], "-", color="#d7191c", lw=2.0, label="real path", zorder=6)
        ring = (robot or RobotSpec()).footprint_points()
        draw_footprint(ax, ring, res.truth[0], label="robot (footprint)")
        draw_footprint(ax, ring, res.truth[-1])
    if len(res.odometry):
        ax.plot(res.odometry[:, 0], res.odometry[:, 1], "--", color="#2b83ba", lw=1.5,
                label="wheel odometry (from the start pose)", zorder=6)
    for k, (_t, x, y, _o) in enumerate(res.collisions):
        ax.plot(x, y, "X", color="black", ms=11, zorder=8, label="collision" if k == 0 else None)
    legend(ax, loc="upper left", fontsize=8, framealpha=0.85)
    ax.set_title(title, fontsize=10, loc="left")
    return save_png(fig, path)
