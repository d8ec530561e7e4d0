"""Fixtures for the navigator plug-in tests.

``example_package`` makes the third-party example (examples/straightline_nav) installed in the
running interpreter's environment, as a user would (``pip install --no-deps -e``): CI starts
from a clean clone, so the tests install it themselves, once, under a file lock (pytest-xdist
workers run this concurrently). When it is already installed this costs one metadata lookup.
"""

from __future__ import annotations

import fcntl
import importlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path

import pytest

from tests.support.nav_plugin_helpers import EXAMPLE, EXAMPLE_SRC


def _entry_point_names() -> set[str]:
    return {ep.name for ep in metadata.entry_points(group="navstress.navigators")}


def _installed() -> bool:
    return "straightline-v1" in _entry_point_names()


@pytest.fixture(scope="session")
def example_package() -> Path:
    """Install examples/straightline_nav (editable, no deps) if its entry points are missing."""
    if not _installed():
        lock_path = Path(tempfile.gettempdir()) / "navstress-example-install.lock"
        with open(lock_path, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                if not _installed():
                    proc = subprocess.run(
                        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "-e",
                         str(EXAMPLE)],
                        capture_output=True, text=True, timeout=300,
                    )
                    if proc.returncode != 0:
                        pytest.fail(f"installing {EXAMPLE} failed:\n{proc.stdout}\n{proc.stderr}")
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)
        importlib.invalidate_caches()
    # an editable install is a .pth file, read only at interpreter start-up
    if str(EXAMPLE_SRC) not in sys.path:
        try:
            importlib.import_module("navstress_example_straightline")
        except ImportError:
            sys.path.append(str(EXAMPLE_SRC))
    assert _installed(), "the example's entry points are still not visible"
    return EXAMPLE


def _procs() -> list[tuple[int, list[str]]]:
    """(pid, stat fields after the command name) of every process, from /proc."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        out.append((int(entry), stat[stat.rfind(")") + 2:].split()))
    return out


def _children_of(pid: int) -> list[int]:
    """Process ids whose parent is ``pid``."""
    return [p for p, f in _procs() if int(f[1]) == pid]


def _group_members(pgid: int) -> list[int]:
    """Live (non-zombie) processes of process group ``pgid``."""
    return [p for p, f in _procs() if int(f[2]) == pgid and f[0] != "Z"]


@pytest.fixture
def no_leftover_process() -> Iterator[list[int]]:
    """Yields a list to append process-group ids to; after the test, asserts that none of
    those groups has a live member and that this process has no new zombie children."""
    groups: list[int] = []
    before = set(_children_of(os.getpid()))
    yield groups
    for pgid in groups:
        # SIGKILL is delivered asynchronously: a killed member may take a moment to die
        deadline = time.monotonic() + 2.0
        while _group_members(pgid) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert _group_members(pgid) == [], f"process group {pgid} still has live processes"
    zombies = []
    for pid in set(_children_of(os.getpid())) - before:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state == "Z":
            zombies.append(pid)
    assert zombies == [], f"unreaped child processes: {zombies}"
