"""a Gazebo world (SDF 1.4 to 1.9) as a source (``kind: sdf``). FOUNDATION PLACEHOLDER: its helper writes it."""

from __future__ import annotations

from pathlib import Path

from navstress.errors import SpecError
from navstress.world.spec import SourceSpec
from navstress.world.world import World

KIND = "sdf"


def claims(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in (".world", ".sdf")


def load(path: Path, options: SourceSpec) -> World:
    raise SpecError("source.path", str(path), "a Gazebo world (SDF 1.4 to 1.9)", "not built yet")
