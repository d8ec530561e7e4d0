"""The SDF importer on what libsdformat's object model does not answer (``<state>``, the warning,
meshes as boxes, heightmaps as terrain) and on bad input: ``navstress world import`` prints one
line naming the file and the fix, exits 2 and writes nothing."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from tests.support.cli_run import cli
from tests.support.world_fixtures import small_world
from navstress.errors import SpecError
from navstress.world.export.sdf import write_sdf
from navstress.world.sources import sdf
from navstress.world.sources.notes import SourceWarning
from navstress.world.spec import SourceSpec
from navstress.world.sources.placeholder import placeholder_mission
from navstress.world.world import Obstacle, World

BOX = "<link name='l'><collision name='c'><geometry><box><size>1 2 3</size></box></geometry></collision></link>"


def _world(tmp: Path, body: str, version: str = "1.6", name: str = "w.sdf") -> Path:
    p = tmp / name
    p.write_text(f"<?xml version='1.0'?>\n<sdf version='{version}'><world name='default'>{body}</world></sdf>\n")
    return p


def _load(p: Path, **opts: object) -> tuple[World, list[str]]:
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        w = sdf.load(p, SourceSpec(path=str(p), **opts))  # type: ignore[arg-type]
    return w, [str(r.message) for r in rec if issubclass(r.category, SourceWarning)]


def _in_source(w: World) -> list[tuple[float, float, float]]:
    assert w.source is not None
    return [(*w.source.to_source(o.x, o.y), o.z) for o in w.obstacles]


def test_the_state_block_moves_models_and_links_as_gazebo_does(tmp_path: Path) -> None:
    body = (f"<model name='a'><static>1</static><pose>1 0 0 0 0 0</pose>{BOX}</model>"
            f"<model name='b'><static>1</static><pose>0 5 0 0 0 0</pose>{BOX}</model>"
            f"<model name='gone'><static>1</static>{BOX}</model>"
            "<state world_name='default'>"
            "<insertions><model name='new'><static>1</static><pose>7 7 0 0 0 0</pose>" + BOX + "</model></insertions>"
            "<deletions><name>gone</name></deletions>"
            "<model name='a'><pose>10 0 0 0 0 0</pose><scale>1 1 1</scale></model>"
            "<model name='b'><pose>0 5 0 0 0 0</pose><link name='l'><pose>3 3 1 0 0 0</pose></link></model>"
            "</state>")
    w, said = _load(_world(tmp_path, body))
    assert np.allclose(sorted(_in_source(w)), sorted([(10.0, 0.0, -1.5), (3.0, 3.0, -0.5), (7.0, 7.0, -1.5)]))
    assert len(said) == 1 and said[0].endswith("notes (1): no ground plane: navstress puts the world on flat "
                                               "ground at z = 0")

def test_every_element_left_out_is_named_in_one_warning_line(tmp_path: Path) -> None:
    body = ("<light name='sun' type='directional'/><light name='lamp' type='point'/>"
            "<actor name='walker'/><plugin name='ros_state' filename='libgazebo_ros_state.so'/>"
            "<model name='ground_plane'><static>1</static><link name='link'><collision name='c'><geometry>"
            "<plane><normal>0 0 1</normal></plane></geometry></collision></link></model>"
            "<model name='house'><static>1</static><link name='l'><collision name='c'><geometry><mesh>"
            "<uri>model://house/meshes/house.dae</uri></mesh></geometry></collision>"
            "<sensor name='cam' type='camera'/></link></model>"
            "<model name='cart'><pose>0 0 1 0.5 0 0</pose>" + BOX + "<plugin name='drive' filename='libdrive.so'/></model>")
    w, said = _load(_world(tmp_path, body))
    (line,) = said
    assert "\n" not in line and line.startswith(f"{tmp_path / 'w.sdf'}: 9 elements not imported or approximated: ")
    for part in ("lights (2): sun, lamp", "actors (1): walker", "plugins (2): ros_state (libgazebo_ros_state.so), "
                 "cart: drive (libdrive.so)", "sensors (1): house::l: cam",
                 "mesh collisions (`meshes: bbox` / --meshes bbox imports their bounding boxes) (1): "
                 "house::l::c (model://house/meshes/house.dae)",
                 "non-static models (their collisions imported at their pose; their dynamics are not simulated) "
                 "(1): cart", "tilted models (imported as upright bounding boxes) (1): cart"):
        assert part in line, part
    (o,) = w.obstacles  # the cart's box, tilted by 0.5 rad about x: its upright bounding box
    c, s = math.cos(0.5), math.sin(0.5)
    assert o.size == pytest.approx((1.0, 2 * c + 3 * s, 2 * s + 3 * c)) and o.yaw == pytest.approx(0.0, abs=1e-12)


def test_meshes_bbox_imports_the_box_of_the_mesh_file(tmp_path: Path) -> None:
    mesh = trimesh.creation.box(extents=(2.0, 1.0, 0.5))
    mesh.apply_translation((1.0, 0.0, 0.25))
    (tmp_path / "meshes").mkdir()
    mesh.export(tmp_path / "meshes" / "thing.stl")
    body = ("<model name='m'><static>1</static><pose>5 5 0 0 0 1.5707963267948966</pose><link name='l'>"
            "<collision name='c'><geometry><mesh><uri>meshes/thing.stl</uri><scale>2 2 2</scale></mesh></geometry>"
            "</collision><collision name='d'><geometry><mesh><uri>meshes/none.stl</uri></mesh></geometry>"
            "</collision></link></model>")
    p = _world(tmp_path, body)
    w, said = _load(p, meshes="bbox")
    (o,) = w.obstacles
    assert (*_in_source(w)[0][:2], o.z) == pytest.approx((5.0, 7.0, 0.0))  # centre (2, 0) turned by 90 degrees
    assert o.size == pytest.approx((4.0, 2.0, 1.0)) and o.kind == "mesh"
    assert "meshes whose bounding box could not be read (1): m::l::d (meshes/none.stl: not found)" in said[0]
    skipped, said = _load(p)
    assert skipped.obstacles == () and "mesh collisions" in said[0]


def test_a_heightmap_is_the_terrain_navstress_exported(tmp_path: Path) -> None:
    src = small_world(5)
    r = write_sdf(src, tmp_path / "exported.sdf")
    w, _said = _load(r.sdf_path, margin_m=0.0)
    assert w.source is not None and w.source.origin == pytest.approx((0.0, 0.0), abs=1e-9)
    t = w.terrain
    rows, cols = t.heights.shape
    xs = np.arange(cols) * t.cell_m
    ys = np.arange(rows) * t.cell_m
    want = np.array([[src.terrain.height_at(x, y) for x in xs] for y in ys])
    span = float(src.terrain.heights.max() - src.terrain.heights.min())
    assert np.max(np.abs(t.heights - want)) <= span / 50  # 8-bit PNG, resampled to 2^n+1, then to the grid
    assert np.allclose(sorted(_in_source(w)), sorted((o.x, o.y, o.z) for o in src.obstacles), atol=1e-9)


def test_model_include_found_on_gazebo_model_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lib = tmp_path / "lib" / "crate"
    lib.mkdir(parents=True)
    (lib / "model.sdf").write_text(f"<sdf version='1.6'><model name='crate'><static>1</static>{BOX}</model></sdf>")
    p = _world(tmp_path, "<include><uri>model://crate</uri><pose>2 3 0 0 0 0</pose></include>")
    monkeypatch.setenv("GAZEBO_MODEL_PATH", str(tmp_path / "lib"))
    w, _ = _load(p)
    assert np.allclose(_in_source(w), [(2.0, 3.0, -1.5)])
    monkeypatch.delenv("GAZEBO_MODEL_PATH")
    with pytest.raises(SpecError, match="model://crate"):
        _load(p)


# ---- bad input through the command line ------------------------------------------------------------------

BAD = {
    "not XML": ("<sdf version='1.6'><world name='w'></sdf>", "well-formed XML"),
    "unknown version": ("<sdf version='2.3'><world name='w'/></sdf>", "an SDF version among 1.4"),
    "old version": ("<sdf version='1.3'><world name='w'/></sdf>", "an SDF version among 1.4"),
    "no version": ("<sdf><world name='w'/></sdf>", "an SDF version among 1.4"),
    "not SDF": ("<gazebo version='1.0'><world name='w'/></gazebo>", "an SDF file"),
    "no world": (f"<sdf version='1.6'><model name='m'>{BOX}</model></sdf>", "a world file"),
    "missing include": ("<sdf version='1.6'><world name='w'><include><uri>model://nowhere</uri></include>"
                        "</world></sdf>", "an included model that is found"),
    "network include": ("<sdf version='1.9'><world name='w'><include><uri>https://fuel.gazebosim.org/x</uri>"
                        "</include></world></sdf>", "on the network"),
    "bad pose": (f"<sdf version='1.6'><world name='w'><model name='m'><pose>1 2 x</pose>{BOX}</model></world></sdf>",
                 "<pose> as 6 numbers"),
    "bad size": ("<sdf version='1.6'><world name='w'><model name='m'><link name='l'><collision name='c'><geometry>"
                 "<box><size>1 2</size></box></geometry></collision></link></model></world></sdf>", "as 3 numbers"),
    "unknown frame": ("<sdf version='1.7'><world name='w'><model name='m'><link name='l'><pose relative_to='nope'>"
                      "0 0 0 0 0 0</pose></link></model></world></sdf>", "a frame named 'nope'"),
    "frame cycle": ("<sdf version='1.7'><world name='w'><model name='m'><link name='l'/><frame name='a'>"
                    "<pose relative_to='b'/></frame><frame name='b'><pose relative_to='a'>0 0 0 0 0 0</pose></frame>"
                    "<link name='k'><pose relative_to='a'>0 0 0 0 0 0</pose></link></model></world></sdf>", "cycle"),
    "entities": ("<?xml version='1.0'?><!DOCTYPE sdf [<!ENTITY a 'aaaa'>]><sdf version='1.6'><world name='w'>"
                 "</world></sdf>", "without entity declarations"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_sdf_is_one_line_exit_2_and_nothing_written(tmp_path: Path, case: str) -> None:
    text, expected = BAD[case]
    p = tmp_path / "bad.world"
    p.write_text(text)
    out = tmp_path / "out"
    code, _stdout, err = cli("world", "import", str(p), "-o", str(out))
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: source.path='{p}' is invalid: expected "), err
    assert expected in lines[0] and "; " in lines[0], err  # the fix after the semicolon
    assert not out.exists() and sorted(x.name for x in tmp_path.iterdir()) == ["bad.world"]


def test_world_import_writes_the_world_and_prints_the_warning_once(tmp_path: Path) -> None:
    mesh = "<mesh><uri>m.stl</uri></mesh>"
    p = _world(tmp_path, "<light name='sun' type='directional'/>"
               f"<model name='m'><static>1</static><pose>3 4 0 0 0 0.25</pose>{BOX}</model>"
               f"<model name='n'><static>1</static><link name='l'><collision name='c'><geometry>{mesh}</geometry>"
               "</collision></link></model>", name="room.world")
    out = tmp_path / "out"
    code, stdout, err = cli("world", "import", str(p), "-o", str(out))
    assert code == 0, err
    assert err.strip().splitlines() == [f"warning: {p}: 3 elements not imported or approximated: lights (1): sun; "
                                        "mesh collisions (`meshes: bbox` / --meshes bbox imports their bounding "
                                        "boxes) (1): n::l::c (m.stl); notes (1): no ground plane: navstress puts the "
                                        "world on flat ground at z = 0"]
    assert sorted(x.name for x in out.iterdir()) == ["preview.png", "terrain.npz", "world.json"]
    doc = json.loads((out / "world.json").read_text())
    assert doc["source"]["kind"] == "sdf" and doc["source"]["path"] == str(p)
    (o,) = doc["obstacles"]
    assert (o["x"] + doc["source"]["origin"][0], o["y"] + doc["source"]["origin"][1]) == pytest.approx((3.0, 4.0))
    assert o["size"] == [1.0, 2.0, 3.0] and o["yaw"] == pytest.approx(0.25) and o["z"] == -1.5
    assert doc["spec"]["size_m"] == [10.0, 10.0] and doc["spec"]["source"]["meshes"] == "skip"
    # --meshes bbox: the unreadable mesh is still named
    code, _o, err = cli("world", "import", str(p), "-o", str(tmp_path / "out2"), "--meshes", "bbox")
    assert code == 0 and "meshes whose bounding box could not be read (1): n::l::c (m.stl: not found)" in err


@pytest.mark.parametrize("seed", range(5))
def test_the_placeholder_mission_is_free_and_far(seed: int) -> None:
    g = np.random.default_rng(seed)
    obs = tuple(Obstacle("box" if k % 2 else "cylinder", float(g.uniform(0, 30)), float(g.uniform(0, 20)),
                         float(g.uniform(-3, 3)), (float(g.uniform(0.2, 3)), float(g.uniform(0.2, 3)), 1.0),
                         shape="box" if k % 2 else "cylinder") for k in range(40))
    obs = tuple(o if not o.is_cylinder else Obstacle(o.kind, o.x, o.y, 0.0, (o.size[0], o.size[0], 1.0),
                                                      shape="cylinder") for o in obs)
    m = placeholder_mission((30.0, 20.0), obs, clearance_m=0.5)
    for x, y in (m.start[:2], m.goal):
        assert 0.5 <= x <= 29.5 and 0.5 <= y <= 19.5
        for o in obs:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            u, v = (x - o.x) * c + (y - o.y) * s, -(x - o.x) * s + (y - o.y) * c
            if o.is_cylinder:
                assert math.hypot(u, v) > o.size[0] / 2 + 0.5
            else:
                assert abs(u) > o.size[0] / 2 + 0.5 or abs(v) > o.size[1] / 2 + 0.5
    assert m.straight_distance_m > 20  # far apart: across the 30 x 20 m map
    assert m.start[2] == pytest.approx(math.atan2(m.goal[1] - m.start[1], m.goal[0] - m.start[0]))
