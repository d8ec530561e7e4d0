"""Run a command in a network namespace of its own that has only the loopback interface.

Ray (2.60, Linux) listens on every interface of the machine whatever address it is given; a
cluster that a test starts inside such a namespace can only be reached on 127.0.0.1, and
nothing it does can reach outside the machine. Used by every test that starts a Ray cluster.
"""

from __future__ import annotations

import functools
import subprocess

# "ip" may be missing: then bring loopback up through Python (SIOCSIFFLAGS is what ip does)
_LO_UP = ("ip link set lo up 2>/dev/null || python3 -c 'import fcntl, socket, struct; "
          "s = socket.socket(); fcntl.ioctl(s, 0x8914, struct.pack(\"16sH\", b\"lo\", 0x1 | 0x40))'")


def loopback_only(argv: list[str]) -> list[str]:
    """``argv`` wrapped to run in a new user + network namespace with loopback up."""
    return ["unshare", "-rn", "sh", "-c", f'{_LO_UP} && exec "$0" "$@"', *argv]


@functools.cache
def available() -> bool:
    """Whether this machine lets us make such a namespace (root or unprivileged user namespaces)."""
    try:
        r = subprocess.run(loopback_only(["python3", "-c", "import socket; s = socket.socket(); "
                                          "s.bind(('127.0.0.1', 0)); s.listen()"]),
                           capture_output=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return False
    return r.returncode == 0


def listening_addresses() -> list[str]:
    """Local addresses of every listening TCP socket (``ss -ltnH``) in this namespace."""
    out = subprocess.run(["ss", "-ltnH"], capture_output=True, text=True, check=True).stdout
    return [line.split()[3] for line in out.splitlines() if line.strip()]


def is_loopback(address: str) -> bool:
    """``127.x.x.x:port``, ``[::1]:port`` or ``[::ffff:127.x.x.x]:port``."""
    host = address.rsplit(":", 1)[0].strip("[]")
    return host.startswith("127.") or host == "::1" or host.startswith("::ffff:127.")
