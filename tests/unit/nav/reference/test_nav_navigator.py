"""ReferenceNavigator and GlobalNavigator, closed loop on synthetic scenes (unicycle + ray-cast lidar)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.support.nav_scenes import BASE_H, MOUNT, Scene, closed_loop, grid_points, to_sensor

from navstress.errors import NavigatorError
from navstress.nav.api import Command, Imu, LidarScan, NavMission, Navigator, Observation, Odometry, PoseReading, Status
from navstress.nav.reference import NO_ARC, GlobalNavigator, ReferenceConfig, ReferenceNavigator
from navstress.robot import RobotSpec

NO_SCAN = ReferenceConfig(scan_turn_deg=0.0, scan_forward_m=0.0)
# a U open toward -x, the goal beyond its back wall
U_TRAP = Scene(boxes=((10.0, -5.4, 0.0, 10.4, 5.4, 2.0), (-2.0, 5.0, 0.0, 10.4, 5.4, 2.0),
                      (-2.0, -5.4, 0.0, 10.4, -5.0, 2.0)))
U_MISSION = NavMission((0.0, 0.0, 0.0), (25.0, 0.0), 2.0)


def _obs(t: float, points: np.ndarray | None = None, *, x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> Observation:
    scans = (LidarScan(t, points, MOUNT),) if points is not None else ()
    return Observation(t, Odometry(t, 0.0, 0.0, 0.0, 0.0, 0.0), Imu(t, 0.0, 0.0, 0.0, (0.0, 0.0, 0.0)),
                       PoseReading(t, x, y, BASE_H, yaw, 0.0, 0.0), scans)


def test_is_a_navigator_and_needs_reset() -> None:
    for cls in (ReferenceNavigator, GlobalNavigator):
        nav = cls()
        assert isinstance(nav, Navigator)
        with pytest.raises(NavigatorError, match="reset"):
            nav.step(_obs(0.0))
        with pytest.raises(NavigatorError, match="reset"):
            nav.final_map()
    with pytest.raises(NavigatorError, match="finite"):
        ReferenceNavigator().reset(NavMission((0.0, math.nan, 0.0), (1.0, 1.0)), RobotSpec(), seed=0)


def test_empty_scans_do_not_crash_and_the_scan_manoeuvre_comes_first() -> None:
    nav = ReferenceNavigator()
    nav.reset(NavMission((0.0, 0.0, 0.0), (50.0, 0.0)), RobotSpec(), seed=0)
    out = nav.step(_obs(0.0, np.zeros((0, 3), np.float32)))
    assert isinstance(out, Command) and out.v == 0.0 and out.omega > 0.0  # turning on the spot
    out = nav.step(_obs(0.1))  # no scan at all
    assert isinstance(out, Command) and nav.phase == "scan_turn"


def test_scan_manoeuvre_turns_then_drives_then_navigates() -> None:
    nav = ReferenceNavigator(ReferenceConfig(scan_turn_deg=360.0, scan_forward_m=2.0))
    res = closed_loop(nav, Scene(), NavMission((0.0, 0.0, 0.5), (30.0, 10.0)), seconds=25.0)
    cmds = [c for c in res.commands if isinstance(c, Command)]
    yaws, xs = res.true[:, 3], res.true[:, 1]
    k_turn = int(np.argmax(yaws - 0.5 >= 2 * math.pi - 1e-6))
    assert k_turn > 0 and all(abs(c.v) < 1e-9 for c in cmds[:k_turn - 1])
    assert np.hypot(xs[k_turn], res.true[k_turn, 2]) < 1e-6  # turned on the spot
    assert nav.phase == "navigate"
    assert not res.collided


def test_reaches_a_goal_on_open_ground_and_reports_arrived() -> None:
    nav = ReferenceNavigator()
    m = NavMission((0.0, 0.0, 0.0), (12.0, 6.0), 1.5)
    res = closed_loop(nav, Scene(a=0.05), m, seconds=60.0, pose_noise=0.05, odom_scale=0.95, seed=3)
    assert res.final == Status("arrived")
    px, py = nav.perceived_trajectory()[-1, 1:3]
    assert math.hypot(px - 12.0, py - 6.0) <= 1.5
    # perceived differs from real (noise, slip) but stays close
    real = res.true[:, 1:3]
    perc = nav.perceived_trajectory()[:, 1:3]
    gap = np.hypot(*(real - perc).T)
    assert gap.max() > 0.02 and gap.max() < 1.0
    # the status is latched
    assert nav.step(res.observations[-1] if res.observations else _obs(999.0)) == Status("arrived")


def test_walls_all_around_give_no_arc_elected() -> None:
    # a tight box: forward arcs hit the front wall, turning on the spot hits the side walls
    box = Scene(boxes=((0.95, -2.0, 0.0, 1.5, 2.0, 1.5), (-1.5, -2.0, 0.0, -0.95, 2.0, 1.5),
                       (-1.5, 0.65, 0.0, 1.5, 1.2, 1.5), (-1.5, -1.2, 0.0, 1.5, -0.65, 1.5)))
    pts = to_sensor(grid_points(box, -3.0, 3.0, -3.0, 3.0), 0.0, 0.0, BASE_H, 0.0)
    nav = ReferenceNavigator(NO_SCAN)
    nav.reset(NavMission((0.0, 0.0, 0.0), (20.0, 0.0)), RobotSpec(), seed=0)
    out = nav.step(_obs(0.0, pts))
    assert out == Status("error", NO_ARC)
    assert nav.step(_obs(0.1, pts)) == Status("error", NO_ARC)
    ev = nav.last_evaluation
    assert ev is not None and not np.isfinite(ev.terrain_cost).any() and ev.is_spin.sum() == 1
    # same box without the side walls: turning on the spot is possible, so an arc is elected
    open_sides = Scene(boxes=box.boxes[:2])
    nav.reset(NavMission((0.0, 0.0, 0.0), (20.0, 0.0)), RobotSpec(), seed=0)
    out = nav.step(_obs(0.0, to_sensor(grid_points(open_sides, -3.0, 3.0, -3.0, 3.0), 0.0, 0.0, BASE_H, 0.0)))
    assert isinstance(out, Command)


def test_local_planner_is_trapped_by_a_u_and_the_global_one_gets_out() -> None:
    local = ReferenceNavigator()
    res_l = closed_loop(local, U_TRAP, U_MISSION, seconds=45.0)
    glob = GlobalNavigator()
    res_g = closed_loop(glob, U_TRAP, U_MISSION, seconds=90.0)
    assert res_g.final == Status("arrived") and not res_g.collided
    assert glob.replans >= 5
    # the local one went for the dead end and is still inside the U, circling
    assert isinstance(res_l.final, Command) and not res_l.collided
    x, y = res_l.true[-1, 1:3]
    assert 5.0 < x < 10.0 and abs(y) < 5.0
    last10s = res_l.true[-100:, 1:3]
    # stuck: for the last 10 s it circles inside the U (walls x in [-2, 10.4], |y| < 5)
    assert (last10s[:, 0] > -2.0).all() and (last10s[:, 0] < 10.4).all() and (np.abs(last10s[:, 1]) < 5.0).all()
    # the global one left through the open end before turning toward the goal
    assert res_g.true[:, 1].min() < -1.0


def test_same_seed_same_observations_same_commands() -> None:
    rec = closed_loop(ReferenceNavigator(), U_TRAP, U_MISSION, seconds=25.0, keep_obs=True, pose_noise=0.05)
    for cls in (ReferenceNavigator, GlobalNavigator):
        outs = []
        for _ in range(2):
            nav = cls()
            nav.reset(U_MISSION, RobotSpec(), seed=11)
            outs.append([nav.step(o) for o in rec.observations])
        assert outs[0] == outs[1]
    # replaying the recorded observations into a fresh navigator reproduces the recorded run
    nav = ReferenceNavigator()
    nav.reset(U_MISSION, RobotSpec(), seed=0)
    assert [nav.step(o) for o in rec.observations] == rec.commands


def test_cost_jitter_draws_from_the_seed_only() -> None:
    rec = closed_loop(ReferenceNavigator(), Scene(), NavMission((0.0, 0.0, 0.0), (30.0, 3.0)), seconds=20.0,
                      keep_obs=True)
    cfg = ReferenceConfig(cost_jitter=3.0)

    def play(seed: int) -> list[Command | Status]:
        nav = ReferenceNavigator(cfg)
        nav.reset(NavMission((0.0, 0.0, 0.0), (30.0, 3.0)), RobotSpec(), seed=seed)
        return [nav.step(o) for o in rec.observations]

    assert play(1) == play(1)
    assert play(1) != play(2)


def test_readouts_final_map_and_trajectory() -> None:
    nav = ReferenceNavigator()
    res = closed_loop(nav, U_TRAP, U_MISSION, seconds=5.0)
    elev, origin, cell = nav.final_map()
    assert elev.dtype == np.float32 and cell == nav.config.cell_m
    # it covers start and goal plus the margin, rows along +y
    assert origin[0] <= -30.0 + 1e-9 and origin[1] <= -30.0 + 1e-9
    assert origin[0] + elev.shape[1] * cell >= 55.0 and origin[1] + elev.shape[0] * cell >= 30.0
    assert np.isnan(elev).any() and np.isfinite(elev).any()
    i, j = int((4.0 - origin[1]) / cell), int((3.0 - origin[0]) / cell)  # ground at (3, 4)
    assert abs(elev[i, j]) < 0.05
    traj = nav.perceived_trajectory()
    assert traj.shape == (len(res.commands), 7)
    assert np.all(np.diff(traj[:, 0]) > 0)
    nav.close()
    assert nav.final_map()[0].shape == elev.shape  # still readable after close


def test_believed_footprint_comes_from_reset() -> None:
    nav = ReferenceNavigator()
    nav.reset(U_MISSION, RobotSpec.footprint_fault(), seed=0)
    assert nav.planner.half_width == pytest.approx(0.45 / 2 + nav.config.footprint_margin_m)
    nav.reset(U_MISSION, RobotSpec(), seed=0)
    assert nav.planner.half_width == pytest.approx(0.67 / 2 + nav.config.footprint_margin_m)


def _bowl_step(spin_min_bearing_deg: float, deg: float = 18.0) -> tuple[Command | Status, ReferenceNavigator]:
    """One planning cycle at the bottom of a conical pit (flat within 0.8 m, ``deg`` walls), goal ahead."""
    from navstress.nav.reference.pose import Pose
    nav = ReferenceNavigator(ReferenceConfig(scan_turn_deg=0.0, scan_forward_m=0.0,
                                             spin_min_bearing_deg=spin_min_bearing_deg))
    nav.reset(NavMission((0.0, 0.0, 0.0), (30.0, 1.0), 2.0), RobotSpec(), seed=0)
    xs, ys = np.meshgrid(np.arange(-12, 12, 0.05), np.arange(-12, 12, 0.05))
    zs = math.tan(math.radians(deg)) * np.maximum(0.0, np.hypot(xs, ys) - 0.8)
    nav.terrain.integrate(np.column_stack([xs.ravel(), ys.ravel(), zs.ravel()]), (0.0, 0.0, 0.0),
                          Pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    return nav.step(_obs(0.0)), nav


def test_no_turn_on_the_spot_while_the_goal_is_ahead_and_a_forward_arc_is_electable() -> None:
    # every forward arc climbs the pit's wall (cost ~10 of 12); turning on the spot costs ~0.6 +
    # 1 m. Allowed at any bearing, the spin wins (and, latched, turns full circles on slopes).
    out, nav = _bowl_step(60.0)
    ev = nav.last_evaluation
    assert ev is not None and isinstance(out, Command)
    assert not ev.is_spin[nav.last_elected] and out.v > 0.0
    assert ev.terrain_cost[nav.last_elected] > 9.0  # a costly climb, still electable
    old, nav0 = _bowl_step(0.0)
    assert isinstance(old, Command) and nav0.last_evaluation is not None
    assert nav0.last_evaluation.is_spin[nav0.last_elected] and old.v == 0.0
    # walls too steep for any forward arc: the spin is still elected (not "no arc elected")
    steep, nav2 = _bowl_step(60.0, deg=35.0)
    assert isinstance(steep, Command) and nav2.last_evaluation is not None
    assert nav2.last_evaluation.is_spin[nav2.last_elected]


def test_obstacle_subcells_sets_the_fine_layer_of_the_map() -> None:
    nav = ReferenceNavigator(ReferenceConfig(obstacle_subcells=2))
    nav.reset(NavMission((0.0, 0.0, 0.0), (10.0, 0.0)), RobotSpec(), seed=0)
    assert nav.terrain.sub == 2 and nav.terrain.fine_cell_m == pytest.approx(0.15)
    assert nav.terrain.fine_obstacles().shape == (2 * nav.terrain.shape[0], 2 * nav.terrain.shape[1])
