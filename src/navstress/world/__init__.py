"""Worlds: specification (genotype), generation, the World value (phenotype), exports."""

from navstress.world.spec import BUILTIN_TYPES, GroundSpec, MissionSpec, ObstaclesSpec, ObstacleType, WorldSpec, load_spec, parse_spec
from navstress.world.world import Mission, Obstacle, Terrain, World, is_world_dir
from navstress.world.generate import generate  # after spec/world: generate imports them

__all__ = [
    "BUILTIN_TYPES", "GroundSpec", "Mission", "MissionSpec", "Obstacle", "ObstacleType", "ObstaclesSpec",
    "Terrain", "World", "WorldSpec", "generate", "is_world_dir", "load_spec", "parse_spec",
]
