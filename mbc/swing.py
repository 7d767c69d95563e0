r"""Swing-foot trajectories: clearance, soft landing, and retargeting from the measured foot.

Horizontal: a time-to-go law. With the minimum-jerk blend b(s) = 10 s^3 - 15 s^4 + 6 s^5 and the
foot measured at p, the desired position one control period ahead (phase s -> s + ds) is

    p_des = p + (p_target - p) (b(s + ds) - b(s)) / (1 - b(s)),

so the foot arrives at the (possibly moving) target at s = 1 with zero velocity, and the output
depends only on the observed foot, the target and the phase (no stored trajectory).

Vertical, relative to the target's ground height: a lift-and-lower profile with apex `clearance`
at s = `apex_phase` and zero velocity at s = 0 and s = 1; after s = 1 (late touchdown) the foot
keeps descending at `late_descent_mps` to find the ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mbc.errors import ConfigError


def min_jerk(s):
    """Minimum-jerk blend b(s) on [0, 1] (clipped outside), and its derivative db/ds (s: float or array)."""
    s = min(max(s, 0.0), 1.0) if isinstance(s, float) else np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - 2 * s + s**2)


@dataclass(frozen=True)
class SwingConfig:
    """Swing-foot trajectory parameters."""

    clearance_m: float = 0.08
    """Apex height of the sole above the landing height [m]."""
    apex_phase: float = 0.5
    """Phase of the apex."""
    landing_velocity_mps: float = 0.0
    """Downward sole speed at s = 1 (0: soft landing) [m/s]."""
    late_descent_mps: float = 0.3
    """Descent speed after s = 1 while waiting for contact [m/s]."""
    landing_offset_m: float = 0.004
    """The profile ends this far above the landing height: tracking lag and the contact threshold
    otherwise make the foot touch down before s = 1, shortening every step [m]."""

    def __post_init__(self) -> None:
        if self.clearance_m < 0:
            raise ConfigError(f"clearance_m must be >= 0, got {self.clearance_m}")
        if not 0 < self.apex_phase < 1:
            raise ConfigError(f"apex_phase must be in (0, 1), got {self.apex_phase}")


def swing_height(s: float, cfg: SwingConfig, duration: float) -> tuple[float, float]:
    """Height above the landing height and its time derivative at phase s.

    Rise: cubic from (0, 0 m/s) to (h, 0 m/s) on [0, apex]; fall: cubic from (h, 0) to
    (0, -landing_velocity) on [apex, 1]; below: linear descent.
    """
    h, a = cfg.clearance_m, cfg.apex_phase
    if s >= 1.0:
        return -cfg.late_descent_mps * (s - 1.0) * duration, -cfg.late_descent_mps
    if s <= a:
        u = max(s, 0.0) / a
        return h * (3 * u**2 - 2 * u**3), h * (6 * u - 6 * u**2) / (a * duration)
    u = (s - a) / (1 - a)
    span = (1 - a) * duration
    v_end = -cfg.landing_velocity_mps * span  # end slope in units of u
    # Hermite: p(0)=h, p'(0)=0, p(1)=0, p'(1)=v_end
    h00, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - u**2
    d00, d11 = 6 * u**2 - 6 * u, 3 * u**2 - 2 * u
    return h * h00 + v_end * h11, (h * d00 + v_end * d11) / span


def swing_reference(p_measured: np.ndarray, p_target: np.ndarray, phase: float, phase_step: float,
                    duration_s: float, cfg: SwingConfig) -> tuple[np.ndarray, np.ndarray]:
    """Desired sole position one control period ahead and its velocity (world) [m, m/s].

    p_measured: (3,) measured sole; p_target: (3,) landing point (its z is the landing height);
    phase: current phase s; phase_step: ds of one control period; duration_s: step duration T.
    """
    b_now, _ = min_jerk(phase)
    b_next, db_next = min_jerk(phase + phase_step)
    remaining = 1.0 - b_now
    (x, y, _), (x_target, y_target, z_target) = p_measured.tolist(), p_target.tolist()
    dx, dy = x_target - x, y_target - y
    if remaining > 1e-6 and phase < 1.0:
        fraction, rate = (b_next - b_now) / remaining, db_next / (remaining * duration_s)
    else:
        fraction, rate = 1.0, 0.0
    height, velocity_z = swing_height(phase + phase_step, cfg, duration_s)
    position = np.array([x + fraction * dx, y + fraction * dy, z_target + cfg.landing_offset_m + height])
    return position, np.array([rate * dx, rate * dy, velocity_z])


def estimate_phase(height_m: float, vertical_velocity_mps: float, cfg: SwingConfig) -> float:
    """The phase at which the swing profile has this height above the landing height.

    Rising (positive vertical velocity) places it before the apex, falling after it; heights at or
    below the ground read as the end of the swing. For taking over mid-gait from an observed state.
    """
    h = cfg.clearance_m
    if h <= 0:
        return 0.5
    ratio = float(np.clip((height_m - cfg.landing_offset_m) / h, 0.0, 1.0))
    # on either side of the apex the profile is the monotone cubic 3u^2 - 2u^3 (mirrored on the fall)
    u = np.clip(np.roots([-2.0, 3.0, 0.0, -ratio]).real, 0.0, 1.0)
    u = float(u[np.argmin(np.abs(3 * u**2 - 2 * u**3 - ratio))])
    a = cfg.apex_phase
    return u * a if vertical_velocity_mps > 0 else 1.0 - u * (1.0 - a)
