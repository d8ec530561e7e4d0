"""Simulation: MuJoCo physics of a World and a RobotSpec, sensors, and the ground-truth observer.

Public facade: :class:`Simulation`, :class:`SimConfig`, :func:`world_to_mjcf`, :class:`Observer`.
"""

from navstress.sim.config import SimConfig
from navstress.sim.model import build_model, world_to_mjcf
from navstress.sim.observer import CollisionEvent, Observer, StopEvent
from navstress.sim.simulation import Simulation

__all__ = ["CollisionEvent", "Observer", "SimConfig", "Simulation", "StopEvent", "build_model", "world_to_mjcf"]
