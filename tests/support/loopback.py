"""Run a command in a network namespace of its own that has only the loopback interface, and
list the sockets a process tree listens on.

Ray (2.60, Linux) listens on every interface of the machine unless it is told otherwise (the
cluster navstress starts is: see ``navstress.campaign.ray_executor``); a cluster that a test
starts inside such a namespace can only be reached on 127.0.0.1 whatever it binds, and nothing
it does can reach outside the machine. :func:`sockets_of_tree` checks, outside any namespace,
what a cluster's processes bind.
"""

from __future__ import annotations

import functools
import ipaddress
import os
import socket
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


def descendants(root: int) -> set[int]:
    """``root`` and every process below it, now."""
    return _descendants(root)


def _descendants(root: int) -> set[int]:
    parent: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", encoding="utf-8", errors="replace") as f:
                    parent[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    out, todo = {root}, [root]
    while todo:
        p = todo.pop()
        for child, pp in parent.items():
            if pp == p and child not in out:
                out.add(child)
                todo.append(child)
    return out


def _decode(hex_address: str) -> str:
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    if len(raw) == 4:
        ip = str(ipaddress.IPv4Address(raw[::-1]))
        return f"{ip}:{int(port, 16)}"
    ip6 = ipaddress.IPv6Address(b"".join(raw[i:i + 4][::-1] for i in range(0, 16, 4)))
    mapped = ip6.ipv4_mapped
    return f"[{f'::ffff:{mapped}' if mapped is not None else ip6}]:{int(port, 16)}"


def sockets_of_tree(root: int) -> list[tuple[str, str, str]]:
    """(process name, protocol, local address) of every listening TCP socket and every bound UDP
    socket held by ``root`` or its descendants (read from /proc: no tool needed)."""
    bound: dict[int, tuple[str, str]] = {}
    for table in ("tcp", "tcp6", "udp", "udp6"):
        try:
            with open(f"/proc/net/{table}", encoding="ascii") as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            if table.startswith("tcp") and cols[3] != "0A":  # TCP_LISTEN
                continue
            bound[int(cols[9])] = (table, _decode(cols[1]))
    out = []
    for pid in sorted(_descendants(root)):
        try:
            with open(f"/proc/{pid}/comm", encoding="utf-8", errors="replace") as f:
                name = f.read().strip()
            fds = os.listdir(f"/proc/{pid}/fd")
        except OSError:
            continue
        for fd in fds:
            try:
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            if target.startswith("socket:[") and int(target[8:-1]) in bound:
                out.append((name, *bound[int(target[8:-1])]))
    return out


def free_port() -> int:
    """A TCP port free on 127.0.0.1 just now (for a server a test starts)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
