"""The campaign store: one directory that loses nothing.

Layout of ``DIR``::

    spec.yaml          the campaign spec as given (byte for byte)
    campaign.sqlite    SQLite (WAL): tables meta, planned, runs
    worlds/<experiment>/<config>/m<k>/    generated worlds (World.save, atomic)
    traces/<experiment>/<config>/m<k>/r<j>-<navigator>-<fault>.mcap    run traces (atomic)

Every record is one ``INSERT`` in its own transaction (a record is there whole or not at
all); ``run_id`` is the primary key, so no run can be recorded twice. Only the campaign
driver writes (single writer), holding an exclusive lock on ``DIR/.lock`` (released by the
OS even on SIGKILL). On resume the runs already in ``runs`` are skipped, and stale partial
files are removed: only the names navstress gives them (``.<trace name>.partial`` beside a
planned trace, ``.m<k>.XXXXXXXX`` and ``.m<k>.old`` beside a planned world), never through a link.
A symbolic link planted anywhere inside ``DIR`` is refused (one line) before anything is written:
nothing navstress writes or deletes leaves ``DIR`` (docs/design.md, invariant 6).

Opening a store checks every row of every table (:data:`RULES`, :func:`_check_types`,
:func:`_check_contents`): a value of the wrong type, out of range or vocabulary, JSON that does
not parse or is of the wrong kind, a record whose keys are not its planned run's, a planned task
that is not its row's, is one StoreError naming table, row and column. So every reader below
returns values of the types it says, and no command meets a damaged store with a traceback.

A campaign grows with :meth:`Store.extend`: a spec that adds experiments at the end of the
stored spec's list (all else unchanged) adds their planned runs and becomes the stored spec in
one transaction. The database is the truth: ``spec.yaml`` is its copy, rewritten after the
transaction (and again, from the text kept in ``meta``, when a killed extension left the old
copy and the store is next opened for writing).

    >>> import tempfile
    >>> from navstress.campaign.presets import demo
    >>> from navstress.campaign.spec import parse_campaign
    >>> d = tempfile.mkdtemp()
    >>> with Store.create(d, parse_campaign(demo()), "...") as s:
    ...     s.progress()
    (0, 90)
"""

from __future__ import annotations

import csv
import errno
import fcntl
import json
import math
import os
import re
import shutil
import sqlite3
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Literal

from navstress import __version__, _files, _json
from navstress._tables import FORMATS, Kind, read_table, write_table
from navstress.campaign.plan import (NOMINAL, Plan, config_key_of, plan, trace_path, variant, variant_of,
                                     world_path)
from navstress.campaign.sources import check_sources, has_sources, pin_sources
from navstress.campaign.spec import CampaignSpec, parse_campaign_text, spec_yaml
from navstress.errors import SpecError, StoreError
from navstress.run.outcome import Outcome
from navstress.run.record import DEFAULT_ROBOT, DEFAULT_ROBOT_DIGEST, SOURCE_COLUMNS, RunRecord, RunTask
from navstress.world.spec import SourceSpec
from navstress.world.world import world_descriptors

DB_NAME = "campaign.sqlite"
SPEC_NAME = "spec.yaml"
LOCK_NAME = ".lock"
SCHEMA_VERSION = "1"
OUTCOMES: tuple[str, ...] = tuple(o.value for o in Outcome)

#: The ``runs`` table columns, in order (RunRecord fields).
COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(RunRecord))
#: The runs table's robot columns: added (the default robot's name and digest in every row) to a
#: store made before robots existed when it is opened for writing; read as those values until then.
ROBOT_COLUMNS = ("robot", "robot_digest")
_TYPES = {"map_index": "INTEGER", "run_index": "INTEGER", "map_seed": "INTEGER", "run_seed": "INTEGER",
          "collisions": "INTEGER", "duration_s": "REAL", "wall_s": "REAL", "goal_distance_m": "REAL",
          "path_length_m": "REAL", "tortuousness": "REAL", "first_collision_s": "REAL"}
#: The runs table's column kinds in exports (navstress._tables).
_KIND_OF: dict[str, Kind] = {"INTEGER": "int", "REAL": "float", "TEXT": "str"}
_KINDS: dict[str, Kind] = {c: _KIND_OF[_TYPES.get(c, "TEXT")] for c in COLUMNS}


def _export_kinds() -> dict[str, Kind]:
    """The record's columns in a runs export: ``config`` the configuration key (the key vocabulary
    of navstress._tables), ``params`` after it (the swept parameters as one JSON object), ``errors``
    a list of strings."""
    out: dict[str, Kind] = {}
    for c, kind in _KINDS.items():
        out[c] = "strlist" if c == "errors" else kind
        if c == "config":
            out["params"] = "str"
    return out


_EXPORT_KINDS = _export_kinds()
_FLOATS = ("duration_s", "wall_s", "goal_distance_m", "path_length_m", "tortuousness")
_TMP_DB = f".{DB_NAME}.tmp"
#: The ``meta`` key of the spec text an extension gave (what ``spec.yaml`` must hold).
_SPEC_TEXT = "spec_text"
#: SQLite's side files of a database file (rollback journal, WAL, shared memory).
_SIDE = ("-journal", "-wal", "-shm")
#: Files a store creation that was killed may leave behind (removed when creation is redone).
_CREATION_LEFTOVERS = (f".{SPEC_NAME}.tmp", _TMP_DB, *(_TMP_DB + x for x in _SIDE), *(DB_NAME + x for x in _SIDE))
_OUR_NAMES = {SPEC_NAME, "worlds", "traces", LOCK_NAME, DB_NAME, *_CREATION_LEFTOVERS}
#: World.save's temporary directory (``tempfile.mkdtemp``'s 8 characters) or replaced old
#: directory, beside a world directory ``m<k>`` (group 1).
_WORLD_TEMP = re.compile(r"^\.(m\d+)\.(?:old|[a-z0-9_]{8})$")
#: Columns every store's tables must have (checked when a store is opened).
_REQUIRED = {"meta": ("key", "value"), "planned": ("run_id", "seq", "task"),
             "runs": tuple(c for c in COLUMNS if c not in ROBOT_COLUMNS and c not in SOURCE_COLUMNS)}


class _Connection(sqlite3.Connection):
    """A connection whose ``execute`` turns SQLite errors into one-line StoreErrors."""

    where = ""

    def execute(self, sql: str, parameters: Any = (), /) -> sqlite3.Cursor:
        try:
            return super().execute(sql, parameters)
        except sqlite3.Error as err:
            if is_disk_full(err):
                raise disk_full(self.where) from None
            if type(err) is sqlite3.DatabaseError or "malformed" in str(err) or "no such" in str(err):
                raise StoreError(f"campaign={self.where!r} has a corrupt {DB_NAME} "
                                 f"({' '.join(str(err).split())[:200]}); restore it from a backup, or run "
                                 "the campaign again into a new -o") from None
            raise


def _connect(path: Path) -> sqlite3.Connection:
    con = sqlite3.connect(path, timeout=30.0, isolation_level=None, factory=_Connection)
    con.where = str(path.parent)
    con.row_factory = sqlite3.Row
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("PRAGMA synchronous=FULL")
    return con


def _schema(con: sqlite3.Connection, sources: bool = False) -> None:
    """The tables; the runs table with the source columns only for a campaign with world sources
    (``sources``): a campaign of generated worlds has the store of before sources existed."""
    cols = ", ".join(f"{c} {_TYPES.get(c, 'TEXT')}" + (" PRIMARY KEY" if c == "run_id" else "") for c in COLUMNS
                     if sources or c not in SOURCE_COLUMNS)
    con.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    con.execute("CREATE TABLE IF NOT EXISTS planned (run_id TEXT PRIMARY KEY, seq INTEGER NOT NULL, "
                "experiment TEXT, config TEXT, map_index INTEGER, run_index INTEGER, navigator TEXT, "
                "fault TEXT, task TEXT NOT NULL)")
    con.execute(f"CREATE TABLE IF NOT EXISTS runs ({cols}, recorded_at REAL)")
    _attempts_schema(con)


def _attempts_schema(con: sqlite3.Connection) -> None:
    """Failed attempts of runs (infrastructure failures and crashes that were retried); added to
    stores made before it existed when they are opened for writing."""
    con.execute("CREATE TABLE IF NOT EXISTS attempts (run_id TEXT NOT NULL, attempt INTEGER NOT NULL, "
                "kind TEXT NOT NULL, reason TEXT NOT NULL, at REAL, PRIMARY KEY (run_id, attempt))")


class DiskFullError(StoreError):
    """The campaign directory's filesystem is full (or over quota): the campaign stops, resumable.

    Its advice names the command that resumes it (``command``, set by the command that ran:
    :meth:`resumed_with`), else "the same command"."""

    def __init__(self, where: str, detail: str = "", command: str | None = None) -> None:
        self.where, self.detail, self.command = where, detail, command
        extra = f" ({detail})" if detail else ""
        again = f"resume with: {command}" if command else "run the same command again to resume"
        super().__init__(f"output={str(where)!r} is invalid: expected a filesystem with free space; the disk "
                         f"is full{extra}: free some space, then {again} (nothing recorded is lost)")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.where, self.detail, self.command))

    def resumed_with(self, command: str) -> "DiskFullError":
        """This error, its advice naming ``command`` (the command line that resumes the work)."""
        return DiskFullError(self.where, self.detail, command)


def disk_full(where: str | Path, detail: str = "") -> DiskFullError:
    """The one-line error of a full disk under campaign directory ``where``."""
    return DiskFullError(str(where), detail)


def is_disk_full(err: BaseException) -> bool:
    """Whether ``err`` is an out-of-space error (ENOSPC / EDQUOT, or SQLite's SQLITE_FULL)."""
    if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
        return True
    return isinstance(err, sqlite3.OperationalError) and "full" in str(err).lower()


class Store:
    """An open campaign directory. Use :meth:`create` (run/resume) or :meth:`open` (read)."""

    def __init__(self, root: Path, con: sqlite3.Connection, spec: CampaignSpec, lock: IO[str] | None) -> None:
        self.root = root
        self.con = con
        self.spec = spec
        self._lock = lock
        #: how each runs column is selected ('r.robot', or the default's value for a store made
        #: before robots existed, opened for reading)
        self._columns()
        #: where a planned world's source is: world_dir -> its source columns (read when first needed)
        self._sources: dict[str, dict[str, str]] | None = None

    def _columns(self) -> None:
        """The runs columns this store's table has, and how each record column is selected."""
        have = {r[1] for r in self.con.execute("PRAGMA table_info(runs)")}
        #: the record columns the runs table has (the source columns: a campaign with world sources)
        self._have = tuple(c for c in COLUMNS if c in have)
        self._select = ", ".join(f"r.{c}" if c in have else f"NULL AS {c}" if c in SOURCE_COLUMNS
                                 else f"{_sql_text(_DEFAULT_ROBOT[c])} AS {c}" for c in COLUMNS)

    # ---- opening ---------------------------------------------------------------------
    @classmethod
    def create(cls, root: str | Path, spec: CampaignSpec, spec_text: str | None = None, *,
               extend: bool = False) -> "Store":
        """Create the store for ``spec`` in ``root``, or reopen it to resume (same spec only;
        with ``extend``, also a spec that extends the stored one: see :meth:`extend`).
        ``spec_text``: the text the spec was read from (``spec.yaml``); None for a spec made in
        code, whose own text (:func:`~navstress.campaign.spec.spec_yaml`) is written.

        Takes the directory's write lock; raises StoreError if another run holds it, if the
        directory holds a different campaign, or is a non-empty directory of something else."""
        d = Path(root)
        if d.exists() and not d.is_dir():
            raise StoreError(f"output={str(d)!r} exists and is not a directory; choose another -o")
        if has_sources(spec):  # the sources' digests: the stored ones (resume), else pinned now; checked
            stored = None
            if (d / DB_NAME).is_file():
                with cls.open(d) as old:
                    stored = old.spec
            spec = pin_sources(spec, stored)
            check_sources(spec)  # before anything is written: a changed source file is refused
        d.mkdir(parents=True, exist_ok=True)
        _files.refuse_links(d)  # before anything is written: a planted link would take it elsewhere
        cls._refuse_foreign(d)  # before the lock file: a folder of something else is left as it was
        lock = cls._take_lock(d)
        try:
            db = d / DB_NAME
            if db.exists():
                store = cls._open_db(d, lock)
                try:
                    store._restore_spec_file()
                    if extend and store.spec.digest() != spec.digest():
                        store.extend(spec, spec_text)
                except BaseException:
                    store.con.close()
                    raise
                why = robot_change(store.spec, spec)
                if why is not None and store.spec.digest() != spec.digest():
                    store.con.close()
                    raise StoreError(f"output={str(d)!r} holds campaign {store.spec.name!r} {why}")
                if store.spec.digest() != spec.digest():
                    store.con.close()
                    raise StoreError(f"output={str(d)!r} holds campaign {store.spec.name!r} made from a different "
                                     f"spec ({d / SPEC_NAME}); resume with that spec, or choose a new -o")
                return store
            cls._refuse_foreign(d)
            try:
                cls._build(d, spec, spec_text if spec_text is not None else spec_yaml(spec))
            except (OSError, sqlite3.Error) as err:
                if is_disk_full(err):
                    raise disk_full(d, "while creating the store") from None
                raise
            return cls._open_db(d, lock)
        except BaseException:
            lock.close()
            raise

    @staticmethod
    def _build(d: Path, spec: CampaignSpec, spec_text: str) -> None:
        """Write spec.yaml and campaign.sqlite (complete, then renamed into place). A creation
        killed at any moment leaves only names of ``_CREATION_LEFTOVERS``: removed here first."""
        for name in _CREATION_LEFTOVERS:
            (d / name).unlink(missing_ok=True)
        _atomic_write(d / SPEC_NAME, spec_text)
        p = plan(spec, d)
        try:
            # created first with the umask's mode (SQLite's own 0644 ignores it; its -wal/-shm copy it)
            with _files.replaced_on_success(d / DB_NAME, d / _TMP_DB, durable=True) as tmp:
                con = sqlite3.connect(tmp, isolation_level=None)
                try:
                    _schema(con, has_sources(spec))
                    con.execute("BEGIN")
                    con.executemany("INSERT INTO meta VALUES (?, ?)", [
                        ("schema", SCHEMA_VERSION), ("spec_digest", spec.digest()),
                        ("spec_json", spec.canonical_json()), ("name", spec.name)])
                    _insert_planned(con, p.tasks, 0, d)
                    con.execute("COMMIT")
                finally:
                    con.close()
        finally:
            for name in _CREATION_LEFTOVERS[1:]:
                (d / name).unlink(missing_ok=True)

    @staticmethod
    def _refuse_foreign(d: Path) -> None:
        """StoreError when ``d`` holds no campaign but files of something else."""
        if (d / DB_NAME).exists():
            return
        extra = sorted(p.name for p in d.iterdir() if p.name not in _OUR_NAMES)
        if extra:
            raise StoreError(f"output={str(d)!r} is a non-empty directory that is not a campaign "
                             f"(holds {extra[:3]}); choose a new or empty -o")

    @classmethod
    def open(cls, root: str | Path) -> "Store":
        """Open an existing campaign directory for reading (no lock taken)."""
        d = Path(root)
        for name in (DB_NAME, *(DB_NAME + x for x in _SIDE)):  # SQLite writes its side files even to read
            if (d / name).is_symlink():
                raise _files.link_error(d / name, d, "campaign", "campaign directory")
        if not (d / DB_NAME).is_file():
            raise StoreError(f"campaign={str(d)!r} is not a campaign directory (no {DB_NAME}); "
                             "create one with `navstress campaign run SPEC -o DIR`")
        return cls._open_db(d, None)

    @classmethod
    def _open_db(cls, d: Path, lock: IO[str] | None) -> "Store":
        """Open and check ``d/campaign.sqlite``: a file that is not SQLite, a missing table or
        column, a bad spec or schema are one-line StoreErrors (nothing is repaired)."""
        con: sqlite3.Connection | None = None
        fix = "restore it from a backup, or run the campaign again into a new -o"
        try:
            con = _connect(d / DB_NAME)
            for table, needed in _REQUIRED.items():
                have = {r[1] for r in con.execute(f"PRAGMA table_info({table})")}
                if not have:
                    raise StoreError(f"campaign={str(d)!r} is invalid: expected a {DB_NAME} with a {table!r} "
                                     f"table; it has none (damaged or not made by navstress); {fix}")
                missing = [c for c in needed if c not in have]
                if missing:
                    raise StoreError(f"campaign={str(d)!r} is invalid: expected column {missing[0]!r} in table "
                                     f"{table!r} of {DB_NAME}; {fix}")
            meta = {r["key"]: r["value"] for r in con.execute("SELECT key, value FROM meta")}
            if meta.get("schema") != SCHEMA_VERSION:
                raise StoreError(f"campaign={str(d)!r} has store schema {meta.get('schema')!r}, expected "
                                 f"{SCHEMA_VERSION} (made by another navstress version); use that version to read it")
            if lock is not None:
                _robot_columns(con)
            _check_types(con, d)
            try:
                spec = _spec_from_json(meta["spec_json"])
            except (ValueError, TypeError) as err:  # (SpecError included)
                raise _bad_value(d, "meta", "key='spec_json'", "value", f"not a campaign spec: {err}") from None
            _check_contents(con, d, spec)
            if lock is not None:
                _attempts_schema(con)
        except StoreError:
            if con is not None:
                con.close()
            raise
        except (sqlite3.Error, KeyError, ValueError, TypeError) as err:
            if con is not None:
                con.close()
            what = "no spec_json in meta" if isinstance(err, KeyError) else " ".join(str(err).split())[:200]
            raise StoreError(f"campaign={str(d)!r} has a corrupt {DB_NAME} ({what}); {fix}") from None
        return cls(d, con, spec, lock)

    @staticmethod
    def _take_lock(d: Path) -> IO[str]:
        f = _files.open_nofollow(d / LOCK_NAME, "a+", encoding="utf-8")
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            raise StoreError(f"output={str(d)!r} is in use by another navstress command (a `campaign run`, "
                             "`search` or `demo` writing into it); wait for it to finish or stop it") from None
        return f

    def close(self) -> None:
        self.con.close()
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    # ---- growing a campaign ----------------------------------------------------------
    def extend(self, spec: CampaignSpec, spec_text: str | None = None) -> int:
        """Grow the campaign to ``spec``, whose experiments list extends the stored one: the
        stored experiments first, unchanged, then new ones; every other field unchanged
        (StoreError saying what differs otherwise). Returns the number of runs added (0 when
        ``spec`` is the stored spec).

        In ONE SQLite transaction: the new experiments' planned runs, the stored spec (text,
        digest, name) and ``spec_text``. Then ``spec.yaml`` is rewritten atomically with
        ``spec_text`` (checked against ``spec``; None for a spec made in code: its own text,
        :func:`~navstress.campaign.spec.spec_yaml`, which needs no check): the database is the
        truth, a kill between the two leaves the old file, restored from the database when the
        store is next opened for writing (or extended).
        The new runs run at the next :func:`~navstress.campaign.scheduler.resume`. Needs the
        write lock (a store from :meth:`create`)."""
        if self._lock is None:
            raise StoreError(f"campaign={str(self.root)!r} is open for reading only; open it with "
                             "Store.create (the write lock) to extend it")
        spec = pin_sources(spec, self.spec)
        check_sources(spec)
        if spec_text is None:
            spec_text = spec_yaml(spec)
        elif not has_sources(spec) and parse_campaign_text(spec_text, "spec_text", max_runs=None).digest() != spec.digest():
            # (a spec with sources: its text names them relative to its file's folder, which the
            # caller read it with; the text alone cannot say that folder)
            raise SpecError("spec_text", spec_text[:60] + ("..." if len(spec_text) > 60 else ""),
                            "the text of the spec given with it (it becomes spec.yaml)")
        changed = robot_change(self.spec, spec)
        if changed is not None:
            raise StoreError(f"campaign={str(self.root)!r} cannot be extended with spec {spec.name!r}: it {changed}")
        why = extension_error(self.spec, spec)
        if why is not None:
            raise StoreError(f"campaign={str(self.root)!r} cannot be extended with spec {spec.name!r}: {why}; a spec "
                             "extends a campaign by adding experiments at the end of its list, all else unchanged")
        stored = {e.name for e in self.spec.experiments}
        tasks = [t for t in plan(spec, self.root).tasks if t.experiment not in stored]
        if has_sources(spec) and SOURCE_COLUMNS[0] not in self._have:  # a first experiment on an imported world
            for c in SOURCE_COLUMNS:
                self.con.execute(f"ALTER TABLE runs ADD COLUMN {c} TEXT")
            self._columns()
            self._sources = None
        if tasks or spec.digest() != self.spec.digest():
            self.con.execute("BEGIN IMMEDIATE")
            try:
                seq = int(self.con.execute("SELECT COALESCE(MAX(seq) + 1, 0) FROM planned").fetchone()[0])
                _insert_planned(self.con, tasks, seq, self.root)
                self.con.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", [
                    ("spec_digest", spec.digest()), ("spec_json", spec.canonical_json()), ("name", spec.name),
                    (_SPEC_TEXT, spec_text)])
                self.con.execute("COMMIT")
            except BaseException:
                self._rollback()
                raise
            self.spec = spec
        self._write_spec_file(spec_text)
        return len(tasks)

    def _restore_spec_file(self) -> None:
        """Rewrite ``spec.yaml`` from the text the last :meth:`extend` kept, where it differs."""
        row = self.con.execute("SELECT value FROM meta WHERE key = ?", (_SPEC_TEXT,)).fetchone()
        if row is not None:
            self._write_spec_file(str(row[0]))

    def _write_spec_file(self, text: str) -> None:
        path = self.root / SPEC_NAME
        try:
            if path.read_text(encoding="utf-8") == text:
                return
        except (OSError, UnicodeDecodeError):
            pass
        try:
            _atomic_write(path, text)
            _files.fsync_dir(self.root)
        except OSError as err:
            if is_disk_full(err):
                raise disk_full(self.root, f"while writing {SPEC_NAME}") from None
            raise

    # ---- planned work ----------------------------------------------------------------
    def plan(self) -> Plan:
        """The campaign's plan for this directory (paths resolved under the current root)."""
        return plan(self.spec, self.root)

    def planned_ids(self) -> list[str]:
        return [r[0] for r in self.con.execute("SELECT run_id FROM planned ORDER BY seq")]

    def task(self, run_id: str) -> RunTask:
        """The planned task of ``run_id`` with paths under the current root."""
        row = self.con.execute("SELECT task FROM planned WHERE run_id = ?", (run_id,)).fetchone()
        if row is None:
            raise StoreError(f"run_id={run_id!r} is not a run of campaign {self.spec.name!r}; "
                             "list them with `navstress campaign export DIR --format csv`")
        d = json.loads(row[0])  # (every planned task was checked when the store was opened: _check_contents)
        base = self.root.resolve()
        for key in ("world_dir", "trace_path"):  # inside the directory, links never followed
            p = os.path.normpath(base / str(d.get(key, "")))
            if not Path(p).is_relative_to(base / ("worlds" if key == "world_dir" else "traces")):
                raise _bad_value(self.root, "planned", f"run_id={_clip(run_id)}", "task",
                                 f"its {key} {_clip(str(d.get(key)), 80)} is not inside the campaign directory")
            d[key] = p
        if not any(m.world_dir == d["world_dir"] for m in self.plan().maps):
            raise _bad_value(self.root, "planned", f"run_id={_clip(run_id)}", "task",
                             f"its world_dir {_clip(d['world_dir'], 80)} is not a map of the campaign's plan")
        return RunTask(**d)

    def done_ids(self) -> set[str]:
        return {r[0] for r in self.con.execute("SELECT run_id FROM runs")}

    def pending(self) -> list[RunTask]:
        """Due tasks not yet recorded, in plan order (every planned one unless adaptive: see
        :meth:`navstress.campaign.plan.Plan.due`)."""
        outcomes = self.outcomes()
        p = self.plan()
        due = p.due(outcomes)
        return [t for t in p.tasks if t.run_id in due and t.run_id not in outcomes]

    def cleanup_partials(self) -> list[Path]:
        """Remove the partial files a killed run left; returns what was removed.

        Only names navstress gives, beside the plan's own paths: ``.<name>.partial`` beside each
        planned trace (TraceWriter), ``.m<k>.XXXXXXXX`` (World.save's temporary directory) and
        ``.m<k>.old`` beside each planned world. Folders reached through a symbolic link are
        never entered and a link is never removed (OutputPathError, the output-directory rule)."""
        p = self.plan()
        partials: dict[str, set[str]] = {}
        for t in p.tasks:
            tp = Path(t.trace_path)
            partials.setdefault(str(tp.parent), set()).add(f".{tp.name}.partial")
        worlds: dict[str, set[str]] = {}
        for m in p.maps:
            wd = Path(m.world_dir)
            worlds.setdefault(str(wd.parent), set()).add(wd.name)
        removed: list[Path] = []
        for folder, names in partials.items():
            for e in self._entries(folder):
                if e.name in names and e.is_file(follow_symlinks=False):
                    Path(e.path).unlink(missing_ok=True)
                    removed.append(Path(e.path))
        for folder, maps in worlds.items():
            for e in self._entries(folder):
                hit = _WORLD_TEMP.match(e.name)
                if hit is not None and hit.group(1) in maps and e.is_dir(follow_symlinks=False):
                    shutil.rmtree(e.path, ignore_errors=True)
                    removed.append(Path(e.path))
        return sorted(removed)

    def _entries(self, folder: str) -> list[os.DirEntry[str]]:
        """The entries of ``folder`` (none when it is not there), after checking that no part of
        it below the campaign directory is a symbolic link."""
        _files.check_below(self.root, folder)
        try:
            with os.scandir(folder) as it:
                return list(it)
        except (FileNotFoundError, NotADirectoryError):
            return []

    # ---- records ---------------------------------------------------------------------
    def add(self, record: RunRecord) -> bool:
        """Record one run atomically; False (and nothing written) if ``run_id`` is already recorded."""
        row = record.to_row()
        if row["trace"]:
            row["trace"] = _rel(row["trace"], self.root)
        row["robot"], row["robot_digest"] = self._robot_of(record.run_id)
        cols = self._have
        if SOURCE_COLUMNS[0] in cols and row.get(SOURCE_COLUMNS[0]) is None:  # (a failure record: the plan's)
            row.update(self._source_of(record.run_id))
        vals = [row.get(c) for c in cols] + [time.time()]
        self.con.execute("BEGIN IMMEDIATE")
        try:
            cur = self.con.execute(
                f"INSERT INTO runs ({', '.join(cols)}, recorded_at) VALUES ({', '.join('?' * (len(cols) + 1))}) "
                "ON CONFLICT(run_id) DO NOTHING", vals)
            self.con.execute("COMMIT")
        except BaseException:
            self._rollback()
            raise
        return cur.rowcount == 1

    def _source_of(self, run_id: str) -> dict[str, str]:
        """The source columns of ``run_id``'s world as the plan has it (its kind, path and pinned
        sha256), for a record made without its world (a world that could not be generated)."""
        if self._sources is None:
            from navstress.world.sources import module_for  # here: importing a source (numba, scipy) only where a world names one

            self._sources = {}
            for job in self.plan().maps:
                src = job.world.get("source")
                if isinstance(src, dict):
                    opt = SourceSpec.model_validate(src)
                    try:
                        kind = str(module_for(opt).KIND)
                    except SpecError:
                        kind = opt.kind
                    self._sources[job.world_dir] = {"source_kind": kind, "source_path": opt.path,
                                                    "source_sha256": opt.sha256 or ""}
        try:
            return self._sources.get(self.task(run_id).world_dir, {})
        except StoreError:  # (not a planned run: add() refuses it anyway)
            return {}

    def _robot_of(self, run_id: str) -> tuple[str, str]:
        """(name, digest) of the robot ``run_id`` was planned on: what its record is stored with,
        whichever path made the record (a run, a failure, a world that could not be generated)."""
        row = self.con.execute("SELECT task FROM planned WHERE run_id = ?", (run_id,)).fetchone()
        robot = json.loads(row[0]).get("robot") if row is not None else None
        if robot is None:
            return DEFAULT_ROBOT, DEFAULT_ROBOT_DIGEST
        spec = RunTask(run_id, "", 0, "", robot=robot).robot_spec()
        return spec.name, spec.digest

    def _rollback(self) -> None:
        if self.con.in_transaction:
            try:
                self.con.execute("ROLLBACK")
            except (sqlite3.Error, StoreError):
                pass

    def add_attempt(self, run_id: str, kind: str, reason: str) -> int:
        """Keep one failed attempt of ``run_id`` (``kind``: 'died', 'infrastructure', ...); returns
        its number (1, 2, ...). Attempts are never results: the run stays pending until recorded."""
        self.con.execute("BEGIN IMMEDIATE")
        try:
            n = int(self.con.execute("SELECT COALESCE(MAX(attempt), 0) + 1 FROM attempts WHERE run_id = ?",
                                     (run_id,)).fetchone()[0])
            self.con.execute("INSERT INTO attempts VALUES (?, ?, ?, ?, ?)", (run_id, n, kind, reason, time.time()))
            self.con.execute("COMMIT")
        except BaseException:
            self._rollback()
            raise
        return n

    def attempts(self, run_id: str | None = None) -> list[tuple[str, int, str, str]]:
        """Failed attempts kept so far, ``(run_id, attempt, kind, reason)`` (empty for stores made
        before attempts were kept and never resumed since)."""
        if not self.con.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'attempts'").fetchone():
            return []
        q = "SELECT run_id, attempt, kind, reason FROM attempts"
        rows = self.con.execute(q + " WHERE run_id = ? ORDER BY attempt", (run_id,)) if run_id is not None \
            else self.con.execute(q + " ORDER BY run_id, attempt")
        return [(str(r[0]), int(r[1]), str(r[2]), str(r[3])) for r in rows]

    def records(self, experiment: str | None = None) -> list[RunRecord]:
        """Every recorded run (of ``experiment`` only, when given), in plan order."""
        q = f"SELECT {self._select} FROM runs r LEFT JOIN planned p USING (run_id)"
        if experiment is None:
            rows = self.con.execute(q + " ORDER BY p.seq")
        else:
            rows = self.con.execute(q + " WHERE r.experiment = ? ORDER BY p.seq", (experiment,))
        return [_record(dict(r), self.root) for r in rows]

    def recorded_by_experiment(self) -> Counter[str]:
        """experiment -> how many of its runs are recorded."""
        return Counter({str(e): int(n) for e, n in
                        self.con.execute("SELECT experiment, COUNT(*) FROM runs GROUP BY experiment")})

    def outcomes(self) -> dict[str, str]:
        """run_id -> outcome of every recorded run."""
        return {str(r[0]): str(r[1]) for r in self.con.execute("SELECT run_id, outcome FROM runs")}

    @property
    def adaptive(self) -> bool:
        """Whether some experiment repeats its runs adaptively (planned counts are then upper bounds)."""
        return any(self.spec.rule_of(e) is not None for e in self.spec.experiments)

    def _at_most(self, group: Any) -> Counter[Any]:
        """Adaptive campaigns: the most runs each group (``group(task)``) will have: a finished
        stream counts its runs, an undecided one its rule's max."""
        p = self.plan()
        outcomes = self.outcomes()
        by_id = {t.run_id: t for t in p.tasks}
        c: Counter[Any] = Counter()
        for st in p.streams:
            c[group(by_id[st.run_ids[0]])] += st.at_most(outcomes)
        return c

    def planned_by_config(self) -> dict[tuple[str, str, str, str], int]:
        """(experiment, config key, navigator, fault or "nominal") -> planned runs: at most, for an
        adaptive experiment (see :meth:`progress`); every configuration of the plan is there."""
        p = self.plan()
        cfg = {m.world_dir: (m.experiment, m.config_key) for m in p.maps}
        out: Counter[tuple[str, str, str, str]] = self._at_most(
            lambda t: (*cfg[t.world_dir], variant_of(t.run_id, t.navigator), t.fault or NOMINAL)) if self.adaptive \
            else Counter((*cfg[t.world_dir], variant_of(t.run_id, t.navigator), t.fault or NOMINAL) for t in p.tasks)
        return dict(out)

    def progress(self) -> tuple[int, int]:
        """(recorded, planned); planned counts an adaptive stream's max until its rule stops it,
        then its runs (so recorded == planned once a campaign is complete)."""
        done = self.con.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
        if self.adaptive:
            return int(done), sum(self._at_most(lambda t: 0).values())
        total = self.con.execute("SELECT COUNT(*) FROM planned").fetchone()[0]
        return int(done), int(total)

    def outcome_counts(self) -> dict[str, int]:
        c = Counter({o: 0 for o in OUTCOMES})
        for o, n in self.con.execute("SELECT outcome, COUNT(*) FROM runs GROUP BY outcome"):
            c[o] = n
        return dict(c)

    def per_experiment(self) -> list[tuple[str, int, int, dict[str, int]]]:
        """(experiment, recorded, planned, outcome counts) per experiment, in spec order."""
        out = []
        most = self._at_most(lambda t: t.experiment) if self.adaptive else None
        for exp in self.spec.experiments:
            planned = most[exp.name] if most is not None else \
                self.con.execute("SELECT COUNT(*) FROM planned WHERE experiment = ?", (exp.name,)).fetchone()[0]
            counts = {o: 0 for o in OUTCOMES}
            for o, n in self.con.execute("SELECT outcome, COUNT(*) FROM runs WHERE experiment = ? GROUP BY outcome",
                                         (exp.name,)):
                counts[o] = n
            out.append((exp.name, sum(counts.values()), int(planned), counts))
        return out

    def per_navigator(self) -> list[tuple[str, str, int, int, dict[str, int]]]:
        """(navigator, fault, recorded, planned, outcome counts) per navigator and fault, in spec order
        (a campaign of several robots: per ``navigator@robot``, never two robots in one row)."""
        if self.spec.several_robots:
            return self._per_variant()
        out = []
        most = self._at_most(lambda t: (t.navigator, t.fault)) if self.adaptive else None
        for nav in self.spec.navigators:
            faults = list(dict.fromkeys(f for e in self.spec.experiments for f in self.spec.faults_of(e)))
            for f in faults:
                planned = most[(nav.name, f)] if most is not None else \
                    self.con.execute("SELECT COUNT(*) FROM planned WHERE navigator = ? AND fault IS ?",
                                     (nav.name, f)).fetchone()[0]
                if not planned:
                    continue
                counts = {o: 0 for o in OUTCOMES}
                for o, n in self.con.execute("SELECT outcome, COUNT(*) FROM runs WHERE navigator = ? AND fault IS ? "
                                             "GROUP BY outcome", (nav.name, f)):
                    counts[o] = n
                out.append((nav.name, f or "nominal", sum(counts.values()), int(planned), counts))
        return out

    def _per_variant(self) -> list[tuple[str, str, int, int, dict[str, int]]]:
        """:meth:`per_navigator` of a campaign of several robots: per (navigator@robot, fault)."""
        p = self.plan()
        outcomes = self.outcomes()
        key = {t.run_id: (variant_of(t.run_id, t.navigator), t.fault) for t in p.tasks}
        planned: Counter[tuple[str, str | None]] = Counter()
        if self.adaptive:
            for st in p.streams:
                planned[key[st.run_ids[0]]] += st.at_most(outcomes)
        else:
            planned.update(key.values())
        counts: dict[tuple[str, str | None], dict[str, int]] = {k: {o: 0 for o in OUTCOMES} for k in planned}
        for rid, o in outcomes.items():
            if rid in key:
                counts[key[rid]][o] += 1
        order = [(variant(n.name, r.name), f) for n in self.spec.navigators for r in self.spec.all_robots()
                 for f in dict.fromkeys(f for e in self.spec.experiments for f in self.spec.faults_of(e))]
        return [(v, f or NOMINAL, sum(counts[(v, f)].values()), planned[(v, f)], counts[(v, f)])
                for v, f in order if planned[(v, f)]]

    def mean_wall_s(self) -> float | None:
        v = self.con.execute("SELECT AVG(wall_s) FROM runs").fetchone()[0]
        return None if v is None else float(v)

    # ---- export ----------------------------------------------------------------------
    def export(self, fmt: Literal["csv", "parquet"], out: str | Path | None = None) -> Path:
        """Write the runs table (plan order) as CSV or Parquet; returns the path written (atomically).

        Columns: the run record's, keys spelled as in every table (``config`` the configuration
        key, ``fault`` ``"nominal"`` for the nominal stack: navstress._tables.KEYS), ``params`` the
        swept parameters as one JSON object, ``errors`` a list of strings (a Parquet list, a JSON
        array in CSV), then one typed column per swept
        parameter (``param.<path>``: int, float, bool or text), then the numeric descriptors of
        each run's world (``world.<name>``, floats, empty where the world is not generated). A
        Parquet file's schema metadata holds ``navstress.version``, ``navstress.table`` and
        ``navstress.spec`` (the campaign spec's text)."""
        if fmt not in FORMATS:
            raise SpecError("format", fmt, "csv or parquet")
        dest = Path(out) if out is not None else self.root / f"runs.{fmt}"
        q = (f"SELECT {self._select}, p.task AS task FROM runs r "
             "LEFT JOIN planned p USING (run_id) ORDER BY p.seq")
        rows = [dict(r) for r in self.con.execute(q)]
        configs = [json.loads(r["config"]) for r in rows]
        params: dict[str, list[Any]] = {k: [] for cfg in configs for k in cfg}
        for r, cfg in zip(rows, configs):
            r["params"] = r["config"]
            r["config"] = config_key_of(r["run_id"], r["experiment"], cfg)
            r["fault"] = r["fault"] or NOMINAL
            for k, vals in params.items():
                vals.append(cfg.get(k))
        kinds = {c: k for c, k in _EXPORT_KINDS.items() if c not in SOURCE_COLUMNS or c in self._have}
        for k, vals in params.items():
            kind = _param_kind(vals)
            kinds[f"param.{k}"] = kind
            for r, v in zip(rows, vals):
                r[f"param.{k}"] = v if kind != "str" or v is None or isinstance(v, str) else _json.dumps(v)
        worlds = _world_descriptors(self.root, [json.loads(r["task"])["world_dir"] if r["task"] else None
                                                for r in rows])
        names = sorted({n for d in worlds.values() for n in d})
        for r in rows:
            d = worlds.get(json.loads(r["task"])["world_dir"] if r["task"] else None, {})
            r.update({f"world.{n}": d.get(n) for n in names})
        kinds.update({f"world.{n}": "float" for n in names})
        meta = {"navstress.version": __version__, "navstress.table": "runs", "navstress.spec": self.spec_text()}
        return write_table(rows, kinds, fmt, dest, metadata=meta)

    def spec_text(self) -> str:
        """The campaign spec's text as the user wrote it (the last extension's, if extended)."""
        row = self.con.execute("SELECT value FROM meta WHERE key = ?", (_SPEC_TEXT,)).fetchone()
        if row is not None:
            return str(row[0])
        try:
            return (self.root / SPEC_NAME).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):  # the copy is gone: the database's canonical form
            return self.spec.canonical_json()


def _param_kind(values: list[Any]) -> Kind:
    """The column kind of a swept parameter's values (None where a run's configuration lacks it)."""
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return "bool"
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return "int"
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return "float"
    return "str"


def _world_descriptors(root: Path, world_dirs: list[str | None]) -> dict[str | None, dict[str, float]]:
    """The numeric descriptors of each (generated) world among ``world_dirs`` (relative to ``root``)."""
    out: dict[str | None, dict[str, float]] = {}
    for wd in dict.fromkeys(world_dirs):
        if wd is not None:
            d = world_descriptors(root / wd)
            if d is not None:
                out[wd] = d
    return out


_DEFAULT_ROBOT = {"robot": DEFAULT_ROBOT, "robot_digest": DEFAULT_ROBOT_DIGEST}


def _sql_text(v: str) -> str:
    return "'" + v.replace("'", "''") + "'"


def _robot_columns(con: sqlite3.Connection) -> None:
    """Add the robot columns to the runs table of a store made before robots existed (its runs
    are all of the default robot, ``rmp400``: the columns' default)."""
    have = {r[1] for r in con.execute("PRAGMA table_info(runs)")}
    for c in ROBOT_COLUMNS:
        if c not in have:
            con.execute(f"ALTER TABLE runs ADD COLUMN {c} TEXT NOT NULL DEFAULT {_sql_text(_DEFAULT_ROBOT[c])}")


def robot_change(stored: CampaignSpec, given: CampaignSpec) -> str | None:
    """How ``given`` changes the robots of the campaign ``stored`` (None: it does not): a robot of
    the same name described otherwise (its file or overrides changed: its digest differs), or a
    campaign of one robot given several (its run ids would change). Said as the end of a sentence
    ``campaign 'x' ...``."""
    was = {r.name: r.digest for r in stored.all_robots()}
    for r in given.all_robots():
        if r.name in was and was[r.name] != r.digest:
            return (f"whose robot {r.name!r} is described otherwise now (digest {was[r.name]}, given {r.digest}: its "
                    "robot file or overrides changed); restore that description, give the changed robot another "
                    "name in a new campaign, or choose a new -o")
    if stored.several_robots != given.several_robots:
        return (f"of {len(was)} robot{'s' if len(was) > 1 else ''}, given {len(given.all_robots())}: a campaign keeps "
                "its number of robots (its run ids name the robot only when it has several); run the robots in a "
                "new campaign (-o)")
    return None


def extension_error(stored: CampaignSpec, given: CampaignSpec) -> str | None:
    """What keeps ``given`` from extending ``stored`` (None: it does, or it is ``stored``)."""
    a, b = json.loads(stored.canonical_json()), json.loads(given.canonical_json())
    for k in sorted(set(a) | set(b)):
        if k != "experiments" and a.get(k) != b.get(k):
            return f"its {k} differs from the stored one (stored {_short(a.get(k))}, given {_short(b.get(k))})"
    ea, eb = a["experiments"], b["experiments"]
    for i, (x, y) in enumerate(zip(ea, eb)):
        if x != y:
            what = "another experiment" if x["name"] != y["name"] else "changed"
            return f"its experiments[{i}] ({y['name']!r}) is {what}: the stored experiments[{i}] is {x['name']!r}"
    if len(eb) < len(ea):
        return (f"it has {len(eb)} experiments, fewer than the stored {len(ea)} "
                f"({', '.join(repr(e['name']) for e in ea[len(eb):][:3])} missing)")
    return None


def _insert_planned(con: sqlite3.Connection, tasks: Sequence[RunTask], first: int, root: Path) -> None:
    """Insert ``tasks`` into the planned table, numbered from ``first`` (plan order)."""
    con.executemany("INSERT INTO planned VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", [
        (t.run_id, first + i, t.experiment, _json.dumps(t.config, sort_keys=True), t.map_index, t.run_index,
         t.navigator, t.fault, _task_json(t, root)) for i, t in enumerate(tasks)])


def _short(v: Any) -> str:
    t = _json.dumps(v, sort_keys=True)
    return t if len(t) <= 60 else t[:57] + "..."


def read_export(path: str | Path) -> list[dict[str, Any]]:
    """Read back an exported runs table (CSV or Parquet) as rows with typed values (an export made
    before robots existed: its runs are the default robot's, ``robot`` and ``robot_digest`` filled)."""
    kinds = dict(_EXPORT_KINDS)
    if Path(path).suffix != ".parquet":
        with open(path, newline="", encoding="utf-8") as f:
            head = set(next(csv.reader(f), []))
        kinds = {c: k for c, k in kinds.items() if c in head or (c not in ROBOT_COLUMNS and c not in SOURCE_COLUMNS)}
    rows = read_table(path, kinds, nullable=("trace", *SOURCE_COLUMNS))
    for row in rows:
        for c in ROBOT_COLUMNS:
            row.setdefault(c, _DEFAULT_ROBOT[c])
    return rows


def _record(row: dict[str, Any], root: Path) -> RunRecord:
    """A ``runs`` row as a RunRecord (every row was checked when the store was opened: _check_types)."""
    for c in _FLOATS:
        if row[c] is None:  # SQLite stores NaN as NULL
            row[c] = math.nan
    return RunRecord.from_row(row)


# ---- what a stored value may be --------------------------------------------------------------
# Every column of every table has a rule, checked for every row when a store is opened (in SQL for
# the types, in one pass of Python for the JSON columns and how the tables agree): a damaged row is
# one StoreError naming its table, row and column, never a traceback in whatever reads it later.


@dataclass(frozen=True)
class _Col:
    """What one stored column holds: ``int`` (SQLite INTEGER, at least ``least``), ``real`` (a
    number, infinities included; NULL where ``null``: SQLite stores NaN as NULL), ``text`` (one of ``vocab`` when
    given), ``object`` / ``array`` (JSON text of that kind; ``array``: of strings)."""

    kind: Literal["int", "real", "text", "object", "array"]
    null: bool = False
    least: int | None = None
    vocab: tuple[str, ...] = ()

    def expected(self) -> str:
        what = {"int": f"an integer >= {self.least}" if self.least is not None else "an integer",
                "real": "a number", "text": "one of " + ", ".join(self.vocab) if self.vocab else "text",
                "object": "a JSON object", "array": "a JSON array of strings"}[self.kind]
        return what + (" or NULL" if self.null else "")

    def bad_sql(self, c: str) -> str:
        """An SQL expression, true where column ``c`` breaks the rule in its SQLite type or range."""
        types = {"int": ("integer",), "real": ("real", "integer")}.get(self.kind, ("text",)) + \
            (("null",) if self.null else ())
        p = f"typeof({c}) NOT IN ({', '.join(repr(t) for t in types)})"
        if self.least is not None:
            p += f" OR (typeof({c}) = 'integer' AND {c} < {self.least})"
        if self.vocab:
            p += f" OR (typeof({c}) = 'text' AND {c} NOT IN ({', '.join(repr(v) for v in self.vocab)}))"
        return f"({p})"


_SQL_TYPE = {str: "text", int: "integer", float: "real", bytes: "blob"}
_TEXT, _TEXT_OR_NULL, _COUNT = _Col("text"), _Col("text", null=True), _Col("int", least=0)
_RUN_COLUMNS: dict[str, _Col] = {
    **{c: _COUNT for c, t in _TYPES.items() if t == "INTEGER"},
    **{c: _Col("real", null=True) for c, t in _TYPES.items() if t == "REAL"},
    "config": _Col("object"), "errors": _Col("array"), "fault": _TEXT_OR_NULL, "trace": _TEXT_OR_NULL,
    "outcome": _Col("text", vocab=OUTCOMES)}
#: The rule of every column of every table (a test checks that it names each column of the schema).
RULES: dict[str, dict[str, _Col]] = {
    "meta": {"key": _TEXT, "value": _TEXT},
    "planned": {"run_id": _TEXT, "seq": _COUNT, "experiment": _TEXT, "config": _Col("object"), "map_index": _COUNT,
                "run_index": _COUNT, "navigator": _TEXT, "fault": _TEXT_OR_NULL, "task": _Col("object")},
    "runs": {**{c: _RUN_COLUMNS.get(c, _TEXT) for c in COLUMNS if c not in SOURCE_COLUMNS},
             "recorded_at": _Col("real", null=True)},
    "attempts": {"run_id": _TEXT, "attempt": _Col("int", least=1), "kind": _TEXT, "reason": _TEXT,
                 "at": _Col("real", null=True)},
}
#: The rules of the runs table's source columns (a campaign with world sources has them).
SOURCE_RULES: dict[str, _Col] = {c: _TEXT_OR_NULL for c in SOURCE_COLUMNS}
#: The planned columns a run's record repeats (they must agree).
_SAME_AS_PLANNED = ("experiment", "map_index", "run_index", "navigator", "fault")


def _task_fields() -> tuple[dict[str, frozenset[type]], frozenset[str]]:
    """The exact Python types the JSON value of each RunTask field may have, and the fields that
    may not be left out (those without a default)."""
    kinds: dict[str, frozenset[type]] = {
        "str": frozenset({str}), "int": frozenset({int}), "float": frozenset({int, float}),
        "bool": frozenset({bool}), "str | None": frozenset({str, type(None)}), "dict[str, Any]": frozenset({dict}),
        "dict[str, Any] | None": frozenset({dict, type(None)})}
    types = {f.name: kinds[str(f.type)] for f in fields(RunTask)}
    return types, frozenset(f.name for f in fields(RunTask) if f.default is MISSING and f.default_factory is MISSING)


_TASK_TYPES, _TASK_REQUIRED = _task_fields()


def _row_name(table: str, row: sqlite3.Row | dict[str, Any], rowid: int) -> str:
    """How a message names a row: its key where it has a text one, else its rowid."""
    key = "key" if table == "meta" else "run_id"
    v = row[key]
    if not isinstance(v, str):
        return f"rowid={rowid}"
    name = f"{key}={_clip(v)}"
    return name + (f", attempt={row['attempt']!r}" if table == "attempts" else "")


def _clip(v: Any, n: int = 60) -> str:
    t = repr(v)
    return t if len(t) <= n else t[:n - 3] + "..."


def _check_types(con: sqlite3.Connection, root: Path) -> None:
    """Every value of every row against :data:`RULES` (its SQLite type, range, vocabulary: one SQL
    query per table). The first damaged value is a StoreError naming table, row and column
    (:func:`_bad_value`); :func:`_check_contents` checks the rest."""
    tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    for table, cols in RULES.items():
        if table not in tables:
            continue  # attempts: stores made before it existed (the required tables are checked before)
        have = {r[1] for r in con.execute(f"PRAGMA table_info({table})")}
        cols = {**cols, **(SOURCE_RULES if table == "runs" else {})}
        cols = {c: col for c, col in cols.items() if c in have}  # (the robot columns of an old store; sources)
        where = " OR ".join(col.bad_sql(c) for c, col in cols.items())
        bad = con.execute(f"SELECT rowid, * FROM {table} WHERE {where} LIMIT 1").fetchone()
        if bad is not None:
            flags = con.execute(f"SELECT {', '.join(col.bad_sql(c) for c, col in cols.items())} FROM {table} "
                                "WHERE rowid = ?", (bad[0],)).fetchone()
            c = next(c for c, f in zip(cols, flags) if f)
            v = bad[c]
            got = "NULL" if v is None else f"{_SQL_TYPE.get(type(v), type(v).__name__)} {_clip(v)}"
            raise _bad_value(root, table, _row_name(table, bad, bad[0]), c, f"expected {cols[c].expected()}, got {got}")


def _check_contents(con: sqlite3.Connection, root: Path, spec: CampaignSpec) -> None:
    """After :func:`_check_types`: the JSON columns' contents, and how the tables agree (a record's
    keys are its planned run's, a planned task is its row's, names are the spec's)."""
    _check_planned(con, root, spec)
    _check_runs(con, root)


def _json_of(root: Path, table: str, row: sqlite3.Row, rowid: int, c: str, kind: type) -> Any:
    try:
        v = json.loads(row[c])
        if not isinstance(v, kind):
            raise ValueError(f"a JSON {type(v).__name__}")
        if isinstance(v, list) and not all(isinstance(x, str) for x in v):
            raise ValueError("an item is not a string")
    except ValueError as err:  # (JSONDecodeError included)
        msg = " ".join(str(err).split())[:80]
        raise _bad_value(root, table, _row_name(table, row, rowid), c,
                         f"expected {RULES[table][c].expected()}, got {_clip(row[c], 40)}: {msg}") from None
    return v


def _check_planned(con: sqlite3.Connection, root: Path, spec: CampaignSpec) -> None:
    names: dict[str, set[str | None]] = {
        "experiment": {e.name for e in spec.experiments}, "navigator": {n.name for n in spec.navigators},
        "fault": {f for e in spec.experiments for f in spec.faults_of(e)}}
    for row in con.execute("SELECT rowid AS rowid_, * FROM planned"):
        rowid = row["rowid_"]
        for c, allowed in names.items():
            if row[c] not in allowed:
                raise _bad_value(root, "planned", _row_name("planned", row, rowid), c,
                                 f"{_clip(row[c])} is not a {c} of the campaign's spec")
        config = _json_of(root, "planned", row, rowid, "config", dict)
        task = _json_of(root, "planned", row, rowid, "task", dict)
        why = _task_error(task, {**{c: row[c] for c in ("run_id", *_SAME_AS_PLANNED)}, "config": config})
        if why:
            raise _bad_value(root, "planned", _row_name("planned", row, rowid), "task", why)


def _task_error(task: dict[str, Any], row: dict[str, Any]) -> str | None:
    """What is wrong with a planned task's JSON object (None: nothing), ``row`` its row's values."""
    for name, v in task.items():
        types = _TASK_TYPES.get(name)
        if types is None:
            return f"unknown field {_clip(name, 40)}"
        if type(v) not in types or (type(v) is float and not math.isfinite(v)):
            return f"field {name}={_clip(v, 40)} is not {' or '.join(sorted(t.__name__ for t in types))}"
    missing = _TASK_REQUIRED - task.keys()
    if missing:
        return f"field {sorted(missing)[0]} is missing"
    for name, v in row.items():
        if task[name] != v or type(task[name]) is not type(v):
            return f"field {name}={_clip(task[name], 40)} is not the row's {name} ({_clip(v, 40)})"
    key = config_key_of(row["run_id"], row["experiment"], row["config"])
    nav = variant_of(row["run_id"], row["navigator"])
    if nav != row["navigator"]:  # a campaign of several robots: the run id names the task's robot
        robot = task.get("robot")
        name = robot.get("name", DEFAULT_ROBOT) if isinstance(robot, dict) else DEFAULT_ROBOT
        if nav != variant(row["navigator"], str(name)):
            return f"field robot (named {_clip(name, 40)}) is not the run id's robot"
    for name, path in (("world_dir", world_path(row["experiment"], key, row["map_index"])),
                       ("trace_path", trace_path(row["experiment"], key, row["map_index"], row["run_index"],
                                                 nav, row["fault"]))):
        if task[name] != path:
            return f"field {name}={_clip(task[name], 40)} is not this run's {path!r} in the campaign directory"
    if min(task.get("map_seed", 0), task["run_seed"]) < 0:
        return "a seed is negative"
    return None


def _check_runs(con: sqlite3.Connection, root: Path) -> None:
    """Each record against its planned run (in SQL, the rows that differ in text only), its errors."""
    differ = " OR ".join(f"r.{c} IS NOT p.{c}" for c in (*_SAME_AS_PLANNED, "config"))
    q = (f"SELECT r.rowid AS rowid_, r.run_id, r.config, {', '.join(f'r.{c}' for c in _SAME_AS_PLANNED)}, "
         f"p.run_id AS p_run_id, p.config AS p_config, {', '.join(f'p.{c} AS p_{c}' for c in _SAME_AS_PLANNED)} "
         f"FROM runs r LEFT JOIN planned p USING (run_id) WHERE p.run_id IS NULL OR {differ}")
    for row in con.execute(q):
        rowid = row["rowid_"]
        name = _row_name("runs", row, rowid)
        if row["p_run_id"] is None:
            raise _bad_value(root, "runs", name, "run_id", "not a run of the campaign's plan (table 'planned')")
        for c in _SAME_AS_PLANNED:
            if row[c] != row[f"p_{c}"]:
                raise _bad_value(root, "runs", name, c, f"{_clip(row[c])} is not its planned run's "
                                 f"{_clip(row[f'p_{c}'])}")
        config = _json_of(root, "runs", row, rowid, "config", dict)
        if config != json.loads(row["p_config"]):  # (the same JSON in another text passes)
            raise _bad_value(root, "runs", name, "config", f"{_clip(row['config'], 40)} is not its planned run's "
                             f"{_clip(row['p_config'], 40)}")
    for row in con.execute("SELECT rowid AS rowid_, run_id, errors FROM runs WHERE errors IS NOT '[]'"):
        _json_of(root, "runs", row, row["rowid_"], "errors", list)
    _check_robots(con, root)


def _check_robots(con: sqlite3.Connection, root: Path) -> None:
    """Each record's robot (name, digest) is its planned task's (one query: the distinct triples)."""
    if not set(ROBOT_COLUMNS) <= {r[1] for r in con.execute("PRAGMA table_info(runs)")}:
        return  # a store made before robots existed, read only: every run is the default robot's
    known: dict[str | None, tuple[str, str]] = {None: (DEFAULT_ROBOT, DEFAULT_ROBOT_DIGEST)}
    q = ("SELECT json_extract(p.task, '$.robot') AS planned, r.robot, r.robot_digest, MIN(r.rowid) AS rowid_, "
         "MIN(r.run_id) AS run_id FROM runs r JOIN planned p USING (run_id) GROUP BY 1, 2, 3")
    for row in con.execute(q):
        planned = row["planned"]
        if planned not in known:
            try:
                r = RunTask("", "", 0, "", robot=json.loads(planned)).robot_spec()
                known[planned] = (r.name, r.digest)
            except (ValueError, TypeError) as err:
                raise _bad_value(root, "planned", f"run_id={_clip(row['run_id'])}", "task",
                                 f"its robot is not a robot description: {err}") from None
        for c, want in zip(ROBOT_COLUMNS, known[planned]):
            if row[c] != want:
                raise _bad_value(root, "runs", _row_name("runs", row, row["rowid_"]), c,
                                 f"{_clip(row[c])} is not its planned run's {want!r}")


def _bad_value(root: Path, table: str, row: str, column: str, why: str) -> StoreError:
    """The one line of a damaged value: table, row (``run_id='...'``), column, what is wrong."""
    msg = " ".join(str(why).split())[:200]
    fix = "delete that row and resume to run it again" if table in ("runs", "attempts") else \
        "run the campaign again into a new -o"
    return StoreError(f"campaign={str(root)!r} has a corrupt {DB_NAME}: table {table!r}, {row}, column {column!r} "
                      f"is not valid ({msg}); restore the file from a backup, or {fix}")


def _task_json(t: RunTask, root: Path) -> str:
    d = json.loads(t.to_json())
    d["world_dir"] = _rel(d["world_dir"], root)
    d["trace_path"] = _rel(d["trace_path"], root)
    return _json.dumps(d, sort_keys=True)


def _rel(path: str, root: Path) -> str:
    """``path`` relative to ``root`` (as followed once, or as given), lexically: a link inside
    ``root`` is never followed."""
    p = Path(os.path.normpath(os.path.abspath(path)))
    for base in (root.resolve(), Path(os.path.normpath(os.path.abspath(root)))):
        if p.is_relative_to(base):
            return str(p.relative_to(base))
    return path


def _spec_from_json(text: str) -> CampaignSpec:
    return parse_campaign_text(text, max_runs=None)


def _atomic_write(path: Path, text: str) -> None:
    """``text`` into ``path`` via ``.NAME.tmp`` (a fixed name: a killed creation's leftover is
    found by it, ``_CREATION_LEFTOVERS``)."""
    _files.write_atomic(path, text, temp=path.with_name(f".{path.name}.tmp"))
