"""The renames of ``navstress._files`` (the only module allowed to rename a temporary file into place,
tests/unit/test_rules.py): a fixed temporary name, a file a library writes by name, a finished file or
directory moved into place, a directory swapped with the one it replaces. Each leaves nothing
behind when it fails and never writes through a link."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from navstress import _files
from navstress.errors import OutputPathError

DEST_KINDS = ["none", "file", "link"]


def _make_dest(tmp_path: Path, kind: str) -> tuple[Path, Path]:
    """``tmp_path/out/f`` as nothing, an old file, or a link to a file outside ``out``; returns
    (dest, the link's target)."""
    out = tmp_path / "out"
    out.mkdir()
    target = tmp_path / "target"
    target.write_bytes(b"target")
    dest = out / "f"
    if kind == "file":
        dest.write_bytes(b"old")
    elif kind == "link":
        dest.symlink_to(target)
    return dest, target


@pytest.mark.parametrize("kind", DEST_KINDS)
@pytest.mark.parametrize("data", [b"\x00bytes\xff", "text é\n"])
def test_write_atomic_with_a_fixed_temporary_name(tmp_path: Path, kind: str, data: bytes | str) -> None:
    dest, target = _make_dest(tmp_path, kind)
    _files.write_atomic(dest, data, temp=dest.with_name(".f.tmp"))
    raw = data.encode() if isinstance(data, str) else data
    assert dest.read_bytes() == raw and not dest.is_symlink()
    assert sorted(p.name for p in dest.parent.iterdir()) == ["f"]
    assert target.read_bytes() == b"target"  # a link at dest is replaced, its target untouched
    assert stat.S_IMODE(dest.stat().st_mode) == _files.file_mode()


@pytest.mark.parametrize("kind", DEST_KINDS)
def test_write_atomic_with_a_fixed_name_leaves_nothing_on_failure(tmp_path: Path, kind: str) -> None:
    dest, target = _make_dest(tmp_path, kind)
    before = sorted(p.name for p in dest.parent.iterdir())
    with pytest.raises(TypeError):
        _files.write_atomic(dest, 42, temp=dest.with_name(".f.tmp"))  # type: ignore[arg-type]
    assert sorted(p.name for p in dest.parent.iterdir()) == before
    assert target.read_bytes() == b"target"


def test_a_link_at_the_fixed_temporary_name_is_refused(tmp_path: Path) -> None:
    dest, target = _make_dest(tmp_path, "none")
    dest.with_name(".f.tmp").symlink_to(target)
    with pytest.raises(OutputPathError, match="symbolic link"):
        _files.write_atomic(dest, b"new", temp=dest.with_name(".f.tmp"))
    assert target.read_bytes() == b"target" and not dest.exists()


@pytest.mark.parametrize("temp", ["../elsewhere.tmp", "sub/../../x.tmp", "/tmp/x.tmp"])
def test_a_temporary_outside_the_folder_is_refused(tmp_path: Path, temp: str) -> None:
    dest, _ = _make_dest(tmp_path, "none")
    t = Path(temp) if temp.startswith("/") else dest.parent / temp
    with pytest.raises(ValueError, match="not beside"):
        _files.write_atomic(dest, b"x", temp=t)
    with pytest.raises(ValueError, match="not beside"):
        _files.rename_into_place(t, dest)
    with pytest.raises(ValueError, match="not beside"):
        _files.replace_dir(t, dest)
    assert not dest.exists()


@pytest.mark.parametrize("kind", DEST_KINDS)
@pytest.mark.parametrize("fixed", [False, True])
@pytest.mark.parametrize("durable", [False, True])
def test_replaced_on_success_renames_what_was_written(tmp_path: Path, kind: str, fixed: bool, durable: bool) -> None:
    dest, target = _make_dest(tmp_path, kind)
    with _files.replaced_on_success(dest, dest.with_name(".f.tmp") if fixed else None, durable=durable) as tmp:
        assert tmp.parent == dest.parent and tmp.name.startswith(".f.") and tmp.stat().st_size == 0
        assert stat.S_IMODE(tmp.stat().st_mode) == _files.file_mode()
        tmp.unlink()  # a program that writes its output anew (a linker) replaces the file
        tmp.write_bytes(b"built")
    assert dest.read_bytes() == b"built" and not dest.is_symlink()
    assert sorted(p.name for p in dest.parent.iterdir()) == ["f"]
    assert target.read_bytes() == b"target"


@pytest.mark.parametrize("kind", DEST_KINDS)
@pytest.mark.parametrize("fixed", [False, True])
def test_replaced_on_success_leaves_nothing_when_the_block_raises(tmp_path: Path, kind: str, fixed: bool) -> None:
    dest, target = _make_dest(tmp_path, kind)
    before = sorted(p.name for p in dest.parent.iterdir())
    with pytest.raises(OSError, match="compiler failed"):
        with _files.replaced_on_success(dest, dest.with_name(".f.tmp") if fixed else None) as tmp:
            tmp.write_bytes(b"half")
            raise OSError("compiler failed")
    assert sorted(p.name for p in dest.parent.iterdir()) == before
    assert target.read_bytes() == b"target"
    if kind == "file":
        assert dest.read_bytes() == b"old"


@pytest.mark.parametrize("kind", DEST_KINDS)
@pytest.mark.parametrize("what", ["file", "dir"])
def test_rename_into_place(tmp_path: Path, kind: str, what: str) -> None:
    dest, target = _make_dest(tmp_path, kind)
    if what == "dir" and kind == "file":
        return  # a directory never replaces a file (rename(2): EISDIR/ENOTDIR, as before)
    built = _files.temp_dir_beside(dest)
    tmp = built / dest.name  # built inside a temporary folder beside dest, as a bag is
    if what == "file":
        tmp.write_bytes(b"new")
    else:
        tmp.mkdir()
        (tmp / "inside").write_bytes(b"new")
    if kind == "link" and what == "dir":
        dest.unlink()
    _files.rename_into_place(tmp, dest)
    assert (dest.read_bytes() if what == "file" else (dest / "inside").read_bytes()) == b"new"
    assert target.read_bytes() == b"target"


def _dir(path: Path, text: str) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    (path / "data").write_text(text)
    return path


@pytest.mark.parametrize("old_left", [False, True])
@pytest.mark.parametrize("exists", [False, True])
def test_replace_dir_swaps_whole_directories(tmp_path: Path, exists: bool, old_left: bool) -> None:
    dest = tmp_path / "w"
    if exists:
        _dir(dest, "old")
    if old_left:  # what a killed replacement left
        _dir(tmp_path / ".w.old", "older")
    tmp = _dir(_files.temp_dir_beside(dest), "new")
    _files.replace_dir(tmp, dest)
    assert (dest / "data").read_text() == "new"
    # the old name is cleared only on the way to replacing (as World.save always did)
    assert sorted(p.name for p in tmp_path.iterdir()) == ([".w.old"] if old_left and not exists else []) + ["w"]


def test_replace_dir_refuses_a_link_at_its_old_name(tmp_path: Path) -> None:
    dest = _dir(tmp_path / "w", "old")
    elsewhere = _dir(tmp_path / "elsewhere", "keep")
    (tmp_path / ".w.old").symlink_to(elsewhere)
    tmp = _dir(_files.temp_dir_beside(dest), "new")
    with pytest.raises(OutputPathError, match="symbolic link"):
        _files.replace_dir(tmp, dest)
    assert (dest / "data").read_text() == "old" and (elsewhere / "data").read_text() == "keep"
    assert os.path.islink(tmp_path / ".w.old")
