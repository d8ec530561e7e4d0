"""The native (AVX-512) terrain walk: bit-identical to the numba walk, built on first use, and a
clear fallback when it cannot be built or used."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.sim import SimConfig, Simulation, native
from navstress.sim.lidar import Lidar, LidarConfig, LidarScene, build_scene
from navstress.world.generate import generate
from navstress.world.spec import WorldSpec
from navstress.world.world import Terrain

needs_native = pytest.mark.skipif(not native.AVAILABLE, reason=f"native walk {native.STATUS}")


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


@needs_native
@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.05, 0.3, 0.8]), st.sampled_from([0.0, 0.2, 1.0, 3.0]))
def test_native_walk_is_bit_identical_on_random_scenes(seed: int, tilt: float, relief: float) -> None:
    """Random relief (flat maps, flat tops, steep grids), boxes and tilts: the same ranges to the bit."""
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


@needs_native
def test_native_walk_is_bit_identical_at_default_fidelity() -> None:
    """The benchmark setting: 100 m, 0.4 m cells, s=4 d=2 ground with trees, 32 x 360 and 32 x 1024."""
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


@needs_native
def test_simulation_runs_are_the_same_with_and_without_the_native_walk() -> None:
    """Same seed, lidar on, rough ground: every scan's points are bit-identical either way."""
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
    from navstress.sim import _raycast

    monkeypatch.setattr(_raycast, "NATIVE", False)
    with pytest.raises(SpecError, match=r"^simd=True .*native walk is"):
        Lidar(LidarScene(np.zeros((5, 5), np.float32), 1.0, np.zeros((0, 7))), simd=True)


def test_build_is_cached(tmp_path: Path) -> None:
    if native.AVAILABLE or native.STATUS.startswith("off (this CPU"):
        a = native.build(out_dir=tmp_path)
        assert a.exists() and a.parent == tmp_path
        mtime = a.stat().st_mtime_ns
        assert native.build(out_dir=tmp_path) == a and a.stat().st_mtime_ns == mtime  # not rebuilt
        assert [p.name for p in tmp_path.iterdir()] == [a.name]  # no temporary files left
    else:
        pytest.skip(f"no working C compiler here: {native.STATUS}")


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
        print(native.AVAILABLE)
        print(native.STATUS)
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
