"""The SDF importer (navstress.world.sources.sdf) against libsdformat's own reading of the same
files: ``tests/oracles/sdf_dump.cc``, compiled once per session against Debian's libsdformat 12
(``libsdformat-dev``, which ``make test`` installs; skipped with the reason where it is missing,
failed under CI). The files: families of hand-written worlds over SDF 1.4 to 1.9 (nested models,
links and collisions with composed poses, 90-degree flips and tilts, ``frame`` / ``relative_to``,
``<frame>``s, joints as frames, ``placement_frame``, ``quat_xyzw`` and degrees, ``<include>``s)
and a sample of BARN's worlds."""

from __future__ import annotations

import hashlib
import json
import math
import os
import random
import shutil
import subprocess
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.support.barn import barn_dir
from tests.support.built_once import built_once
from tests.support.required import need
from navstress.world.sources import sdf
from navstress.world.sources.notes import SourceWarning
from navstress.world.spec import SourceSpec
from navstress.world.world import World

SOURCE = Path(__file__).resolve().parents[2] / "oracles" / "sdf_dump.cc"
TOL = 1e-6
VERSIONS = ("1.4", "1.5", "1.6", "1.7", "1.8", "1.9")
HALF_PI = "1.5707963267948966"


def _build(d: Path) -> str:
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", "sdformat12"], capture_output=True, text=True,
                           check=True).stdout.split()
    exe = d / "sdf_dump"
    subprocess.run(["g++", "-std=c++17", "-O1", str(SOURCE), "-o", str(exe), *flags], check=True,
                   capture_output=True, text=True)
    return str(exe)


@pytest.fixture(scope="module")
def sdf_dump(tmp_path_factory: pytest.TempPathFactory) -> str:
    need(shutil.which("g++") is not None and shutil.which("pkg-config") is not None, "g++ or pkg-config missing")
    need(subprocess.run(["pkg-config", "--exists", "sdformat12"]).returncode == 0,
         "libsdformat-dev missing (apt-get install libsdformat-dev)")
    exe: str = built_once(tmp_path_factory, "sdf-dump", _build)
    return exe


def oracle(exe: str, files: list[Path], env: dict[str, str] | None = None) -> list[dict[str, Any]]:
    """libsdformat's reading of each file (one process for all)."""
    r = subprocess.run([exe, *map(str, files)], capture_output=True, text=True, timeout=600,
                       env=None if env is None else {**os.environ, **env})
    docs = [json.loads(line) for line in r.stdout.splitlines() if line.strip()]
    assert len(docs) == len(files), r.stderr[-2000:]
    for d in docs:
        assert d["errors"] == [], (d["file"], d["errors"])
        for c in d["worlds"][0]["collisions"]:
            assert c["pose"] is not None, (d["file"], c)
    return docs


def _rot(q: list[float]) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _solid_points(col: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """(centre, rotation, geometry) of an oracle collision."""
    p = col["pose"]
    return np.array(p[:3]), _rot(p[3:]), col["geometry"]


def _extent_along(col: dict[str, Any], e: np.ndarray) -> float:
    """Half the width of the collision's solid along the unit direction ``e`` (exact)."""
    _c, r, g = _solid_points(col)
    if g["type"] == "box":
        half = np.array(g["size"]) / 2
        return float(np.sum(half * np.abs(r.T @ e)))
    if g["type"] == "ellipsoid":
        half = np.array(g["radii"])
        return float(np.sum(half * np.abs(r.T @ e)))  # its bounding box's
    axis = r[:, 2]
    d = float(abs(axis @ e))
    if g["type"] == "cylinder":
        return g["length"] / 2 * d + g["radius"] * math.sqrt(max(0.0, 1 - d * d))
    if g["type"] == "capsule":
        return g["length"] / 2 * d + g["radius"]
    raise AssertionError(g)


def _upright(col: dict[str, Any]) -> bool:
    _c, r, g = _solid_points(col)
    c = math.cos(sdf.UPRIGHT_TOL_RAD)
    if g["type"] in ("box", "ellipsoid"):
        return bool(np.any(np.abs(r[2, :]) >= c))
    if g["type"] in ("cylinder", "capsule"):
        return bool(abs(r[2, 2]) >= c)
    return True  # a sphere


def check_matches(world: World, docs_world: dict[str, Any], *, meshes: bool = False) -> None:
    """Every box / cylinder / sphere / capsule / ellipsoid collision libsdformat read is one of the
    world's obstacles (in the source's frame) within TOL, and there is no other obstacle."""
    cols = [c for c in docs_world["collisions"]
            if c["geometry"]["type"] in ("box", "cylinder", "sphere", "capsule", "ellipsoid")]
    obs = [(o, world.source.to_source(o.x, o.y)) for o in world.obstacles]  # type: ignore[union-attr]
    assert len(obs) == len(cols)
    left = list(range(len(obs)))
    for col in cols:
        centre, r, g = _solid_points(col)
        best = min(left, key=lambda k: (obs[k][1][0] - centre[0]) ** 2 + (obs[k][1][1] - centre[1]) ** 2
                   + (obs[k][0].z + obs[k][0].size[2] / 2 - centre[2]) ** 2)
        o, (x, y) = obs[best]
        left.remove(best)
        where = f"{col['model']}::{col['link']}::{col['name']} ({g['type']})"
        assert abs(x - centre[0]) <= TOL and abs(y - centre[1]) <= TOL, where
        assert abs(o.z + o.size[2] / 2 - centre[2]) <= TOL, where
        if g["type"] == "sphere":
            assert o.is_cylinder and o.size == pytest.approx((2 * g["radius"],) * 3, abs=TOL), where
            continue
        if g["type"] in ("cylinder", "capsule") and _upright(col):
            cap = g["radius"] if g["type"] == "capsule" else 0.0
            assert o.is_cylinder, where
            assert o.size == pytest.approx((2 * g["radius"], 2 * g["radius"], g["length"] + 2 * cap), abs=TOL), where
            continue
        assert not o.is_cylinder, where
        if g["type"] == "box" and _upright(col):  # exact: the box's sizes, its footprint's corners
            k = int(np.argmax(np.abs(r[2, :])))
            i, j = [a for a in range(3) if a != k]
            size = g["size"]
            assert o.size == pytest.approx((size[i], size[j], size[k]), abs=TOL), where
            half = np.array(size) / 2
            corners = sorted(tuple(np.round(centre[:2] + si * half[i] * r[:2, i] + sj * half[j] * r[:2, j], 5))
                             for si in (-1, 1) for sj in (-1, 1))
            mine = sorted(tuple(np.round(np.asarray(world.source.to_source(*c)), 5))  # type: ignore[union-attr]
                          for c in o.corners())
            assert np.allclose(corners, mine, atol=2e-5), where
            continue
        # tilted, or an ellipsoid: the upright bounding box, tight along its own axes
        ax = np.array([math.cos(o.yaw), math.sin(o.yaw), 0.0])
        ay = np.array([-math.sin(o.yaw), math.cos(o.yaw), 0.0])
        ez = np.array([0.0, 0.0, 1.0])
        got = (o.size[0] / 2, o.size[1] / 2, o.size[2] / 2)
        if g["type"] == "ellipsoid" and _upright(col):
            k = int(np.argmax(np.abs(r[2, :])))
            i, j = [a for a in range(3) if a != k]
            radii = g["radii"]
            assert got == pytest.approx((radii[i], radii[j], radii[k]), abs=TOL), where
            continue
        want = tuple(_extent_along(col, e) for e in (ax, ay, ez))
        assert got == pytest.approx(want, abs=TOL), where
    assert not left


# ---- families of hand-written worlds ---------------------------------------------------------------

def _num(v: float) -> str:
    return repr(float(v))


class _Gen:
    """A random SDF world of one version: what that version can say, chosen by a seeded rng."""

    def __init__(self, version: str, seed: int) -> None:
        self.v = tuple(int(x) for x in version.split("."))
        self.version = version
        self.rng = random.Random(seed * 1000 + self.v[1])
        self.n = 0

    def uid(self, prefix: str) -> str:
        self.n += 1
        return f"{prefix}{self.n}"

    def rpy(self, tilt: bool = True) -> tuple[str, str, str]:
        r = self.rng
        yaw = _num(r.uniform(-math.pi, math.pi))
        if not tilt or r.random() < 0.6:
            return "0", "0", yaw
        roll = r.choice(["0", HALF_PI, "-" + HALF_PI, "3.141592653589793", _num(r.uniform(-1, 1))])
        pitch = r.choice(["0", HALF_PI, "0", _num(r.uniform(-1, 1))])
        return roll, pitch, yaw

    def pose(self, rel: str = "", spread: float = 3.0, z: tuple[float, float] = (0.0, 1.0),
             tilt: bool = True) -> str:
        r = self.rng
        x, y, zz = _num(r.uniform(-spread, spread)), _num(r.uniform(-spread, spread)), _num(r.uniform(*z))
        roll, pitch, yaw = self.rpy(tilt)
        attr = ""
        if rel:
            attr = f" relative_to='{rel}'" if self.v >= (1, 7) else f" frame='{rel}'"
        if self.v >= (1, 9) and r.random() < 0.25:
            if r.random() < 0.5:
                deg = [_num(math.degrees(float(a))) for a in (roll, pitch, yaw)]
                return f"<pose{attr} degrees='true'>{x} {y} {zz} {' '.join(deg)}</pose>"
            q = _quat(float(roll), float(pitch), float(yaw))
            return (f"<pose{attr} rotation_format='quat_xyzw'>{x} {y} {zz} {_num(q[1])} {_num(q[2])} {_num(q[3])} "
                    f"{_num(q[0])}</pose>")
        return f"<pose{attr}>{x} {y} {zz} {roll} {pitch} {yaw}</pose>"

    def geometry(self) -> str:
        r = self.rng
        kinds = ["box", "cylinder", "sphere"] + (["capsule", "ellipsoid"] if self.v >= (1, 8) else [])
        k = r.choice(kinds)
        u = lambda: _num(r.uniform(0.1, 2.0))  # noqa: E731
        if k == "box":
            return f"<box><size>{u()} {u()} {u()}</size></box>"
        if k == "cylinder":
            return f"<cylinder><radius>{u()}</radius><length>{u()}</length></cylinder>"
        if k == "sphere":
            return f"<sphere><radius>{u()}</radius></sphere>"
        if k == "capsule":
            return f"<capsule><radius>{u()}</radius><length>{u()}</length></capsule>"
        return f"<ellipsoid><radii>{u()} {u()} {u()}</radii></ellipsoid>"

    def link(self, frames: list[str]) -> tuple[str, str]:
        name = self.uid("link")
        rel = self.rng.choice(frames) if frames and self.v >= (1, 5) and self.rng.random() < 0.4 else ""
        cols = []
        for _ in range(self.rng.randint(1, 2)):
            crel = ""
            if frames and self.v >= (1, 7) and self.rng.random() < 0.3:
                crel = self.rng.choice(frames)
            cols.append(f"<collision name='{self.uid('col')}'>{self.pose(crel, 1.0)}"
                        f"<geometry>{self.geometry()}</geometry></collision>")
        return name, f"<link name='{name}'>{self.pose(rel, 1.0)}{''.join(cols)}</link>"

    def model(self, depth: int = 0, rel: str = "") -> str:
        r = self.rng
        name = self.uid("model")
        body: list[str] = []
        frames: list[str] = []
        links: list[str] = []
        for _ in range(r.randint(1, 3)):
            ln, text = self.link(frames)
            body.append(text)
            frames.append(ln)
            links.append(ln)
        if self.v >= (1, 7) and r.random() < 0.7:
            f = self.uid("frame")
            att = r.choice(links)
            body.append(f"<frame name='{f}' attached_to='{att}'>{self.pose('', 1.0)}</frame>")
            frames.append(f)
            ln, text = self.link([f])
            body.append(text)
            links.append(ln)
        if self.v >= (1, 7) and len(links) >= 2 and r.random() < 0.6:
            j = self.uid("joint")
            body.append(f"<joint name='{j}' type='fixed'><parent>{links[0]}</parent><child>{links[1]}</child>"
                        f"{self.pose('', 0.5)}</joint>")
            f = self.uid("frame")
            body.append(f"<frame name='{f}'>{self.pose(j, 0.5)}</frame>")
            ln, text = self.link([f])
            body.append(text)
            links.append(ln)
        if self.v >= (1, 5) and depth < 2 and r.random() < 0.6:
            body.append(self.model(depth + 1))
        static = "<static>true</static>" if depth == 0 else ""
        place = ""
        if self.v >= (1, 8) and r.random() < 0.3:
            place = f" placement_frame='{r.choice(links)}'"
        return f"<model name='{name}'{place}>{static}{self.pose(rel, 20.0 if depth == 0 else 2.0)}{''.join(body)}</model>"

    def world(self, include: str | None) -> str:
        models = [self.model() for _ in range(self.rng.randint(2, 4))]
        if self.v >= (1, 7):  # a model placed relative to another
            first = models[0].split("'")[1]
            models.append(self.model(rel=first))
        ground = ("<model name='ground_plane'><static>true</static><link name='link'><collision name='c'>"
                  "<geometry><plane><normal>0 0 1</normal><size>100 100</size></plane></geometry></collision>"
                  "</link></model>")
        inc = ""
        if include is not None:
            inc = (f"<include><uri>model://{include}</uri><name>included_a</name>{self.pose('', 10.0)}</include>"
                   f"<include><uri>model://{include}</uri><name>included_b</name>"
                   f"<pose>3 4 0 0 0 0.5</pose><static>true</static></include>")
        return (f"<?xml version='1.0'?>\n<sdf version='{self.version}'><world name='w'>"
                f"<light name='sun' type='directional'/>{ground}{''.join(models)}{inc}</world></sdf>\n")

    def model_file(self) -> str:
        return f"<?xml version='1.0'?>\n<sdf version='{self.version}'>{self.model()}</sdf>\n"


def _quat(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    q = sdf.rpy_pose(0, 0, 0, roll, pitch, yaw).q
    return q


def _family(tmp: Path, seeds: range) -> list[tuple[str, Path]]:
    out = []
    models = tmp / "models"
    for v in VERSIONS:
        for s in seeds:
            g = _Gen(v, s)
            name = f"thing_{v.replace('.', '_')}_{s}"
            mdir = models / name
            mdir.mkdir(parents=True)
            (mdir / "model.config").write_text(f"<?xml version='1.0'?><model><name>{name}</name>"
                                               f"<sdf version='{v}'>thing.sdf</sdf></model>")
            (mdir / "thing.sdf").write_text(g.model_file())
            p = tmp / f"w_{v}_{s}.sdf"
            p.write_text(g.world(include=name))
            out.append((v, p))
    return out


def _load(p: Path, **opts: Any) -> World:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SourceWarning)
        return sdf.load(p, SourceSpec(path=str(p), **opts))


def test_hand_written_worlds_of_every_version_match_libsdformat(sdf_dump: str, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    family = _family(tmp_path, range(4))
    docs = oracle(sdf_dump, [p for _v, p in family], env={"SDF_PATH": str(tmp_path / "models")})
    monkeypatch.delenv("GAZEBO_MODEL_PATH", raising=False)
    monkeypatch.delenv("SDF_PATH", raising=False)
    tilted = upright = 0
    for (v, p), doc in zip(family, docs):
        w = _load(p)  # finds the models in models/ beside the world
        check_matches(w, doc["worlds"][0])
        for c in doc["worlds"][0]["collisions"]:
            if c["geometry"]["type"] not in ("plane", "sphere"):
                tilted += not _upright(c)
                upright += _upright(c)
    assert tilted >= 10 and upright >= 50  # the family has both kinds


def test_the_frame_semantics_each_version_has(sdf_dump: str, tmp_path: Path) -> None:
    """One small world per feature, whose answer is also known by hand."""
    cases = {
        # 1.6 frame='' is the parent; frame='l1' is relative to the link l1 (libsdformat's reading)
        "frame16": ("1.6", "<model name='m'><static>1</static><pose frame=''>1 2 0 0 0 0</pose>"
                    "<link name='l1'><pose>1 0 0 0 0 0</pose></link>"
                    "<link name='l2'><pose frame='l1'>0 1 0 0 0 0</pose><collision name='c'><pose>0 0 0.5 0 0 0</pose>"
                    "<geometry><box><size>1 1 1</size></box></geometry></collision></link></model>", (2.0, 3.0, 0.5)),
        # 1.7 <frame attached_to> with a pose relative to it, a collision relative_to the frame
        "frame17": ("1.7", "<model name='m'><static>1</static><pose>0 0 0 0 0 1.5707963267948966</pose>"
                    "<link name='l'><pose>1 0 0 0 0 0</pose></link>"
                    "<frame name='f' attached_to='l'><pose>0 2 0 0 0 0</pose></frame>"
                    "<link name='k'><collision name='c'><pose relative_to='f'>1 0 0.5 0 0 0</pose>"
                    "<geometry><box><size>1 1 1</size></box></geometry></collision></link></model>", (-2.0, 2.0, 0.5)),
        # 1.8 placement_frame: the link l sits at the model's pose
        "placement18": ("1.8", "<model name='m' placement_frame='l'><static>1</static><pose>5 5 0 0 0 0</pose>"
                        "<link name='l'><pose>1 1 0 0 0 0</pose><collision name='c'><pose>0 0 0.5 0 0 0</pose>"
                        "<geometry><box><size>1 1 1</size></box></geometry></collision></link></model>", (5.0, 5.0, 0.5)),
        # 1.8 nested::name as a frame
        "scoped18": ("1.8", "<model name='m'><static>1</static><model name='n'><pose>3 0 0 0 0 0</pose>"
                     "<link name='l'><pose>0 1 0 0 0 0</pose></link></model>"
                     "<link name='k'><pose relative_to='n::l'>0 0 0 0 0 0</pose><collision name='c'>"
                     "<pose>0 0 0.5 0 0 0</pose><geometry><box><size>1 1 1</size></box></geometry></collision>"
                     "</link></model>", (3.0, 1.0, 0.5)),
        # 1.9 degrees and quaternions
        "deg19": ("1.9", "<model name='m'><static>1</static><pose degrees='true'>0 0 0 0 0 90</pose>"
                  "<link name='l'><pose rotation_format='quat_xyzw'>1 0 0 0 0 0 1</pose><collision name='c'>"
                  "<pose>0 0 0.5 0 0 0</pose><geometry><box><size>1 1 1</size></box></geometry></collision>"
                  "</link></model>", (0.0, 1.0, 0.5)),
    }
    files = []
    for name, (v, body, _want) in cases.items():
        p = tmp_path / f"{name}.sdf"
        p.write_text(f"<sdf version='{v}'><world name='w'>{body}</world></sdf>")
        files.append(p)
    docs = oracle(sdf_dump, files)
    for (name, (_v, _b, want)), p, doc in zip(cases.items(), files, docs):
        (c,) = doc["worlds"][0]["collisions"]
        assert c["pose"][:3] == pytest.approx(want, abs=1e-9), name  # the hand answer is libsdformat's
        w = _load(p)
        (o,) = w.obstacles
        assert (*w.source.to_source(o.x, o.y), o.z + 0.5) == pytest.approx(want, abs=1e-9), name  # type: ignore[union-attr]
        check_matches(w, doc["worlds"][0])


# ---- BARN ---------------------------------------------------------------------------------------------

BARN_SAMPLE = (0, 1, 6, 42, 77, 120, 150, 199, 250, 299)


def _barn_cylinders(world_file: Path) -> int:
    text = world_file.read_text()
    body = text[:text.index("<state")]
    return body.count("<model name='unit_cylinder_")


def check_barn(world: World, world_file: Path, path_file: Path) -> None:
    """BARN's cylinders, once each, on its 0.15 m lattice; its path's cells are free."""
    assert world.source is not None
    n = _barn_cylinders(world_file)
    assert len(world.obstacles) == n and n > 50
    pts = np.array([world.source.to_source(o.x, o.y) for o in world.obstacles])
    for o in world.obstacles:
        assert o.is_cylinder and o.kind == "cylinder"
        assert o.size == pytest.approx((0.15, 0.15, 1.0), abs=1e-12) and o.z == pytest.approx(-0.5, abs=1e-12)
    # on the lattice x = -0.075 - 0.15 i, y = 0.075 + 0.15 j, each point once
    i = (-0.075 - pts[:, 0]) / 0.15
    j = (pts[:, 1] - 0.075) / 0.15
    assert np.allclose(i, np.round(i), atol=1e-6) and np.allclose(j, np.round(j), atol=1e-6)
    assert len({(round(a), round(b)) for a, b in zip(i, j)}) == n
    path = np.load(path_file)
    px, py = path[:, 0] * 0.15 - 4.575, path[:, 1] * 0.15 + 5.075
    d = np.hypot(px[:, None] - pts[None, :, 0], py[:, None] - pts[None, :, 1])
    assert d.min() >= 0.15 - 1e-6  # no cylinder on a cell of BARN's own shortest path
    # the world: the content's lower-left corner minus the margin at (0, 0), flat, 10 m at least
    assert min(o.x - 0.075 for o in world.obstacles) == pytest.approx(1.0, abs=1e-9)
    assert min(o.y - 0.075 for o in world.obstacles) == pytest.approx(1.0, abs=1e-9)
    assert min(world.spec.size_m) >= 10 and not world.terrain.heights.any()


@pytest.fixture(scope="module")
def barn_sample(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return barn_dir(tmp_path_factory, BARN_SAMPLE)


@pytest.mark.parametrize("n", BARN_SAMPLE)
def test_a_barn_world_loads_its_cylinders_once(barn_sample: Path, n: int) -> None:
    f = barn_sample / f"world_{n}.world"
    with pytest.warns(SourceWarning) as rec:
        w = sdf.load(f, SourceSpec(path=str(f)))
    (msg,) = [str(r.message) for r in rec]
    assert msg == f"{f}: 1 element not imported or approximated: lights (1): sun"
    check_barn(w, f, barn_sample / "path_files" / f"path_{n}.npy")
    assert w.source is not None and w.source.kind == "sdf" and w.source.path == str(f.resolve())
    assert w.source.sha256 == hashlib.sha256(f.read_bytes()).hexdigest()


def test_barn_worlds_match_libsdformat(sdf_dump: str, barn_sample: Path) -> None:
    ns = BARN_SAMPLE[:1]  # libsdformat takes ~1.5 s of CPU per BARN world: the slow suite compares 50
    files = [barn_sample / f"world_{n}.world" for n in ns]
    for f, doc in zip(files, oracle(sdf_dump, files)):
        check_matches(_load(f), doc["worlds"][0])


#: The BARN worlds ``test_all_300_barn_worlds_load`` imports in the suite: 30 of the 300 drawn with
#: a fixed seed (besides BARN_SAMPLE's 10 above; ~0.13 s of CPU a world: all 300 took ~40 s of
#: the suite's 10-minute budget). ``NAVSTRESS_BARN_ALL=1`` imports all 300 (docs/performance.md,
#: "Test loops"): ``NAVSTRESS_BARN_ALL=1 pytest tests/unit/world/test_import_sdf.py -k all_300``.
BARN_ALL = os.environ.get("NAVSTRESS_BARN_ALL", "") == "1"
BARN_DRAWN = tuple(range(300)) if BARN_ALL else tuple(sorted(random.Random(300).sample(range(300), 30)))


@pytest.mark.slow
def test_all_300_barn_worlds_load(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Every BARN world imports as BARN's cylinders on its lattice, clear of its own path: all
    300 with ``NAVSTRESS_BARN_ALL=1``, else the fixed-seed sample ``BARN_DRAWN``."""
    assert len(BARN_DRAWN) == (300 if BARN_ALL else 30)
    d = barn_dir(tmp_path_factory, BARN_DRAWN)
    for n in BARN_DRAWN:
        f = d / f"world_{n}.world"
        check_barn(_load(f), f, d / "path_files" / f"path_{n}.npy")


@pytest.mark.slow
def test_barns_test_set_matches_libsdformat(sdf_dump: str, tmp_path_factory: pytest.TempPathFactory) -> None:
    # every fifth world of BARN's test set (0, 30, ..., 270): libsdformat takes about 1.5 s of CPU a
    # world, and the suite's budget is 10 minutes on 2 cores (all 50 matched when this was written)
    ns = range(0, 300, 30)
    d = barn_dir(tmp_path_factory, ns, paths=False)
    files = [d / f"world_{n}.world" for n in ns]
    for f, doc in zip(files, oracle(sdf_dump, files)):
        check_matches(_load(f), doc["worlds"][0])
