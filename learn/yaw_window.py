"""The yaw rate averaged over a window of about a stride, beside the commanded one: the heading's drift without
the gait's sway.

A walking base yaws back and forth once per stride: RMS 0.10 rad/s on flat ground and 0.20 on a 14 deg climb
(the distilled policy, 0.5 m/s). A fine-tuning's turn off a climb's fall line is a slow drift under that sway,
0.11 rad/s on average (PPF at 5 M steps). Over a window of T seconds,

    w_avg = (psi(t) - psi(t - T)) / T,        w_cmd_avg = (1 / T) int_{t - T}^{t} w_cmd dt,

with psi the unwrapped yaw, a window of one stride cancels the sway and keeps the drift: averaged over 0.8 s the
distilled policy's yaw rate has an RMS of 0.010 rad/s on flat ground and 0.023 on the climb, the drifting PPF's
0.127 (docs/design.md, "heading on inclines"). Until T has passed since the reset the window is what has.
"""

from __future__ import annotations

from collections import deque

from mbc.errors import ConfigError
from mbc.geometry import wrap_angle


class WindowedYawRate:
    """Running `(w_avg, w_cmd_avg)` over the last `window_s`, one update per control tick of `dt_s`."""

    def __init__(self, window_s: float, dt_s: float) -> None:
        if window_s <= 0 or dt_s <= 0:
            raise ConfigError(f"the yaw-rate window and the tick must be positive, got {window_s} s and {dt_s} s")
        self.dt_s = dt_s
        ticks = max(1, round(window_s / dt_s))
        self._yaw = deque(maxlen=ticks + 1)
        """Unwrapped yaw at the window's ticks [rad]."""
        self._commanded = deque(maxlen=ticks + 1)
        """Integral of the commanded yaw rate at the same ticks [rad]."""

    def reset(self, yaw_rad: float) -> None:
        self._yaw.clear()
        self._commanded.clear()
        self._yaw.append(yaw_rad)
        self._commanded.append(0.0)

    def update(self, yaw_rad: float, yaw_rate_command_radps: float) -> tuple[float, float]:
        """Add a tick (the yaw reached, the yaw rate commanded over it); the window's mean yaw rate and mean command."""
        last = self._yaw[-1]
        self._yaw.append(last + wrap_angle(yaw_rad - last))
        self._commanded.append(self._commanded[-1] + yaw_rate_command_radps * self.dt_s)
        span_s = (len(self._yaw) - 1) * self.dt_s
        return (self._yaw[-1] - self._yaw[0]) / span_s, (self._commanded[-1] - self._commanded[0]) / span_s
