"""Physical parameters that randomization varies, and their nominal values."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mbc.errors import ConfigError
from robots.digit.constants import NUM_JOINTS


@dataclass(frozen=True)
class DomainParams:
    """Physical parameters of one simulated robot; the defaults are the nominal model."""

    friction: float = 1.0
    """Scale of every geom's sliding friction coefficient: the friction of feet and ground (1.0 nominal), and a
    terrain's slippery parts (a `board`) scaled alike."""
    mass_scale: np.ndarray | float = 1.0
    """Scale of every link mass and inertia: a scalar or one per body (incl. world) of the model."""
    motor_strength: np.ndarray | float = 1.0
    """Scale of each joint's PD + feed-forward torque: a scalar or (12,)."""
    delay_s: float = 0.0
    """Actuator delay: a new command takes effect this long into the control period [s]."""
    com_offset_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Offset of the pelvis CoM in the pelvis frame [m]."""
    joint_friction_scale: float = 1.0
    """Scale of the leg joints' dry friction (`robots.digit.constants.FRICTIONLOSS_NM`)."""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.friction) and self.friction > 0):
            raise ConfigError(f"friction must be positive and finite, got {self.friction}")
        if np.any(~np.isfinite(self.mass_scale)) or np.any(np.asarray(self.mass_scale) <= 0):
            raise ConfigError(f"mass_scale must be positive and finite, got {self.mass_scale}")
        strength = np.asarray(self.motor_strength, dtype=float)
        if strength.shape not in ((), (NUM_JOINTS,)) or np.any(~np.isfinite(strength)) or np.any(strength <= 0):
            raise ConfigError(f"motor_strength must be a positive scalar or ({NUM_JOINTS},), got {self.motor_strength}")
        if not (np.isfinite(self.delay_s) and self.delay_s >= 0):
            raise ConfigError(f"delay_s must be >= 0, got {self.delay_s}")
        if not (np.isfinite(self.joint_friction_scale) and self.joint_friction_scale >= 0):
            raise ConfigError(f"joint_friction_scale must be >= 0, got {self.joint_friction_scale}")
        if np.asarray(self.com_offset_m).shape != (3,):
            raise ConfigError(f"com_offset_m must have shape (3,), got {np.shape(self.com_offset_m)}")
