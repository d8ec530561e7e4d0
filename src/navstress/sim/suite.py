"""The sensors a run simulates: the robot's suite (``RobotSpec.sensors``), or its default one (the
paper's 32-channel lidar, named ``lidar``, with the figures of ``sim.lidar``), checked against the
simulation's time step. Odometry, IMU and pose are built in and not listed.

    >>> from navstress.robot import profile
    >>> [s.name for s in suite(profile("jackal"), SimConfig())]
    ['lidar']
    >>> suite(profile("jackal"), SimConfig(lidar_enabled=False))
    ()
"""

from __future__ import annotations

import dataclasses

from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.sensors import Sensor, check_rates, default_suite
from navstress.sim.config import SimConfig
from navstress.sim.drives import drive_model
from navstress.sim.lidar import LidarConfig


def suite(robot: RobotSpec, config: SimConfig) -> tuple[Sensor, ...]:
    """The ray sensors of a run, in the order they fire within a step (the robot's order).

    ``sim.lidar_enabled: false`` turns every one of them off. ``sim.lidar`` sets the figures of the
    default suite's lidar; with a robot that lists its sensors it must be left at its defaults
    (SpecError: the sensor's own entry holds them)."""
    if not config.lidar_enabled:
        return ()
    if robot.sensors is None:
        (s,) = default_suite(robot.mounts)
        params = {**s.params, **dataclasses.asdict(config.lidar)}
        out: tuple[Sensor, ...] = (Sensor(name=s.name, kind=s.kind, profile=s.profile, mount=s.mount, params=params),)
    else:
        if config.lidar != LidarConfig():
            raise SpecError("sim.lidar", dataclasses.asdict(config.lidar),
                            "no sim.lidar with a robot that lists its sensors",
                            "set the lidar's figures in its entry of sensors: (docs/sensors.md)")
        out = robot.sensors
    check_rates(out, effective_config(robot, config).timestep_s)
    return out


def effective_config(robot: RobotSpec, config: SimConfig) -> SimConfig:
    """``config`` with the time step the robot's drive model needs, when that is smaller
    (docs/simulation.md, "Drive types")."""
    dt = drive_model(robot).timestep_s
    if config.timestep_s <= dt:
        return config
    return dataclasses.replace(config, timestep_s=dt)


def lidar_config(sensor: Sensor) -> LidarConfig:
    """The :class:`LidarConfig` of a ``lidar3d`` sensor (its figures that the scan kernels read)."""
    if sensor.kind != "lidar3d":
        raise SpecError("sensor.kind", sensor.kind, "lidar3d")
    names = [f.name for f in dataclasses.fields(LidarConfig)]
    return LidarConfig(**{n: sensor.params[n] for n in names})
