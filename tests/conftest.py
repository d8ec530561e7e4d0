"""Shared fixtures. Helpers live in ``world_fixtures`` (a uniquely named module: several
``conftest`` modules exist in this tree, so ``from conftest import ...`` would be ambiguous)."""

from __future__ import annotations

import pytest

from world_fixtures import small_world
from navstress.world import World


@pytest.fixture
def world() -> World:
    return small_world()
