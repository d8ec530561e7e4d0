"""The optional native lidar walk: ``_march_avx512.c``, built at first use, never at import.

The lidar's terrain cell walk (``_raycast.walk_cells``) has a native twin, a small C function
that walks eight rays at a time with AVX-512 (``nv_march_channel``). It gives bit-identical
ranges to the numba walk (same IEEE operations, no fused multiply-adds), so runs are the same
with or without it; it only makes rough-terrain scans faster (docs/performance.md).

:func:`load` (called by the first :class:`~navstress.sim.lidar.Lidar` of a process) compiles the
C file with the system's C compiler (``$CC``, else ``cc``) into a cache directory
(``$NAVSTRESS_CACHE_DIR``, else ``$XDG_CACHE_HOME/navstress``, else ``~/.cache/navstress``),
named by a hash of the source and the compiler, written atomically (parallel workers may build
at once), and returns the function's address, which the kernels take as an argument. The walk
is used when the CPU has AVX-512F/DQ/VL; otherwise, without a compiler, on another architecture,
or with ``NAVSTRESS_NATIVE=0``, the numba walk runs and the status says why.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import shlex
import shutil
import subprocess
from pathlib import Path
from typing import NamedTuple

from navstress import _files, cache_dir

SOURCE = Path(__file__).with_name("_march_avx512.c")
FLAGS = ("-O3", "-ffp-contract=off", "-fno-math-errno", "-fPIC", "-shared")
CPU_FLAGS = ("avx512f", "avx512dq", "avx512vl")  # what the C walk needs (its nv_march_ok checks the same)


class Native(NamedTuple):
    """The native walk in this process: ``address`` of ``nv_march_channel`` (0: off) and why."""

    address: int
    status: str


def build(cc: str | None = None, out_dir: Path | None = None) -> Path:
    """Compile the C walk (if not built yet) and return the library's path.

    Raises OSError with the compiler's message when it cannot be built."""
    cc = cc or os.environ.get("CC") or "cc"
    cmd = shlex.split(cc)
    if not cmd or shutil.which(cmd[0]) is None:
        raise OSError(f"no C compiler: {cc!r} not found (set CC, or NAVSTRESS_NATIVE=0)")
    src = SOURCE.read_bytes()
    key = hashlib.sha256(src + " ".join(cmd + list(FLAGS)).encode()).hexdigest()[:16]
    d = out_dir or cache_dir()
    lib = d / f"libnavstress_march_{key}.so"
    if lib.exists():
        return lib
    d.mkdir(parents=True, exist_ok=True)
    # renamed onto lib when built (atomic: a concurrent build of the same key writes the same bytes)
    with _files.replaced_on_success(lib) as tmp:
        r = subprocess.run([*cmd, *FLAGS, "-o", str(tmp), str(SOURCE)], capture_output=True, text=True, timeout=120)
        if r.returncode != 0:
            raise OSError(f"{cc} failed to build {SOURCE.name}: {(r.stderr or r.stdout).strip()[-500:]}")
    return lib


_LIBS: list[ctypes.CDLL] = []  # loaded libraries stay referenced (their code is called by address)


@functools.cache
def load() -> Native:
    """The native walk of this process: built and loaded on the first call, then remembered."""
    if os.environ.get("NAVSTRESS_NATIVE", "1").strip().lower() in ("0", "false", "no", "off"):
        return Native(0, "off (NAVSTRESS_NATIVE=0)")
    try:
        path = build()
        lib = ctypes.CDLL(str(path))
        if not lib.nv_march_ok():
            return Native(0, "off (this CPU lacks AVX-512F/DQ/VL)")
        _LIBS.append(lib)
        address = ctypes.cast(lib.nv_march_channel, ctypes.c_void_p).value
        if not address:
            return Native(0, f"off ({path} has no nv_march_channel)")
        return Native(int(address), f"on ({path})")
    except (OSError, RuntimeError, subprocess.SubprocessError) as err:
        return Native(0, f"off ({err})")


def available() -> bool:
    """Whether the native walk runs in this process (builds it on the first call)."""
    return load().address != 0


def status() -> str:
    """``on (library path)`` or ``off (why)`` (builds it on the first call)."""
    return load().status
