"""Every command that writes a file or folder x a family of output paths it cannot write:
exit 2, exactly one ``error:`` line naming the path, no traceback, nothing written.

The user here is root, so ``chmod`` stops nothing: the families are a parent that is a regular
file (ENOTDIR/EEXIST), a folder under /proc that cannot exist (ENOENT), a file in /sys's root
(EACCES/EPERM for root too), an existing directory where a file is expected, and a read-only
tmpfs mounted in a private user+mount namespace (``unshare -rm``; EROFS).
"""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.cli_inputs import OUTPUT_COMMANDS, OutputCommand, assert_one_line_error, invoke, prepare, snapshot

ROOT = Path(__file__).resolve().parents[3]  # the child scripts import tests.support from there
FAMILIES = {
    "parent is a file": "{root}/afile/out",
    "parent under /proc": "/proc/navstress-no-such-dir/out",
    "in /sys (EACCES)": "/sys/navstress-out",
}


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("badpaths")
    prepare(r)
    (r / "afile").write_text("not a folder")
    (r / "adir").mkdir()
    (r / "adir" / "keep.txt").write_text("mine")
    return r


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("cmd", OUTPUT_COMMANDS, ids=lambda c: c.name)
def test_unwritable_output_is_one_line_exit_2_nothing_written(root: Path, cmd: OutputCommand, family: str) -> None:
    out = FAMILIES[family].replace("{root}", str(root))
    argv = cmd.argv(root, out)
    before = snapshot(root)
    line = assert_one_line_error(*invoke(argv), argv)
    assert "path=" in line or "--output=" in line or "output=" in line, line
    assert snapshot(root) == before
    assert not Path(out).exists()


@pytest.mark.parametrize("cmd", [c for c in OUTPUT_COMMANDS if c.kind == "file"], ids=lambda c: c.name)
def test_output_naming_an_existing_directory_is_refused(root: Path, cmd: OutputCommand) -> None:
    argv = cmd.argv(root, str(root / "adir"))
    before = snapshot(root)
    line = assert_one_line_error(*invoke(argv), argv)
    assert str(root / "adir") in line, line
    assert snapshot(root) == before


def test_os_errors_name_the_user_path_not_a_temporary_one(root: Path) -> None:
    argv = ["world", "export", str(root / "w"), "--format", "mjcf", "-o", "/sys/navstress-x.xml"]
    line = assert_one_line_error(*invoke(argv), argv)
    assert "path='/sys/navstress-x.xml'" in line and "EACCES" in line, line


_RO_SCRIPT = """
import json, sys
sys.path[:0] = sys.argv[3].split(":")
from pathlib import Path
from tests.support.cli_inputs import OUTPUT_COMMANDS, invoke, snapshot
root, ro = Path(sys.argv[1]), sys.argv[2]
out = {}
for c in OUTPUT_COMMANDS:
    before = snapshot(root)
    code, so, se = invoke(c.argv(root, ro + "/out"))
    out[c.name] = [code, so, se, snapshot(root) == before]
print(json.dumps(out))
"""


def _unshare_works() -> bool:
    if shutil.which("unshare") is None:
        return False
    r = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o ro tmpfs /mnt && ! touch /mnt/x"],
                       capture_output=True)
    return r.returncode == 0


@pytest.mark.slow
@pytest.mark.skipif(not _unshare_works(), reason="needs unshare -rm and tmpfs mounts")
def test_read_only_file_system_in_every_output_command(tmp_path: Path) -> None:
    root = tmp_path / "root"
    prepare(root)
    ro = tmp_path / "ro"
    ro.mkdir()
    paths = str(ROOT)
    script = f"mount -t tmpfs -o ro tmpfs {ro} && exec {sys.executable} -c '{_RO_SCRIPT}' {root} {ro} {paths}"
    r = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    results = json.loads(r.stdout.strip().splitlines()[-1])
    assert set(results) == {c.name for c in OUTPUT_COMMANDS}
    for name, (code, so, se, unchanged) in results.items():
        line = assert_one_line_error(code, so, se, [name])
        assert "EROFS" in line and str(ro) in line, (name, line)
        assert unchanged, name
    assert list(ro.iterdir()) == []


_FULL_SCRIPT = """
import json, subprocess, sys
sys.path[:0] = sys.argv[3].split(":")
from pathlib import Path
from tests.support.cli_inputs import OUTPUT_COMMANDS, invoke
root, base = Path(sys.argv[1]), Path(sys.argv[2])
skip = set(sys.argv[4].split(","))
out = {}
for i, c in enumerate(OUTPUT_COMMANDS):
    if c.name in skip:
        continue
    full = base / str(i)
    full.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=24k", "tmpfs", str(full)], check=True)
    code, so, se = invoke(c.argv(root, str(full / "out")))
    out[c.name] = [code, so, se, sorted(p.name for p in full.rglob("*"))]
print(json.dumps(out))
"""

# a full disk under the campaign store is the store's own error (SQLite), checked with the store
_FULL_SKIP = {"demo", "campaign run", "search"}


@pytest.mark.slow
@pytest.mark.skipif(not _unshare_works(), reason="needs unshare -rm and tmpfs mounts")
def test_full_disk_in_every_output_command_is_one_line_and_leaves_nothing(tmp_path: Path) -> None:
    root = tmp_path / "root"
    prepare(root)
    base = tmp_path / "full"
    base.mkdir()
    skip = shlex.quote(",".join(sorted(_FULL_SKIP)))
    script = (f"mount -t tmpfs tmpfs {base} && exec {sys.executable} -c '{_FULL_SCRIPT}' {root} {base} "
              f"{ROOT} {skip}")
    r = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    results = json.loads(r.stdout.strip().splitlines()[-1])
    refused = 0
    for name, (code, so, se, left) in results.items():
        if code == 0:  # it fitted in 24 KiB
            assert left, name
            continue
        line = assert_one_line_error(code, so, se, [name])
        assert "ENOSPC" in line and "free some space" in line, (name, line)
        assert left == [], (name, left)  # nothing partial
        refused += 1
    assert refused >= 8  # worlds, pictures, meshes, runs and reports do not fit


#: What each command that resumes its work says to run again on a full disk: itself.
_RESUME = {"campaign run": "navstress campaign run {root}/spec.yaml -o {out}",
           "search": "navstress search {root}/search.yaml -o {out}",
           "demo": "navstress demo -o {out}"}


@pytest.mark.slow
@pytest.mark.skipif(not _unshare_works(), reason="needs unshare -rm and tmpfs mounts")
def test_a_full_disk_under_a_resumable_command_says_to_resume_with_that_command(tmp_path: Path) -> None:
    assert set(_RESUME) == _FULL_SKIP
    root = tmp_path / "root"
    prepare(root)
    base = tmp_path / "full"
    base.mkdir()
    only = shlex.quote(",".join(sorted(c.name for c in OUTPUT_COMMANDS if c.name not in _FULL_SKIP)))
    script = (f"mount -t tmpfs tmpfs {base} && exec {sys.executable} -c '{_FULL_SCRIPT}' {root} {base} "
              f"{ROOT} {only}")
    r = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    results = json.loads(r.stdout.strip().splitlines()[-1])
    assert set(results) == _FULL_SKIP
    for i, c in enumerate(OUTPUT_COMMANDS):
        if c.name not in _FULL_SKIP:
            continue
        code, so, se, _left = results[c.name]
        line = assert_one_line_error(code, so, se, [c.name])
        want = _RESUME[c.name].replace("{root}", str(root)).replace("{out}", str(base / str(i) / "out"))
        assert "disk is full" in line and f"resume with: {want} " in line, (c.name, line)
        if c.name != "campaign run":
            assert "campaign run" not in line, line
