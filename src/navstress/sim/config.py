"""SimConfig: time step, friction model, sensor rates, noise and latency of a simulation.

All defaults are the DESIGN "default fidelity". Everything random (noise, rate jitter, command
latency jitter) is drawn from generators derived from the run seed (see
:class:`navstress.sim.simulation.Simulation`); ``noise=False`` and ``jitter=False`` make a run
exactly nominal.

    >>> SimConfig().timestep_s
    0.01
    >>> SimConfig(lidar_enabled=False).lidar_enabled
    False
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from navstress.errors import SpecError
from navstress.sim.lidar import LidarConfig


#: Drive figures that moved from ``sim:`` to the robot (``sim.<key>`` -> ``robot.<field>``).
MOVED_TO_ROBOT: dict[str, str] = {
    "skid_factor": "track_multiplier", "wheel_torque_nm": "wheel_torque_nm", "wheel_kv": "wheel_kv",
    "wheel_armature": "wheel_armature_kgm2", "wheel_hold_gain": "wheel_hold_gain", "yaw_kp": "yaw_kp",
    "yaw_ki": "yaw_ki"}


@dataclass(frozen=True)
class SimConfig:
    """Physics and sensor settings. Rates in Hz, times in seconds, angles in radians."""

    # --- physics (see docs/simulation.md for why) ---
    timestep_s: float = 0.01
    solver_iterations: int = 20
    friction: float = 0.8  # wheel-ground Coulomb coefficient (dry dirt / grass)
    friction_floor: float = 0.05  # smallest directional share of the friction limit
    slip_eps_mps: float = 0.005  # below this slip speed both directions keep full (static) friction
    max_speed_mps: float = 20.0  # any body speed above this is physics instability
    analytic_wheel_contacts: bool = False  # exact sphere-mesh wheel contacts instead of MuJoCo's hfield collision
    obstacle_pool: int = 32  # obstacle slots near the robot in MuJoCo (0: every obstacle, static)
    obstacle_margin_m: float = 1.5  # an obstacle enters the pool this close to the robot's footprint circle
    # --- events ---
    flip_threshold_rad: float = math.radians(60.0)
    map_margin_m: float = 0.7  # the robot "left the map" when its centre is this close to an edge
    collision_debounce_s: float = 0.5
    # --- command path ---
    command_latency_s: float = 0.05
    command_latency_jitter_s: float = 0.02
    # --- sensors ---
    lidar_enabled: bool = True
    lidar: LidarConfig = LidarConfig()  # channels, azimuth steps, rate, range, noise
    odom_rate_hz: float = 50.0
    imu_rate_hz: float = 50.0
    pose_rate_hz: float = 10.0
    rate_jitter: float = 0.05  # each sensor period is scaled by 1 + U(-j, j)
    noise: bool = True
    jitter: bool = True
    pose_pos_std_m: float = 0.05
    pose_att_std_rad: float = 0.01
    imu_att_std_rad: float = 0.002
    imu_rate_std_rps: float = 0.005
    imu_yaw_drift_rps: float = 2e-4  # random-walk intensity of the yaw bias, rad/s/sqrt(s)
    # --- observer ---
    observer_rate_hz: float = 10.0

    def __post_init__(self) -> None:
        if isinstance(self.lidar, dict):  # a mapping from a spec's ``sim: {lidar: {...}}``
            object.__setattr__(self, "lidar", _lidar_from_mapping(self.lidar))
        if not isinstance(self.lidar, LidarConfig):
            raise SpecError("sim.lidar", self.lidar, "a mapping of LidarConfig fields")
        for f in fields(self):
            v = getattr(self, f.name)
            default = f.default
            if isinstance(default, bool):
                if not isinstance(v, bool):
                    raise SpecError(f"sim.{f.name}", v, "true or false")
            elif isinstance(default, int):
                if not isinstance(v, int) or isinstance(v, bool):
                    raise SpecError(f"sim.{f.name}", v, "an integer")
            elif isinstance(default, float):
                if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                    raise SpecError(f"sim.{f.name}", v, "a finite number")
        positive = ("timestep_s", "friction",
                    "odom_rate_hz", "imu_rate_hz", "pose_rate_hz", "observer_rate_hz", "max_speed_mps",
                    "flip_threshold_rad")
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SpecError(f"sim.{name}", v, "a finite number > 0")
        if self.timestep_s > 0.02:
            raise SpecError("sim.timestep_s", self.timestep_s, "at most 0.02 s for stable contacts",
                            "use the default 0.01")
        nonneg = ("friction_floor", "slip_eps_mps", "obstacle_margin_m", "map_margin_m",
                  "collision_debounce_s", "command_latency_s", "command_latency_jitter_s", "rate_jitter",
                  "pose_pos_std_m", "pose_att_std_rad", "imu_att_std_rad", "imu_rate_std_rps",
                  "imu_yaw_drift_rps")
        for name in nonneg:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise SpecError(f"sim.{name}", v, "a finite number >= 0")
        if self.rate_jitter >= 0.5:
            raise SpecError("sim.rate_jitter", self.rate_jitter, "a fraction in [0, 0.5)")
        if not (isinstance(self.obstacle_pool, int) and 0 <= self.obstacle_pool <= 4096):
            raise SpecError("sim.obstacle_pool", self.obstacle_pool, "an integer in [0, 4096] (0: no pool)")
        if not 1 <= self.solver_iterations <= 1000:
            raise SpecError("sim.solver_iterations", self.solver_iterations, "an integer in [1, 1000]")

    @classmethod
    def from_mapping(cls, data: Any) -> "SimConfig":
        """Validate a spec's ``sim:`` mapping (unknown keys, types, ranges); SpecError naming ``sim.<field>``."""
        if not isinstance(data, dict):
            raise SpecError("sim", data, "a mapping of SimConfig fields")
        known = [f.name for f in fields(cls)]
        for k in data:
            if k in MOVED_TO_ROBOT:
                raise SpecError(f"sim.{k}", data[k], "no drive figure in sim: the robot carries it",
                                f"set robot.{MOVED_TO_ROBOT[k]} instead")
            if k not in known:
                raise SpecError(f"sim.{k}", data[k], "a SimConfig field (check its spelling); one of "
                                + ", ".join(known))
        return cls(**data)

    def to_json(self) -> dict[str, Any]:
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["lidar"] = {f.name: getattr(self.lidar, f.name) for f in fields(self.lidar)}
        return out


def _lidar_from_mapping(data: dict[str, Any]) -> LidarConfig:
    known = [f.name for f in fields(LidarConfig)]
    for k in data:
        if k not in known:
            raise SpecError(f"sim.lidar.{k}", data[k], "a LidarConfig field; one of " + ", ".join(known))
    try:
        return LidarConfig(**data)
    except SpecError as err:
        raise SpecError(f"sim.{err.field}", err.value, err.expected, err.fix) from None
