"""Misbehaving navigators for campaign tests, importable by worker processes (``module:attr``).

Each drives straight toward the goal for ``after_s`` simulated seconds, then misbehaves.
"""

from __future__ import annotations

import ctypes
import math
import os
import time
from typing import Any

from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.robot import RobotSpec


class _Base:
    def __init__(self, config: dict[str, Any] | None = None) -> None:
        self.after_s = float((config or {}).get("after_s", 1.0))
        self.t0: float | None = None

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        self.t0 = None

    def step(self, obs: Observation) -> Command | Status:
        t = float(getattr(obs, "t", 0.0))
        if self.t0 is None:
            self.t0 = t
        if t - self.t0 >= self.after_s:
            return self.misbehave()
        return Command(0.5, 0.0)

    def misbehave(self) -> Command | Status:
        return Command(0.0, 0.0)

    def close(self) -> None:
        pass


class Exits(_Base):
    """Kills its own process (as a crashing native library would)."""

    def misbehave(self) -> Command | Status:
        os._exit(7)


class Segfaults(_Base):
    """Dereferences a null pointer: SIGSEGV."""

    def misbehave(self) -> Command | Status:
        ctypes.string_at(0)
        return Command(0.0, 0.0)


class Hangs(_Base):
    """Never answers again."""

    def misbehave(self) -> Command | Status:
        while True:
            time.sleep(0.5)


class Slow(_Base):
    """Drives straight on, taking ``delay_s`` of wall time per step (a slow planner): its runs last
    long enough in real time for a test to stop the campaign mid-way, however loaded the machine."""

    def step(self, obs: Observation) -> Command | Status:
        time.sleep(float(getattr(self, "delay_s", 0.05)))
        return Command(0.5, 0.0)

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        super().__init__(config)
        self.delay_s = float((config or {}).get("delay_s", 0.05))


class Raises(_Base):
    """Raises an exception from step()."""

    def misbehave(self) -> Command | Status:
        raise RuntimeError("planner exploded" + "!" * int(math.copysign(1, 1)))


class Prints(_Base):
    """Drives normally and prints on its standard output at every call (as a chatty planner
    library does); also writes on file descriptor 1 directly, as C code would."""

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        super().__init__(config)
        self.after_s = math.inf
        print("Prints: init", flush=True)

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        super().reset(mission, robot, seed=seed)
        print("Prints: reset {", flush=True)

    def step(self, obs: Observation) -> Command | Status:
        print("Prints: step", flush=True)
        os.write(1, b"Prints: step (fd 1)\n")
        return super().step(obs)


class Validated(_Base):
    """A third-party navigator whose factory validates its config up front (``validate_config``)."""

    @staticmethod
    def validate_config(config: dict[str, Any]) -> None:
        from navstress.errors import SpecError

        unknown = sorted(set(config) - {"after_s", "gain"})
        if unknown:
            raise SpecError(unknown[0], config[unknown[0]], "one of after_s, gain")
        gain = config.get("gain", 1.0)
        if not isinstance(gain, (int, float)) or isinstance(gain, bool) or not 0 < gain < 10:
            raise SpecError("gain", gain, "a number in (0, 10)")


class KilledOnce(_Base):
    """On its first attempt (no ``marker`` file yet) writes its process id to ``marker`` and waits
    to be killed from outside; later attempts drive normally (a worker killed by the OOM killer)."""

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        super().__init__(config)
        self.marker = str((config or {})["marker"])

    def misbehave(self) -> Command | Status:
        if not os.path.exists(self.marker):
            with open(self.marker + ".tmp", "w") as f:
                f.write(str(os.getpid()))
            os.replace(self.marker + ".tmp", self.marker)
            while True:
                time.sleep(0.1)
        self.after_s = math.inf
        return Command(0.5, 0.0)


class Coin:
    """Says "arrived" (a success when the goal is within tolerance of the start) with
    probability ``p`` drawn from its seed, else gives up: a Bernoulli stream of known ``p`` that
    costs one control cycle per run (adaptive repetition tests)."""

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        self.p = float((config or {}).get("p", 0.5))
        self.heads = False

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None:
        import numpy as np

        self.heads = bool(np.random.default_rng(seed).random() < self.p)

    def step(self, obs: Observation) -> Command | Status:
        return Status("arrived") if self.heads else Status("error", "tails")

    def close(self) -> None:
        pass


def _sleeper(pidfile: str, spawn: str, sleep_s: float) -> None:
    """Start a process that sleeps ``sleep_s`` holding what it inherited (stdout, stderr, the
    worker's pipes), writing its pid on a line of ``pidfile``: ``fork`` a plain child, ``double`` a
    daemon (double fork + setsid: its parent gone at once), ``setsid`` a child in a session of its
    own, ``popen`` ``sleep`` through subprocess (an exec'd program)."""
    if spawn == "popen":
        import subprocess

        p = subprocess.Popen(["sleep", str(sleep_s)])
        with open(pidfile, "a") as f:
            f.write(f"{p.pid}\n")
        return
    before = len(_lines(pidfile))
    pid = os.fork()
    if pid == 0:  # the child: never returns into the navigator
        try:
            if spawn == "double" and os.fork() != 0:
                os._exit(0)
            if spawn in ("setsid", "double"):
                os.setsid()
            fd = os.open(pidfile, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            os.write(fd, f"{os.getpid()}\n".encode())
            os.close(fd)
            time.sleep(sleep_s)
        finally:
            os._exit(0)
    if spawn == "double":
        os.waitpid(pid, 0)
    # the pid is in the file before the navigator goes on
    deadline = time.monotonic() + 10.0
    while pidfile != os.devnull and time.monotonic() < deadline and len(_lines(pidfile)) <= before:
        time.sleep(0.005)


def _lines(pidfile: str) -> list[str]:
    try:
        with open(pidfile) as f:
            return f.read().split()
    except OSError:
        return []


class Escapes(_Base):
    """Starts processes and misbehaves, once ``after_s`` simulated seconds have passed (at build
    time with ``where: init``), and only when the file ``trigger`` exists if one is given (a
    campaign recorded without it, a replay with it):

    - ``spawn``: ``none``, ``fork``, ``double``, ``setsid`` or ``popen`` (:func:`_sleeper`; the
      sleepers' pids go to ``pidfile``, one a line);
    - ``then``: ``drive`` (on to the goal, as before), ``hang``, ``exit`` (``os._exit(code)``),
      ``sigkill`` (SIGKILL to itself) or ``raise``.
    """

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        cfg = dict(config or {})
        super().__init__(cfg)
        self.spawn = str(cfg.get("spawn", "none"))
        self.then = str(cfg.get("then", "drive"))
        self.code = int(cfg.get("code", 7))
        self.pidfile = str(cfg.get("pidfile", os.devnull))
        self.trigger = cfg.get("trigger")
        self.sleep_s = float(cfg.get("sleep_s", 120.0))
        self.done = False
        if cfg.get("where") == "init":
            self.misbehave()

    def armed(self) -> bool:
        return self.trigger is None or os.path.exists(str(self.trigger))

    def misbehave(self) -> Command | Status:
        if self.done or not self.armed():
            return Command(0.5, 0.0)
        self.done = True
        escape(self.spawn, self.then, code=self.code, pidfile=self.pidfile, sleep_s=self.sleep_s)
        return Command(0.5, 0.0)


def escape(spawn: str, then: str, code: int = 7, pidfile: str = os.devnull, sleep_s: float = 120.0) -> str:
    """What :class:`Escapes` does (``spawn`` then ``then``), callable on its own in a worker
    process; returns "drove on" when ``then`` is ``drive``."""
    if spawn != "none":
        _sleeper(pidfile, spawn, sleep_s)
    if then == "hang":
        while True:
            time.sleep(0.2)
    if then == "exit":
        os._exit(code)
    if then == "sigkill":
        os.kill(os.getpid(), 9)
    if then == "raise":
        raise RuntimeError("planner exploded")
    return "drove on"
