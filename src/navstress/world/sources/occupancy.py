"""a ROS map_server map (YAML + PGM/PNG image) as a source (``kind: map``). FOUNDATION PLACEHOLDER: its helper writes it."""

from __future__ import annotations

from pathlib import Path

from navstress.errors import SpecError
from navstress.world.spec import SourceSpec
from navstress.world.world import World

KIND = "map"


def claims(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in (".yaml", ".yml")


def load(path: Path, options: SourceSpec) -> World:
    raise SpecError("source.path", str(path), "a ROS map_server map (YAML + PGM/PNG image)", "not built yet")
