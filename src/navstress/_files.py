"""Files navstress writes for others to read: modes that follow the process umask.

``tempfile.mkstemp`` and ``mkdtemp`` create owner-only files (0600) and directories (0700)
whatever the umask, which breaks a Gazebo container running as another user or Ray nodes
with another uid. Every writer goes through these helpers, which give new files
``0o666 & ~umask`` and new directories ``0o777 & ~umask``, as ``open`` and ``mkdir`` would.
"""

from __future__ import annotations

import os
import tempfile
import threading
from collections.abc import Mapping
from pathlib import Path

_LOCK = threading.Lock()
_SWAPPED: list[int] = []  # the umask read by swapping, once (only where /proc cannot tell)


def umask() -> int:
    """The process umask, read without changing it where Linux tells (``/proc/self/status``);
    elsewhere read once by setting a restrictive one and restoring it, under a lock."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _LOCK:
        if not _SWAPPED:
            old = os.umask(0o077)  # a racing thread meanwhile creates owner-only files, never wider ones
            os.umask(old)
            _SWAPPED.append(old)
        return _SWAPPED[0]


def file_mode() -> int:
    """Mode of a new regular file: ``0o666 & ~umask``."""
    return 0o666 & ~umask()


def dir_mode() -> int:
    """Mode of a new directory: ``0o777 & ~umask``."""
    return 0o777 & ~umask()


def apply_file_mode(path: str | os.PathLike[str]) -> None:
    """Give ``path`` (a file some library created with its own mode) the umask's file mode."""
    os.chmod(path, file_mode())


def _write_temp(dest: Path, raw: bytes) -> Path:
    """``raw`` in a unique temporary file beside ``dest`` (fsynced, the umask's mode); removed
    again on failure."""
    dest.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent)
    except OSError as e:  # name the file the user asked for, not our temporary one
        raise OSError(e.errno, e.strerror, str(dest)) from None
    try:
        os.fchmod(fd, file_mode())
        with os.fdopen(fd, "wb") as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return Path(tmp)


def write_atomic(path: str | os.PathLike[str], data: bytes | str) -> None:
    """Write ``data`` to ``path`` via a unique temporary file in the same folder (fsynced, with
    the umask's mode), then rename it into place; nothing is left behind on failure."""
    write_atomic_group({Path(path): data})


def write_atomic_group(files: Mapping[Path, bytes | str]) -> None:
    """Write several files that belong together (an SDF and its heightmap, an OBJ, its MTL and
    texture): every one to a temporary file first, then all renamed into place, so that a failure
    while writing (a full disk) leaves none of them, new or half-written, behind."""
    temps: list[tuple[Path, Path]] = []
    try:
        for dest, data in files.items():
            raw = data.encode("utf-8") if isinstance(data, str) else data
            temps.append((_write_temp(Path(dest), raw), Path(dest)))
        while temps:
            tmp, dest = temps[0]
            os.replace(tmp, dest)
            temps.pop(0)
    except BaseException:
        for tmp, _ in temps:
            tmp.unlink(missing_ok=True)
        raise


def temp_dir_beside(dest: str | os.PathLike[str]) -> Path:
    """A new hidden directory next to ``dest`` (to be renamed onto it), with the umask's mode."""
    d = Path(dest)
    d.parent.mkdir(parents=True, exist_ok=True)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{d.name}.", dir=d.parent))
    except OSError as e:  # name the directory the user asked for, not our temporary one
        raise OSError(e.errno, e.strerror, str(d)) from None
    os.chmod(tmp, dir_mode())
    return tmp


def create_file(path: str | os.PathLike[str]) -> None:
    """Create an empty file at ``path`` with the umask's mode (before a library such as SQLite,
    which would use its own fixed mode, opens it)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o666)  # the OS applies the umask
    os.close(fd)


def probe_writable(dest: str | os.PathLike[str]) -> None:
    """Raise the OSError (naming ``dest``) that writing a file at ``dest`` would meet, now,
    before long work whose result would be lost; leaves nothing behind."""
    d = Path(dest)
    parent = d.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{d.name}.", suffix=".probe", dir=parent)
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(d)) from None
    os.close(fd)
    os.unlink(probe)


def fsync_dir(path: str | os.PathLike[str]) -> None:
    """Make a rename inside directory ``path`` durable."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
