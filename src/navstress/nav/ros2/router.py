"""The Zenoh router navstress starts for a run (``router: auto``), and the check that a router
given by the user can be reached.

The router is eclipse-zenoh's own (the package navstress already depends on), opened in
``router`` mode in a process of its own: ``python -m navstress.nav.ros2.router ENDPOINT``. It
plays the part of rmw_zenoh's ``rmw_zenohd`` (which is the same Zenoh router with rmw_zenoh's
configuration): it listens on 127.0.0.1 only, with multicast scouting off, and gossip on so that
the peers it introduces (navstress and the stack) connect to each other directly. It runs in its
own session (process group), so that stopping it stops everything it started.

    router = start_router()      # a free port on 127.0.0.1
    ... router.endpoint ...      # 'tcp/127.0.0.1:PORT'
    router.stop()
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import subprocess
import sys
import time
import weakref
from collections.abc import Sequence
from typing import Any

from navstress.errors import NavigatorError
from navstress.nav.external import _kill_group

__all__ = ["Router", "endpoint_address", "free_port", "reachable", "start_router"]

READY = "navstress-zenoh-router ready"


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now (the kernel's choice)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def endpoint_address(endpoint: str) -> tuple[str, int]:
    """``tcp/HOST:PORT`` -> ``(HOST, PORT)`` (brackets of an IPv6 host removed)."""
    rest = endpoint.split("/", 1)[1]
    host, _, port = rest.rpartition(":")
    return host.strip("[]"), int(port)


def reachable(endpoint: str, timeout_s: float = 2.0) -> str | None:
    """Why the router at ``endpoint`` cannot be reached (a TCP connection to it fails), or None."""
    if not endpoint.startswith("tcp/"):
        return None  # udp, quic, tls: left to Zenoh, which says so in the run's first seconds
    host, port = endpoint_address(endpoint)
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return None
    except OSError as e:
        return f"no Zenoh router answers at {endpoint} ({e.strerror or e})"


class Router:
    """A router process navstress started; :meth:`stop` kills its process group (idempotent)."""

    def __init__(self, proc: subprocess.Popen[bytes], endpoint: str) -> None:
        self.proc = proc
        self.endpoint = endpoint
        self._finalizer = weakref.finalize(self, _kill, proc)

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self) -> None:
        self._finalizer()


def _kill(proc: subprocess.Popen[bytes]) -> None:
    _kill_group(proc)
    for stream in (proc.stdout, proc.stderr):
        with contextlib.suppress(Exception):
            if stream is not None:
                stream.close()


def start_router(*, timeout_s: float = 20.0, tries: int = 3) -> Router:
    """A router on ``tcp/127.0.0.1:<free port>``, ready to accept connections; NavigatorError
    when none could be started (with the router's last words)."""
    last = ""
    for _ in range(tries):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        proc = subprocess.Popen([sys.executable, "-m", "navstress.nav.ros2.router", endpoint],
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True)
        router = Router(proc, endpoint)
        assert proc.stdout is not None
        deadline = time.monotonic() + timeout_s
        buf = b""
        while time.monotonic() < deadline and proc.poll() is None:
            r, _, _ = select.select([proc.stdout], [], [], 0.05)
            if r:
                chunk = os.read(proc.stdout.fileno(), 4096)
                buf += chunk
                if READY.encode() in buf:
                    return router
        err = b""
        if proc.poll() is not None and proc.stderr is not None:
            with contextlib.suppress(Exception):
                err = proc.stderr.read()[-2000:]
        router.stop()
        last = err.decode("utf-8", "replace").strip().splitlines()[-1:] and \
            err.decode("utf-8", "replace").strip().splitlines()[-1] or "no answer"
    raise NavigatorError(f"cannot start a Zenoh router on 127.0.0.1 ({last}); "
                         "give one with the navigator config's 'router'")


def _config(endpoint: str) -> Any:
    """rmw_zenoh's router configuration (its ``config/DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5``, the
    "ROS setting" entries) listening on ``endpoint`` only: no multicast scouting, gossip to routers
    and peers, no failover brokering (every peer connects to every other directly), timestamps,
    60 s query timeout."""
    import zenoh  # the router process only

    conf = zenoh.Config()
    for key, value in (
            ("mode", '"router"'),
            ("listen/endpoints", f'["{endpoint}"]'),
            ("connect/endpoints", "[]"),
            ("scouting/multicast/enabled", "false"),
            ("scouting/gossip/enabled", "true"),
            ("scouting/gossip/multihop", "false"),
            ("scouting/gossip/target", '{router: ["router", "peer"], peer: ["router"]}'),
            ("scouting/gossip/autoconnect", '{router: [], peer: ["router", "peer"]}'),
            ("scouting/gossip/autoconnect_strategy", '{router: {to_router: "always", to_peer: "always"}}'),
            ("timestamping/enabled", "{router: true, peer: true, client: true}"),
            ("queries_default_timeout", "60000"),
            ("routing/router/peers_failover_brokering", "false")):
        conf.insert_json5(key, value)
    return conf


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m navstress.nav.ros2.router ENDPOINT``: a router until killed (or its parent,
    or stops by itself when the process that started it is gone)."""
    import zenoh  # the router process only

    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1 or not args[0].startswith("tcp/127.0.0.1:"):
        print("usage: python -m navstress.nav.ros2.router tcp/127.0.0.1:PORT", file=sys.stderr)
        return 2
    session = zenoh.open(_config(args[0]))
    print(f"{READY} {session.info.zid()} {args[0]}", flush=True)
    parent = os.getppid()
    try:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:  # whoever started it is gone: stop with it
                return 0
    finally:
        with contextlib.suppress(Exception):
            session.close()  # type: ignore[no-untyped-call]


if __name__ == "__main__":
    raise SystemExit(main())
