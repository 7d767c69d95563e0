r"""Digit's motor model, shared by every simulator of the project: torque limit and torque-speed line.

Agility's and roadrunner's simulators give a motor its full torque up to half its no-load speed and
none at it:

    |tau| <= min(tau_max, 2 tau_max (1 - |qd| / qd_0)),   clipped at 0 beyond qd_0,

with tau_max and qd_0 in the coordinates the motor drives (joint torque and speed through the gear).
The closed chain applies it to its motors at every physics step; the open chain to its joints (the
motors seen through the leg's transmission, `robots.digit.constants`) once per control period.
"""

from __future__ import annotations

import numpy as np


class TorqueSpeedLine:
    """The torque limit of each motor at its speed: min(tau_max, max(0, a - b |qd|)), a = 2 tau_max, b = a / qd_0."""

    def __init__(self, torque_limit_nm: np.ndarray, no_load_speed_radps: np.ndarray) -> None:
        self.torque_limit_nm = np.asarray(torque_limit_nm, dtype=float)
        no_load = np.asarray(no_load_speed_radps, dtype=float)
        if self.torque_limit_nm.shape != no_load.shape or np.any(self.torque_limit_nm <= 0) or np.any(no_load <= 0):
            raise ValueError("torque limits and no-load speeds must be positive arrays of one shape")
        self._intercept_nm = 2.0 * self.torque_limit_nm
        self._drop_nm_per_radps = self._intercept_nm / no_load

    def limit(self, speed_radps: np.ndarray) -> np.ndarray:
        """(n,) the largest torque magnitude each motor gives at `speed_radps` [N m]."""
        line = self._intercept_nm - self._drop_nm_per_radps * np.abs(speed_radps)
        return np.minimum(self.torque_limit_nm, np.maximum(line, 0.0))

    def clip(self, torque_nm: np.ndarray, speed_radps: np.ndarray) -> np.ndarray:
        """`torque_nm` clipped to the limit at `speed_radps`."""
        limit = self.limit(speed_radps)
        return np.minimum(np.maximum(torque_nm, -limit), limit)
