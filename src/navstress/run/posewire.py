"""Pose trajectories decoded straight from a trace's chunk bytes (numba), for the report's thousands of reads.

A report reads the trajectory of every run of a campaign (2,375 for the paper preset; about 1,500
``foxglove.PoseInFrame`` messages each). Decoding them one by one with protobuf and converting each
quaternion in Python was most of a report's time. :func:`pose_rows` does the same work in one
compiled loop over the decompressed chunk: it reads each MCAP Message record at the offsets the
file's message index gives, parses the protobuf wire format of ``PoseInFrame`` (only the fields a
pose needs: ``pose.position`` x, y, z and ``pose.orientation`` x, y, z, w; everything else is
skipped by its wire type) and converts the quaternion to yaw, pitch, roll exactly as
:func:`navstress.run.trace.euler` does.

Same results as the protobuf path, bit for bit, on every CPU:

- doubles are copied from their 8 little-endian bytes, never computed;
- protobuf's rules are followed: an absent field is 0.0, a repeated scalar keeps its last value, a
  repeated sub-message is merged into the earlier one, a field with an unexpected wire type is
  skipped as unknown;
- the angles use the same libm ``atan2`` and ``asin`` that Python's :mod:`math` calls (with
  CPython's own special cases of ``atan2`` for NaN, infinities and zeros repeated), on the same
  expressions in the same order (numba compiles without fast-math, so nothing is reassociated or
  fused), and the clamp of the pitch's sine repeats Python's ``max(-1.0, min(1.0, v))`` with NaN;
- anything the loop does not expect (a record that is not a Message, a truncated or overlong
  field, a wire type protobuf would reject) makes it stop and say so: the caller then decodes the
  file with protobuf, which gives the same rows or the error a user should see.

A hypothesis test compares the two decoders on arbitrary poses (zeros, signed zeros, NaN,
infinities, absent fields, fields repeated and out of order, unknown fields) and on real traces.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import navstress._jit  # noqa: F401  (numba's cache directory, before any @njit(cache=True))


@numba.njit(cache=True)
def _varint(data: np.ndarray, pos: int, end: int) -> tuple[int, int]:
    """(value, next position); next position -1 when the varint runs past ``end`` or is over 10 bytes."""
    value = 0
    shift = 0
    while pos < end and shift < 70:
        b = int(data[pos])
        pos += 1
        if shift == 63 and b > 1:
            return 0, -1  # more than 64 bits: let protobuf judge
        value |= (b & 0x7F) << shift
        if b < 0x80:
            return value, pos
        shift += 7
    return 0, -1


@numba.njit(cache=True)
def _skip(data: np.ndarray, pos: int, end: int, wire: int) -> int:
    """The position after a field's value of wire type ``wire``; -1 when malformed or unsupported."""
    if wire == 0:
        _v, pos = _varint(data, pos, end)
        return pos
    if wire == 1:
        return pos + 8 if pos + 8 <= end else -1
    if wire == 5:
        return pos + 4 if pos + 4 <= end else -1
    if wire == 2:
        n, pos = _varint(data, pos, end)
        if pos < 0 or n < 0 or pos + n > end:
            return -1
        return pos + n
    return -1  # groups (3, 4) and invalid wire types: not in these schemas; let protobuf judge


@numba.njit(cache=True)
def _double(data: np.ndarray, pos: int, bits: np.ndarray, value: np.ndarray) -> float:
    """The little-endian double at ``pos``: its 8 bytes put in ``bits`` (one uint64), read back
    through ``value`` (the same memory as float64), so the bits are copied, never converted."""
    u = 0
    for b in range(8):
        u |= int(data[pos + b]) << (8 * b)
    bits[0] = u
    return float(value[0])


# The messages a pose is in, as the walk below sees them: PoseInFrame (field 3: a Pose), Pose
# (field 1: a Vector3 position, field 2: a Quaternion orientation), Vector3 (doubles x, y, z:
# slots 0-2 of the values) and Quaternion (doubles x, y, z, w: slots 3-6).
# A Timestamp (field 1 of PoseInFrame) is walked too, its fields skipped: protobuf parses it, so
# a malformed one is an error there. The frame id (field 2) must be ASCII here: protobuf checks
# that a string is UTF-8, and any other byte sends the message to protobuf.
_POSE_IN_FRAME, _POSE, _VECTOR3, _QUATERNION, _TIMESTAMP = 0, 1, 2, 3, 4
_MAX_FIELD = (1 << 29) - 1  # protobuf's largest field number


@numba.njit(cache=True)
def _pose_in_frame(data: np.ndarray, pos: int, end: int, vals: np.ndarray, depth_type: np.ndarray,
                   depth_end: np.ndarray, bits: np.ndarray, value: np.ndarray) -> bool:
    """Parse the PoseInFrame in ``data[pos:end]`` into ``vals`` (position x, y, z, orientation x, y,
    z, w; absent ones 0.0), one field at a time with a stack of the messages it is inside (each
    one's type and end); False when the bytes are not a message this walk reads."""
    vals[:] = 0.0
    depth = 0
    depth_type[0], depth_end[0] = _POSE_IN_FRAME, end
    while True:
        stop = depth_end[depth]
        if pos >= stop:
            if pos > stop:
                return False
            if depth == 0:
                return True
            depth -= 1  # the end of a sub-message: back in its parent
            continue
        key, pos = _varint(data, pos, stop)
        if pos < 0 or key >> 3 == 0 or key >> 3 > _MAX_FIELD:
            return False
        field, wire, kind = key >> 3, key & 7, depth_type[depth]
        child = -1
        if wire == 2 and kind == _POSE_IN_FRAME and field == 3:
            child = _POSE
        elif wire == 2 and kind == _POSE_IN_FRAME and field == 1:
            child = _TIMESTAMP
        elif wire == 2 and kind == _POSE_IN_FRAME and field == 2:
            n, pos = _varint(data, pos, stop)
            if pos < 0 or n < 0 or pos + n > stop:
                return False
            for k in range(pos, pos + n):
                if data[k] >= 0x80:
                    return False
            pos += n
            continue
        elif wire == 2 and kind == _POSE and (field == 1 or field == 2):
            child = _VECTOR3 if field == 1 else _QUATERNION
        if child >= 0:  # into the sub-message (a repeated one merges into the same values, as protobuf)
            n, pos = _varint(data, pos, stop)
            if pos < 0 or n < 0 or pos + n > stop:
                return False
            depth += 1
            depth_type[depth], depth_end[depth] = child, pos + n
        elif wire == 1 and ((kind == _VECTOR3 and field <= 3) or (kind == _QUATERNION and field <= 4)):
            if pos + 8 > stop:
                return False
            vals[(0 if kind == _VECTOR3 else 3) + field - 1] = _double(data, pos, bits, value)
            pos += 8
        else:  # any other field: unknown to a pose (or of another wire type), skipped as protobuf does
            pos = _skip(data, pos, stop, wire)
            if pos < 0:
                return False


@numba.njit(cache=True)
def _atan2(y: float, x: float) -> float:
    """Python's ``math.atan2`` (CPython's ``m_atan2``: its own special cases, then libm's atan2)."""
    if math.isnan(x) or math.isnan(y):
        return np.nan
    if math.isinf(y):
        if math.isinf(x):
            if math.copysign(1.0, x) == 1.0:
                return math.copysign(0.25 * math.pi, y)
            return math.copysign(0.75 * math.pi, y)
        return math.copysign(0.5 * math.pi, y)
    if math.isinf(x) or y == 0.0:
        if math.copysign(1.0, x) == 1.0:
            return math.copysign(0.0, y)
        return math.copysign(math.pi, y)
    return math.atan2(y, x)


@numba.njit(cache=True)
def pose_rows(data: np.ndarray, offsets: np.ndarray, log_times: np.ndarray, out: np.ndarray) -> int:
    """Fill ``out[i]`` (t, x, y, z, yaw, pitch, roll) from the MCAP Message record at ``offsets[i]``
    of the decompressed chunk ``data`` (uint8), whose log time is ``log_times[i]`` (ns). Returns -1
    when every message was decoded, else the index of the first one this loop cannot decode."""
    size = data.shape[0]
    vals = np.zeros(7)
    depth_type = np.zeros(3, dtype=np.int64)  # PoseInFrame, Pose, Vector3 or Quaternion: 3 deep at most
    depth_end = np.zeros(3, dtype=np.int64)
    bits = np.zeros(1, dtype=np.uint64)
    value = bits.view(np.float64)
    for i in range(offsets.shape[0]):
        at = offsets[i]
        # a Message record: opcode 0x05 (1), length (8), channel (2), sequence (4), log time (8),
        # publish time (8), then the payload
        if at < 0 or at + 31 > size or data[at] != 0x05:
            return i
        length = 0
        for b in range(8):
            length |= int(data[at + 1 + b]) << (8 * b)
        if length < 22 or at + 9 + length > size:
            return i
        if not _pose_in_frame(data, at + 31, at + 9 + length, vals, depth_type, depth_end, bits, value):
            return i
        w, x, y, z = vals[6], vals[3], vals[4], vals[5]
        # navstress.run.trace.euler, term for term
        roll = _atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        s = 2 * (w * y - z * x)
        s = s if s < 1.0 else 1.0  # min(1.0, s)
        s = s if s > -1.0 else -1.0  # max(-1.0, s)
        pitch = math.asin(s)
        yaw = _atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        out[i, 0] = log_times[i] / 1e9
        out[i, 1] = vals[0]
        out[i, 2] = vals[1]
        out[i, 3] = vals[2]
        out[i, 4] = yaw
        out[i, 5] = pitch
        out[i, 6] = roll
    return -1
