"""Reference2dConfig: every parameter of ``reference-2d-v1`` (Nav2's defaults, rebuilt).

One frozen pydantic model, loaded like the reference stack's (:func:`parse_config`); bad values
raise :class:`~navstress.errors.SpecError` naming ``field=value``. Names follow Nav2's where one
exists (``inflation_radius``, ``cost_scaling_factor``, ``sim_time``, ``vx_samples``...), in SI
units with the unit in the name. The footprint is not a parameter: the costmap inflates by the
:class:`~navstress.robot.RobotSpec` given to ``reset`` (plus ``footprint_padding_m``), so the
paper's footprint fault applies; the speeds and accelerations are capped by the robot's.

    >>> c = Reference2dConfig()
    >>> (c.cell_m, c.cost_scaling_factor, c.vx_samples, c.sim_time_s)
    (0.1, 3.0, 11, 1.7)
    >>> parse_config({"cell_m": 0})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: cell_m=0 is invalid: expected a value >= 0.05
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field, model_validator

from navstress._models import SPEC_CONFIG, parse
from navstress.errors import SpecError

__all__ = ["Reference2dConfig", "parse_config"]


class Reference2dConfig(BaseModel):
    """Parameters of ``reference-2d-v1`` (docs/plugins.md, "reference-2d-v1")."""

    model_config = SPEC_CONFIG

    control_rate_hz: float = Field(10.0, gt=0.0, le=100.0, description="control cycle rate")
    # --- costmap (Nav2 costmap_2d: obstacle layer + inflation layer) ---
    cell_m: float = Field(0.1, ge=0.05, le=1.0, description="costmap resolution (Nav2's 0.05; 0.1 halves the work)")
    map_margin_m: float = Field(10.0, ge=2.0, le=500.0, description="the costmap covers the start-goal box (and the mission area) plus this margin")
    obstacle_max_range_m: float = Field(4.0, gt=0.0, description="returns farther than this are not marked (Nav2 obstacle_max_range 2.5)")
    raytrace_max_range_m: float = Field(5.0, gt=0.0, description="beams clear free space up to this range; a no-return beam clears its whole length up to it (Nav2 raytrace_max_range 3.0)")
    beam_step_deg: float = Field(0.75, ge=0.0, le=10.0, description="beams used at least this far apart (a 0.25 deg scanner: every 3rd); 0 = every beam")
    ground_tolerance_m: float = Field(0.05, ge=0.0, description="a return lower than this above the ground under the robot is a ground hit: it clears, never marks")
    max_slope_deg: float = Field(10.0, gt=0.0, lt=90.0, description="scans taken while the believed body tilts more than this (pitch or roll) only clear (their beams may hit the ground ahead)")
    unknown_cell_cost: float = Field(30.0, ge=0.0, le=252.0, description="cost (0-252) of a never-seen cell to the planners (Nav2 allow_unknown: traversable)")
    footprint_padding_m: float = Field(0.05, ge=0.0, le=1.0, description="added around the believed footprint (Nav2 footprint_padding 0.01)")
    inflation_radius_m: float = Field(0.55, gt=0.0, le=5.0, description="costs decay to zero this far from an obstacle (at least the circumscribed radius + one cell)")
    cost_scaling_factor: float = Field(3.0, gt=0.0, le=100.0, description="cost = 252 exp(-factor (d - inscribed radius)) beyond the inscribed radius")
    # --- global planner (NavFn-style A*) ---
    replan_period_s: float = Field(1.0, gt=0.0, description="global replanning period (Nav2's 1 Hz); also replanned when the path is blocked")
    heuristic_weight: float = Field(1.5, ge=1.0, le=10.0, description="weighted A*: the straight-line heuristic (x the never-seen cell's multiplier) times this; 1 = plain A*, larger plans faster and less optimally (a path at most this factor longer)")
    cost_weight: float = Field(3.0, ge=0.0, description="a step through a cell of cost c costs its length x (1 + cost_weight c / 252)")
    # --- local planner (DWB) ---
    max_speed_mps: float = Field(1.0, gt=0.0, description="top linear speed (capped by the robot's)")
    max_yaw_rate_rps: float = Field(1.5, gt=0.0, description="top turn rate (capped by the robot's)")
    max_accel_mps2: float = Field(2.5, gt=0.0, description="linear acceleration of the dynamic window (capped by the robot's)")
    max_yaw_accel_rps2: float = Field(3.2, gt=0.0, description="angular acceleration of the dynamic window (capped by the robot's)")
    vx_samples: int = Field(11, ge=2, le=100, description="linear velocity samples in the dynamic window")
    vtheta_samples: int = Field(21, ge=3, le=200, description="turn samples (angular velocity, or curvature for an ackermann drive)")
    sim_time_s: float = Field(1.7, gt=0.0, le=10.0, description="rollout horizon")
    sim_step_s: float = Field(0.1, gt=0.0, le=1.0, description="rollout integration step")
    obstacle_weight: float = Field(0.5, ge=0.0, description="BaseObstacle: x mean cost / 252 along the rollout")
    path_dist_weight: float = Field(1.0, ge=0.0, description="PathDist: x distance (m) of the rollout's end from the path")
    path_align_weight: float = Field(1.0, ge=0.0, description="PathAlign: x distance (m) of a point forward_point_m ahead of the end from the path")
    goal_dist_weight: float = Field(1.5, ge=0.0, description="GoalDist: x path length (m) left from the rollout's end")
    speed_weight: float = Field(0.5, ge=0.0, description="x (1 - v / max speed): prefer driving")
    oscillation_weight: float = Field(0.5, ge=0.0, description="a turn whose sign flips the previous command's")
    forward_point_m: float = Field(0.325, ge=0.0, description="PathAlign's forward point (Nav2's 0.325)")
    rotate_to_path_deg: float = Field(45.0, gt=0.0, le=180.0, description="turn in place toward the path first when it lies more than this off the heading (Nav2 RotationShim; never for an ackermann drive)")
    carrot_m: float = Field(1.0, gt=0.0, description="look-ahead along the path for the heading to rotate to")
    arrival_fraction: float = Field(0.5, gt=0.0, le=1.0, description="arrived when the perceived distance to the goal is below this fraction of the mission's tolerance")
    # --- recoveries (Nav2 behaviour tree: clear costmap, spin, back up, wait) ---
    progress_radius_m: float = Field(0.5, gt=0.0, description="progress checker: the robot must move this far (Nav2 required_movement_radius 0.5)...")
    progress_timeout_s: float = Field(5.0, gt=0.0, description="...within this time, else a recovery runs (Nav2 movement_time_allowance 10)")
    max_recoveries: int = Field(6, ge=0, le=100, description="recovery actions without progress before Status error (Nav2 number_of_retries 6)")
    progress_reset_m: float = Field(1.0, gt=0.0, description="getting this much closer to the goal than at the last recovery resets the count")
    clear_keep_radius_m: float = Field(3.0, ge=0.0, description="clearing forgets every cell farther than this from the robot (Nav2 ClearCostmapExceptRegion reset_distance 3.0)")
    spin_rad: float = Field(1.57, gt=0.0, le=6.3, description="spin recovery angle")
    backup_m: float = Field(0.3, gt=0.0, description="back-up recovery distance")
    backup_speed_mps: float = Field(0.1, gt=0.0, description="back-up recovery speed")
    wait_s: float = Field(2.0, ge=0.0, description="wait recovery duration")
    # --- POM (the reference stack's pose filter) ---
    pose_tau_xy_s: float = Field(0.5, gt=0.0, description="time constant pulling the odometry toward the pose sensor (x, y)")
    pose_tau_yaw_s: float = Field(2.0, gt=0.0, description="same, yaw")
    history_s: float = Field(10.0, gt=0.0, description="pose history kept for placing scans by their time")
    # --- seeds ---
    cost_jitter: float = Field(0.0, ge=0.0, description="uniform noise in [0, cost_jitter) added to each rollout's score, drawn from the run seed (0: deterministic given the observations)")

    @model_validator(mode="after")
    def _check(self) -> "Reference2dConfig":
        if self.raytrace_max_range_m < self.obstacle_max_range_m:
            raise SpecError("raytrace_max_range_m", self.raytrace_max_range_m,
                            f"a range >= obstacle_max_range_m={self.obstacle_max_range_m}")
        if self.sim_step_s > self.sim_time_s:
            raise SpecError("sim_step_s", self.sim_step_s, f"a step <= sim_time_s={self.sim_time_s}")
        return self

    @property
    def control_period_s(self) -> float:
        return 1.0 / self.control_rate_hz


def parse_config(data: dict[str, Any]) -> Reference2dConfig:
    """Validate a mapping into :class:`Reference2dConfig`; SpecError on bad input."""
    if not isinstance(data, dict):
        raise SpecError("config", data, "a mapping of parameters")
    return parse(Reference2dConfig, data)
