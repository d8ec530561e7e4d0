"""The BARN worlds for tests: extracted from ``tests/data/barn/BARN.tar.xz`` (a copy of
``shared/barn/BARN.tar.xz``, kept in the repository so that every checkout has it; or
``NAVSTRESS_BARN_TAR``), only the members a test asks for, once per session (per pytest worker),
into a folder laid out as BARN's: ``world_N.world`` and ``path_files/path_N.npy``. Skipped with
the reason where the archive is missing (failed under CI)."""

from __future__ import annotations

import hashlib
import os
import tarfile
from collections.abc import Iterable
from pathlib import Path

import pytest

from tests.support.required import need

ROOT = Path(__file__).resolve().parents[2]
N_WORLDS = 300


def barn_tar() -> Path | None:
    """The BARN archive: ``NAVSTRESS_BARN_TAR``, else the repository's copy."""
    env = os.environ.get("NAVSTRESS_BARN_TAR")
    if env:
        return Path(env) if Path(env).is_file() else None
    p = ROOT / "tests" / "data" / "barn" / "BARN.tar.xz"
    return p if p.is_file() else None


def barn_dir(factory: pytest.TempPathFactory, worlds: Iterable[int] | None = None, *, paths: bool = True) -> Path:
    """A BARN folder holding ``worlds`` (indices; None: all 300) and, with ``paths``, their path files."""
    tar = barn_tar()
    need(tar is not None, "the BARN worlds (tests/data/barn/BARN.tar.xz, or NAVSTRESS_BARN_TAR) are missing")
    assert tar is not None
    ids = sorted(set(range(N_WORLDS) if worlds is None else worlds))
    wanted = {f"BARN/world_{i}.world" for i in ids}
    if paths:
        wanted |= {f"BARN/path_files/path_{i}.npy" for i in ids}
    key = hashlib.sha256(repr((ids, paths)).encode()).hexdigest()[:12]
    out = factory.getbasetemp() / f"barn-{key}"
    done = out / ".complete"
    if done.is_file():
        return out / "BARN"
    with tarfile.open(tar, "r:xz") as tf:
        members = [m for m in tf.getmembers() if m.name in wanted and m.isfile()]
        assert len(members) == len(wanted), f"{tar} lacks {sorted(wanted - {m.name for m in members})[:5]}"
        tf.extractall(out, members=members, filter="data")
    done.touch()
    return out / "BARN"
