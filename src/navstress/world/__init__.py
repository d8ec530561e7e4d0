"""Worlds: specification (genotype), generation, the World value (phenotype), exports."""

from navstress.world.spec import BUILTIN_MOVER_TYPES, BUILTIN_TYPES, BehaviourSpec, GroundSpec, MoversSpec, MoverType, MissionSpec, ObstaclesSpec, ObstacleType, WorldSpec, load_spec, parse_spec
from navstress.world.world import Mission, Mover, Obstacle, Terrain, World, is_world_dir
from navstress.world.generate import generate  # after spec/world: generate imports them

__all__ = [
    "BUILTIN_MOVER_TYPES", "BUILTIN_TYPES", "BehaviourSpec", "GroundSpec", "Mission", "MissionSpec", "Mover",
    "MoverType", "MoversSpec", "Obstacle", "ObstacleType", "ObstaclesSpec",
    "Terrain", "World", "WorldSpec", "generate", "is_world_dir", "load_spec", "parse_spec",
]
