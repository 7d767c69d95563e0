"""The command the gait follows: a step in the given command becomes a ramp at bounded rates.

The ALIP foot placement changes the walking velocity by at most about one step's worth per step;
a command that jumps (1 m/s forward to 0.5 m/s backward, or to fast turning) asks for more, and
the robot fell within about a second of such changes in the random velocity test. The ramp moves
the followed command toward the given one by at most `rates * (t - t_last)` per call, per axis: by
the time since the last call, not per call, so a controller asked to act on every k-th state only
(an expert labelling a subset) ramps as fast as one that acts on every tick. Plain floats: it runs in
every control tick (numpy on three numbers cost 14 us of a 0.28 ms tick).
"""

from __future__ import annotations


class CommandRamp:
    """Rate-limits (vx, vy, yaw rate) [m/s, m/s, rad/s] at `rates_per_s` [m/s^2, m/s^2, rad/s^2]."""

    def __init__(self, rates_per_s: tuple[float, float, float]) -> None:
        self.rates = tuple(float(rate) for rate in rates_per_s)
        self.followed: tuple[float, float, float] | None = None
        self.time_s = 0.0

    def reset(self) -> None:
        """Forget the followed command: the next one is followed at once (a start or a takeover)."""
        self.followed = None

    def __call__(self, target: tuple[float, float, float], time_s: float) -> tuple[float, float, float]:
        """The command to follow at `time_s` [s]: at most rates x (time since the last call) from the last
        one toward `target`."""
        if self.followed is None:
            self.followed = tuple(float(v) for v in target)
        else:
            elapsed = max(time_s - self.time_s, 0.0)
            self.followed = tuple(f + min(max(t - f, -rate * elapsed), rate * elapsed)
                                  for f, t, rate in zip(self.followed, target, self.rates))
        self.time_s = time_s
        return self.followed
