"""Any world (issue 37, item 5): realise() on imported worlds (missions given in the source's frame
or drawn with the robot's clearance, added and moved obstacles, descriptors), relative source
paths in every spec loader, the sources' digests pinned into a campaign's stored spec, the
source in records. Real files: world directories and office maps written here."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from navstress.campaign.sources import pin_sources
from navstress.campaign.spec import load_campaign
from navstress.errors import GenerationError, SpecError
from navstress.robot import PROFILES, RobotSpec
from navstress.search.spec import load_search
from navstress.world.generate import generate
from navstress.world.sources import missions
from navstress.world.spec import WorldSpec, load_spec, parse_spec
from navstress.world.world import Mission, Obstacle, World, WorldSource
from tests.support.office import write_office

ROBOTS = [PROFILES["jackal"], RobotSpec()]
ORIGIN = (5.0, -3.0)  # the source's frame: navstress's (0, 0) is (5, -3) there


def _wall(x: float, y: float, sx: float, sy: float) -> Obstacle:
    return Obstacle(kind="wall", x=x, y=y, yaw=0.0, size=(sx, sy, 2.0))


def office_dir(path: Path, *, placeholder: bool = False) -> Path:
    """A 20 x 12 m world directory (rooms and a corridor of box walls) whose source frame is shifted by ORIGIN."""
    spec = WorldSpec(size_m=(20.0, 12.0), cell_m=0.1)
    obs = (_wall(10, 0.1, 20, 0.2), _wall(10, 11.9, 20, 0.2), _wall(0.1, 6, 0.2, 12), _wall(19.9, 6, 0.2, 12),
           _wall(3, 5, 6, 0.2), _wall(10, 5, 6, 0.2), _wall(17, 5, 6, 0.2), _wall(7, 8.5, 0.2, 7),
           _wall(13, 8.5, 0.2, 7), Obstacle(kind="pillar", x=4.0, y=2.5, yaw=0.0, size=(0.6, 0.6, 2.0),
                                           shape="cylinder"))
    m = (Mission(start=(10.0, 10.0, 0.0), goal=(10.0, 10.0), free_radius_m=0.0) if placeholder
         else Mission(start=(1.0, 2.5, 0.0), goal=(16.0, 9.0), free_radius_m=0.5))
    w = World.flat(spec, obstacles=obs, mission=m)
    w = World(spec=w.spec, seed=0, terrain=w.terrain, obstacles=w.obstacles, mission=w.mission,
              source=WorldSource(kind="dir", path=str(path), sha256="", origin=ORIGIN))
    w.save(path)
    return path


def _distance(o: Obstacle, x: float, y: float) -> float:
    """Exact distance from (x, y) to the footprint of ``o``."""
    if o.is_cylinder:
        return max(0.0, math.hypot(x - o.x, y - o.y) - o.size[0] / 2)
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    lx, ly = c * (x - o.x) + s * (y - o.y), -s * (x - o.x) + c * (y - o.y)
    return math.hypot(max(abs(lx) - o.size[0] / 2, 0.0), max(abs(ly) - o.size[1] / 2, 0.0))


def _spec(src: Path, **world: object) -> WorldSpec:
    return WorldSpec.model_validate({"source": {"path": str(src)}, **world})


@pytest.fixture(scope="module")
def office(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return office_dir(tmp_path_factory.mktemp("src") / "office")


@pytest.fixture(scope="module")
def placeholder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return office_dir(tmp_path_factory.mktemp("src") / "empty", placeholder=True)


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda r: r.name)
@pytest.mark.parametrize("seed", range(6))
def test_drawn_missions_keep_the_robots_clearance(office: Path, placeholder: Path, robot: RobotSpec, seed: int) -> None:
    """mode random, and a source whose mission is a placeholder: start and goal drawn per seed in the
    free space, at least the robot's half diagonal + margin from every footprint and edge, apart by
    the capped least distance, reachable (feasible for the robot), deterministic."""
    for src, world in ((office, {"mission": {"mode": "random"}}), (placeholder, {})):
        w = generate(_spec(src, **world), seed, robot=robot)
        again = generate(_spec(src, **world), seed, robot=robot)
        assert w == again and w.digest() == again.digest()
        clearance = robot.half_diagonal_m + missions.CLEARANCE_MARGIN_M
        for x, y in (w.mission.start[:2], w.mission.goal):
            assert min(_distance(o, x, y) for o in w.obstacles) >= clearance - 1e-9
            assert min(x, y, w.size_m[0] - x, w.size_m[1] - y) >= clearance - 1e-9
        cap = missions.MIN_DISTANCE_CAP * math.hypot(*w.size_m)
        assert w.mission.straight_distance_m >= min(50.0, cap) - 1e-9
        assert w.descriptors["feasible"] is True
        assert w.mission.free_radius_m == pytest.approx(clearance)
        assert w.source is not None and w.source.kind == "dir" and w.source.origin == ORIGIN
        assert w.spec.size_m == (20.0, 12.0) and w.spec.cell_m == 0.1 and w.spec.source is not None
    # different seeds, different missions
    starts = {generate(_spec(office, mission={"mode": "random"}), s, robot=robot).mission.start for s in range(4)}
    assert len(starts) > 1


@pytest.mark.parametrize("start,goal", [((6.0, 0.0, 0.5), (21.0, 6.0)), ((7.5, 1.5, -1.0), (9.0, 7.0)),
                                        ((20.0, 5.5, 3.0), (6.5, -1.0))])
def test_given_points_are_in_the_sources_frame(office: Path, start: tuple[float, float, float],
                                                goal: tuple[float, float]) -> None:
    w = generate(_spec(office, mission={"start": list(start), "goal": list(goal)}), 0, robot=PROFILES["jackal"])
    assert w.mission.start == pytest.approx((start[0] - ORIGIN[0], start[1] - ORIGIN[1], start[2]))
    assert w.mission.goal == pytest.approx((goal[0] - ORIGIN[0], goal[1] - ORIGIN[1]))
    assert w.source is not None and w.source.to_source(*w.mission.goal) == pytest.approx(goal)


def test_the_sources_own_mission_is_kept(office: Path) -> None:
    w = generate(_spec(office), 3, robot=PROFILES["jackal"])
    assert w.mission.start == (1.0, 2.5, 0.0) and w.mission.goal == (16.0, 9.0)
    # one point given: the other is the source's
    w = generate(_spec(office, mission={"goal": [20.0, 5.0]}), 3, robot=PROFILES["jackal"])
    assert w.mission.start == (1.0, 2.5, 0.0) and w.mission.goal == (15.0, 8.0)


@pytest.mark.parametrize("name,point,why", [
    ("start", [4.0, -3.5, 0.0], "outside the map"), ("start", [30.0, 0.0, 0.0], "outside the map"),
    ("goal", [15.0, 2.0], "inside a wall"), ("goal", [9.0, -0.5], "inside a pillar"),
    ("start", [5.05, 3.0, 0.0], "inside a wall")])
def test_a_point_outside_the_map_or_in_an_obstacle_is_one_line(office: Path, name: str, point: list[float],
                                                                why: str) -> None:
    with pytest.raises(SpecError) as e:
        generate(_spec(office, mission={name: point}), 0)
    text = str(e.value)
    assert "\n" not in text and f"mission.{name}" in text and str(office) in text and why.split()[-1] in text


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("pct", [1.0, 3.0])
def test_added_obstacles_avoid_the_imported_geometry_and_the_mission(office: Path, seed: int, pct: float) -> None:
    spec = _spec(office, mission={"mode": "random"},
                 obstacles={"types": {"box": {"base_m": [0.4, 0.4], "height_m": 1.0}}, "obstruction": {"box": pct}})
    w = generate(spec, seed, robot=PROFILES["jackal"])
    added = [o for o in w.obstacles if o.kind == "box"]
    imported = [o for o in w.obstacles if o.kind != "box"]
    assert added and abs(w.descriptors["obstruction_pct"]["box"] - pct) <= 0.5
    for a in added:
        x0, y0, x1, y1 = a.x - a.size[0] / 2, a.y - a.size[1] / 2, a.x + a.size[0] / 2, a.y + a.size[1] / 2
        assert x0 >= 0 and y0 >= 0 and x1 <= w.size_m[0] and y1 <= w.size_m[1]
        for o in imported:  # no shared interior point with an imported footprint (boxes: bounding boxes)
            r = o.radius_xy if o.is_cylinder else None
            if r is not None:
                assert _distance(a, o.x, o.y) >= r - 1e-9
            else:
                assert (x1 <= o.x - o.size[0] / 2 + 1e-9 or o.x + o.size[0] / 2 <= x0 + 1e-9
                        or y1 <= o.y - o.size[1] / 2 + 1e-9 or o.y + o.size[1] / 2 <= y0 + 1e-9)
        for x, y in (w.mission.start[:2], w.mission.goal):
            assert _distance(a, x, y) >= w.mission.free_radius_m - 1e-9
    # the imported geometry itself is untouched, the mission the one without added obstacles
    assert imported == list(generate(_spec(office, mission={"mode": "random"}), seed, robot=PROFILES["jackal"]).obstacles)


def test_moves_take_imported_obstacles_at_a_point_of_the_sources_frame(office: Path) -> None:
    # the pillar is at (4, 2.5) here, (9, -0.5) in the source's frame
    w = generate(_spec(office, obstacles={"moves": [{"at": [9.0, -0.5], "by": [0.5, 0.25]}]}), 0,
                 robot=PROFILES["jackal"])
    pillar = next(o for o in w.obstacles if o.kind == "pillar")
    assert (pillar.x, pillar.y) == (4.5, 2.75) and w.descriptors["moves_applied"] == 1
    # a move into a wall is not applied
    w = generate(_spec(office, obstacles={"moves": [{"at": [9.0, -0.5], "by": [0.0, 2.5]}]}), 0)
    assert w.descriptors["moves_applied"] == 0


def test_no_room_for_the_robot_is_a_generation_error(tmp_path: Path) -> None:
    spec = WorldSpec(size_m=(10.0, 10.0), cell_m=0.1)
    walls = tuple(_wall(x + 0.5, 5.0, 0.4, 10.0) for x in range(10))  # 1 m apart: 0.6 m gaps
    World.flat(spec, obstacles=walls, mission=Mission((1, 1, 0), (1, 1), 0.0)).save(tmp_path / "w")
    with pytest.raises(GenerationError, match="clearance"):
        generate(_spec(tmp_path / "w", mission={"mode": "random"}), 0)  # the RMP 400: 0.66 m half diagonal


def test_an_office_map_is_realised(tmp_path: Path) -> None:
    """The map importer's world (a placeholder mission) gets a drawn mission in its free space."""
    yaml = write_office(tmp_path / "m", origin=(-3.0, 2.0))
    w = generate(_spec(yaml), 2, robot=PROFILES["jackal"])
    assert w.source is not None and w.source.kind == "map" and w.source.origin == (-3.0, 2.0)
    assert w.descriptors["feasible"] is True and w.mission.straight_distance_m > 5.0


# ---- spec files: relative sources, pins -------------------------------------------------------


def test_every_spec_loader_resolves_a_relative_source_against_its_file(tmp_path: Path, office: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    d = tmp_path / "specs" / "deep"
    office_dir(d / "maps" / "o")
    monkeypatch.chdir(tmp_path)  # elsewhere: a path relative to the working directory would miss
    want = str((d / "maps" / "o").resolve())
    (d / "c.yaml").write_text("name: c\nworld: {source: maps/o}\nexperiments:\n"
                              "  - {name: a, overrides: {source: {path: maps/o}}}\n"
                              "  - {name: b, worlds: [{key: k, map_seed: 1, world: {source: {path: ./maps/o}}}]}\n")
    c, _ = load_campaign(d / "c.yaml")
    assert c.world["source"]["path"] == want and c.experiments[0].overrides["source"]["path"] == want
    assert c.experiments[1].worlds is not None and c.experiments[1].worlds[0].world["source"]["path"] == want
    (d / "s.yaml").write_text("world: {source: {path: maps/o}}\nspace: {map_seed: true}\n"
                              "objective: {name: failure}\nbudget: {runs: 100}\n")
    s, _ = load_search(d / "s.yaml")
    assert s.world["source"]["path"] == want
    (d / "w.yaml").write_text("source: {path: maps/o}\n")
    w = load_spec(d / "w.yaml")
    assert w.source is not None and w.source.path == want
    # an absolute one is kept
    (d / "w2.yaml").write_text(f"source: {{path: {office}}}\n")
    assert load_spec(d / "w2.yaml").source.path == str(office)  # type: ignore[union-attr]


def test_pins_come_from_the_stored_spec_and_a_changed_source_is_refused(tmp_path: Path) -> None:
    src = office_dir(tmp_path / "o")
    (tmp_path / "c.yaml").write_text("name: c\nworld: {source: o}\nexperiments: [{name: a}]\n")
    spec, _ = load_campaign(tmp_path / "c.yaml")
    pinned = pin_sources(spec)
    sha = pinned.world["source"]["sha256"]
    assert len(sha) == 64 and pinned.digest() != spec.digest()
    World.flat(WorldSpec(size_m=(20.0, 12.0))).save(src)  # the source changes
    again = pin_sources(spec, pinned)
    assert again.world["source"]["sha256"] == sha and again.digest() == pinned.digest()
    with pytest.raises(SpecError) as e:
        generate(WorldSpec.model_validate(again.world), 0)
    assert "\n" not in str(e.value) and str(src) in str(e.value) and sha in str(e.value)
    # a spec without sources is the same object: its store is the one of before sources existed
    (tmp_path / "g.yaml").write_text("name: g\nexperiments: [{name: a}]\n")
    plain, _ = load_campaign(tmp_path / "g.yaml")
    assert pin_sources(plain) is plain


@pytest.mark.parametrize("extra,field", [({"generator": "rooms"}, "generator"),
                                         ({"ground": {"subdivisions": 3, "deformation": 1.0}}, "ground")])
def test_what_a_source_cannot_take_is_one_line(office: Path, extra: dict[str, object], field: str) -> None:
    with pytest.raises(SpecError) as e:
        parse_spec({"source": {"path": str(office)}, **extra})
    assert str(e.value).startswith(f"{field}=") and "\n" not in str(e.value)
