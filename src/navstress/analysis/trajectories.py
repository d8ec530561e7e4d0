"""Decoded trajectories of a campaign's traces, read once per process and in parallel when there are many.

(A module of its own with light imports: its worker processes import it, and nothing of the
analysis, before they read their first trace.)
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from navstress.errors import NavstressError
from navstress.isolate import Worker
from navstress.run.trace import TOPIC_TRUTH, read_poses_of

#: How many trajectories make :meth:`TrajectoryCache.prefetch` read in worker processes.
PARALLEL_FROM = 200


def _poses_or_none(path: str, topics: Sequence[str]) -> dict[str, np.ndarray | None]:
    """Each topic's (N, 7) poses of one trace; None for all when the trace is missing or
    unreadable, None for a topic without a message."""
    try:
        arrays = read_poses_of(path, topics)
    except NavstressError:
        return {t: None for t in topics}
    return {t: a if len(a) else None for t, a in arrays.items()}


def _poses_many(requests: list[tuple[str, tuple[str, ...]]]) -> list[dict[str, np.ndarray | None]]:
    """What a worker process answers (see :meth:`TrajectoryCache.prefetch`)."""
    return [_poses_or_none(p, topics) for p, topics in requests]


class TrajectoryCache:
    """Decoded trajectories by (trace path, topic), read once per process (keyed by mtime too).

    Reading a paper-sized campaign's trajectories is Python and compiled work (about 4 ms a trace);
    :meth:`prefetch` spreads many over worker processes, started once per cache (their start and
    imports cost about a second) and stopped by :meth:`close` (or at the end of a ``with``
    block; they also die with this process)."""

    def __init__(self) -> None:
        self._c: dict[tuple[str, str, float], np.ndarray | None] = {}
        self._workers: list[Any] = []
        self._drivers: list[threading.Thread] = []
        self._queue: queue.Queue[list[tuple[str, float, tuple[str, ...]]] | None] = queue.Queue()
        self._pending: set[tuple[str, str, float]] = set()

    def __enter__(self) -> TrajectoryCache:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Finish what was asked, then stop the worker processes (the cache keeps what it holds)."""
        self.wait()
        for _ in self._drivers:
            self._queue.put(None)
        for t in self._drivers:
            t.join()
        for w in self._workers:
            w.close()
        self._workers, self._drivers = [], []

    def wait(self) -> None:
        """Wait until every trajectory asked for with ``prefetch(..., wait=False)`` is in the cache."""
        if self._drivers:
            self._queue.join()

    def get(self, path: str | Path | None, topic: str = TOPIC_TRUTH) -> np.ndarray | None:
        """(N, 7) poses, or None when the trace is missing or unreadable."""
        if not path:
            return None
        p = str(path)
        try:
            mt = os.stat(p).st_mtime
        except OSError:
            return None
        k = (p, topic, mt)
        if k not in self._c:
            self._c[k] = _poses_or_none(p, (topic,))[topic]
        return self._c[k]

    def prefetch(self, paths: Sequence[Path | str | None], topic: str | Sequence[str] = TOPIC_TRUTH,
                 workers: int | None = None, *, wait: bool = True) -> None:
        """Read the trajectories on ``topic`` (one topic, or several read together from each trace)
        of many traces into the cache at once: in worker processes (:class:`navstress.isolate.Worker`;
        ``workers``, or by default one per core when there are at least :data:`PARALLEL_FROM`
        trajectories to read). The arrays are the ones :meth:`get` would read, byte for byte.

        ``wait=False`` returns at once while the workers read (:meth:`wait` waits for them; with
        too few trajectories for workers it reads nothing: :meth:`get` reads on demand). A
        trajectory already asked for is not asked for again."""
        topics = (topic,) if isinstance(topic, str) else tuple(topic)
        todo: list[tuple[str, float, tuple[str, ...]]] = []
        seen: set[str] = set()
        for path in paths:
            if not path or str(path) in seen:
                continue
            p = str(path)
            seen.add(p)
            try:
                mt = os.stat(p).st_mtime
            except OSError:
                continue
            want = tuple(t for t in topics if (p, t, mt) not in self._c and (p, t, mt) not in self._pending)
            if want:
                todo.append((p, mt, want))
        count = sum(len(w) for _p, _mt, w in todo)
        if workers is None:
            n = min(os.cpu_count() or 1, 8, max(1, count // 64)) if count >= PARALLEL_FROM else 1
        else:
            n = workers
        if n <= 1 or len(todo) < 2:
            if wait:
                for p, mt, want in todo:
                    self._store(p, mt, _poses_or_none(p, want))
                self.wait()
            return
        self._start(n)
        for p, mt, want in todo:
            self._pending.update((p, t, mt) for t in want)
        for i in range(4 * len(self._drivers)):
            self._queue.put(todo[i::4 * len(self._drivers)])
        if wait:
            self.wait()

    def _start(self, n: int) -> None:
        """At least ``n`` worker processes (navstress's one worker loop, :mod:`navstress.isolate`:
        spawned, they die with this process), each with a thread here that feeds it chunks of
        traces from the queue and waits on its pipe while it decodes."""
        while len(self._drivers) < n:
            w = Worker(600.0, preload=(__name__,))
            t = threading.Thread(target=self._drive, args=(w,), daemon=True)
            self._workers.append(w)
            self._drivers.append(t)
            t.start()

    def _drive(self, w: Any) -> None:
        while True:
            chunk = self._queue.get()
            if chunk is None:
                self._queue.task_done()
                return
            try:
                status, answers = w.call(_poses_many, [(p, want) for p, _mt, want in chunk]) if chunk else ("ok", [])
                if status != "ok":  # the worker could not read them: read them here
                    answers = [_poses_or_none(p, want) for p, _mt, want in chunk]
                for (p, mt, _want), arrays in zip(chunk, answers):
                    self._store(p, mt, arrays)
            except Exception:  # left unread: get() reads them on demand, and says what is wrong
                pass
            finally:
                for p, mt, want in chunk:
                    self._pending.difference_update((p, t, mt) for t in want)
                self._queue.task_done()

    def _store(self, path: str, mtime: float, arrays: dict[str, np.ndarray | None]) -> None:
        for t, arr in arrays.items():
            self._c[(path, t, mtime)] = arr

    @staticmethod
    def thin(arr: np.ndarray, max_points: int) -> np.ndarray:
        if max_points <= 0 or len(arr) <= max_points:
            return arr
        step = int(np.ceil(len(arr) / max_points))
        idx = np.arange(0, len(arr), step)
        if idx[-1] != len(arr) - 1:
            idx = np.append(idx, len(arr) - 1)
        return arr[idx]
