"""The velocity error averaged over a gait cycle, which the gait-averaged tracking term reads (`learn.rewards`).

    e_1 <- e_1 + (dt / tau) ((v_xy - v_ramp) - e_1),    e_2 <- e_2 + (dt / tau) (e_1 - e_2)

v_xy is the base velocity in the heading frame and v_ramp the command as the MBC follows it (`mbc.command_ramp`, at
`AlipControllerConfig.command_rates`): a step in the command asks for no jump in velocity. Two first-order stages of
tau = 0.5 s attenuate the lateral sway, at the gait cycle's 0.7 s period, about 20x (1 + (w tau)^2 with w = 9 rad/s)
and lag about 2 tau; one stage of 0.7 s left 0.05 m/s of the MBC's sway, as much as the drift the term is for.
To a constant error u from rest, with a = dt / tau, e_2 after n ticks is u (1 - (1 - a)^n - n a (1 - a)^n).
"""

from __future__ import annotations

from mbc.command_ramp import CommandRamp
from mbc.controller import AlipControllerConfig


class MeanVelocityError:
    """e_2 above [m/s]: `update` it once per control tick, `reset` it at an episode's start. Plain floats: it runs
    in every tick of every environment (numpy on two numbers cost 18 us, a third of a simulator step)."""

    def __init__(self, time_constant_s: float, command_rates: tuple[float, float, float] = AlipControllerConfig.command_rates):
        self.time_constant_s = time_constant_s
        self.ramp = CommandRamp(command_rates)
        self.stages = [0.0, 0.0, 0.0, 0.0]
        """x and y of the first stage, then of the second."""

    def reset(self) -> None:
        self.stages = [0.0, 0.0, 0.0, 0.0]
        self.ramp.reset()

    def update(self, vx_mps: float, vy_mps: float, command: tuple[float, float, float], time_s: float,
               dt_s: float) -> tuple[float, float]:
        """The filtered error (x, y) after this tick's heading-frame velocity under `command` (vx, vy, yaw rate)."""
        followed_x, followed_y, _ = self.ramp(command, time_s)
        a = dt_s / max(self.time_constant_s, dt_s)
        x1, y1, x2, y2 = self.stages
        x1 += a * (vx_mps - followed_x - x1)
        y1 += a * (vy_mps - followed_y - y1)
        x2 += a * (x1 - x2)
        y2 += a * (y1 - y2)
        self.stages = [x1, y1, x2, y2]
        return x2, y2
