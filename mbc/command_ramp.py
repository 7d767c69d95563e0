"""The command the gait follows: a step in the given command becomes a ramp at bounded rates.

The ALIP foot placement changes the walking velocity by at most about one step's worth per step;
a command that jumps (1 m/s forward to 0.5 m/s backward, or to fast turning) asks for more, and
the robot fell within about a second of such changes in the random velocity test. The ramp moves
the followed command toward the given one by at most `rates * dt` per tick, per axis.
"""

from __future__ import annotations

import numpy as np


class CommandRamp:
    """Rate-limits (vx, vy, yaw rate) [m/s, m/s, rad/s] at `rates_per_s` [m/s^2, m/s^2, rad/s^2]."""

    def __init__(self, rates_per_s: tuple[float, float, float], dt: float) -> None:
        self.step = np.asarray(rates_per_s, float) * dt
        self.followed: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the followed command: the next one is followed at once (a start or a takeover)."""
        self.followed = None

    def __call__(self, target: tuple[float, float, float]) -> tuple[float, float, float]:
        """The command to follow this tick, one rate-limited step from the last toward `target`."""
        target = np.asarray(target, float)
        if self.followed is None:
            self.followed = target
        else:
            self.followed = self.followed + np.clip(target - self.followed, -self.step, self.step)
        return tuple(float(v) for v in self.followed)
