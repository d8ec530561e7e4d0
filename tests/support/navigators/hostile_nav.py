"""A navigator that attacks its host on purpose, in one of its methods.

In process: ``Hostile(config={"mode": MODE, "where": WHERE})`` (register it as
``"tests.support.navigators.hostile_nav:Hostile"``). Out of process: ``python hostile_nav.py
MODE WHERE`` serves the same navigator over the line protocol
(:func:`navstress.nav.external.serve`), so the attack hits the navigator's own process.

WHERE: ``init``, ``reset``, ``step`` (or ``close``). MODE:
  exit0 / exit3      sys.exit(0) / sys.exit(3)
  os_exit0           os._exit(0) (no clean-up at all)
  segv               SIGSEGV sent to itself (as a crashing native library would)
  sigkill            SIGKILL sent to itself (as the OOM killer would)
  loop               an infinite loop (never answers)
  keyboardinterrupt, systemexit, generatorexit   raise that BaseException subclass
  garbage            step returns a string (step only)
  raise              an ordinary exception (ZeroDivisionError)
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Any

from navstress.nav.api import Command

MODES = ("exit0", "exit3", "os_exit0", "segv", "sigkill", "loop", "keyboardinterrupt", "systemexit",
         "generatorexit")


def attack(mode: str) -> Any:
    if mode == "exit0":
        sys.exit(0)
    if mode == "exit3":
        sys.exit(3)
    if mode == "os_exit0":
        os._exit(0)
    if mode == "segv":
        os.kill(os.getpid(), signal.SIGSEGV)
    if mode == "sigkill":
        os.kill(os.getpid(), signal.SIGKILL)
    if mode == "loop":
        while True:
            pass
    if mode == "keyboardinterrupt":
        raise KeyboardInterrupt
    if mode == "systemexit":
        raise SystemExit("planner gave up")
    if mode == "generatorexit":
        raise GeneratorExit
    if mode == "garbage":
        return "full speed ahead"
    if mode == "raise":
        raise ZeroDivisionError("planner bug")
    raise ValueError(f"unknown mode {mode!r}")


class Hostile:
    def __init__(self, config: dict[str, Any] | None = None) -> None:
        cfg = dict(config or {})
        self.mode, self.where = str(cfg["mode"]), str(cfg["where"])
        if self.where == "init":
            attack(self.mode)

    def reset(self, mission: Any, robot: Any, *, seed: int) -> None:
        if self.where == "reset":
            attack(self.mode)

    def step(self, obs: Any) -> Any:
        if self.where == "step":
            return attack(self.mode)
        return Command(0.3, 0.0)

    def close(self) -> None:
        if self.where == "close":
            attack(self.mode)


if __name__ == "__main__":
    from navstress.nav.external import serve

    nav = Hostile({"mode": sys.argv[1], "where": sys.argv[2]})
    raise SystemExit(serve(nav, sys.stdin.buffer, sys.stdout.buffer, name="hostile"))
