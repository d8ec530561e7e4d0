"""The SDF export read by Gazebo's own libraries: libsdformat 12 (the SDF parser of Gazebo
Fortress) and ign-common 4's ImageHeightmap (Fortress's heightmap loader), through the small
loader program ``tests/oracles/sdf_load.cc``, compiled once per session (Debian's
``libsdformat-dev`` and ``libignition-common-graphics-dev``, which ``make test`` installs).

The test is skipped where they are missing, and fails instead under CI (``CI=true``)."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.support.built_once import built_once
from tests.support.required import need as _need
from tests.support.world_fixtures import small_world
from navstress.world import World
from navstress.world.export._grid import MARKER, surface_heights
from navstress.world.export.sdf import write_sdf

SOURCE = Path(__file__).resolve().parents[3] / "oracles" / "sdf_load.cc"
PACKAGES = ("sdformat12", "ignition-common4-graphics")


def _build(d: Path) -> str:
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", *PACKAGES], capture_output=True, text=True,
                           check=True).stdout.split()
    exe = d / "sdf_load"
    subprocess.run(["g++", "-std=c++17", "-O1", str(SOURCE), "-o", str(exe), *flags], check=True,
                   capture_output=True, text=True)
    return str(exe)


@pytest.fixture(scope="module")
def sdf_load(tmp_path_factory: pytest.TempPathFactory) -> str:
    _need(shutil.which("g++") is not None and shutil.which("pkg-config") is not None, "g++ or pkg-config missing")
    ok = subprocess.run(["pkg-config", "--exists", *PACKAGES]).returncode == 0
    _need(ok, "libsdformat-dev / libignition-common-graphics-dev missing "
              "(apt-get install libsdformat-dev libignition-common-graphics-dev)")
    exe: str = built_once(tmp_path_factory, "sdf-load", _build)
    return exe


def _load(exe: str, sdf: Path) -> dict[str, Any]:
    r = subprocess.run([exe, str(sdf)], capture_output=True, text=True, timeout=60)
    doc: dict[str, Any] = json.loads(r.stdout)
    assert r.returncode == 0 and doc["errors"] == [], (doc["errors"], r.stderr[-2000:])
    return doc


def _worlds() -> dict[str, World]:
    flat = small_world(2, bumpy=False)
    return {"bumpy": small_world(5), "steep": small_world(11, size=30.0, cell=0.4), "flat": flat}


@pytest.mark.parametrize("name", sorted(_worlds()))
def test_gazebo_reads_the_heightmap_as_the_simulators_terrain(sdf_load: str, tmp_path: Path, name: str) -> None:
    w = _worlds()[name]
    r = write_sdf(w, tmp_path / "w.sdf")
    doc = _load(sdf_load, r.sdf_path)
    (world,) = doc["worlds"]
    ground = next(m for m in world["models"] if m["name"] == "ground")
    hm = ground["links"][0]["collisions"][0]["geometry"]["heightmap"]
    assert hm["load_rc"] == 0 and hm["width"] == hm["height"] == r.heightmap_side
    span = r.z_max - r.z_min
    assert hm["max_elevation"] == (1.0 if span > 0 else 0.0)  # the brightest pixel is the top
    n = hm["width"]
    heights = np.asarray(hm["heights"], np.float64).reshape(n, n) + hm["pos"][2]
    sx, sy = w.terrain.size_m
    assert hm["size"][:2] == pytest.approx([sx, sy]) and hm["pos"][:2] == pytest.approx([sx / 2, sy / 2])
    expected = surface_heights(w.terrain, np.linspace(0, sx, n)[None, :], np.linspace(0, sy, n)[:, None])
    # 8 bits: within half a quantisation step of the simulator's surface (plus float32 rounding)
    assert np.max(np.abs(heights - expected)) <= span / 510 + 1e-4


def test_gazebo_reads_obstacles_and_mission_markers(sdf_load: str, tmp_path: Path) -> None:
    w = small_world(3)
    doc = _load(sdf_load, write_sdf(w, tmp_path / "w.sdf").sdf_path)
    models = {m["name"]: m for m in doc["worlds"][0]["models"]}
    assert set(models) == {"ground", "mission_start", "mission_goal"} | {f"{o.kind}_{k:04d}"
                                                                         for k, o in enumerate(w.obstacles)}
    for k, o in enumerate(w.obstacles):
        m = models[f"{o.kind}_{k:04d}"]
        assert m["static"]
        x, y, z, roll, pitch, yaw = m["pose"]
        assert (x, y, z, roll, pitch) == pytest.approx((o.x, o.y, o.z + o.size[2] / 2, 0.0, 0.0), abs=1e-6)
        assert math.remainder(yaw - o.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
        (col,) = m["links"][0]["collisions"]
        assert col["geometry"] == {"type": "box", "size": pytest.approx(list(o.size))}
    ms = w.mission
    for name, (x, y, yaw) in (("mission_start", ms.start), ("mission_goal", (*ms.goal, 0.0))):
        m = models[name]
        assert m["static"] and m["pose"][:3] == pytest.approx([x, y, w.terrain.height_at(x, y)], abs=1e-6)
        assert math.remainder(m["pose"][5] - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
        (link,) = m["links"]
        assert link["collisions"] == [] and len(link["visuals"]) == 2  # seen, never collided with
    arrow = next(v for v in models["mission_start"]["links"][0]["visuals"] if v["geometry"]["type"] == "box")
    assert arrow["pose"][0] == pytest.approx(MARKER["arrow_length"] / 2)  # ahead along the heading


def test_gazebo_reads_cylinders_and_walls_as_their_shapes(sdf_load: str, tmp_path: Path) -> None:
    """Cylinders as SDF ``<cylinder>`` (radius, length = height) centred half their height above their
    base; a wall polyline's segments as turned boxes; as libsdformat reads them."""
    from tests.support.world_fixtures import shapes_world

    w = shapes_world(4)
    doc = _load(sdf_load, write_sdf(w, tmp_path / "w.sdf").sdf_path)
    models = {m["name"]: m for m in doc["worlds"][0]["models"]}
    assert {o.shape for o in w.obstacles} == {"box", "cylinder"} and any(o.kind == "wall" for o in w.obstacles)
    for k, o in enumerate(w.obstacles):
        m = models[f"{o.kind}_{k:04d}"]
        x, y, z, roll, pitch, yaw = m["pose"]
        assert (x, y, z, roll, pitch) == pytest.approx((o.x, o.y, o.z + o.size[2] / 2, 0.0, 0.0), abs=1e-6)
        assert math.remainder(yaw - o.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
        (link,) = m["links"]
        for el in (*link["collisions"], *link["visuals"]):
            if o.is_cylinder:
                assert el["geometry"] == {"type": "cylinder", "radius": pytest.approx(o.size[0] / 2),
                                          "length": pytest.approx(o.size[2])}
            else:
                assert el["geometry"] == {"type": "box", "size": pytest.approx(list(o.size))}
