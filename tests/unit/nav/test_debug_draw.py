"""A navigator's debug drawing (``navstress.nav.api.DebugDraw``): what ``check_debug`` accepts
and refuses, and that a drawing comes back the same from the trace and from the line protocol;
``crop_known`` keeps every known cell of a map where it was."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navstress.nav import wire
from navstress.nav.api import (MAX_DEBUG_POINTS, DebugDraw, DebugLine, DebugPoints, DebugText, InvalidAnswer,
                               check_debug)
from navstress.run.mission import crop_known
from navstress.run.trace import TraceWriter, read_debug

coord = st.floats(-1e4, 1e4, allow_nan=False, width=32)
unit = st.floats(0.0, 1.0, width=32)
size = st.floats(0.001, 100.0).map(lambda v: float(np.float32(v)))
frame = st.sampled_from(["map", "robot"])
colour = st.tuples(unit, unit, unit, unit)


def _pts(least: int) -> st.SearchStrategy[np.ndarray]:
    return st.integers(least, 30).flatmap(lambda n: arrays(np.float64, (n, 3), elements=coord))


drawings = st.builds(
    DebugDraw,
    lines=st.lists(st.builds(DebugLine, _pts(2), frame, colour, size), max_size=5).map(tuple),
    points=st.lists(st.builds(DebugPoints, _pts(1), frame, colour, size), max_size=3).map(tuple),
    texts=st.lists(st.builds(DebugText, st.tuples(coord, coord, coord), st.text(max_size=200), frame, colour, size),
                   max_size=3).map(tuple))


def _flat(d: DebugDraw) -> tuple[object, ...]:
    """A drawing as plain values; point sets split into one set per point (as a trace keeps them)."""
    return (tuple((ln.points.tolist(), ln.frame, tuple(ln.colour), ln.width_m) for ln in d.lines),
            tuple(sorted((p, ps.frame, tuple(ps.colour), ps.size_m) for ps in d.points for p in ps.points.tolist())),
            tuple((tuple(t.position), t.text, t.frame, tuple(t.colour), t.size_m) for t in d.texts))


@given(drawings)
@settings(max_examples=60, deadline=None)
def test_a_valid_drawing_comes_back_the_same_over_the_line_protocol(d: DebugDraw) -> None:
    checked = check_debug(d)
    line = wire.dumps({"type": "command", "v": 0.0, "omega": 0.0, "debug": wire.encode_debug(checked)})
    back = wire.decode_debug(wire.loads(line)["debug"])
    assert _flat(back) == _flat(checked) == _flat(d)


@given(drawings)
@settings(max_examples=25, deadline=None)
def test_a_valid_drawing_comes_back_the_same_from_the_trace(tmp_path_factory: pytest.TempPathFactory,
                                                           d: DebugDraw) -> None:
    path = tmp_path_factory.mktemp("debug") / "d.mcap"
    tw = TraceWriter(path)
    tw.debug(1.5, check_debug(d))
    tw.close()
    ((t, back),) = read_debug(path)
    assert t == 1.5
    # the trace stores coordinates and sizes as protobuf doubles, colours as doubles too: exact;
    # the line order within a frame is kept, map-frame items come before robot-frame ones
    want = _flat(check_debug(DebugDraw(
        tuple(sorted(d.lines, key=lambda x: x.frame != "map")), d.points,
        tuple(sorted(d.texts, key=lambda x: x.frame != "map")))))
    assert _flat(back) == want


def test_check_debug_copies_the_arrays() -> None:
    p = np.zeros((2, 3))
    checked = check_debug(DebugDraw(lines=(DebugLine(p),)))
    p[0, 0] = 7.0  # a navigator reusing its buffer does not change what was recorded
    assert checked.lines[0].points[0, 0] == 0.0


BAD = [
    ("arcs", "debug returned str"),
    (DebugDraw(lines=[DebugLine(np.zeros((2, 3)))] * 2), None),  # a list is accepted like a tuple
    (DebugDraw(lines=(DebugLine(np.zeros((1, 3))),)), "lines[0].points has shape (1, 3), not (N, 3) with N >= 2"),
    (DebugDraw(lines=(DebugLine(np.zeros((3, 2))),)), "lines[0].points has shape (3, 2)"),
    (DebugDraw(lines=(DebugLine([["a", 0, 0], [0, 0, 0]]),)), "lines[0].points is not an array of numbers"),  # type: ignore[arg-type]
    (DebugDraw(lines=(DebugLine(np.array([[0, 0, 0], [np.nan, 0, 0]])),)), "lines[0].points holds a value that is not finite"),
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), frame="odom"),)), "lines[0].frame='odom' is not one of 'map', 'robot'"),
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), colour=(1, 0, 0)),)), "lines[0].colour=(1, 0, 0) is not 4 numbers"),  # type: ignore[arg-type]
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), colour=(1, 0, 0, 2)),)), "in [0, 1]"),
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), colour="red"),)), "lines[0].colour='red' is not 4 numbers (r, g, b, a)"),  # type: ignore[arg-type]
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), width_m=0.0),)), "lines[0].width_m=0.0 is not in (0, 100] meters"),
    (DebugDraw(lines=(DebugLine(np.zeros((2, 3)), width_m=float("inf")),)), "lines[0].width_m=inf is not finite"),
    (DebugDraw(points=(DebugPoints(np.zeros((0, 3))),)), "points[0].points has shape (0, 3), not (N, 3) with N >= 1"),
    (DebugDraw(points=(DebugPoints(np.zeros((1, 3)), size_m=-1),)), "points[0].size_m=-1 is not in (0, 100]"),
    (DebugDraw(texts=(DebugText((0, 0, 0), 5),)), "texts[0].text is a int, not a string"),  # type: ignore[arg-type]
    (DebugDraw(texts=(DebugText((0, 0, 0), "x" * 201),)), "texts[0].text has 201 characters, more than 200"),
    (DebugDraw(texts=(DebugText((0, 0), "x"),)), "texts[0].position=(0, 0) is not 3 finite numbers (x, y, z)"),  # type: ignore[arg-type]
    (DebugDraw(texts=tuple(DebugText((0, 0, 0), "x") for _ in range(51))), "51 texts, more than 50"),
    (DebugDraw(lines=(DebugPoints(np.zeros((2, 3))),)), "lines[0] is a DebugPoints, not a DebugLine"),  # type: ignore[arg-type]
    (DebugDraw(lines=DebugLine(np.zeros((2, 3)))), "DebugDraw.lines is a DebugLine, not a tuple"),  # type: ignore[arg-type]
    (DebugDraw(lines=(DebugLine(np.zeros((MAX_DEBUG_POINTS, 3))), DebugLine(np.zeros((2, 3))))),
     "the drawing has 20,002 points, more than 20,000"),
]


@pytest.mark.parametrize("draw,message", BAD)
def test_check_debug_says_what_is_wrong(draw: object, message: str | None) -> None:
    if message is None:
        assert len(check_debug(draw).lines) == 2
        return
    with pytest.raises(InvalidAnswer) as e:
        check_debug(draw)
    assert message in str(e.value)


@pytest.mark.parametrize("field,message", [
    ([], "debug is a list, not an object"),
    ({"arcs": []}, "debug has unknown field(s) 'arcs'"),
    ({"lines": {}}, "debug.lines is a dict, not a list"),
    ({"lines": [[0, 0, 0]]}, "debug.lines[0] is not an object with fields points, frame, colour, width_m"),
    ({"lines": [{"points": [[0, 0, 0], [1, 1, 1]], "color": [1, 1, 1, 1]}]}, "debug.lines[0] is not an object"),
    ({"texts": [{"text": "x"}]}, "debug.texts[0] has no 'position'"),
    ({"lines": [{"points": [[0, 0, 0], [1, 1, "x"]]}]}, "lines[0].points is not an array of numbers"),
    ({"points": [{"points": [[0, 0, 0]], "frame": "world"}]}, "points[0].frame='world' is not one of"),
])
def test_the_wire_decoder_says_what_is_wrong(field: object, message: str) -> None:
    with pytest.raises(InvalidAnswer) as e:
        wire.decode_debug(json.loads(json.dumps(field)))
    assert message in str(e.value)


def test_the_wire_decoder_fills_defaults() -> None:
    d = wire.decode_debug({"lines": [{"points": [[0, 0, 0], [1, 0, 0]]}], "texts": [{"position": [0, 0, 1],
                                                                                      "text": "hi"}]})
    assert d.lines[0].frame == "map" and d.lines[0].colour == (1.0, 1.0, 1.0, 1.0) and d.texts[0].frame == "robot"


@given(arrays(np.float32, st.tuples(st.integers(1, 12), st.integers(1, 12)),
              elements=st.one_of(st.just(np.nan), st.floats(-5, 5, width=32))),
       st.floats(-100, 100), st.floats(-100, 100), st.sampled_from([0.1, 0.25, 0.3, 1.0]))
@settings(max_examples=150, deadline=None)
def test_crop_known_keeps_every_known_cell_where_it_was(g: np.ndarray, ox: float, oy: float, cell: float) -> None:
    out = crop_known((g, (ox, oy), cell))
    known = np.argwhere(np.isfinite(g))
    if not len(known):
        assert out is None
        return
    assert out is not None
    v, (cx, cy), c = out
    assert c == cell and int(np.isfinite(v).sum()) == len(known)
    for i, j in known:  # the same cell centre in the map frame holds the same value
        x, y = ox + (j + 0.5) * cell, oy + (i + 0.5) * cell
        ii, jj = round((y - cy) / cell - 0.5), round((x - cx) / cell - 0.5)
        assert v[ii, jj] == g[i, j]
    k = np.isfinite(v)
    assert k[0].any() and k[-1].any() and k[:, 0].any() and k[:, -1].any()


@pytest.mark.parametrize("answer", ["map", (np.zeros(3), (0, 0), 1.0), (np.zeros((2, 2)), (0, np.nan), 1.0),
                                    (np.zeros((2, 2)), (0, 0), 0.0), (np.zeros((2, 2)), (0,), 1.0), None])
def test_crop_known_refuses_what_is_not_a_map(answer: object) -> None:
    with pytest.raises(InvalidAnswer, match="final_map returned"):
        crop_known(answer)


def test_the_trace_reader_knows_a_trace_without_drawings(tmp_path: Path) -> None:
    tw = TraceWriter(tmp_path / "t.mcap")
    tw.event(0.0, "info", "x")
    tw.close()
    assert read_debug(tmp_path / "t.mcap") == []
