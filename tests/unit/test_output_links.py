"""The output-directory rule (docs/design.md, invariant 6): nothing navstress writes or deletes
leaves the directory it was given.

Families of planted symbolic links (to a user's folder holding a ``.git`` and a ``.env``, to one
of its files, dangling) at every name navstress uses inside a campaign, a search and a demo
directory, on the first run and on resume, through the real CLI: one line naming the link, exit
2, the link's target byte for byte as it was, nothing created outside the output directory. File
outputs of every command with links at every name they write and at the fixed temporary names of
before (``.NAME.tmp``, ``.NAME.partial``): written, the target untouched. The clean-up of partial
files removes only the names navstress gives them (a property over arbitrary hidden names), and
never through a link. And a test lists every place in ``src/`` that opens a path for writing or
deletes one, each reviewed.
"""

from __future__ import annotations

import json
import re
import shutil
import sqlite3
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import navstress
from tests.support.cli_inputs import CAMPAIGN, OUTPUT_COMMANDS, SEARCH, assert_one_line_error, invoke, prepare
from tests.support.links import KINDS, make_outside, outside_of, plant, target, tree
from navstress import _files
from navstress.campaign.plan import plan
from navstress.campaign.scheduler import WorkQueue
from navstress.campaign.spec import parse_campaign
from navstress.campaign.store import Store
from navstress.errors import OutputPathError
from navstress.run.mission import execute
from navstress.run.trace import TraceWriter
from tests.support.world_fixtures import small_world

SPEC = parse_campaign(CAMPAIGN)
TEXT = yaml.safe_dump(CAMPAIGN)


def _paths(out: Path) -> tuple[Path, Path]:
    """The tiny campaign's one trace and one world, relative to its directory."""
    t = plan(SPEC, out).tasks[0]
    base = out.resolve()
    return Path(t.trace_path).relative_to(base), Path(t.world_dir).relative_to(base)


def campaign_names(out: Path) -> list[str]:
    """Every name navstress writes, keeps or removes inside a campaign directory (of the tiny
    campaign), at every depth."""
    trace, world = _paths(out)
    return ["traces", "worlds", ".lock", "spec.yaml", "campaign.sqlite", "campaign.sqlite-wal", "campaign.sqlite-shm",
            "campaign.sqlite-journal", ".spec.yaml.tmp", ".campaign.sqlite.tmp",
            *[str(p) for p in list(reversed(trace.parents))[2:]], str(trace), str(trace.with_name(f".{trace.name}.partial")),
            *[str(p) for p in list(reversed(world.parents))[2:]], str(world), str(world.with_name(f".{world.name}.old")),
            str(world.with_name(f".{world.name}.abcd_123")), str(world / "world.json")]


@pytest.fixture()
def base(tmp_path: Path) -> Path:
    """``tmp_path`` with the user's folder ``outside`` and the spec files."""
    make_outside(tmp_path)
    (tmp_path / "spec.yaml").write_text(TEXT, encoding="utf-8")
    (tmp_path / "search.yaml").write_text(yaml.safe_dump(SEARCH), encoding="utf-8")
    return tmp_path


def _assert_refused(argv: list[str], link: Path, base: Path, out: Path) -> None:
    before = outside_of(base, out)
    line = assert_one_line_error(*invoke(argv), argv)
    assert repr(str(link)) in line and "symbolic link" in line, line
    assert outside_of(base, out) == before  # the link's target byte for byte, nothing created outside
    assert not (base / "outside" / "missing").exists()


@pytest.fixture(scope="module")
def pending(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A campaign directory to resume: its store, its run pending, its world generated."""
    out = tmp_path_factory.mktemp("pending") / "c"
    with Store.create(out, SPEC, TEXT):
        pass
    small_world().save(out / _paths(out)[1])
    return out


def _copy(src: Path, dest: Path) -> Path:
    shutil.copytree(src, dest, symlinks=True)
    return dest


def _rotated(names: list[str], modes: int = 1) -> list[tuple[str, int, str]]:
    """(name, mode, kind) for every name and mode, the kinds turning so that each name meets a
    different kind in each mode and every kind is met at every depth."""
    return [(n, m, KINDS[(i + m) % len(KINDS)]) for i, n in enumerate(names) for m in range(modes)]


# ---- campaign run ------------------------------------------------------------------------------


#: every name in two of the three kinds, and the reported case: traces/ or worlds/ a link to the
#: user's folder, on the first run and on resume
_CAMPAIGN_CASES = _rotated(campaign_names(Path("/c")), modes=2) + [("traces", 1, "dir"), ("worlds", 0, "dir"),
                                                                  ("worlds", 1, "dir")]


@pytest.mark.not_traces  # links named *.mcap, to files that are no traces
@pytest.mark.parametrize("name,resume,kind", _CAMPAIGN_CASES,
                         ids=[f"{n}-{'resume' if r else 'first-run'}-{k}" for n, r, k in _CAMPAIGN_CASES])
def test_campaign_run_refuses_a_planted_link(base: Path, pending: Path, name: str, resume: int, kind: str) -> None:
    out = _copy(pending, base / "c") if resume else base / "c"
    out.mkdir(exist_ok=True)
    link = out / name
    plant(link, kind, base / "outside")
    _assert_refused(["campaign", "run", str(base / "spec.yaml"), "-q", "-o", str(out)], link, base, out)


def test_the_output_directory_itself_may_be_a_link(base: Path) -> None:
    """The directory the user names is followed once: a store made through a link to it lives in
    its target, and resumes through the link."""
    real = base / "real"
    real.mkdir()
    (base / "c").symlink_to(real)
    with Store.create(base / "c", SPEC, TEXT) as s:
        assert s.progress() == (0, 1)
        assert Path(s.task(s.planned_ids()[0]).trace_path).is_relative_to(real.resolve())
    assert (real / "campaign.sqlite").is_file()
    with Store.create(base / "c", SPEC, TEXT) as s:
        assert s.progress() == (0, 1)


# ---- search ------------------------------------------------------------------------------------

SEARCH_NAMES = ["search.yaml", "search.json", "suite", "suite/suite.yaml", "suite/worlds", ".suite.tmp", ".suite.old",
                "traces", "worlds", ".lock", "campaign.sqlite-wal"]


@pytest.mark.parametrize("name,_,kind", _rotated(SEARCH_NAMES))
def test_search_refuses_a_planted_link_on_its_first_run(base: Path, name: str, _: int, kind: str) -> None:
    out = base / "s"
    link = out / name
    plant(link, kind, base / "outside")
    _assert_refused(["search", str(base / "search.yaml"), "-q", "-o", str(out)], link, base, out)


@pytest.mark.not_traces  # the copied search's traces were checked when it ran
@pytest.mark.parametrize("name,_,kind", [(n, m, KINDS[(i + 1) % len(KINDS)]) for i, (n, m, _k) in
                                         enumerate(_rotated(SEARCH_NAMES))])
def test_search_refuses_a_planted_link_on_resume(base: Path, tiny_searches: object, name: str, _: int,
                                                 kind: str) -> None:
    out = base / "s"
    shutil.copytree(tiny_searches.search, out, symlinks=True)  # type: ignore[attr-defined]
    (base / "search.yaml").write_bytes((out / "search.yaml").read_bytes())  # the spec it was run with
    link = out / name
    plant(link, kind, base / "outside")
    _assert_refused(["search", str(base / "search.yaml"), "-q", "-o", str(out)], link, base, out)


# ---- demo --------------------------------------------------------------------------------------

DEMO_NAMES = ["demo.yaml", "campaign", "report.html", ".demo.yaml.tmp", "campaign/traces", "campaign/.lock"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", DEMO_NAMES)
def test_demo_refuses_a_planted_link(base: Path, name: str, kind: str) -> None:
    out = base / "d"
    link = out / name
    plant(link, kind, base / "outside")
    _assert_refused(["demo", "-o", str(out)], link, base, out)


# ---- file outputs ------------------------------------------------------------------------------

_FILE_COMMANDS = [c for c in OUTPUT_COMMANDS if c.kind == "file"]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("inputs")
    prepare(root)
    return root


@pytest.mark.parametrize("cmd", _FILE_COMMANDS, ids=lambda c: c.name)
def test_file_outputs_never_write_through_a_link(inputs: Path, tmp_path: Path, cmd: object) -> None:
    """Every name the command writes (learnt from a first run), and the fixed temporary names of
    before beside each, planted with links: the command writes its files (a link at its own name
    is replaced, its target untouched) or refuses in one line."""
    argv_of = cmd.argv  # type: ignore[attr-defined]
    learn = tmp_path / "learn"
    learn.mkdir()
    code, so, se = invoke(argv_of(inputs, str(learn / f"out{cmd.suffix}")))  # type: ignore[attr-defined]
    assert code == 0, se
    written = sorted(p.name for p in learn.iterdir())
    assert written, "the command wrote nothing"
    outside = make_outside(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    # its own names: the one named dangling (an existing one is refused by some), the others links
    # to the user's .env; the temporary names of before: links to the user's .env
    for i, w in enumerate(written):
        plant(out / w, "dangling" if i == 0 else "file", outside)
        for tmp in (f".{w}.tmp", f".{w}.partial"):
            plant(out / tmp, "file", outside)
    before = outside_of(tmp_path, out)
    argv = argv_of(inputs, str(out / f"out{cmd.suffix}"))  # type: ignore[attr-defined]
    code, so, se = invoke(argv)
    if code != 0:
        assert_one_line_error(code, so, se, argv)
    else:
        for w in written:
            assert (out / w).is_file() and not (out / w).is_symlink(), w
    assert outside_of(tmp_path, out) == before
    assert not (outside / "missing").exists()


def test_campaign_export_into_the_campaign_never_writes_through_a_link(base: Path, pending: Path) -> None:
    out = _copy(pending, base / "c")
    for i, name in enumerate(("runs.csv", ".runs.csv.tmp")):
        plant(out / name, KINDS[i], base / "outside")
    before = outside_of(base, out)
    code, so, se = invoke(["campaign", "export", str(out)])
    assert code == 0, se
    assert (out / "runs.csv").is_file() and not (out / "runs.csv").is_symlink()
    assert outside_of(base, out) == before


# ---- world generate, trace export, run ---------------------------------------------------------


def test_world_generate_replaces_a_world_holding_links_without_following_them(base: Path) -> None:
    out = base / "w"
    small_world().save(out)
    for name, kind in zip(("preview.png", "extra", ".hidden"), KINDS):
        plant(out / name, kind, base / "outside")
    before = outside_of(base, out)
    code, so, se = invoke(["world", "generate", "--size", "20", "--cell", "0.5", "-o", str(out)])
    assert code == 0, se
    assert outside_of(base, out) == before
    assert sorted(p.name for p in out.iterdir()) == ["preview.png", "terrain.npz", "world.json"]


@pytest.mark.parametrize("kind", KINDS)
def test_world_generate_refuses_a_link_at_its_old_name(base: Path, kind: str) -> None:
    out = base / "w"
    small_world().save(out)
    link = base / ".w.old"
    plant(link, kind, base / "outside")
    before = outside_of(base, out, link)
    argv = ["world", "generate", "--size", "20", "--cell", "0.5", "-o", str(out)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert repr(str(link)) in line, line
    assert outside_of(base, out, link) == before


def test_world_generate_follows_a_link_named_as_its_output_once(base: Path) -> None:
    """The link the user names is the user's choice: the world it points to is replaced, the link stays."""
    real = base / "real-world"
    small_world().save(real)
    (base / "w").symlink_to(real)
    code, so, se = invoke(["world", "generate", "--size", "20", "--cell", "0.5", "--seed", "7", "-o", str(base / "w")])
    assert code == 0, se
    assert (base / "w").is_symlink() and json.loads((real / "world.json").read_text())["seed"] == 7
    assert not list(base.glob(".w*")) and not list(base.glob(".real-world.*"))


@pytest.mark.parametrize("kind", KINDS)
def test_trace_export_refuses_a_link_as_its_new_directory(inputs: Path, base: Path, kind: str) -> None:
    link = base / "bag"
    plant(link, kind, base / "outside")
    before = outside_of(base, link)
    argv = ["trace", "export", str(inputs / "t.mcap"), "-o", str(link)]
    line = assert_one_line_error(*invoke(argv), argv)
    assert str(link) in line, line
    assert outside_of(base, link) == before


# ---- replay ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny campaign with its one run recorded (run here, on a small world: its trace)."""
    out = tmp_path_factory.mktemp("ran") / "c"
    with Store.create(out, SPEC, TEXT) as s:
        task = s.task(s.planned_ids()[0])
        small_world().save(task.world_dir)
        assert s.add(execute(task))
    return out


@pytest.mark.slow
def test_replay_keeps_its_trace_without_following_a_link(ran: Path, base: Path) -> None:
    outside = base / "outside"
    keep = base / "keep"
    keep.mkdir()
    for name, kind in (("a.mcap", "file"), (".a.mcap.tmp", "file"), (".a.mcap.partial", "dir")):
        plant(keep / name, kind, outside)
    before = outside_of(base, keep)
    with Store.open(ran) as s:
        run_id = s.planned_ids()[0]
    code, so, se = invoke(["replay", str(ran), run_id, "--keep", str(keep / "a.mcap")])
    assert code == 0, so + se
    assert (keep / "a.mcap").is_file() and not (keep / "a.mcap").is_symlink()
    assert outside_of(base, keep) == before


@pytest.mark.not_traces  # a t.mcap that is no trace
@pytest.mark.parametrize("kind", KINDS)
def test_copy_atomic_replaces_a_link_never_its_target(base: Path, kind: str) -> None:
    (base / "src").write_bytes(b"new trace")
    plant(base / "out" / "t.mcap", kind, base / "outside")
    plant(base / "out" / ".t.mcap.tmp", "file", base / "outside")
    before = tree(base / "outside")
    _files.copy_atomic(base / "src", base / "out" / "t.mcap")
    assert (base / "out" / "t.mcap").read_bytes() == b"new trace" and not (base / "out" / "t.mcap").is_symlink()
    assert tree(base / "outside") == before


@pytest.mark.parametrize("kind", ["dir", "dangling"])
def test_replay_never_generates_a_missing_world_through_a_link(ran: Path, base: Path, kind: str) -> None:
    c = base / "c"
    shutil.copytree(ran, c, symlinks=True)
    plant(c / "worlds", kind, base / "outside")  # its world gone, the folder a link
    before = outside_of(base, c)
    with Store.open(c) as s:
        run_id = s.planned_ids()[0]
    argv = ["replay", str(c), run_id]
    line = assert_one_line_error(*invoke(argv), argv)
    assert repr(str(c / "worlds")) in line, line
    assert outside_of(base, c) == before


# ---- the clean-up of partial files -------------------------------------------------------------

_HIDDEN = st.from_regex(r"\.[A-Za-z0-9_][A-Za-z0-9_.=-]{0,14}", fullmatch=True)


@pytest.fixture(scope="module")
def store_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cleanup") / "c"
    with Store.create(out, SPEC, TEXT):
        pass
    return out


@settings(max_examples=25, deadline=None)
@given(files=st.sets(_HIDDEN, max_size=6), dirs=st.sets(_HIDDEN, max_size=6), in_world=st.booleans())
def test_cleanup_removes_only_the_names_navstress_gives(store_dir: Path, files: set[str], dirs: set[str],
                                                        in_world: bool) -> None:
    """Arbitrary hidden files and folders (a .git, a .env, names near ours) beside a planned trace
    or world: the clean-up removes exactly ``.<trace>.partial``, ``.m<k>.XXXXXXXX`` and ``.m<k>.old``."""
    trace, world = (store_dir / p for p in _paths(store_dir))
    folder = world.parent if in_world else trace.parent
    shutil.rmtree(store_dir / "traces", ignore_errors=True)
    shutil.rmtree(store_dir / "worlds", ignore_errors=True)
    folder.mkdir(parents=True)
    dirs = dirs | {".git", ".cache", ".m1.abcd_123", ".m0.old", ".m0.abcd_123", ".m0.zz9_0a1b"}
    files = (files | {".env", ".m0.abc", ".m0.abcdefghi", f".{trace.name}.partial", f".{trace.name}.partial.x",
                      f".x{trace.name}.partial"}) - dirs
    for n in files:
        (folder / n).write_bytes(b"x")
    for n in dirs:
        (folder / n).mkdir()
        (folder / n / ".env").write_text("SECRET=1\n")
    if in_world:
        expected = {n for n in dirs if re.fullmatch(r"\.m0\.(old|[a-z0-9_]{8})", n)}
    else:
        expected = {n for n in files if n == f".{trace.name}.partial"}
    with Store.open(store_dir) as s:
        removed = s.cleanup_partials()
    assert {p.name for p in removed} == expected and all(p.parent == folder for p in removed)
    assert {p.name for p in folder.iterdir()} == (files | dirs) - expected


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("where", ["traces", "worlds", "trace folder", "world parent"])
def test_cleanup_never_goes_through_a_link_planted_after_the_check(base: Path, where: str, kind: str) -> None:
    out = base / "c"
    with Store.create(out, SPEC, TEXT) as s:
        trace, world = _paths(out)
        rel = {"traces": "traces", "worlds": "worlds", "trace folder": str(trace.parent),
               "world parent": str(world.parent)}[where]
        (base / "outside" / f".{trace.name}.partial").write_text("user's")
        (base / "outside" / ".m0.old").mkdir()
        plant(out / rel, kind, base / "outside")
        before = tree(base / "outside")
        with pytest.raises(OutputPathError, match=re.escape(repr(str(out / rel)))):
            s.cleanup_partials()
        assert tree(base / "outside") == before


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("depth", [0, 1, 2, 3])
def test_the_driver_checks_each_job_s_path(base: Path, depth: int, kind: str) -> None:
    """A link planted while the campaign runs (after the directory was checked): the next job
    writing below it is refused before it is handed to a worker."""
    out = base / "c"
    p = plan(SPEC, out)
    for what, path in (("run", Path(p.tasks[0].trace_path).parent), ("world", Path(p.maps[0].world_dir))):
        q = WorkQueue(p, p.tasks)
        if what == "run":
            q.ready.extend(q.by_map.pop(p.maps[0].world_dir))
            q.to_generate.clear()
        rel = path.relative_to(out.resolve())
        link = out / Path(*rel.parts[:depth + 1])
        plant(link, kind, base / "outside")
        with pytest.raises(OutputPathError, match="symbolic link"):
            q.next()
        link.unlink()


# ---- the helpers -------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("mode", ["wb", "w", "a", "ab", "a+"])
def test_open_nofollow_refuses_a_link(base: Path, mode: str, kind: str) -> None:
    link = base / "f"
    plant(link, kind, base / "outside")
    before = tree(base / "outside")
    with pytest.raises(OutputPathError, match="symbolic link"):
        _files.open_nofollow(link, mode)
    assert tree(base / "outside") == before
    with _files.open_nofollow(base / "g", mode) as f:
        f.write(b"x" if "b" in mode else "x")
    assert (base / "g").read_bytes() == b"x"


@pytest.mark.parametrize("kind", KINDS)
def test_trace_writer_refuses_a_link_at_its_partial_name(base: Path, kind: str) -> None:
    link = base / "t" / ".r.mcap.partial"
    plant(link, kind, base / "outside")
    before = tree(base / "outside")
    with pytest.raises(OutputPathError):
        TraceWriter(base / "t" / "r.mcap")
    assert tree(base / "outside") == before


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(depth=st.integers(0, 4), at=st.integers(0, 4), kind=st.sampled_from(KINDS))
def test_first_link_finds_a_link_at_any_depth(tmp_path_factory: pytest.TempPathFactory, depth: int, at: int,
                                              kind: str) -> None:
    d = tmp_path_factory.mktemp("tree")
    outside = make_outside(d)
    root = d / "root"
    cur = root
    for i in range(depth):
        cur = cur / f"d{i}"
        cur.mkdir(parents=True)
        (cur / ".hidden").write_text("x")
    root.mkdir(exist_ok=True)
    assert _files.first_link(root) is None
    link = root.joinpath(*[f"d{i}" for i in range(min(at, depth))], ".x")
    link.symlink_to(target(outside, kind))
    assert _files.first_link(root) == link
    with pytest.raises(OutputPathError, match=re.escape(repr(str(link)))):
        _files.refuse_links(root)


def test_remove_tree_and_check_below(base: Path) -> None:
    outside = base / "outside"
    before = tree(outside)
    (base / "link").symlink_to(outside)
    with pytest.raises(OutputPathError):
        _files.remove_tree(base / "link")
    with pytest.raises(OutputPathError):
        _files.check_below(base, base / "link" / "x" / "y")
    with pytest.raises(OutputPathError, match="outside"):
        _files.check_below(base / "c", base / "c" / ".." / "elsewhere")
    _files.check_below(base, base / "not" / "yet" / "there")
    (base / "real" / "sub").mkdir(parents=True)
    (base / "real" / "sub" / "link").symlink_to(outside)
    _files.remove_tree(base / "real")  # links inside a real tree are removed as links
    assert not (base / "real").exists() and tree(outside) == before


def test_store_open_refuses_links_at_the_sqlite_files(base: Path, pending: Path) -> None:
    out = _copy(pending, base / "c")
    for side in ("-wal", "-shm", "-journal"):
        p = out / f"campaign.sqlite{side}"
        p.unlink(missing_ok=True)
        p.symlink_to(base / "outside" / ".env")
        before = tree(base / "outside")
        argv = ["campaign", "status", str(out)]
        line = assert_one_line_error(*invoke(argv), argv)
        assert repr(str(p)) in line, line
        assert tree(base / "outside") == before
        p.unlink()
    assert sqlite3.connect(out / "campaign.sqlite").execute("PRAGMA integrity_check").fetchone()[0] == "ok"


# ---- every writer and deleter of src/, reviewed ------------------------------------------------

SRC = Path(navstress.__file__).parent
_WRITES = re.compile(r"rmtree\(|\.unlink\(|os\.unlink\(|os\.remove\(|\.rglob\(|\.glob\(|open\([^)]*[\"'][wax][b+]?[\"']"
                     r"|\.write_text\(|\.write_bytes\(|copyfile\(|copytree\(|shutil\.(copy|move)\(|savefig\(")
#: (file, the line's code): why it cannot leave the directory it was given. A new writer or
#: deleter goes through navstress._files, or is added here with its reason.
REVIEWED = {
    ("_files.py", 'Path(tmp).unlink(missing_ok=True)'): "its own unique temporary file",
    ("_files.py", 'tmp.unlink(missing_ok=True)'): "its own unique temporary files",
    ("_files.py", 'os.unlink(probe)'): "its own unique probe file",
    ("_files.py", 'with os.fdopen(fd, "wb") as f:'): "its own unique temporary file (mkstemp)",
    ("_files.py", 'shutil.rmtree(p, ignore_errors=True)'): "remove_tree: a real directory, links refused",
    ("_files.py", 'p.unlink(missing_ok=True)'): "remove_tree: a file, links refused",
    ("_files.py", 'with os.fdopen(fd, "wb") as f, open(src, "rb") as s:'): "copy_atomic: reads src",
    ("_files.py", 'shutil.rmtree(old, ignore_errors=True)'): "replace_dir: the directory it just renamed away",
    ("_jit.py", 'for p in sorted(root.rglob("*")):'): "reads navstress's own sources",
    ("campaign/store.py", '(d / name).unlink(missing_ok=True)'): "exact creation leftovers, after refuse_links",
    ("campaign/store.py", 'Path(e.path).unlink(missing_ok=True)'): "cleanup_partials: exact names, no link",
    ("campaign/store.py", 'shutil.rmtree(e.path, ignore_errors=True)'): "cleanup_partials: exact names, no link",
    ("campaign/replay.py", 'shutil.rmtree(scratch, ignore_errors=True)'): "its own mkdtemp scratch folder",
    ("_files.py", 'for d in sorted(root.glob(prefix + "*-*")):'): "scratch folders named by navstress, in the temp directory",
    ("_files.py", 'shutil.rmtree(d, ignore_errors=True)'): "sweep_dead_scratch: a dead process's scratch folder, never a link",
    ("world/world.py", 'with open(tmp / WORLD_JSON, "w", encoding="utf-8") as f:'): "inside its new mkdtemp folder",
    ("world/world.py", 'with open(tmp / TERRAIN_NPZ, "wb") as f:'): "inside its new mkdtemp folder",
    ("world/world.py", 'shutil.rmtree(tmp, ignore_errors=True)'): "its own mkdtemp folder",
    ("world/export/images.py", 'fig.savefig(buf, format="png", dpi=dpi)'): "into memory",
    ("robot/describe.py", 'fig.savefig(buf, format=fmt[1:])'): "into memory",
    ("world/export/images.py", 'shutil.rmtree(out, ignore_errors=True)'): "the world folder it made just now",
    ("search/driver.py", '(tmp / "suite.yaml").write_text(text + yaml.safe_dump(data, sort_keys=False), encoding="utf-8")'):
        "inside .suite.tmp, made just now (a link there refused)",
    ("search/driver.py", 'shutil.copytree(src, tmp / "worlds" / e.candidate.key)'): "into .suite.tmp",
    ("search/driver.py", '(tmp / "suite.json").write_text(_json.dumps(info, indent=1, sort_keys=True) + "\\n", encoding="utf-8")'):
        "inside .suite.tmp",
    ("sim/mjabi.py", 'LIBS = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))'):
        "reads MuJoCo's libraries",
    ("cli/run.py", 'shutil.rmtree(output, ignore_errors=True)'): "the -o folder it created, nothing recorded",
    ("run/trace.py", 'self._tmp.unlink(missing_ok=True)'): "its own partial file (opened O_NOFOLLOW)",
    ("run/ros2.py", 'shutil.rmtree(tmp, ignore_errors=True)'): "its own mkdtemp folder",
    ("run/batch.py", 'p.with_name(f".{p.name}.partial").unlink(missing_ok=True)'): "the exact partial name (a link: only the link)",
    ("run/figures.py", 'fig.savefig(buf, format="png")'): "into memory",
}


def test_every_writer_and_deleter_is_reviewed() -> None:
    found = {(str(p.relative_to(SRC)), line.strip()) for p in sorted(SRC.rglob("*.py"))
             for line in p.read_text(encoding="utf-8").splitlines()
             if _WRITES.search(line) and not line.lstrip().startswith(("#", ">>>", "``"))}
    found = {(f, code) for f, code in found if not code.startswith(('"', "'"))}  # docstrings
    assert found - REVIEWED.keys() == set(), "new writers or deleters: go through navstress._files or review them here"
