"""RobotSpec: the physical robot the simulator simulates (its truth).

A navigator is told a RobotSpec too; usually the same one. Telling it another one
(e.g. a smaller footprint) is how the paper's footprint fault is injected.

Defaults are a Segway RMP 400 class platform (the paper's Mana): four-wheel skid steer,
footprint 1.14 m x 0.67 m.

    >>> r = RobotSpec()
    >>> (r.length_m, r.width_m)
    (1.14, 0.67)
    >>> RobotSpec.footprint_fault().length_m
    0.84
"""

from __future__ import annotations

from pydantic import BaseModel, Field

from navstress._models import SPEC_CONFIG


class LidarMount(BaseModel):
    """Where the 3D lidar sits on the robot (robot frame: x forward, y left, z up from base)."""

    model_config = SPEC_CONFIG
    x_m: float = 0.35
    y_m: float = 0.0
    z_m: float = 0.75  # above the chassis origin


class RobotSpec(BaseModel):
    """Geometry, mass and limits of the robot. All lengths in meters, SI units throughout."""

    model_config = SPEC_CONFIG

    name: str = "rmp400"
    length_m: float = Field(1.14, gt=0, description="footprint length (x)")
    width_m: float = Field(0.67, gt=0, description="footprint width (y)")
    body_height_m: float = Field(0.45, gt=0, description="chassis box height")
    mass_kg: float = Field(110.0, gt=0, description="total mass (RMP 400: ~110 kg)")
    wheel_radius_m: float = Field(0.265, gt=0, description="wheel radius (21 in tyres)")
    wheel_width_m: float = Field(0.15, gt=0)
    wheelbase_m: float = Field(0.62, gt=0, description="front-rear axle distance")
    track_m: float = Field(0.55, gt=0, description="left-right wheel centre distance")
    max_speed_mps: float = Field(1.2, gt=0, description="top linear speed used by navigation")
    max_yaw_rate_rps: float = Field(1.0, gt=0, description="top turn rate")
    max_accel_mps2: float = Field(1.0, gt=0, description="linear acceleration limit")
    max_yaw_accel_rps2: float = Field(2.0, gt=0, description="angular acceleration limit")
    lidar: LidarMount = LidarMount()

    @property
    def half_diagonal_m(self) -> float:
        return float(0.5 * (self.length_m**2 + self.width_m**2) ** 0.5)

    @classmethod
    def footprint_fault(cls) -> "RobotSpec":
        """The paper's faulty belief: the robot is 0.84 m x 0.45 m."""
        return cls(name="rmp400-small-belief", length_m=0.84, width_m=0.45)
