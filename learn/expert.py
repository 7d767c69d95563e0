"""The model-based controller as a labeller: one per environment, fed every visited state in order.

The `AlipController` keeps state between ticks (the gait clock above all), so it must see each state
of an episode once, in order, whichever policy is acting; `reset` at every episode start. Its PD
output (`output="pd"`) is exactly the action space of the policy, so its command converts to an
action without loss. A tick where it fell back to its damped hold gives no label.
"""

from __future__ import annotations

import warnings

import numpy as np

from learn.action import ActionSpace
from mbc.controller import AlipController, AlipControllerConfig, ControllerDiagnostics
from mbc.types import Command, CommandLimits, RobotState


def teacher_command_limits() -> CommandLimits:
    """The commands the expert follows (its range and turning limit); beyond them it acts for clipped ones."""
    return AlipControllerConfig().limits


class Expert:
    """`AlipController` in PD mode, returning normalized actions."""

    def __init__(self, action_space: ActionSpace, **controller_options) -> None:
        self.controller = AlipController.for_digit(output="pd", **controller_options)
        self.action_space = action_space

    def reset(self, state: RobotState, stance: int, phase: float = 0.0) -> None:
        """Start at `state` with the environment's gait clock (stance side, phase), so both clocks agree."""
        self.controller.reset(state, stance=stance, phase=phase)

    def follow(self, state: RobotState) -> None:
        """See `state` without labelling it (its gait clock advances): `AlipController.follow`."""
        self.controller.follow(state)

    def label(self, state: RobotState, command: np.ndarray) -> tuple[np.ndarray, bool]:
        """(24,) the expert's action at `state`, and whether it is a label (False on a fallback tick)."""
        with warnings.catch_warnings():  # a fallback is reported by the flag, not a warning per env
            warnings.simplefilter("ignore", RuntimeWarning)
            joint_command = self.controller.act(state, Command(*command))
        return self.action_space.from_command(joint_command, state), not self.diagnostics.fallback

    def followed(self, command: np.ndarray) -> bool:
        """Whether the last label is the expert's action for `command` itself: not clipped to its range or
        turning limit, not mid-ramp toward it (then it is its action for another command)."""
        used = self.diagnostics.command_used
        return bool(abs(used[0] - command[0]) < 1e-9 and abs(used[1] - command[1]) < 1e-9
                    and abs(used[2] - command[2]) < 1e-9)

    @property
    def diagnostics(self) -> ControllerDiagnostics:
        """The controller's report of the last labelled tick (assumption monitors, QP health)."""
        return self.controller.last_diagnostics
