"""The native (AVX-512) terrain walk: bit-identical to the numba walk, built on first use (never
at import), called with the kernels' queue, and a clear fallback when it cannot be built or used.
Where it cannot run here its tests skip, or fail with NAVSTRESS_REQUIRE_NATIVE=1 (native_gate)."""

from __future__ import annotations

import ctypes
import math
import os
import re
import shlex
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.native_gate import REQUIRE, require_compiler, require_native
from navstress.errors import SpecError
from navstress.sim import SimConfig, Simulation, _raycast, native
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import Terrain


def rot_zyx(yaw: float, pitch: float, roll: float) -> np.ndarray:
    cy, sy, cp, sp, cr, sr = (math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch), math.cos(roll),
                              math.sin(roll))
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def assert_same_bits(sc: LidarScene, cfg: LidarConfig, origin: np.ndarray, rot: np.ndarray) -> None:
    ref = Lidar(sc, cfg, simd=False).ranges(origin, rot)
    fast = Lidar(sc, cfg, simd=True).ranges(origin, rot)
    diff = bits(ref) != bits(fast)
    assert not diff.any(), (np.argwhere(diff)[:5], ref[diff][:5], fast[diff][:5])


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.05, 0.3, 0.8]), st.sampled_from([0.0, 0.2, 1.0, 3.0]))
def test_native_walk_is_bit_identical_on_random_scenes(seed: int, tilt: float, relief: float) -> None:
    """Random relief (flat maps, flat tops, steep grids), boxes and tilts: the same ranges to the bit."""
    require_native()
    g = np.random.default_rng(seed)
    rows, cols = int(g.integers(10, 40)), int(g.integers(10, 40))
    cell = float(g.uniform(0.3, 1.0))
    h = relief * g.uniform(-1, 1, (rows, cols)).cumsum(0).cumsum(1) / max(rows, cols)
    if g.uniform() < 0.3:  # a flat top at the highest height
        i, j = int(g.integers(0, rows - 3)), int(g.integers(0, cols - 3))
        h[i:i + 3, j:j + 3] = h.max() + float(g.uniform(0.0, 1.0))
    t = Terrain(h.astype(np.float32), cell)
    W, H = (cols - 1) * cell, (rows - 1) * cell
    boxes = [[g.uniform(0, W), g.uniform(0, H), g.uniform(-3, 3), g.uniform(0.2, 2), g.uniform(0.2, 2), z - 0.1,
              z + g.uniform(0.5, 4)] for z in (t.height_at(g.uniform(0, W), g.uniform(0, H))
                                               for _ in range(int(g.integers(0, 10))))]
    sc = LidarScene(t.heights, cell, np.array(boxes).reshape(-1, 7))
    x, y = g.uniform(0.1 * W, 0.9 * W), g.uniform(0.1 * H, 0.9 * H)
    origin = np.array([x, y, t.height_at(x, y) + g.uniform(0.1, 2.5)])
    rot = rot_zyx(g.uniform(-np.pi, np.pi), tilt * g.uniform(-1, 1), tilt * g.uniform(-1, 1))
    assert_same_bits(sc, LidarConfig(azimuth_steps=int(g.integers(8, 120)), max_range_m=float(g.uniform(5, 60))),
                     origin, rot)


def test_native_walk_is_bit_identical_at_default_fidelity() -> None:
    """The benchmark setting: 100 m, 0.4 m cells, s=4 d=2 ground with trees, 32 x 360 and 32 x 1024."""
    require_native()
    w = generate(WorldSpec.model_validate({"ground": {"subdivisions": 4, "deformation": 2.0},
                                           "obstacles": {"obstruction": {"tree": 6}}}), seed=1)
    sc = build_scene(w)
    g = np.random.default_rng(7)
    for _ in range(6):
        x, y = g.uniform(5, 95, 2)
        origin = np.array([x, y, w.terrain.height_at(x, y) + 0.9])
        rot = rot_zyx(g.uniform(-3, 3), g.uniform(-0.3, 0.3), g.uniform(-0.3, 0.3))
        for az in (360, 1024):
            assert_same_bits(sc, LidarConfig(azimuth_steps=az), origin, rot)


def test_simulation_runs_are_the_same_with_and_without_the_native_walk() -> None:
    """Same seed, lidar on, rough ground: every scan's points are bit-identical either way."""
    require_native()
    w = generate(WorldSpec.model_validate({"size_m": [40.0, 40.0], "ground": {"subdivisions": 4, "deformation": 2.0}}),
                 seed=3)
    runs = []
    for simd in (False, True):
        sim = Simulation(w, config=SimConfig(), seed=5, start=(10.0, 10.0, 0.7))
        assert sim._lidar is not None
        sim._lidar.simd = simd
        scans = []
        for _ in range(20):
            sim.advance(0.1)
            scans += [s.points.copy() for s in sim.observe().scans]
        runs.append(scans)
    assert len(runs[0]) == len(runs[1]) >= 20
    for a, b in zip(*runs):
        assert a.shape == b.shape and np.array_equal(a.view(np.int32), b.view(np.int32))


def test_lidar_refuses_simd_when_the_native_walk_is_off(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(native, "load", lambda: native.Native(0, "off (switched off for this test)"))
    with pytest.raises(SpecError, match=r"^simd=True .*native walk is"):
        Lidar(LidarScene(np.zeros((5, 5), np.float32), 1.0, np.zeros((0, 7))), simd=True)


def test_build_is_cached(tmp_path: Path) -> None:
    require_compiler()
    a = native.build(out_dir=tmp_path)
    assert a.exists() and a.parent == tmp_path
    mtime = a.stat().st_mtime_ns
    assert native.build(out_dir=tmp_path) == a and a.stat().st_mtime_ns == mtime  # not rebuilt
    assert [p.name for p in tmp_path.iterdir()] == [a.name]  # no temporary files left


def test_build_errors_name_the_compiler(tmp_path: Path) -> None:
    with pytest.raises(OSError, match="no C compiler: 'no-such-cc' not found"):
        native.build(cc="no-such-cc", out_dir=tmp_path)
    with pytest.raises(OSError, match=r"^false failed to build _march_avx512\.c"):
        native.build(cc="false", out_dir=tmp_path)
    assert list(tmp_path.iterdir()) == []  # no partial library left behind


def _fresh_python(code: str, **env: str) -> str:
    e = {**os.environ, **env}
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=e,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout


@pytest.mark.parametrize("env, why", [({"NAVSTRESS_NATIVE": "0"}, "off (NAVSTRESS_NATIVE=0)"),
                                      ({"CC": "no-such-cc"}, "off (no C compiler: 'no-such-cc' not found")])
def test_without_the_native_walk_scans_still_work(tmp_path: Path, env: dict[str, str], why: str) -> None:
    """A fresh process that cannot (or may not) use the native walk says why and scans with numba."""
    out = _fresh_python("""
        import numpy as np
        from navstress.sim import native
        from navstress.sim.lidar import Lidar, LidarScene
        print(native.available())
        print(native.status())
        sc = LidarScene(np.zeros((30, 30), np.float32), 0.5, np.zeros((0, 7)))
        lid = Lidar(sc)
        print(lid.simd, int(np.isfinite(lid.ranges(np.array([7.0, 7.0, 1.0]), np.eye(3))).sum()))
    """, NAVSTRESS_CACHE_DIR=str(tmp_path), NUMBA_CACHE_DIR=str(numba.config.CACHE_DIR), **env)  # warm numba cache
    available, status, last = out.strip().splitlines()
    assert available == "False" and status.startswith(why)
    simd, hits = last.split()
    assert simd == "False" and int(hits) > 1000


def test_numba_cache_lives_in_a_directory_per_source_tree(tmp_path: Path) -> None:
    """navstress points numba's cache at <cache>/numba/<hash of its sources> (a cached caller can
    then never run an older callee from another file); a NUMBA_CACHE_DIR set by the user wins."""
    code = """
        import numba, navstress
        from navstress.sim import _noise
        _noise.standard_normals(__import__('numpy').random.default_rng(0), 4)
        print(numba.config.CACHE_DIR)
    """
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=600,
                       env={**env, "NAVSTRESS_CACHE_DIR": str(tmp_path)})
    assert r.returncode == 0, r.stderr[-2000:]
    used = Path(r.stdout.strip().splitlines()[-1])
    assert used.parent == tmp_path / "numba" and len(used.name) == 16
    assert any(used.rglob("*.nbi")), "numba wrote its cache index there"
    mine = tmp_path / "mine"
    out = _fresh_python("import numba, navstress; print(numba.config.CACHE_DIR)", NUMBA_CACHE_DIR=str(mine))
    assert out.strip() == str(mine)


# ---------------------------------------------------------------------------------------------
# built at first use, not at import; called by address with the kernels' queue
# ---------------------------------------------------------------------------------------------


def test_importing_the_simulator_runs_no_compiler_the_first_lidar_does(tmp_path: Path) -> None:
    """A fresh process imports navstress.sim (config, lidar, kernels) without compiling anything;
    the first Lidar builds the native walk (here with a stand-in compiler that logs its call)."""
    log = tmp_path / "cc.log"
    cc = tmp_path / "cc"
    cc.write_text(f"#!/bin/sh\necho \"$@\" >> {log}\nexit 1\n")
    cc.chmod(0o755)
    out = _fresh_python(f"""
        import sys
        from pathlib import Path
        import numpy as np
        import navstress.sim, navstress.sim.config, navstress.sim.lidar, navstress.sim.native
        print(Path({str(log)!r}).exists())
        from navstress.sim.lidar import Lidar, LidarScene
        lid = Lidar(LidarScene(np.zeros((5, 5), np.float32), 1.0, np.zeros((0, 7))))
        print(Path({str(log)!r}).exists(), lid.simd)
        print(navstress.sim.native.status())
    """, CC=str(cc), NAVSTRESS_CACHE_DIR=str(tmp_path / "cache"), NUMBA_CACHE_DIR=str(numba.config.CACHE_DIR))
    at_import, at_first_lidar, status = out.strip().splitlines()
    assert at_import == "False"
    assert at_first_lidar == "True False" and status.startswith(f"off ({cc} failed to build _march_avx512.c")


PROBE_C = r"""
#include <math.h>
#include <stdint.h>
double seen_d[3];
int64_t seen_i[4];
float seen_h;
/* nv_march_channel's signature: records its scalars, checks each queued ray's rows against each
   other, and answers R[q] = -(q + 1.5) (NaN for a row that is not a walk's) */
void probe(const float *h, int64_t W, int64_t ncx, int64_t ncy, double oz, double oxc, double oyc,
           int64_t nq, const double *Q, const int64_t *I, int64_t qs, double *R) {
    seen_d[0] = oz; seen_d[1] = oxc; seen_d[2] = oyc;
    seen_i[0] = W; seen_i[1] = ncx; seen_i[2] = ncy; seen_i[3] = qs;
    seen_h = h[W + 1];
    for (int64_t q = 0; q < nq; q++) {
        double dx = Q[5 * qs + q], dy = Q[6 * qs + q];
        int64_t cx = I[q], cy = I[qs + q], sx = I[2 * qs + q], sy = I[3 * qs + q];
        int ok = sx == (dx > 0.0 ? 1 : -1) && sy == (dy > 0.0 ? 1 : -1) && cx >= 0 && cx < ncx && cy >= 0 &&
                 cy < ncy && Q[3 * qs + q] == (dx != 0.0 ? fabs(1.0 / dx) : 0.0) &&
                 Q[4 * qs + q] == (dy != 0.0 ? fabs(1.0 / dy) : 0.0);
        R[q] = ok ? -((double)q + 1.5) : NAN;
    }
}
"""


def test_the_kernel_hands_its_queue_to_the_native_walk_by_address(tmp_path: Path) -> None:
    """Any CPU: a probe with the native walk's signature, called by address, receives the scene's
    scalars and a consistent queue; its answers land on the queued rays, in queue order, and
    every other ray keeps the numba walk's range."""
    require_compiler()
    cc = shlex.split(os.environ.get("CC") or "cc")
    lib_path = tmp_path / "probe.so"
    (tmp_path / "probe.c").write_text(PROBE_C)
    subprocess.run([*cc, "-O1", "-fPIC", "-shared", "-o", str(lib_path), str(tmp_path / "probe.c")], check=True)
    lib = ctypes.CDLL(str(lib_path))
    address = ctypes.cast(lib.probe, ctypes.c_void_p).value
    assert address
    w = generate(WorldSpec.model_validate({"size_m": [40.0, 40.0], "ground": {"subdivisions": 4, "deformation": 2.0}}),
                 seed=3)
    sc = build_scene(w)
    cfg = LidarConfig(azimuth_steps=90)
    lid = Lidar(sc, cfg, simd=False)
    origin, rot = np.array([20.0, 20.0, w.terrain.height_at(20.0, 20.0) + 0.9]), rot_zyx(0.3, 0.05, -0.04)
    ref, out = np.empty((2, cfg.channels, cfg.azimuth_steps))
    for walk, dest in ((0, ref), (address, out)):
        params = _raycast.new_scan_params(max_range=cfg.max_range_m, min_range=cfg.min_range_m, plane_march=1,
                                          walk=walk)
        _raycast.terrain_kernel(sc.grid, lid._beams, params, origin, rot, dest)
    assert not np.isnan(out).any(), "a queued row was inconsistent"
    queued = out < 0
    assert queued.sum() > cfg.azimuth_steps  # the walks of many channels went to the probe
    for k in range(cfg.channels):
        n = int(queued[k].sum())
        assert np.array_equal(out[k][queued[k]], -(np.arange(n) + 1.5))
    # the rays the kernel settled without a walk: the same ranges as with the numba walk
    assert (~queued).any() and np.array_equal(bits(out[~queued]), bits(ref[~queued]))
    assert (ctypes.c_double * 3).in_dll(lib, "seen_d")[:] == [origin[2], origin[0] * (1.0 / sc.cell_m),
                                                             origin[1] * (1.0 / sc.cell_m)]
    ncy, ncx = sc.heights.shape[0] - 1, sc.heights.shape[1] - 1
    assert (ctypes.c_int64 * 4).in_dll(lib, "seen_i")[:] == [ncx + 1, ncx, ncy, cfg.azimuth_steps + 9]
    assert ctypes.c_float.in_dll(lib, "seen_h").value == sc.heights[1, 1]


# ---------------------------------------------------------------------------------------------
# NAVSTRESS_REQUIRE_NATIVE: a native walk that cannot run fails its tests instead of skipping
# ---------------------------------------------------------------------------------------------

GATED_TEST = """
from tests.support.native_gate import require_native


def test_gated():
    require_native()
"""


@pytest.mark.slow
@pytest.mark.parametrize("off", [{"NAVSTRESS_NATIVE": "0"}, {"NAVSTRESS_NATIVE": "1", "CC": "no-such-cc"}])
@pytest.mark.parametrize("require", ["1", None])
def test_require_native_turns_the_skip_into_a_failure(tmp_path: Path, off: dict[str, str], require: str | None) -> None:
    """A pytest run of a gated test in a process whose native walk is off: skipped, or failed
    (naming why) with NAVSTRESS_REQUIRE_NATIVE=1."""
    (tmp_path / "test_gated.py").write_text(GATED_TEST)
    env = {k: v for k, v in os.environ.items() if k != REQUIRE}
    env.update(off, NAVSTRESS_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(Path(__file__).resolve().parents[3]), env.get("PYTHONPATH", "")]))
    if require is not None:
        env[REQUIRE] = require
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rfs", "-p", "no:cacheprovider", "-p", "no:xdist",
                        "test_gated.py"], cwd=tmp_path, capture_output=True, text=True, env=env, timeout=600)
    if require == "1":
        assert r.returncode == 1 and "1 failed" in r.stdout, r.stdout[-2000:]
        assert f"{REQUIRE}=1 but native walk off (" in r.stdout
    else:
        assert r.returncode == 0 and "1 skipped" in r.stdout, r.stdout[-2000:]


REPO = Path(__file__).resolve().parents[3]


def test_ci_requires_the_native_walk_exactly_where_it_can_run(tmp_path: Path) -> None:
    """.ci/native-required (which makes .ci/run set NAVSTRESS_REQUIRE_NATIVE=1): every CPU flag
    the C walk needs, a C compiler and the walk not switched off; any one missing: not required."""
    script = REPO / ".ci" / "native-required"
    assert "if .ci/native-required; then\n    export NAVSTRESS_REQUIRE_NATIVE=1" in (REPO / ".ci" / "run").read_text()

    def required(flags: list[str], **env: str) -> bool:
        info = tmp_path / "cpuinfo"
        info.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx2 " + " ".join(flags) + " avx512cd\n")
        e = {k: v for k, v in os.environ.items() if k not in ("CC", "NAVSTRESS_NATIVE")}
        r = subprocess.run([str(script), str(info)], capture_output=True, text=True, env={**e, **env}, timeout=60)
        assert r.returncode in (0, 1) and r.stdout.startswith("native walk "), r.stdout + r.stderr
        return r.returncode == 0

    flags = list(native.CPU_FLAGS)
    assert required(flags, CC=sys.executable)
    assert required(flags, CC=f"{sys.executable} -O2", NAVSTRESS_NATIVE="1")
    for missing in flags:
        assert not required([f for f in flags if f != missing] + [missing + "x"], CC=sys.executable)
    assert not required(flags, CC="no-such-cc")
    for off in ("0", "off", "No"):
        assert not required(flags, CC=sys.executable, NAVSTRESS_NATIVE=off)


def test_the_cpu_flags_agree_in_the_c_walk_native_and_ci() -> None:
    """The flags the C walk checks and compiles for, native.CPU_FLAGS and .ci/native-required."""
    c = native.SOURCE.read_text()
    checked = re.findall(r'__builtin_cpu_supports\("(\w+)"\)', c)
    (target,) = re.findall(r'__attribute__\(\(target\("([\w,]+)"\)\)\)', c)
    (ci,) = re.findall(r"for f in ([\w ]+); do", (REPO / ".ci" / "native-required").read_text())
    assert checked == target.split(",") == ci.split() == list(native.CPU_FLAGS)
