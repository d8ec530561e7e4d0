"""The one way navstress writes rates for a person (navstress._percent), by property; and every
command that prints rates (gate, compare, analyze, campaign status, the report) printing them
through it: no more than one decimal, never a rounded ``100%`` for a rate below 1."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st

from tests.support.analysis_synth import make_store, record
from tests.support.cli_inputs import invoke
from navstress._percent import percent, percent_vs, points, setting

RATE = st.floats(0.0, 1.0)
#: a percentage a person reads: whole, or one decimal, or bounded near the ends
TEXT = re.compile(r"^(?:<0\.1|>99\.9|\d{1,3}(?:\.\d)?)%$")


def _value(text: str) -> float:
    return float(text.rstrip("%").lstrip("<>+"))


@given(RATE)
@example(2 / 3)
@example(0.995)
@example(0.9995)
@example(0.004)
@example(1e-300)
@example(1 - 2**-53)
def test_percent_is_short_close_and_never_rounds_to_an_end(x: float) -> None:
    t = percent(x)
    assert TEXT.match(t), t
    assert not t.endswith(".0%")
    assert (t == "100%") == (x == 1.0) and (t == "0%") == (x == 0.0)
    if t[0] not in "<>":
        assert abs(_value(t) - 100 * x) <= (0.05 if "." in t else 0.5) + 1e-9, (x, t)
    else:
        assert (0 < 100 * x < 0.1 + 1e-9) if t[0] == "<" else (99.9 - 1e-9 < 100 * x < 100), (x, t)


@given(RATE, RATE)
def test_percent_keeps_the_order_of_rates(x: float, y: float) -> None:
    assume(x < y)
    key = {"<": -0.01, ">": 0.01}
    tx, ty = percent(x), percent(y)

    def v(t: str) -> float:
        return _value(t) + (key.get(t[0], 0.0))

    assert v(tx) <= v(ty), (x, tx, y, ty)


@given(st.integers(0, 10_000), st.integers(1, 10_000))
def test_a_fraction_of_runs_has_at_most_one_decimal(k: int, n: int) -> None:
    assume(k <= n)
    t = percent(k / n)
    assert TEXT.match(t) and len(t.rstrip("%").partition(".")[2]) <= 1, t


#: a bar a user types: a rate with up to 6 decimals (a percentage with up to 4)
BAR = st.integers(0, 1_000_000).map(lambda k: k / 1_000_000)


@given(st.floats(0.0, 1.0), BAR)
@example(0.79996, 0.8)
@example(0.8, 0.8)
@example(0.80004, 0.8)
@example(0.9999999, 1.0)
@example(0.4729, 0.4)
def test_percent_vs_stands_on_the_same_side_of_the_bar(x: float, bar: float) -> None:
    t = percent_vs(x, bar)
    want = (x > bar) - (x < bar)
    bar_shown = _value(setting(bar))
    assert bar_shown == pytest.approx(100 * bar, abs=1e-9)
    if t[0] in "<>":  # an open interval of percentages, wholly on the right side of the bar
        lo, hi = (0.0, 0.1) if t[0] == "<" else (99.9, 100.0)
        assert (want > 0 and bar_shown <= lo) or (want < 0 and bar_shown >= hi), (x, bar, t)
    else:
        shown = _value(t)
        assert (shown > bar_shown) - (shown < bar_shown) == want, (x, bar, t, setting(bar))
        assert (shown == 100) <= (x == 1) and (shown == 0) <= (x == 0), (x, t)
    if abs(x - bar) > 0.01:
        assert t == percent(x)  # decimals only where the bar needs them


@given(st.decimals(0, 1, places=4))
def test_setting_writes_what_the_user_chose(d: object) -> None:
    x = float(d)  # type: ignore[arg-type]
    t = setting(x)
    assert t.endswith("%") and not t.endswith(".%") and not re.search(r"\.\d*0%$", t)
    assert math.isclose(_value(t), 100 * x, abs_tol=1e-9), (x, t)


@given(st.floats(-1.0, 1.0))
def test_points_are_signed_and_short(d: float) -> None:
    t = points(d)
    if d == 0:
        assert t == "0"
        return
    assert t[0] == ("+" if d > 0 else "-"), t
    body = t[1:]
    assert re.match(r"^(?:<0\.1|>99\.9|\d{1,3}(?:\.\d)?)$", body), t
    assert body != "0" and (body != "100" or abs(d) == 1.0), t


@pytest.mark.parametrize("x", [None, math.nan, math.inf])
def test_a_missing_rate_is_a_dash(x: float | None) -> None:
    assert percent(x) == percent_vs(x, 0.5) == points(x) == "-"


# ---- every command that prints rates --------------------------------------------------------

#: Any number directly before a % sign in a command's output.
PERCENT_IN_TEXT = re.compile(r"([<>]?\d+(?:\.\d+)?)\s?%")


@pytest.fixture(scope="module")
def thirds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A store whose rates are thirds (2 of 3 runs succeed): 66.666...% everywhere."""
    root = tmp_path_factory.mktemp("pct") / "c"
    with make_store(root, trees=[0, 4], defs=[], maps=1, runs=3, faults=[None, "small-footprint"]) as s:
        for key in ("tree=0", "tree=4"):
            for r in range(3):
                s.add(record("trees", key, 0, r, "success" if r else "fail-timeout"))
                s.add(record("trees", key, 0, r, "fail-collision" if r else "success", fault="small-footprint",
                             collisions=int(r > 0)))
    return root


COMMANDS = [
    ["gate", "{c}", "--min-success", "0.5", "--navigator", "reference-v1", "--fault", "nominal", "--fault",
     "small-footprint"],
    ["compare", "{c}", "--a", "reference-v1", "--b", "reference-v1:small-footprint"],
    ["analyze", "{c}"],
    ["campaign", "status", "{c}"],
    ["report", "{c}", "-o", "{t}/r.html"],
]


@pytest.mark.parametrize("argv", COMMANDS, ids=[" ".join(a[:2]) for a in COMMANDS])
def test_every_rate_a_command_prints_has_at_most_one_decimal(argv: list[str], thirds: Path, tmp_path: Path) -> None:
    args = [a.replace("{c}", str(thirds)).replace("{t}", str(tmp_path)) for a in argv]
    code, out, err = invoke(args)
    assert code in (0, 1), (args, out, err)
    text = (tmp_path / "r.html").read_text(encoding="utf-8") if argv[0] == "report" else out
    if argv[0] == "report":
        # what a person reads: not the scripts (the chart libraries; a chart's data, exact, whose
        # tooltips print rates with one decimal: tests/unit/analysis/test_charts.py)
        text = re.sub(r"<script\b.*?</script>", "", text, flags=re.S)
    found = PERCENT_IN_TEXT.findall(text)
    assert found, f"{argv[0]} printed no percentage"
    long = [f for f in found if len(f.partition(".")[2]) > 1]
    assert not long, f"{argv[0]}: percentages with more than one decimal: {long}"
    if argv[0] != "campaign":
        assert "67%" in text and "66.6" not in text, text[:2000]
