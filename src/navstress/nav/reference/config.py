"""ReferenceConfig: every parameter of the reference navigation stack (POM + DTM + P3D).

One frozen pydantic model; load it from YAML/JSON with :func:`load_config` or from a mapping
with :func:`parse_config`. Bad values raise :class:`~navstress.errors.SpecError` naming
``field=value`` and the allowed range.

    >>> cfg = ReferenceConfig()
    >>> (cfg.control_rate_hz, cfg.n_arcs, cfg.nodes_per_arc, cfg.forward_arcs)
    (10.0, 20, 15, 19)
    >>> parse_config({"n_arcs": 0})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: n_arcs=0 is invalid: expected a value >= 2

The footprint is *not* a parameter here: the planner uses the :class:`~navstress.robot.RobotSpec`
the navigator is given in ``reset`` (that is how the paper's footprint fault is injected), grown
by ``footprint_margin_m``. The goal tolerance comes from the mission (``NavMission``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, Field, model_validator

from navstress._models import SPEC_CONFIG, parse
from navstress.errors import SpecError
from navstress.robot import RobotSpec
from navstress.specfile import load_file

__all__ = ["GlobalConfig", "ReferenceConfig", "load_config", "parse_config"]


class ReferenceConfig(BaseModel):
    """Parameters of ``reference-v1``. Lengths in meters, angles in degrees, rates in Hz.

    Costs: a node (the robot footprint placed at one point of an arc) costs
    ``slope_weight * slope / max_slope + roughness_weight * roughness / max_roughness`` (each ratio
    in [0, 1] on traversable ground) and is infinite when a footprint cell is unknown or an
    obstacle, or the slope or roughness exceeds its maximum. An arc costs the sum of its node costs
    plus ``goal_weight`` times the remaining distance to the goal from its end. An arc whose node
    cost sum exceeds ``election_threshold`` cannot be elected; when none can, the navigator stops
    with ``Status("error", "no arc elected")``.
    """

    model_config = SPEC_CONFIG

    # --- loop ---
    control_rate_hz: float = Field(10.0, gt=0.0, le=100.0, description="control cycle rate (the framework calls step at this rate)")
    # --- P3D arc fan ---
    n_arcs: int = Field(20, ge=2, le=200, description="paths considered per cycle (forward arcs + the turn-in-place path when enabled)")
    nodes_per_arc: int = Field(15, ge=2, le=100, description="nodes (footprint placements) along each arc")
    arc_length_m: float = Field(3.0, gt=0.0, le=20.0, description="length of every forward arc")
    max_curvature_per_m: float = Field(1.0, gt=0.0, le=10.0, description="the sharpest arcs' curvature; forward arcs are evenly spaced in [-max, +max], straight included")
    curvature_spacing: Literal["linear", "quadratic"] = Field("linear", description="how forward-arc curvatures are spread over [-max, +max]: evenly, or k = max * u|u| for u evenly spread (denser near straight, so the fan can aim through narrow gaps)")
    turn_in_place: bool = Field(True, description="one of the n_arcs paths is a turn on the spot toward the goal side")
    turn_in_place_angle_deg: float = Field(90.0, gt=0.0, le=180.0, description="rotation covered by the turn-in-place path's nodes")
    spin_min_bearing_deg: float = Field(60.0, ge=0.0, le=180.0, description="the turn on the spot is electable only when the goal (global navigator: its carrot) lies more than this off the heading, or when no forward arc is electable: it makes no progress, and on slopes it used to beat the costlier forward arcs and turn full circles")
    turn_in_place_penalty_m: float = Field(1.0, ge=0.0, description="extra goal-distance charged to turning on the spot (it makes no progress)")
    # --- costs ---
    max_slope_deg: float = Field(25.0, gt=0.0, lt=90.0, description="footprint plane tilt above which a node is untraversable")
    max_roughness_m: float | None = Field(None, gt=0.0, description="max |residual| of cell heights to the footprint plane above which a node is untraversable; null: follows the believed robot, min(0.2, max(0.1, wheel radius + ground clearance)) (the RMP 400's 0.2)")
    slope_weight: float = Field(1.0, ge=0.0, description="cost per node at the max slope")
    roughness_weight: float = Field(1.0, ge=0.0, description="cost per node at the max roughness")
    goal_weight: float = Field(1.0, gt=0.0, description="cost per meter of remaining distance to the goal from an arc's end")
    election_threshold: float = Field(15.0, gt=0.0, description="an arc whose summed node cost exceeds this is not electable (15 = 15 nodes at the max slope; 12, a mean of ~20 deg, refused the way out of pits the robot had driven down into at 19 deg)")
    unknown_cell_cost: float = Field(math.inf, allow_inf_nan=True, description="cost of a node whose footprint touches a never-seen cell (infinite: the paper's P3D)")
    obstacle_height_m: float | None = Field(None, gt=0.0, description="a cell is an obstacle when it rises this much (plus the max-slope allowance) above its 3x3 neighbourhood's ground; null: follows the believed robot, min(0.3, max(0.1, wheel radius + ground clearance)) (the RMP 400's 0.3)")
    exempt_current_footprint: bool = Field(True, description="cells under the robot's current (margined) footprint are not checked at the nodes: an obstacle cell dilated into the margin does not forbid driving away from it")
    footprint_margin_m: float = Field(0.0, ge=0.0, le=2.0, description="added on every side of the believed RobotSpec footprint (hard: a node whose margined footprint touches an obstacle is infinite)")
    clearance_margin_m: float = Field(0.3, ge=0.0, le=5.0, description="soft clearance: a node whose footprint grown by this much (beyond the hard margin) touches an obstacle cell costs clearance_cost more")
    clearance_cost: float = Field(0.2, ge=0.0, description="extra node cost when an obstacle lies within the clearance margin")
    arrival_fraction: float = Field(0.5, gt=0.0, le=1.0, description="arrived when the perceived distance to the goal is below this fraction of the mission's tolerance (aims well inside it, so pose error does not lose a success)")
    # --- speed ---
    max_speed_mps: float = Field(1.0, gt=0.0, description="top linear speed (capped by the RobotSpec's max_speed_mps)")
    slowdown_per_cost: float = Field(1.0, ge=0.0, description="speed = max * (1 - min(0.7, slowdown * mean node cost))")
    # --- DTM ---
    cell_m: float = Field(0.3, ge=0.05, le=2.0, description="map cell size")
    obstacle_subcells: int = Field(3, ge=1, le=10, description="the fine obstacle layer splits each map cell into this many x this many sub-cells (3: 0.1 m); footprints are checked against it")
    map_margin_m: float = Field(30.0, ge=5.0, le=1000.0, description="the map grid covers the start-goal bounding box plus this margin on every side")
    max_range_m: float = Field(40.0, gt=0.0, description="lidar points farther than this from the sensor are not integrated")
    base_height_m: float | None = Field(None, description="height of the robot frame origin above the ground, used only to seed cells under the robot when nothing around is known; None = the RobotSpec's wheel radius")
    fill_radius_m: float = Field(3.0, gt=0.0, description="known cells within this radius give the ground plane used to fill never-seen cells under the robot")
    # --- POM ---
    pose_tau_xy_s: float = Field(0.5, gt=0.0, description="time constant pulling the odometry-propagated position (x, y, z) toward the pose sensor (2 s lagged 0.3-0.6 m behind the skid-steer slides on slopes)")
    pose_tau_yaw_s: float = Field(2.0, gt=0.0, description="time constant pulling the yaw toward the pose sensor")
    history_s: float = Field(30.0, gt=0.0, description="how long pose history is kept for placing scans by their time")
    # --- initial scan manoeuvre ---
    scan_turn_deg: float = Field(360.0, ge=0.0, le=720.0, description="turn on the spot at start (0 = none)")
    scan_forward_m: float = Field(3.0, ge=0.0, le=20.0, description="then drive this far straight ahead (0 = none)")
    scan_yaw_rate_rps: float = Field(0.6, gt=0.0, description="turn rate during the scan manoeuvre")
    scan_speed_mps: float = Field(0.5, gt=0.0, description="speed of the forward part of the scan manoeuvre")
    # --- seeds ---
    cost_jitter: float = Field(0.0, ge=0.0, description="uniform noise in [0, cost_jitter) added to each arc cost, drawn from the run seed; 0 = fully deterministic given the observations (the seed is then unused)")

    @model_validator(mode="after")
    def _check(self) -> "ReferenceConfig":
        if self.forward_arcs < 1 or self.forward_arcs % 2 == 0:
            raise SpecError("n_arcs", self.n_arcs,
                            "a number of forward arcs that is odd (so the fan is symmetric and includes straight)",
                            f"use n_arcs={self.n_arcs + 1}" + (" or turn_in_place=false" if not self.turn_in_place else ""))
        if not (self.unknown_cell_cost >= 0.0):
            raise SpecError("unknown_cell_cost", self.unknown_cell_cost, "a cost >= 0 (inf = never drive over unknown)")
        if self.base_height_m is not None and not (0.0 <= self.base_height_m <= 5.0):
            raise SpecError("base_height_m", self.base_height_m, "a height in [0, 5] meters or null")
        return self

    @property
    def forward_arcs(self) -> int:
        """Number of curved/straight forward arcs (n_arcs minus the turn-in-place path)."""
        return self.n_arcs - 1 if self.turn_in_place else self.n_arcs

    @property
    def control_period_s(self) -> float:
        return 1.0 / self.control_rate_hz


class GlobalConfig(ReferenceConfig):
    """Parameters of ``reference-global-v1``: the local planner plus a global cost-to-go.

    The global planner is a Dijkstra wavefront from the goal over the current map (8-connected),
    replanned every ``replan_period_s``: obstacle cells are forbidden, cells within the believed
    footprint's half width plus ``inflation_margin_m`` of an obstacle cost ``inflated_cost_factor``
    times more, never-seen cells are optimistic (``unknown_cost_factor``, 1 = as free ground).
    """

    replan_period_s: float = Field(2.0, gt=0.0, description="period of the global replanning")
    inflation_margin_m: float = Field(0.2, ge=0.0, description="extra inflation around obstacles")
    inflated_cost_factor: float = Field(10.0, ge=1.0, description="cost multiplier of cells near obstacles")
    unknown_cost_factor: float = Field(1.0, ge=1.0, description="cost multiplier of never-seen cells")
    carrot_m: float = Field(4.0, gt=0.0, description="look-ahead along the global path that sets the turn-in-place direction")


def parse_config(data: dict[str, Any], *, cls: type[ReferenceConfig] = ReferenceConfig) -> ReferenceConfig:
    """Validate a mapping into ``cls`` (ReferenceConfig or GlobalConfig); SpecError on bad input."""
    if not isinstance(data, dict):
        raise SpecError("config", data, "a mapping of parameters")
    return parse(cls, data)


def load_config(path: str | Path, *, cls: type[ReferenceConfig] = ReferenceConfig) -> ReferenceConfig:
    """Read a config from a YAML (``.yaml``/``.yml``) or JSON file."""
    p = Path(path)
    data = load_file(p, field="config")  # bounded: size, nesting, aliases (navstress.specfile)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SpecError("config", str(p), "a mapping of parameters at the top level")
    return parse_config(data, cls=cls)


C = TypeVar("C", bound=ReferenceConfig)

#: The thresholds of a robot the RMP 400's size or larger (the paper's figures), and the least any
#: robot gets (below it the lidar's noise on the ground would read as obstacles).
OBSTACLE_HEIGHT_MAX_M, ROUGHNESS_MAX_M, THRESHOLD_MIN_M = 0.3, 0.2, 0.1


def for_robot(config: C, robot: RobotSpec) -> C:
    """``config`` with the thresholds it leaves to the robot (``obstacle_height_m``,
    ``max_roughness_m`` null) set from the believed robot: what its wheels and belly clear,
    ``wheel_radius_m + ground_clearance_m``, bounded to [0.1, 0.3] m and [0.1, 0.2] m. A step the
    robot cannot climb must be an obstacle to its planner: with the RMP 400's fixed 0.3 m, a
    Jackal's lidar 0.3 m above the ground saw box trees as passable and drove into them.

        >>> from navstress.robot import profile
        >>> c = for_robot(ReferenceConfig(), profile("rmp400"))
        >>> (c.obstacle_height_m, c.max_roughness_m)
        (0.3, 0.2)
        >>> c = for_robot(ReferenceConfig(), profile("jackal"))
        >>> (round(c.obstacle_height_m, 4), round(c.max_roughness_m, 4))
        (0.1615, 0.1615)
    """
    clear = robot.wheel_radius_m + robot.ground_clearance_m
    update: dict[str, float] = {}
    if config.obstacle_height_m is None:
        update["obstacle_height_m"] = min(OBSTACLE_HEIGHT_MAX_M, max(THRESHOLD_MIN_M, clear))
    if config.max_roughness_m is None:
        update["max_roughness_m"] = min(ROUGHNESS_MAX_M, max(THRESHOLD_MIN_M, clear))
    return config.model_copy(update=update) if update else config
