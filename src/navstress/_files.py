"""Files navstress writes for others to read: modes that follow the process umask, and writes
and deletions that never leave the directory they were given.

``tempfile.mkstemp`` and ``mkdtemp`` create owner-only files (0600) and directories (0700)
whatever the umask, which breaks a Gazebo container running as another user or Ray nodes
with another uid. Every writer goes through these helpers, which give new files
``0o666 & ~umask`` and new directories ``0o777 & ~umask``, as ``open`` and ``mkdir`` would.

The output-directory rule (docs/design.md, invariant 6): nothing navstress writes or deletes
leaves the directory it was given. A file is written under a unique temporary name made with
``O_EXCL`` (never an existing name, so never through a link) and renamed onto its name (a link
there is replaced, its target untouched); a file kept under a fixed name is opened with
``O_NOFOLLOW`` (:func:`open_nofollow`); a tree is removed only when it is a real directory
(:func:`remove_tree`); and a directory navstress keeps working in (a campaign, a search, a demo)
is refused when a symbolic link is planted anywhere inside it (:func:`refuse_links`). The
directory the user names may itself be a link: that is the user's choice, followed once.

Every temporary-file-and-rename of navstress is written here, once (``tests/unit/test_rules.py``
refuses an ``os.replace``, ``os.rename``, ``Path.replace`` or ``Path.rename`` anywhere else):

- bytes or text: :func:`write_atomic`, :func:`write_atomic_group`, :func:`copy_atomic`;
- a file a library or a program writes by name (SQLite, a compiler): :func:`replaced_on_success`;
- a file or directory finished under its own temporary name (a trace's ``.NAME.partial``, a bag
  built inside :func:`temp_dir_beside`): :func:`rename_into_place`;
- a directory built beside the one it replaces (a world, a search's suite): :func:`replace_dir`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import stat
import tempfile
import threading
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

from navstress.errors import OutputPathError

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


def _new_temp(dest: Path, temp: Path | None = None) -> tuple[int, Path]:
    """A new empty temporary file beside ``dest`` with the umask's mode, open for writing: a unique
    name (``O_EXCL``), or the fixed name ``temp`` in the same folder (a link there refused)."""
    dest.parent.mkdir(parents=True, exist_ok=True)
    if temp is not None:
        _check_beside(temp, dest)
        return _open_nofollow_fd(temp, "wb"), Path(temp)  # the OS applies the umask
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent)
    except OSError as e:  # name the file the user asked for, not our temporary one
        raise OSError(e.errno, e.strerror, str(dest)) from None
    try:
        os.fchmod(fd, file_mode())
    except BaseException:
        os.close(fd)
        Path(tmp).unlink(missing_ok=True)
        raise
    return fd, Path(tmp)


def _write_temp(dest: Path, raw: bytes, temp: Path | None = None) -> Path:
    """``raw`` in a temporary file beside ``dest`` (:func:`_new_temp`; fsynced); removed again on
    failure."""
    fd, tmp = _new_temp(dest, temp)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def write_atomic(path: str | os.PathLike[str], data: bytes | str, *,
                 temp: str | os.PathLike[str] | None = None) -> None:
    """Write ``data`` to ``path`` via a unique temporary file in the same folder (fsynced, with
    the umask's mode), then rename it into place; nothing is left behind on failure.

    ``temp``: a fixed temporary name in ``path``'s folder instead of a unique one, for a file whose
    leftover a later run removes by name (a campaign's ``.spec.yaml.tmp``); a link there is refused."""
    dest = Path(path)
    if temp is None:
        write_atomic_group({dest: data})
        return
    tmp = _write_temp(dest, data.encode("utf-8") if isinstance(data, str) else data, Path(temp))
    try:
        os.replace(tmp, dest)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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


def _check_beside(tmp: str | os.PathLike[str], dest: str | os.PathLike[str]) -> None:
    """ValueError unless ``tmp`` lies inside ``dest``'s folder (lexically): a rename from there
    stays on one file system and inside the directory navstress was given."""
    folder = os.path.dirname(os.path.normpath(os.path.abspath(dest)))
    t = os.path.normpath(os.path.abspath(tmp))
    if os.path.dirname(t) != folder and not t.startswith(folder.rstrip(os.sep) + os.sep):
        raise ValueError(f"temporary {str(tmp)!r} is not beside {str(dest)!r}")


def rename_into_place(tmp: str | os.PathLike[str], dest: str | os.PathLike[str]) -> None:
    """Rename the finished file or directory ``tmp`` (made by the caller inside ``dest``'s folder:
    a ``.NAME.partial`` file, a bag built in :func:`temp_dir_beside`) onto ``dest`` in one step: a
    file or link at ``dest`` is replaced (a link's target untouched). ValueError when ``tmp`` is
    not in ``dest``'s folder."""
    _check_beside(tmp, dest)
    os.replace(tmp, dest)


@contextlib.contextmanager
def replaced_on_success(dest: str | os.PathLike[str], temp: str | os.PathLike[str] | None = None, *,
                        durable: bool = False) -> Iterator[Path]:
    """A temporary file beside ``dest`` for a library or a program that writes a file by name
    (SQLite, a compiler): a new empty file with the umask's mode, under a unique name (``O_EXCL``)
    or, with ``temp``, under that fixed name in ``dest``'s folder (a link there refused). When the
    block ends normally the file is fsynced and renamed onto ``dest`` (``durable``: the folder is
    fsynced too, so that the rename survives a power cut); when it raises, the file is removed."""
    d = Path(dest)
    fd, tmp = _new_temp(d, None if temp is None else Path(temp))
    os.close(fd)
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, d)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if durable:
        fsync_dir(d.parent)


def replace_dir(tmp: str | os.PathLike[str], dest: str | os.PathLike[str]) -> None:
    """Rename the finished directory ``tmp`` (built inside ``dest``'s folder) onto ``dest``. An
    existing ``dest`` is first renamed to ``.NAME.old`` beside it (whatever a killed replacement
    left there is removed first; a link there is refused, never followed) and removed after, so
    that ``dest`` is at every moment the old directory, or the new one. ValueError when ``tmp``
    is not in ``dest``'s folder."""
    t, d = Path(tmp), Path(dest)
    _check_beside(t, d)
    if d.exists():
        old = d.with_name(f".{d.name}.old")
        remove_tree(old)
        os.replace(d, old)
        os.replace(t, d)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(t, d)


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
    which would use its own fixed mode, opens it); a symbolic link there is refused."""
    open_nofollow(path, "wb").close()


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


# ---- the output-directory rule -------------------------------------------------------------

_MODES = {"wb": os.O_WRONLY | os.O_CREAT | os.O_TRUNC, "w": os.O_WRONLY | os.O_CREAT | os.O_TRUNC,
          "ab": os.O_WRONLY | os.O_CREAT | os.O_APPEND, "a": os.O_WRONLY | os.O_CREAT | os.O_APPEND,
          "a+": os.O_RDWR | os.O_CREAT | os.O_APPEND}


def link_error(link: str | os.PathLike[str], root: str | os.PathLike[str] | None = None,
               field: str = "output", flag: str = "-o") -> OutputPathError:
    """The one-line error for symbolic link ``link`` met inside output directory ``root``."""
    p = Path(link)
    try:
        target = os.readlink(p)
    except OSError:
        target = "?"
    where = f"{field}={str(root if root is not None else p.parent)!r}"
    return OutputPathError(
        f"{where} is invalid: expected a directory with no symbolic link inside (navstress writes and deletes only "
        f"inside the directory it is given); {str(p)!r} is a symbolic link (to {target!r}): remove the link, or "
        f"choose another {flag}")


def _open_nofollow_fd(path: str | os.PathLike[str], mode: str) -> int:
    """The descriptor of :func:`open_nofollow`."""
    try:
        return os.open(path, _MODES[mode] | os.O_NOFOLLOW | os.O_CLOEXEC, 0o666)  # the OS applies the umask
    except OSError as e:
        if e.errno == errno.ELOOP and Path(path).is_symlink():
            raise link_error(path) from None
        raise


def open_nofollow(path: str | os.PathLike[str], mode: str = "wb", **kw: Any) -> IO[Any]:
    """``open(path, mode)`` for writing (``w``, ``wb``, ``a``, ``ab``, ``a+``) that refuses a symbolic
    link at ``path`` (OutputPathError) instead of writing into its target; new files get the umask's
    mode. For files kept under a fixed name (a lock, a partial trace, a log appended to)."""
    fd = _open_nofollow_fd(path, mode)
    try:
        return os.fdopen(fd, mode, **kw)
    except BaseException:
        os.close(fd)
        raise


def first_link(root: str | os.PathLike[str]) -> Path | None:
    """The first symbolic link found under directory ``root`` (depth first, in name order), links
    never followed; ``root`` itself is followed (the user's choice). None when there is none."""
    stack = [Path(root)]
    while stack:
        d = stack.pop()
        try:
            with os.scandir(d) as it:
                entries = sorted(it, key=lambda e: e.name)
        except (FileNotFoundError, NotADirectoryError):
            continue
        subdirs = []
        for e in entries:
            if e.is_symlink():
                return Path(e.path)
            if e.is_dir(follow_symlinks=False):
                subdirs.append(Path(e.path))
        stack.extend(reversed(subdirs))
    return None


def refuse_links(root: str | os.PathLike[str], field: str = "output", flag: str = "-o") -> None:
    """OutputPathError naming the first symbolic link planted anywhere inside directory ``root``
    (for directories navstress keeps writing in and cleaning: a campaign, a search, a demo)."""
    link = first_link(root)
    if link is not None:
        raise link_error(link, root, field, flag)


def check_below(root: str | os.PathLike[str], path: str | os.PathLike[str], field: str = "output",
                flag: str = "-o") -> None:
    """OutputPathError unless ``path`` is lexically inside ``root`` and none of its existing
    components below ``root`` (``path`` included) is a symbolic link: then writing or deleting at
    ``path`` stays inside ``root``."""
    p = Path(os.path.normpath(os.path.abspath(path)))
    rel = None
    for b in (os.path.realpath(root), os.path.abspath(root)):  # the root as followed once, or as given
        base = Path(os.path.normpath(b))
        try:
            rel = p.relative_to(base)
            break
        except ValueError:
            continue
    if rel is None:
        raise OutputPathError(f"{field}={str(root)!r} is invalid: navstress was about to write {str(path)!r}, outside "
                              "it; restore the directory from a backup, or choose another " + flag)
    cur = base
    for part in rel.parts:
        cur = cur / part
        try:
            st = os.lstat(cur)
        except (FileNotFoundError, NotADirectoryError):
            return
        if stat.S_ISLNK(st.st_mode):
            raise link_error(cur, root, field, flag)


def remove_tree(path: str | os.PathLike[str]) -> None:
    """Remove the directory tree navstress made at ``path`` (nothing when there is none). A
    symbolic link there is refused (OutputPathError), never followed; links inside the tree are
    removed as links (``shutil.rmtree`` never follows them)."""
    p = Path(path)
    if p.is_symlink():
        raise link_error(p)
    if p.is_dir():
        shutil.rmtree(p, ignore_errors=True)
    elif p.exists():
        p.unlink(missing_ok=True)


def copy_atomic(src: str | os.PathLike[str], dest: str | os.PathLike[str]) -> None:
    """Copy file ``src`` to ``dest`` the way :func:`write_atomic` writes (a unique temporary file
    beside ``dest``, renamed onto it: a link at ``dest`` is replaced, its target untouched)."""
    d = Path(dest)
    d.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{d.name}.", suffix=".tmp", dir=d.parent)
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(d)) from None
    try:
        os.fchmod(fd, file_mode())
        with os.fdopen(fd, "wb") as f, open(src, "rb") as s:
            shutil.copyfileobj(s, f, 1 << 20)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, d)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (another user's process counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process: alive
        return True
    return True


def sweep_dead_scratch(prefix: str, parent: str | os.PathLike[str] | None = None) -> list[Path]:
    """Remove the scratch folders ``<prefix><pid>-...`` in ``parent`` (the temporary directory by
    default) whose process ``pid`` no longer runs, and return them. A process killed outright
    (SIGKILL) cannot remove its own scratch folder; naming it with the process id lets the next
    one do it. A folder of a live process (or a reused pid) and a link are left alone."""
    root = Path(parent if parent is not None else tempfile.gettempdir())
    gone = []
    for d in sorted(root.glob(prefix + "*-*")):
        pid = d.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not d.is_symlink() and d.is_dir() and not _alive(int(pid)):
            shutil.rmtree(d, ignore_errors=True)
            gone.append(d)
    return gone
