"""`ClosedChainDigitSim`: Digit's closed-chain leg behind `DigitSim`'s interface (`robot="digit_closed_chain"`).

Controllers keep the open chain's `RobotState` and `JointCommand`; this simulator translates
(`mbc.sim.closed_chain_maps`). Each control period, with M = d q_open / d q_motor (6 x 6 per leg, loops
closed, springs rigid) at the measured state (q, qd) = (q_open, qd_open) and motors at (q_m0, qd_m0):

1. the command map: the open chain's PD law at the mapped state, tau = Kp (q_des - q) + Kd (qd_des - qd)
   + tau_ff, becomes the motor torque M^T tau (virtual work), and the motors keep the same stiffness
   and damping as the joints while they move within the period, K_m = M^T Kp M, D_m = M^T Kd M:

       tau_m(t) = M^T tau - K_m (q_m(t) - q_m0) - D_m (qd_m(t) - qd_m0);

   so the joint torque a command asks for is the open chain's exactly at every control tick, however
   far `q_des` is from the state (a target is an offset of the joints, not a pose the loop's inverse
   kinematics must reach);
2. at every physics step (0.5 ms) that torque goes through a delay line of 6 physics steps (3 ms) and
   is clipped by the motor model both simulators share (`mbc.sim.motor`: full torque up to half the
   no-load speed of the facts, none at it);
3. the state map turns the closed chain's feet into open-chain joints (foot-pose IK).

`springs=False` welds the shin and heel springs; `delay=False` removes the 3 ms torque delay: the
switches that say which part of the closed chain a controller fails on.
"""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np

from mbc.errors import ConfigError
from mbc.robot import JointMap, as_slice
from mbc.sim.closed_chain_maps import ClosedChainLegs, OpenChainLegs, stand_qpos
from mbc.sim.closed_chain_model import SIDES, SPRING_JOINTS, closed_chain_mjspec
from mbc.sim.digit_sim import DigitSim, SimConfig
from mbc.sim.motor import TorqueSpeedLine
from mbc.types import JointCommand, RobotState
from robots.digit import closed_chain_constants as cc
from robots.digit import constants as digit

_MOTORS = cc.LEG_MOTORS + cc.LEG_MOTORS
MOTOR_LINE = TorqueSpeedLine([m.torque_limit_nm for m in _MOTORS], [m.no_load_speed_radps for m in _MOTORS])
"""The motors' torque limits and torque-speed lines (motor coordinates)."""


class ClosedChainDigitSim(DigitSim):
    """Simulated closed-chain Digit; see the module docstring. Extra keywords: `springs`, `delay`."""

    robot_name = "digit_closed_chain"

    def __init__(self, terrain="flat", *, springs: bool = True, delay: bool = True, **kwargs) -> None:
        self.springs, self.torque_delay_steps = springs, cc.TORQUE_DELAY_STEPS if delay else 0
        super().__init__(terrain, **kwargs)

    @classmethod
    def default_config(cls) -> SimConfig:
        return SimConfig(timestep_s=cc.TIMESTEP_S)

    def _robot_spec(self) -> mujoco.MjSpec:
        return closed_chain_mjspec(springs=self.springs)

    def _bind_robot(self) -> None:
        m = self.model
        self.legs = ClosedChainLegs(m)  # kinematics only: its own MjData, the simulator's model
        self.open_legs = OpenChainLegs()
        motor_joints = m.actuator_trnid[:, 0]
        self._motor_q = as_slice(m.jnt_qposadr[motor_joints])
        self._motor_v = as_slice(m.jnt_dofadr[motor_joints])
        self._spring_q = m.jnt_qposadr[[m.joint(f"{side}_{name}").id for side in SIDES for name in SPRING_JOINTS]]
        self.joint_map = JointMap(q=self._motor_q, v=self._motor_v)
        """The motors' columns in qpos and qvel (the joints the simulator drives; not the open chain's)."""
        self._stand_qpos = self.stand_qpos()
        self._qpos_solved = self._stand_qpos.copy()  # warm start of `set_state`'s loop solve
        self._q_open, self._qd_open = digit.Q_STAND.copy(), np.zeros(12)  # the last state handed out
        self._jacobians = np.tile(np.eye(6), (2, 1, 1))  # M per leg, refreshed by `state`
        self._targets = (self._stand_qpos[self._motor_q].copy(), np.zeros(12), np.zeros(12))
        self._stiffness, self._damping = np.zeros((12, 12)), np.zeros((12, 12))
        self._torques: deque[np.ndarray] = deque()

    def stand_qpos(self) -> np.ndarray:
        """The closed chain in the open chain's stand: loops closed, springs at rest, both feet where the open
        chain's are at `Q_STAND` (pelvis at the origin)."""
        qpos = stand_qpos(self.legs)
        qpos[self._spring_q] = 0.0
        return self.legs.solve(qpos, self.legs.loop_dofs, self.open_legs.foot_poses(digit.Q_STAND), strict=True)

    # --- episode -------------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> RobotState:
        """The stand of the open chain (same pelvis height, feet flat on the terrain), at rest."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_kinematics(self.model, self.data)
        self._qpos_solved = self._stand_qpos.copy()
        self.data.qpos[:] = self._qpos_solved
        self.data.qpos[:3] = [0.0, 0.0, self.terrain_height(0.0, 0.0) + digit.PELVIS_HEIGHT_STAND_M + 0.002]
        self._q_open = digit.Q_STAND.copy()
        self._push_substeps_left = 0
        self._torques = deque()
        mujoco.mj_forward(self.model, self.data)
        state = self.state()
        self._command_motors(JointCommand.hold(digit.Q_STAND))
        return state

    def step(self, command: JointCommand) -> RobotState:
        """Apply `command` (open-chain joints) for one control period and return the new state."""
        if not isinstance(command, JointCommand):
            raise ConfigError(f"step expects a JointCommand, got {type(command).__name__}")
        self._command_motors(command)
        delay = self.torque_delay_steps + self._delay_substeps  # the domain's delay adds to the motors'
        while len(self._torques) < delay:
            self._torques.appendleft(np.zeros(12))
        while len(self._torques) > delay:
            self._torques.popleft()
        for _ in range(self.config.substeps):
            self._torques.append(self._motor_torque())
            self.data.ctrl[:] = MOTOR_LINE.clip(self._torques.popleft(), self.data.qvel[self._motor_v])
            self._advance(1)
        if self._viewer is not None:
            self._viewer.sync()
        return self.state()

    def _command_motors(self, command: JointCommand) -> None:
        """Motor torque at the period's start and the motor stiffness and damping about it (module docstring, 1)."""
        torque = self._kp * (command.q_des - self._q_open) + self._kd * (command.qd_des - self._qd_open) + command.tau_ff
        feedforward = np.empty(12)
        for side, jacobian in enumerate(self._jacobians):
            leg = slice(6 * side, 6 * side + 6)
            feedforward[leg] = jacobian.T @ torque[leg]
            self._stiffness[leg, leg] = (jacobian.T * self._kp[leg]) @ jacobian
            self._damping[leg, leg] = (jacobian.T * self._kd[leg]) @ jacobian
        self._targets = (self.data.qpos[self._motor_q].copy(), self.data.qvel[self._motor_v].copy(), feedforward)

    def _motor_torque(self) -> np.ndarray:
        """tau_m(t) = M^T tau - K_m (q_m - q_m0) - D_m (qd_m - qd_m0) this physics step, times the motor strength."""
        q0, qd0, feedforward = self._targets
        qd = self.data.qvel[self._motor_v]
        tau = feedforward - self._stiffness @ (self.data.qpos[self._motor_q] - q0) - self._damping @ (qd - qd0)
        return self._strength * tau

    # --- state -----------------------------------------------------------------------------------

    def state(self) -> RobotState:
        """The open-chain `RobotState` of the closed chain (module docstring, 3)."""
        d = self.data
        legs, open_legs = self.legs, self.open_legs
        legs.set(d.qpos)
        poses = [legs.foot_pose(side) for side in range(2)]
        self._q_open = open_legs.inverse(poses, self._q_open)
        self._qd_open = qd = np.empty(12)
        leg_velocity = d.qvel.copy()
        leg_velocity[:6] = 0.0
        tau = np.empty(12)
        for side in range(2):
            leg = slice(6 * side, 6 * side + 6)
            open_jacobian = open_legs.jacobian(side)
            self._jacobians[side] = legs.motor_jacobian(side, open_jacobian)
            qd[leg] = self._jacobians[side] @ d.qvel[self._motor_v][leg]
            tau[leg] = np.linalg.solve(self._jacobians[side].T, d.actuator_force[leg])
        force = d.sensordata[self._touch_adr]
        return RobotState(
            time=d.time, base_pos=d.qpos[:3].copy(), base_quat=d.qpos[3:7].copy(), base_linvel=d.qvel[:3].copy(),
            base_angvel=d.xmat[self._pelvis].reshape(3, 3) @ d.qvel[3:6], q=self._q_open.copy(), qd=qd,
            contact=force > self.config.contact_threshold_n, foot_force=force, tau=tau,
        )

    def set_state(self, state: RobotState) -> None:
        """Put the closed chain where `state` says (loops closed, springs at rest; leg rates through M^-1)."""
        d = self.data
        self._qpos_solved = self.legs.solve(self._qpos_solved, self.legs.loop_dofs, self.open_legs.foot_poses(state.q))
        d.qpos[:] = self._qpos_solved
        d.qpos[:3], d.qpos[3:7] = state.base_pos, state.base_quat / np.linalg.norm(state.base_quat)
        mujoco.mj_kinematics(self.model, d)
        d.qvel[:] = 0.0
        d.qvel[:3] = state.base_linvel
        d.qvel[3:6] = d.xmat[self._pelvis].reshape(3, 3).T @ state.base_angvel
        self._q_open = np.array(state.q, dtype=float)
        self.state()  # the motor Jacobians at this configuration
        for side, jacobian in enumerate(self._jacobians):
            leg = slice(6 * side, 6 * side + 6)
            d.qvel[self.legs.leg_dofs[side]] = self.legs.leg_rates(side, np.linalg.solve(jacobian, state.qd[leg]))
        d.time = state.time
        mujoco.mj_forward(self.model, d)
        self._qd_open = np.array(state.qd, dtype=float)

    # --- randomization hooks -----------------------------------------------------------------------

    def _set_gains(self, kp: np.ndarray, kd: np.ndarray) -> None:
        """`kp`, `kd` are the open chain's joint gains (what a `JointCommand` means); the motor gains follow
        from them each control period."""
        self._kp, self._kd = np.array(kp, dtype=float), np.array(kd, dtype=float)
