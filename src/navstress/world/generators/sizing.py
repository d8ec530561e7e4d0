"""A world sized to a robot: the start and goal free discs' radius, and whether a robot fits them
(every generator and source uses these)."""

from __future__ import annotations

from navstress._models import parse
from navstress.errors import SpecError
from navstress.robot import PROFILES, RobotSpec
from navstress.world.spec import WorldSpec


#: The free discs' radius of a spec that sets none (``MissionSpec.free_radius_m``'s default), made
#: for the paper's RMP 400: its initial scanning manoeuvre (turn on the spot, about 3 m forward),
#: its half diagonal (0.661 m) and a margin of about 1 m.
DEFAULT_FREE_RADIUS_M = 5.0


def free_radius_for(robot: RobotSpec) -> float:
    """The free discs' radius for ``robot`` when the spec sets none: the default's with the RMP
    400's half diagonal replaced by ``robot``'s (exactly 5 m for the RMP 400).

        >>> free_radius_for(RobotSpec()), round(free_radius_for(PROFILES["jackal"]), 3)
        (5.0, 4.672)
    """
    return DEFAULT_FREE_RADIUS_M + (robot.half_diagonal_m - PROFILES["rmp400"].half_diagonal_m)


def check_robot_fits(free_radius_m: float, robot: RobotSpec, field: str = "robot") -> None:
    """SpecError naming ``field`` when ``robot`` cannot stand in the world's start and goal free
    discs of radius ``free_radius_m`` (its half diagonal is larger); a world without free discs
    (radius 0) asks nothing."""
    r, hd = float(free_radius_m), robot.half_diagonal_m
    if r > 0 and hd > r:
        raise SpecError(field, robot.name, f"a robot that fits the world's start and goal free discs (radius "
                        f"mission.free_radius_m={r:g} m; the robot's half diagonal is {hd:.3g} m)",
                        "choose a smaller robot, or generate the world for this one (navstress world generate "
                        "--robot) with a larger mission.free_radius_m")


def sized_to_robot(spec: WorldSpec, robot: RobotSpec, field: str = "robot") -> WorldSpec:
    """``spec`` with its free discs sized to ``robot`` (:func:`free_radius_for`) when it sets no
    ``mission.free_radius_m`` of its own (a radius the spec sets is kept); SpecError naming
    ``field`` when the robot does not fit the free discs (:func:`check_robot_fits`) or its
    discs do not fit the spec's mission (a start or goal too near an edge for them)."""
    r = spec.mission.free_radius_m
    if "free_radius_m" not in spec.mission.model_fields_set:
        r = free_radius_for(robot)
    check_robot_fits(r, robot, field)
    if r == spec.mission.free_radius_m:
        return spec  # (the RMP 400's: the same spec, the same files)
    data = spec.model_dump(mode="json")
    data["mission"]["free_radius_m"] = r
    try:
        return parse(WorldSpec, data)
    except SpecError as err:
        raise SpecError(field, robot.name, f"a robot whose start and goal free discs (radius {r:.3g} m, sized to "
                        f"it) fit the world's mission ({err})", "set mission.free_radius_m or mission.inset_m "
                        "in the world spec") from None
