r"""The policy's action space: leg PD targets, expressed as the torques they ask for.

The action is the paper's (leg `q_des`, `qd_des`), parameterized so that one unit means the same
torque on every joint. With the simulator's PD law tau = Kp (q_des - q) + Kd (qd_des - qd) + tau_ff,

    a = [Kp (q_des - q), Kd (qd_des - qd)] / tau_max        (24,), dimensionless

so a squared action error is a squared torque error in units of each joint's torque limit: a 0.05 rad
error on a knee (Kp 1200) weighs as much as 60 N m, on an ankle roll (Kp 80) as 4 N m. That is what
matters to the robot (issue 13: position targets carry the walking). `tau_ff` is zero: the policy,
like the expert in PD mode, acts through the targets only.
"""

from __future__ import annotations

import numpy as np

from mbc.types import JointCommand, RobotState
from robots.digit import constants as digit

ACTION_DIM = 2 * digit.NUM_JOINTS


class ActionSpace:
    """Maps normalized actions to `JointCommand`s and back, given the state they act from."""

    def __init__(self, kp: np.ndarray = digit.KP, kd: np.ndarray = digit.KD,
                 torque_scale: np.ndarray = digit.TORQUE_LIMIT_NM) -> None:
        self.kp, self.kd = np.asarray(kp, float), np.asarray(kd, float)
        self.torque_scale = np.asarray(torque_scale, float)
        self._q_per_unit = self.torque_scale / self.kp  # rad per action unit
        self._qd_per_unit = self.torque_scale / self.kd  # rad/s per action unit

    def to_command(self, action: np.ndarray, state: RobotState) -> JointCommand:
        """q_des = q + a[:12] tau_max / Kp, qd_des = qd + a[12:] tau_max / Kd."""
        action = np.asarray(action, float)
        return JointCommand(q_des=state.q + action[:digit.NUM_JOINTS] * self._q_per_unit,
                            qd_des=state.qd + action[digit.NUM_JOINTS:] * self._qd_per_unit)

    def from_command(self, command: JointCommand, state: RobotState) -> np.ndarray:
        """(24,) the action of a PD command (its feed-forward torque folded into the position term)."""
        q_term = (command.q_des - state.q) + command.tau_ff / self.kp
        return np.concatenate([q_term / self._q_per_unit, (command.qd_des - state.qd) / self._qd_per_unit])
