"""Tables written for other tools and read back: CSV or Parquet, typed columns, atomic.

One writer and one reader for every table navstress exports (the runs table of a campaign, the
verdicts). A column is ``int``, ``float``, ``bool``, ``str`` or ``strlist`` (a list of strings:
a Parquet list column, a JSON array in CSV); in CSV a missing value (``None``, or a float NaN)
is an empty cell, read back as ``None`` for numbers and booleans and for the ``str`` columns
named ``nullable``; booleans are ``true``/``false``. Parquet files carry ``metadata`` (string
keys and values) in their schema. pyarrow is imported only when Parquet is written or read (it costs ~0.35 s, and
the modules that export are imported by every campaign worker).

**One vocabulary for keys.** Every table and every JSON output that names a run, a world or a
configuration uses the columns of :data:`KEYS`, spelled and typed the same way, never empty:
``config`` is the configuration key (``tree=4``, the run id's second part), ``fault`` is
``"nominal"`` for the nominal stack; so any two tables join on the keys they share, and a
reader's default ``groupby`` keeps every run. :func:`write_table` refuses a table that breaks it.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

from navstress import _files, _json
from navstress.errors import SpecError

Kind = Literal["int", "float", "bool", "str", "strlist"]
FORMATS = ("csv", "parquet")
#: The fault of the nominal stack, in every table and JSON output.
NOMINAL = "nominal"
#: The key columns (see the module doc): name -> kind, the same in every table that has them.
KEYS: dict[str, Kind] = {"run_id": "str", "experiment": "str", "config": "str", "map_index": "int",
                         "run_index": "int", "navigator": "str", "fault": "str"}


def _check_keys(rows: list[Mapping[str, Any]], columns: Mapping[str, Kind]) -> None:
    """ValueError (a bug of the caller, never the user's) when a key column has another kind or a
    missing value, or an ``int`` key holds something else than an int."""
    for c, kind in columns.items():
        if c in KEYS:
            if kind != KEYS[c]:
                raise ValueError(f"key column {c!r} must be {KEYS[c]}, not {kind}")
            want = str if kind == "str" else int
            for r in rows:
                if not isinstance(r[c], want) or isinstance(r[c], bool):
                    raise ValueError(f"key column {c!r} holds {r[c]!r}: every row needs a {kind}")


def _cell(x: Any, kind: Kind) -> Any:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return ""
    if kind == "bool":
        return "true" if x else "false"
    if kind == "strlist" and not isinstance(x, str):
        return _json.dumps(list(x), ensure_ascii=False)
    return x


def _arrow(kind: Kind, x: Any) -> Any:
    """A value as pyarrow takes it for a column of ``kind`` (a strlist given as JSON text is parsed)."""
    if kind == "strlist" and isinstance(x, str):
        return json.loads(x)
    return x


def write_table(rows: Iterable[Mapping[str, Any]], columns: Mapping[str, Kind], fmt: str, dest: Path,
                metadata: Mapping[str, str] | None = None) -> Path:
    """Write ``rows`` (the ``columns``, in their order) to ``dest`` as CSV or Parquet, under a
    temporary name renamed into place; returns ``dest``. ``metadata`` goes into a Parquet file's
    schema (CSV has no place for it)."""
    if fmt not in FORMATS:
        raise SpecError("format", fmt, "csv or parquet")
    rows = list(rows)
    _check_keys(rows, columns)
    raw: bytes | str
    if fmt == "csv":
        f = io.StringIO(newline="")
        w = csv.DictWriter(f, fieldnames=list(columns))
        w.writeheader()
        w.writerows([{c: _cell(r[c], k) for c, k in columns.items()} for r in rows])
        raw = f.getvalue()
    else:
        import pyarrow as pa  # local: see the module's doc
        import pyarrow.parquet as pq

        types = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(), "str": pa.string(),
                 "strlist": pa.list_(pa.string())}
        schema = pa.schema([(c, types[k]) for c, k in columns.items()], metadata=dict(metadata or {}))
        data = [{c: _arrow(k, r[c]) for c, k in columns.items()} for r in rows]
        sink = pa.BufferOutputStream()
        pq.write_table(pa.Table.from_pylist(data, schema=schema), sink)
        raw = sink.getvalue().to_pybytes()
    _files.write_atomic(dest, raw)  # a unique temporary name, renamed into place
    return dest


def _guess(v: str) -> Any:
    """A CSV cell of a column not in ``columns``: None, a bool, an int, a float or the text."""
    if v == "":
        return None
    if v in ("true", "false"):
        return v == "true"
    for kind in (int, float):
        try:
            return kind(v)
        except ValueError:
            pass
    return v


def read_table(path: str | Path, columns: Mapping[str, Kind], nullable: Collection[str] = ()) -> list[dict[str, Any]]:
    """Read back a table :func:`write_table` wrote (by its suffix: ``.parquet`` or CSV) as typed rows;
    a CSV's columns beyond ``columns`` are typed by their text (:func:`_guess`)."""
    p = Path(path)
    if p.suffix == ".parquet":
        import pyarrow.parquet as pq  # local: see the module's doc

        return list(pq.read_table(p).to_pylist())
    out = []
    with open(p, newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            d: dict[str, Any] = {}
            for c, kind in columns.items():
                v = r[c]
                d[c] = None if v == "" and (kind != "str" or c in nullable) else (
                    int(v) if kind == "int" else float(v) if kind == "float" else v == "true" if kind == "bool"
                    else json.loads(v) if kind == "strlist" else v)
            d.update({c: _guess(v) for c, v in r.items() if c not in columns})
            out.append(d)
    return out


def config_key_of(rid: str, experiment: str, config: Mapping[str, Any]) -> str:
    """The configuration key of run ``rid`` of ``experiment`` (what every table and JSON output
    calls ``config``): the run id's second part, else (a run id of another form) a stable text of
    the swept parameters ``config``.

        >>> config_key_of("trees/tree=4/m0/r1/reference-v1/nominal", "trees", {})
        'tree=4'
    """
    parts = rid.split("/")
    if len(parts) >= 6 and parts[0] == experiment:
        return "/".join(parts[1:-4])
    return ",".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, v in sorted(config.items())) or "base"
