"""`HeadingSetpoint`: the heading a walking controller holds, advanced by the followed yaw-rate command.

A controller that turns each step relative to its stance foot (landing yaw = stance yaw + w T) has no
heading feedback: whatever the feet slip in yaw stays. Up a 14 deg incline that slip adds up to a turn
off the fall line (8-24 deg in 16-20 s) and a fall across the slope (docs/design.md, "heading on
inclines"). The setpoint integrates the commanded yaw rate,

    psi_ref(t) = psi_ref(t_0) + integral_{t_0}^{t} w_cmd dt,

so the swing foot can land at psi_ref instead: a zero yaw-rate command then holds the heading. The
setpoint is kept within `max_error_rad` of the measured heading (anti-windup: a robot that cannot
turn, held or pushed round, is not asked for more than that).
"""

from __future__ import annotations

from mbc.geometry import wrap_angle

MAX_HEADING_ERROR_RAD = 0.5
"""Largest |psi_ref - psi| the setpoint keeps [rad] (about 29 deg: two steps of the largest turn)."""


class HeadingSetpoint:
    """psi_ref [rad, world yaw], integrated from the yaw rate followed between updates."""

    def __init__(self, max_error_rad: float = MAX_HEADING_ERROR_RAD) -> None:
        self.max_error_rad = max_error_rad
        self.heading_rad = 0.0
        self._time_s = 0.0
        self._yaw_rate_radps = 0.0

    def reset(self, heading_rad: float, time_s: float) -> None:
        """Hold `heading_rad` from `time_s` on."""
        self.heading_rad, self._time_s, self._yaw_rate_radps = float(heading_rad), float(time_s), 0.0

    def update(self, heading_rad: float, time_s: float, yaw_rate_radps: float) -> float:
        """psi_ref at `time_s`: advanced by the rate followed since the last update (ticks the controller only
        followed included), clamped to within `max_error_rad` of the measured `heading_rad`; `yaw_rate_radps` is
        followed from now on."""
        advanced = self.heading_rad + self._yaw_rate_radps * (time_s - self._time_s)
        error = min(max(wrap_angle(advanced - heading_rad), -self.max_error_rad), self.max_error_rad)
        self.heading_rad, self._time_s, self._yaw_rate_radps = heading_rad + error, float(time_s), float(yaw_rate_radps)
        return self.heading_rad
