"""The optional native lidar walk: ``_march_avx512.c``, built on first use.

The lidar's terrain cell walk (``_raycast.terrain_kernel``) can hand each channel's marches to a
small C function that walks eight rays at a time with AVX-512 (``nv_march_channel``). It gives
bit-identical ranges to the numba walk (same IEEE operations, no fused multiply-adds), so runs
are the same with or without it; it only makes rough-terrain scans faster (docs/performance.md).

On first use the C file is compiled with the system's C compiler (``$CC``, else ``cc``) into a
cache directory (``$NAVSTRESS_CACHE_DIR``, else ``$XDG_CACHE_HOME/navstress``, else
``~/.cache/navstress``), named by a hash of the source and the compiler, written atomically
(parallel workers may build at once). The library is used when the CPU has AVX-512F/DQ/VL;
otherwise, without a compiler, on another architecture, or with ``NAVSTRESS_NATIVE=0``, the
numba walk runs and :data:`STATUS` says why. Either way the symbol is registered with LLVM (a
stub that is never called when the walk is off), so the compiled kernels link and cache alike.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path

from llvmlite import binding as llvm

from navstress import cache_dir

SYMBOL = "nv_march_channel"
SOURCE = Path(__file__).with_name("_march_avx512.c")
FLAGS = ("-O3", "-ffp-contract=off", "-fno-math-errno", "-fPIC", "-shared")

_STUB_TYPE = ctypes.CFUNCTYPE(None, *([ctypes.c_void_p] * 12))
_stub = _STUB_TYPE(lambda *a: None)  # kept alive: LLVM holds its address


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
    fd, tmp = tempfile.mkstemp(prefix=lib.name + ".", suffix=".tmp", dir=d)
    os.close(fd)
    try:
        r = subprocess.run([*cmd, *FLAGS, "-o", tmp, str(SOURCE)], capture_output=True, text=True, timeout=120)
        if r.returncode != 0:
            raise OSError(f"{cc} failed to build {SOURCE.name}: {(r.stderr or r.stdout).strip()[-500:]}")
        os.replace(tmp, lib)  # atomic: a concurrent build of the same key writes the same bytes
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return lib


def _load() -> tuple[bool, str]:
    if os.environ.get("NAVSTRESS_NATIVE", "1").strip().lower() in ("0", "false", "no", "off"):
        return False, "off (NAVSTRESS_NATIVE=0)"
    try:
        path = build()
        lib = ctypes.CDLL(str(path))
        if not lib.nv_march_ok():
            return False, "off (this CPU lacks AVX-512F/DQ/VL)"
        llvm.load_library_permanently(str(path))
        return True, f"on ({path})"
    except (OSError, RuntimeError, subprocess.SubprocessError) as err:
        return False, f"off ({err})"


AVAILABLE, STATUS = _load()
if not AVAILABLE:
    llvm.add_symbol(SYMBOL, ctypes.cast(_stub, ctypes.c_void_p).value)
