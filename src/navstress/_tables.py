"""Tables written for other tools and read back: CSV or Parquet, typed columns, atomic.

One writer and one reader for every table navstress exports (the runs table of a campaign, the
verdicts). A column is ``int``, ``float`` or ``str``; in CSV a missing value (``None``, or a
float NaN) is an empty cell, read back as ``None`` for numbers and for the ``str`` columns named
``nullable``. pyarrow is imported only when Parquet is written or read (it costs ~0.35 s, and
the modules that export are imported by every campaign worker).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

from navstress.errors import SpecError

Kind = Literal["int", "float", "str"]
FORMATS = ("csv", "parquet")


def _cell(x: Any) -> Any:
    return "" if x is None or (isinstance(x, float) and math.isnan(x)) else x


def write_table(rows: Iterable[Mapping[str, Any]], columns: Mapping[str, Kind], fmt: str, dest: Path) -> Path:
    """Write ``rows`` (the ``columns``, in their order) to ``dest`` as CSV or Parquet, under a
    temporary name renamed into place; returns ``dest``."""
    if fmt not in FORMATS:
        raise SpecError("format", fmt, "csv or parquet")
    rows = list(rows)
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = dest.with_name(f".{dest.name}.tmp")
    try:
        if fmt == "csv":
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                w = csv.DictWriter(f, fieldnames=list(columns))
                w.writeheader()
                w.writerows([{c: _cell(r[c]) for c in columns} for r in rows])
        else:
            import pyarrow as pa  # local: see the module's doc
            import pyarrow.parquet as pq

            types = {"int": pa.int64, "float": pa.float64, "str": pa.string}
            schema = pa.schema([(c, types[k]()) for c, k in columns.items()])
            pq.write_table(pa.Table.from_pylist(rows, schema=schema), tmp)
        os.replace(tmp, dest)
    finally:
        tmp.unlink(missing_ok=True)
    return dest


def read_table(path: str | Path, columns: Mapping[str, Kind], nullable: Collection[str] = ()) -> list[dict[str, Any]]:
    """Read back a table :func:`write_table` wrote (by its suffix: ``.parquet`` or CSV) as typed rows."""
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
                    int(v) if kind == "int" else float(v) if kind == "float" else v)
            out.append(d)
    return out
