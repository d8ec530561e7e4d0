"""Planted symbolic links for the output-directory tests (docs/design.md, invariant 6): a user's
folder outside every output directory (a fake ``.git`` and ``.env`` among its files), links to it
of every kind, and snapshots that see links, hidden files and file contents without following
any link."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

#: What a planted link points to: the user's folder, one of its files, or nothing.
KINDS = ("dir", "file", "dangling")


def make_outside(base: Path) -> Path:
    """``base/outside``: a user's project folder (a git checkout with a .env), what a planted link
    points to."""
    out = base / "outside"
    (out / ".git" / "objects" / "ab").mkdir(parents=True)
    (out / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    (out / ".git" / "objects" / "ab" / "cdef").write_bytes(b"\x78\x9c blob")
    (out / ".env").write_text("SECRET=hunter2\n")
    (out / ".cache" / "deep").mkdir(parents=True)
    (out / ".cache" / "deep" / ".keep").write_text("")
    (out / "notes.txt").write_text("mine\n")
    return out


def target(outside: Path, kind: str) -> Path:
    """The target of a link of ``kind`` into ``outside``."""
    return {"dir": outside, "file": outside / ".env", "dangling": outside / "missing" / "nothing"}[kind]


def plant(link: Path, kind: str, outside: Path) -> None:
    """Make ``link`` a symbolic link of ``kind``, replacing whatever is there."""
    if link.is_symlink() or link.is_file():
        link.unlink()
    elif link.is_dir():
        shutil.rmtree(link)
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target(outside, kind))


def tree(root: Path) -> dict[str, str | bytes]:
    """Every entry under ``root``, links never followed: a file's bytes, ``<dir>``, or
    ``-> target`` for a link."""
    out: dict[str, str | bytes] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "-> " + os.readlink(p)
            elif p.is_dir():
                out[rel] = "<dir>"
            else:
                out[rel] = p.read_bytes()
    return out


def outside_of(base: Path, *inside: Path) -> dict[str, str | bytes]:
    """:func:`tree` of ``base`` less the output directories ``inside`` (what a command may change)."""
    skip = [str(p.relative_to(base)) for p in inside]
    return {k: v for k, v in tree(base).items() if not any(k == s or k.startswith(s + os.sep) for s in skip)}
