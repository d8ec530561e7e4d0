"""Seed derivation: stable, independent streams, no global state."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from navstress.seeding import derive_seed, rng

parts = st.lists(st.one_of(st.integers(0, 2**40), st.text(max_size=8)), max_size=4)


@given(st.integers(0, 2**62), parts)
def test_same_path_same_seed(root: int, path: list) -> None:
    assert derive_seed(root, *path) == derive_seed(root, *path)
    assert 0 <= derive_seed(root, *path) < 2**63


@given(st.integers(0, 2**62), parts, st.integers(0, 1000))
def test_different_index_different_seed(root: int, path: list, i: int) -> None:
    assert derive_seed(root, *path, i) != derive_seed(root, *path, i + 1)


def test_known_value_is_stable_across_processes() -> None:
    # SeedSequence and blake2b are specified algorithms: the value must never change
    # between runs, or recorded seeds would stop replaying.
    a = derive_seed(42, "map", "trees=6", 3)
    b = derive_seed(42, "map", "trees=6", 3)
    assert a == b
    assert derive_seed(42, "map", "trees=6", 3) != derive_seed(42, "run", "trees=6", 3)


def test_rng_streams_are_reproducible_and_independent() -> None:
    x = rng(7, "terrain").random(5)
    y = rng(7, "terrain").random(5)
    z = rng(7, "obstacles").random(5)
    assert np.array_equal(x, y)
    assert not np.array_equal(x, z)


def test_global_state_is_untouched() -> None:
    np.random.seed(0)
    before = np.random.random()
    np.random.seed(0)
    rng(1).random(10)
    derive_seed(1, "x")
    assert np.random.random() == before


@pytest.mark.parametrize("bad", [-1, True])
def test_bad_path_parts_rejected(bad: object) -> None:
    with pytest.raises((ValueError, TypeError)):
        derive_seed(1, bad)  # type: ignore[arg-type]
