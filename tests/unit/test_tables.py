"""The one writer and reader of exported tables (``navstress._tables``): every kind of column
round-trips through CSV and Parquet, and the swept parameters of a runs export get the column
kind their values have."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress._tables import Kind, read_table, write_table
from navstress.campaign.store import _param_kind

KINDS: dict[str, Kind] = {"i": "int", "f": "float", "b": "bool", "s": "str", "l": "strlist"}
TEXT = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\r\x00"), max_size=12)
ROW = st.fixed_dictionaries({
    "i": st.none() | st.integers(-2**63, 2**63 - 1),
    "f": st.none() | st.floats(allow_nan=False, allow_infinity=False),
    "b": st.none() | st.booleans(),
    "s": TEXT.filter(lambda t: t != ""),
    "l": st.lists(TEXT, max_size=3)})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(ROW, max_size=5), fmt=st.sampled_from(["csv", "parquet"]))
def test_every_kind_round_trips(tmp_path: Path, rows: list[dict[str, Any]], fmt: str) -> None:
    out = write_table(rows, KINDS, fmt, tmp_path / f"t.{fmt}", metadata={"navstress.table": "t"})
    back = read_table(out, KINDS)
    assert len(back) == len(rows)
    for a, b in zip(back, rows):
        for c in KINDS:
            if c == "f" and b[c] is not None:
                assert a[c] == b[c] or math.isclose(a[c], b[c], rel_tol=1e-15)  # CSV keeps repr's digits
            else:
                assert a[c] == b[c], (c, a[c], b[c])
    if fmt == "parquet":
        assert pq.read_schema(out).metadata == {b"navstress.table": b"t"}


@pytest.mark.parametrize("values,kind", [
    ([1, 2, None], "int"), ([1, 2.5], "float"), ([0.5, None], "float"), ([True, False], "bool"),
    (["a", None], "str"), ([[1, 2], [3, 4]], "str"), ([1, "a"], "str"), ([True, 1], "str"), ([None], "str")])
def test_a_swept_parameter_gets_the_kind_of_its_values(values: list[Any], kind: str) -> None:
    assert _param_kind(values) == kind
