"""The compiled pose decoder (navstress.run.posewire) against protobuf, on the wire: any
PoseInFrame (zeros, signed zeros, NaN, infinities, absent fields, fields repeated and out of
order, unknown fields, fields of a known number with another wire type) and payloads that are not
one at all. read_poses through the index (the compiled loop) must give protobuf's rows byte for
byte, or fail as the library path fails."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.run.trace import TOPIC_PERCEIVED, TOPIC_TRUTH, read_poses, read_poses_of

# hand-made files (out of order, odd payloads): not navstress traces, not checked as such
pytestmark = pytest.mark.not_traces


def _varint(v: int) -> bytes:
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        if v:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def _key(field: int, wire: int) -> bytes:
    return _varint(field << 3 | wire)


def _len(field: int, body: bytes) -> bytes:
    return _key(field, 2) + _varint(len(body)) + body


doubles = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, 1.0, -1.0]),
                    st.floats(-1.0, 1.0))


def unknown(numbers: st.SearchStrategy[int]) -> st.SearchStrategy[bytes]:
    """A field protobuf keeps as unknown: varint, fixed64, fixed32 or length-delimited."""
    return st.one_of(
        st.builds(lambda f, v: _key(f, 0) + _varint(v), numbers, st.integers(0, 2**64 - 1)),
        st.builds(lambda f, b: _key(f, 1) + b, numbers, st.binary(min_size=8, max_size=8)),
        st.builds(lambda f, b: _key(f, 5) + b, numbers, st.binary(min_size=4, max_size=4)),
        st.builds(lambda f, b: _len(f, b), numbers, st.binary(max_size=12)))


def doubles_message(n: int) -> st.SearchStrategy[bytes]:
    """A Vector3 (n = 3) or Quaternion (n = 4): its double fields in any order, any of them
    absent or repeated, sometimes with the wrong wire type, and unknown fields among them."""
    field = st.one_of(
        st.builds(lambda f, v: _key(f, 1) + struct.pack("<d", v), st.integers(1, n), doubles),
        st.builds(lambda f, v: _key(f, 0) + _varint(v), st.integers(1, n), st.integers(0, 2**40)),
        unknown(st.integers(n + 1, 40)))
    return st.lists(field, max_size=8).map(b"".join)


pose = st.lists(st.one_of(st.builds(lambda b: _len(1, b), doubles_message(3)),
                          st.builds(lambda b: _len(2, b), doubles_message(4)),
                          unknown(st.integers(3, 30))), max_size=5).map(b"".join)
pose_in_frame = st.lists(st.one_of(
    st.builds(lambda s, n: _len(1, _key(1, 0) + _varint(s) + _key(2, 0) + _varint(n)),
              st.integers(0, 2**64 - 1), st.integers(0, 999_999_999)),
    st.builds(lambda s: _len(2, s.encode()), st.sampled_from(["map", "odom", "", "carte", "\u00e9t\u00e9"])),
    st.builds(lambda b: _len(3, b), pose),
    unknown(st.one_of(st.integers(4, 30), st.integers((1 << 29) - 3, (1 << 29) - 1)))), max_size=5).map(b"".join)
# what protobuf may refuse: a malformed timestamp, a frame id that is not UTF-8, a field number
# past protobuf's largest, a varint past 64 bits
not_quite = st.one_of(
    st.builds(lambda b: _len(1, b), st.binary(max_size=6)),
    st.builds(lambda b: _len(2, b), st.binary(max_size=6)),
    st.builds(lambda f: _key(f, 0) + b"\x01", st.integers(1 << 29, (1 << 29) + 4)),
    st.builds(lambda last: _key(9, 0) + b"\xff" * 9 + bytes([last]), st.integers(0, 127)))


def _write(path: Path, payloads: dict[str, list[bytes]], chunk_size: int) -> None:
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from mcap.writer import Writer
    from mcap_protobuf.schema import build_file_descriptor_set

    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size)
        w.start()
        sid = w.register_schema("foxglove.PoseInFrame", "protobuf",
                                build_file_descriptor_set(PoseInFrame).SerializeToString())
        seq = 0
        for topic, msgs in payloads.items():
            cid = w.register_channel(topic, "protobuf", sid)
            for i, data in enumerate(msgs):
                seq += 1
                t = (len(msgs) - i) * 10**8 if topic == TOPIC_PERCEIVED else i * 10**8  # out of order too
                w.add_message(cid, log_time=t, data=data, publish_time=t, sequence=seq)
        w.finish()


def _read(path: Path, topic: str, indexed: bool) -> np.ndarray | str:
    try:
        return read_poses(path, topic, indexed=indexed)
    except Exception as err:  # noqa: BLE001 (compared: both paths must fail alike)
        return type(err).__name__


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(truth=st.lists(pose_in_frame, max_size=12), perceived=st.lists(pose_in_frame, max_size=6),
       chunk_size=st.sampled_from([64, 1024, 1 << 20]))
def test_the_compiled_decoder_reads_any_pose_as_protobuf_does(tmp_path: Path, truth: list[bytes],
                                                              perceived: list[bytes], chunk_size: int) -> None:
    path = tmp_path / "p.mcap"
    _write(path, {TOPIC_TRUTH: truth, TOPIC_PERCEIVED: perceived}, chunk_size)
    for topic in (TOPIC_TRUTH, TOPIC_PERCEIVED):
        fast, slow = _read(path, topic, True), _read(path, topic, False)
        assert isinstance(fast, np.ndarray) and isinstance(slow, np.ndarray)  # valid PoseInFrames all
        assert fast.shape == slow.shape and fast.tobytes() == slow.tobytes()
    both = read_poses_of(path, (TOPIC_TRUTH, TOPIC_PERCEIVED))
    for topic in (TOPIC_TRUTH, TOPIC_PERCEIVED):
        assert both[topic].tobytes() == read_poses(path, topic, indexed=False).tobytes()


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msgs=st.lists(st.one_of(pose_in_frame, st.binary(max_size=40), pose_in_frame.map(lambda b: b[:-1]),
                               st.tuples(pose_in_frame, not_quite, pose_in_frame).map(b"".join)),
                     min_size=1, max_size=6))
def test_a_payload_that_is_no_pose_fails_as_the_library_path_fails(tmp_path: Path, msgs: list[bytes]) -> None:
    """Truncated or arbitrary bytes: the compiled loop gives up and protobuf decides (the same rows,
    or the same error as the library's reader)."""
    path = tmp_path / "q.mcap"
    _write(path, {TOPIC_TRUTH: msgs}, 1 << 20)
    fast, slow = _read(path, TOPIC_TRUTH, True), _read(path, TOPIC_TRUTH, False)
    if isinstance(slow, np.ndarray):
        assert isinstance(fast, np.ndarray) and fast.tobytes() == slow.tobytes()
    else:
        assert isinstance(fast, str) and fast == slow


_GOOD = _len(3, _len(1, _key(1, 1) + struct.pack("<d", 2.5)))


@pytest.mark.parametrize("payload", [
    _GOOD + _key((1 << 29) - 1, 0) + b"\x01",  # the largest field number: fine
    _GOOD + _key(1 << 29, 0) + b"\x01",  # past it: protobuf refuses
    _GOOD + _key(1 << 31, 0) + b"\x01",
    _len(2, b"\xff\xfe") + _GOOD,  # a frame id that is not UTF-8
    _len(2, "\u00e9".encode()) + _GOOD,  # one that is, not ASCII
    _len(1, b"\x08") + _GOOD,  # a truncated timestamp
    _len(1, b"\x08\x01\x10\x02") + _GOOD,  # a whole one
    _len(1, b"\x0b") + _GOOD,  # a group in the timestamp
    _GOOD + _key(9, 0) + b"\xff" * 9 + b"\x7f",  # a 10-byte varint
    _GOOD + _key(9, 0) + b"\xff" * 10 + b"\x01",  # an 11-byte one
    _GOOD + _key(9, 6), _GOOD + _key(9, 7),  # wire types that do not exist
    _len(3, _len(1, _key(1, 1) + b"\x00" * 7)),  # a double cut short
])
def test_what_protobuf_refuses_the_compiled_decoder_does_not_accept(tmp_path: Path, payload: bytes) -> None:
    """Messages at the edges of the wire format: rows only where protobuf gives rows, the same ones."""
    path = tmp_path / "e.mcap"
    _write(path, {TOPIC_TRUTH: [payload]}, 1 << 20)
    fast, slow = _read(path, TOPIC_TRUTH, True), _read(path, TOPIC_TRUTH, False)
    if isinstance(slow, np.ndarray):
        assert isinstance(fast, np.ndarray) and fast.tobytes() == slow.tobytes()
    else:
        assert isinstance(fast, str) and fast == slow


def test_the_compiled_decoder_is_taken_on_a_trace_the_writer_wrote(tmp_path: Path) -> None:
    """On navstress's own traces the compiled loop decodes every message (no fallback)."""
    from navstress.run.trace import TraceWriter, _poses_indexed

    rows = np.column_stack([np.arange(50) * 0.1, np.linspace(0, 5, 50), np.zeros(50), np.full(50, 0.2),
                            np.linspace(-3, 3, 50), np.full(50, 0.1), np.full(50, -0.05)])
    with TraceWriter(tmp_path / "t.mcap") as tw:
        tw.poses(TOPIC_TRUTH, rows)
    fast = _poses_indexed(tmp_path / "t.mcap", [TOPIC_TRUTH])
    assert fast is not None and fast[TOPIC_TRUTH] is not None
    assert fast[TOPIC_TRUTH].tobytes() == read_poses(tmp_path / "t.mcap", indexed=False).tobytes()
    assert fast[TOPIC_TRUTH][:, 1:4] == pytest.approx(rows[:, 1:4]) and fast[TOPIC_TRUTH][:, 4:] == pytest.approx(rows[:, 4:])
