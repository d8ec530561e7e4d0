"""Checks every MCAP trace the tests write: messages in log-time order in the file, each
channel's sequence numbers 1, 2, 3, ... in that order, and a valid, consistent summary (what
``mcap doctor --strict-message-order`` and Foxglove rely on).

Used by the autouse fixtures in ``tests/conftest.py``. When the official ``mcap`` CLI is on
PATH (or ``NAVSTRESS_MCAP_CLI`` names it), ``mcap doctor --strict-message-order`` runs too.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections import Counter
from pathlib import Path

from mcap.reader import NonSeekingReader, SeekingReader


def trace_problems(path: Path) -> list[str]:
    """What is wrong with the trace at ``path`` (empty when nothing is). A ROS 2 bag's MCAP file
    (profile ``ros2``, written by rosbags for ``trace export``) gets every check but the
    sequence numbers, which rosbag2 writers leave at 0."""
    problems: list[str] = []
    times: list[int] = []
    per_channel: Counter[int] = Counter()
    with open(path, "rb") as f:
        ours = NonSeekingReader(f).get_header().profile != "ros2"
    with open(path, "rb") as f:  # file order, CRCs checked
        for _schema, channel, message in NonSeekingReader(f, validate_crcs=True).iter_messages(log_time_order=False):
            if times and message.log_time < times[-1]:
                problems.append(f"message {len(times)} on {channel.topic} goes back in time: "
                                f"log_time {message.log_time} < previous {times[-1]}")
            times.append(message.log_time)
            per_channel[message.channel_id] += 1
            if ours and message.sequence != per_channel[message.channel_id] and len(problems) < 20:
                problems.append(f"message {len(times) - 1} on {channel.topic} has sequence {message.sequence}, "
                                f"expected {per_channel[message.channel_id]} (the channel's count so far)")
    with open(path, "rb") as f:
        reader = SeekingReader(f, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            return problems + ["no summary section with statistics"]
        st = summary.statistics
        if st.message_count != len(times):
            problems.append(f"statistics count {st.message_count} messages, the file holds {len(times)}")
        if times and (st.message_start_time, st.message_end_time) != (min(times), max(times)):
            problems.append(f"statistics time range {st.message_start_time}..{st.message_end_time} "
                            f"!= messages' {min(times)}..{max(times)}")
        if dict(st.channel_message_counts) != {k: v for k, v in per_channel.items()}:
            problems.append(f"per-channel counts {dict(st.channel_message_counts)} != {dict(per_channel)}")
        chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
        for a, b in zip(chunks, chunks[1:]):
            if b.message_start_time < a.message_end_time:
                problems.append(f"chunk at {b.chunk_start_offset} starts at {b.message_start_time}, "
                                f"before the previous chunk ends ({a.message_end_time})")
        indexed = sum(1 for _ in reader.iter_messages(log_time_order=True))
        if indexed != len(times):
            problems.append(f"reading through the index gives {indexed} messages, the file holds {len(times)}")
    cli = os.environ.get("NAVSTRESS_MCAP_CLI") or shutil.which("mcap")
    if cli:
        out = subprocess.run([cli, "doctor", "--strict-message-order", str(path)],
                             capture_output=True, text=True, timeout=120)
        if out.returncode != 0:
            problems.append(f"mcap doctor --strict-message-order: {(out.stdout + out.stderr).strip()[-2000:]}")
    return problems[:20]


class TraceChecker:
    """Checks each ``*.mcap`` under a directory once (by path, size and mtime)."""

    def __init__(self) -> None:
        self._seen: set[tuple[str, int, int]] = set()

    def ignore_under(self, root: Path) -> None:
        """Mark every ``*.mcap`` under ``root`` as checked without checking it (junk on purpose)."""
        for p in root.rglob("*.mcap") if root.is_dir() else ():
            try:
                st = p.stat()
            except OSError:
                continue
            self._seen.add((str(p), st.st_size, st.st_mtime_ns))

    def check_under(self, root: Path) -> list[str]:
        """Problems of every trace under ``root`` not checked before, as ``path: problem`` lines."""
        bad: list[str] = []
        if not root.is_dir():
            return bad
        for p in sorted(root.rglob("*.mcap")):
            try:
                st = p.stat()
            except OSError:
                continue
            key = (str(p), st.st_size, st.st_mtime_ns)
            if key in self._seen:
                continue
            self._seen.add(key)
            if p.name.startswith(".") or p.name.endswith(".partial"):
                continue
            try:
                bad += [f"{p}: {m}" for m in trace_problems(p)]
            except Exception as err:  # an unreadable file a test made on purpose is reported, not hidden
                bad.append(f"{p}: unreadable: {type(err).__name__}: {err}")
        return bad
