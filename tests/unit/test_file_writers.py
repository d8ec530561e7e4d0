"""Every writer of files that others read goes through ``navstress._files`` (modes that follow
the umask): no other module creates files or directories with tempfile's owner-only modes."""

from __future__ import annotations

import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import navstress
from navstress import _files

SRC = Path(navstress.__file__).parent
OWNER_ONLY = re.compile(r"\b(mkstemp|mkdtemp|NamedTemporaryFile|TemporaryDirectory)\b|os\.open\(")
# scratch space deleted after use, never read by anyone else
ALLOWED = {"_files.py", "campaign/replay.py", "campaign/work.py"}


def test_no_owner_only_writers_outside_the_helper() -> None:
    offenders = [f"{p.relative_to(SRC)}:{i}: {line.strip()}"
                 for p in sorted(SRC.rglob("*.py")) if str(p.relative_to(SRC)) not in ALLOWED
                 for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                 if OWNER_ONLY.search(line) and not line.lstrip().startswith(("#", ">>>"))]
    assert offenders == []


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077, 0o027])
def test_helper_modes_follow_the_umask(tmp_path: Path, umask: int) -> None:
    code = ("import sys; from navstress import _files; d = sys.argv[1];"
            "_files.write_atomic(d + '/a/f.bin', b'x'); t = _files.temp_dir_beside(d + '/b');"
            "_files.create_file(d + '/c'); print(oct(_files.umask()), t)")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, umask=umask,
                         env=env, check=True)
    got_umask, tmpdir = out.stdout.split()
    assert int(got_umask, 8) == umask
    assert stat.S_IMODE((tmp_path / "a" / "f.bin").stat().st_mode) == 0o666 & ~umask
    assert stat.S_IMODE((tmp_path / "c").stat().st_mode) == 0o666 & ~umask
    assert stat.S_IMODE(Path(tmpdir).stat().st_mode) == 0o777 & ~umask
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["f.bin"]  # no temporary left


def test_write_atomic_leaves_nothing_on_failure(tmp_path: Path) -> None:
    (tmp_path / "f").write_bytes(b"old")
    with pytest.raises(TypeError):
        _files.write_atomic(tmp_path / "f", 42)  # type: ignore[arg-type]
    assert [p.name for p in tmp_path.iterdir()] == ["f"] and (tmp_path / "f").read_bytes() == b"old"


@pytest.mark.parametrize("n,bad", [(2, 0), (2, 1), (3, 1), (3, 2), (4, 3)])
def test_write_atomic_group_writes_all_or_none(tmp_path: Path, n: int, bad: int) -> None:
    (tmp_path / "f0").write_bytes(b"old")  # an earlier export of the same name stays as it was
    files: dict[Path, bytes | str] = {tmp_path / f"f{i}": f"new {i}" for i in range(n)}
    files[tmp_path / f"f{bad}"] = 42  # type: ignore[assignment]  # fails while being written
    with pytest.raises(TypeError):
        _files.write_atomic_group(files)
    assert [p.name for p in tmp_path.iterdir()] == ["f0"] and (tmp_path / "f0").read_bytes() == b"old"
    files[tmp_path / f"f{bad}"] = b"fixed"
    _files.write_atomic_group(files)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"f{i}" for i in range(n)]
    assert (tmp_path / "f0").read_bytes() == (b"fixed" if bad == 0 else b"new 0")
