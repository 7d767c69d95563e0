"""`AlipController`: ALIP foot placement + whole-body IK + passivity-based QP, one `act` per tick.

One tick (200 Hz):
1. gait clock: stance side and phase from time and contact (touchdown-triggered);
2. ALIP state (x, L) about the stance sole, heading frame; predict (x, L) at touchdown;
3. next foot placement: one-step-ahead law (or the ALIP MPC), clipped to kinematic bounds;
4. swing-foot reference one tick ahead (time-to-go from the measured foot, clearance, soft landing);
5. whole-body IK (placo) -> q_des, qd_des;
6. passivity-based inverse-dynamics QP (proxsuite, pinocchio terms) -> joint torque tau;
7. action-space conversion: the (q_des, qd_des) whose PD gives tau at this tick, so the controller
   acts in the same space as a learned policy (`output="pd"`), or tau itself as tau_ff (`"torque"`).

Everything that persists between ticks follows the observed robot (the gait clock needs only time
and contacts), so the controller can label states produced by other policies. Failures (QP not
solved, IK diverged, non-finite state) never raise: the tick falls back to a damped hold of the
last good targets and is counted in the diagnostics.
"""

from __future__ import annotations

import dataclasses
import math
import operator
import time
import warnings
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mbc.alip import AlipModel, GaitEndMomenta
from mbc.alip_mpc import AlipMpc, AlipMpcConfig, StepReach
from mbc.alip_state import AlipState, alip_state
from mbc.assumptions import AssumptionReport, saturation
from mbc.command_ramp import CommandRamp
from mbc.errors import ConfigError
from mbc.geometry import rotate_z, wrap_angle, yaw_of_quaternion, yaw_of_rotation
from mbc.heading import HeadingSetpoint
from mbc.ik import IkConfig, IkResult, IkTargets, WholeBodyIK
from mbc.passivity import PassivityConfig, PassivityQp, QpResult
from mbc.pd import position_target_for_torque
from mbc.pin_robot import PinRobot
from mbc.swing import SwingConfig, estimate_phase, min_jerk, swing_reference
from mbc.timing import LEFT, RIGHT, GaitClock, TimingConfig, is_standing
from mbc.types import CONTROL_PERIOD_S, Command, CommandLimits, JointCommand, RobotState
from robots.digit import constants as digit

SOLVER_ERRORS = (RuntimeError, ArithmeticError, np.linalg.LinAlgError, ValueError)
"""What the IK (placo: its C++ QPError arrives as RuntimeError), the QP (proxsuite) and linear algebra raise
when they fail: a fallback, not a crash. Anything else is a bug and is raised."""
_JOINT_SPEED_BOUND = (10 * digit.SPEED_LIMIT_RADPS).tolist()
"""Joint speeds beyond 10x the motors' limits mark a state as implausible [rad/s]."""


TURN_ACCEL_LIMIT_MPS2 = 0.3
"""The controller's limit on |v_xy| |yaw rate|: random commands of 0.45-0.83 m/s^2 fell (fast walking or
sideways stepping while turning fast; docs/design.md, "Known limits"), 0.4 walked."""


@dataclass(frozen=True)
class AlipControllerConfig:
    """Parameters of the ALIP walking controller."""

    nominal_com_height_m: float = 0.95
    """ALIP z_bar: the CoM height above the stance sole that the model assumes and the IK holds [m]."""
    step_width_m: float = 0.26
    """Lateral distance between the feet in the periodic gait [m]."""
    max_step_length_m: float = 0.5
    """Bound on the sagittal step (new foot minus stance foot) [m]."""
    min_step_width_m: float = 0.10
    """Smallest lateral distance between the feet at touchdown (no crossing) [m]."""
    max_step_width_m: float = 0.60
    """Largest lateral step; Digit's ALIP controllers clamp to [0.1, 0.6] m. Wide steps are what
    catches a sideways push (0.45 m caught 5 of 10 pushes of 100 N x 0.2 s, 0.6 m 9 of 10)."""
    max_turn_per_step_rad: float = 0.3
    heading_correction_per_step_rad: float = 0.0
    """Largest turn a step adds to w T to land the swing foot at the heading setpoint (`mbc.heading`: the commanded
    yaw rate integrated), so that a zero yaw-rate command holds the heading [rad]. 0 (the default, the distilled
    policies' teacher): each step turns w T from the stance foot, and what the feet slip in yaw stays; up an 8 m
    incline of 14 deg that turned the MBC off the fall line and it fell on 3 of 5 seeds, 16 deg 5 of 5. At 0.1 it
    climbed both 5/5, but fell on every step onto the slippery board under an operator's heading hold
    (`step_slip_15`: 0/5 against 3/5): docs/design.md, "heading on inclines"."""
    command_rates: tuple[float, float, float] = (0.8, 0.8, 1.6)
    """Largest rate of change of the followed command: vx, vy [m/s^2], yaw rate [rad/s^2]
    (`mbc.command_ramp`; inf: none)."""
    ground_tilt_deadband_rad: float = 0.07
    """The stance sole's tilt below this (4 deg) reads as flat ground: the foot rocks a little when
    walking, and on bumpy ground a local tilt extrapolated over a step misplaces the landing."""
    max_ground_tilt_rad: float = 0.35
    """Largest ground slope the landing plane follows [rad]."""
    adapt_step_timing: bool = True
    """With the one-step law: when the step is beyond reach (longer than `max_step_length_m` or wider
    than `max_step_width_m`, after a push), touch down sooner, when the law's step is within reach
    (`AlipModel.time_left_for_step`), down to the pace `timing.min_step_duration_s`. Steps clipped at
    `min_step_width_m` (the legs would cross) are not retimed: a sooner step did not help there."""
    foot_placement: Literal["one_step", "mpc"] = "one_step"
    """One-step-ahead law (default) or the multi-step ALIP MPC with step timing."""
    output: Literal["pd", "torque"] = "pd"
    """Action space: PD targets reproducing the QP torque (the policy's space) or raw torque as tau_ff."""
    kp: np.ndarray = field(default_factory=lambda: digit.KP.copy())
    """(12,) joint stiffness of the simulator, for the action-space conversion."""
    kd: np.ndarray = field(default_factory=lambda: digit.KD.copy())
    limits: CommandLimits = field(default_factory=lambda: CommandLimits(turn_accel_mps2=TURN_ACCEL_LIMIT_MPS2))
    timing: TimingConfig = field(default_factory=TimingConfig)
    swing: SwingConfig = field(default_factory=SwingConfig)
    ik: IkConfig = field(default_factory=IkConfig)
    qp: PassivityConfig = field(default_factory=PassivityConfig)
    mpc: AlipMpcConfig = field(default_factory=AlipMpcConfig)

    def __post_init__(self) -> None:
        if not 0.5 < self.nominal_com_height_m < 1.2:
            raise ConfigError(f"nominal_com_height_m must be in (0.5, 1.2), got {self.nominal_com_height_m}")
        if not 0 < self.min_step_width_m <= self.step_width_m <= self.max_step_width_m:
            raise ConfigError("need 0 < min_step_width_m <= step_width_m <= max_step_width_m")
        if self.heading_correction_per_step_rad < 0:
            raise ConfigError(f"heading_correction_per_step_rad must be >= 0 (0: no heading hold), got "
                              f"{self.heading_correction_per_step_rad}")
        if self.foot_placement not in ("one_step", "mpc"):
            raise ConfigError(f"foot_placement must be 'one_step' or 'mpc', got {self.foot_placement!r}")
        if self.output not in ("pd", "torque"):
            raise ConfigError(f"output must be 'pd' or 'torque', got {self.output!r}")
        if np.any(np.asarray(self.kp) <= 0) and self.output == "pd":
            raise ConfigError("the PD action-space conversion needs positive kp")


@dataclass
class ControllerDiagnostics:
    """What the controller saw and did in one tick."""

    assumptions: AssumptionReport
    stance: int
    phase: float
    touchdown: bool
    alip: AlipState | None
    foot_target_world: np.ndarray
    """(3,) planned landing point of the swing foot [m]."""
    stance_sole_world: np.ndarray
    """(3,) stance sole (the ALIP contact point) [m]."""
    swing_reference_world: np.ndarray
    """(3,) swing sole reference one tick ahead [m]."""
    com_world: np.ndarray
    """(3,) whole-body CoM [m]."""
    command_used: np.ndarray
    """(3,) the command after clipping."""
    command_clipped: bool
    ik_converged: bool
    qp_iterations: int
    fallback: bool
    fallback_count: int
    tau: np.ndarray
    """(12,) the controller's joint torque at this tick [N m]."""
    tick_time_s: dict[str, float]
    """Wall time of the parts: 'alip', 'ik', 'qp', 'total' [s]."""

    @classmethod
    def of_fallback(cls, stance: int, phase: float, command: tuple[float, float, float], clipped: bool,
                    qp_iterations: int, fallback_count: int, total_s: float) -> ControllerDiagnostics:
        """The record of a tick that fell back: no ALIP state, targets or torque (NaN, zero torque)."""
        nan3 = np.full(3, np.nan)
        return cls(assumptions=AssumptionReport.unavailable(), stance=stance, phase=phase, touchdown=False, alip=None,
                   foot_target_world=nan3, stance_sole_world=nan3, swing_reference_world=nan3, com_world=nan3,
                   command_used=np.array(command), command_clipped=clipped, ik_converged=False, qp_iterations=qp_iterations,
                   fallback=True, fallback_count=fallback_count, tau=np.zeros(digit.NUM_JOINTS),
                   tick_time_s={"alip": 0.0, "ik": 0.0, "qp": 0.0, "total": total_s})


class AlipController:
    """ALIP walking controller for Digit; implements the `Controller` protocol at 200 Hz."""

    dt = CONTROL_PERIOD_S

    def __init__(self, config: AlipControllerConfig | None = None) -> None:
        self.config = cfg = config or AlipControllerConfig()
        self.robot = PinRobot()
        self.alip = AlipModel(self.robot.mass, cfg.nominal_com_height_m)
        self.clock = GaitClock(cfg.timing)
        self.ik = WholeBodyIK(cfg.ik, dt=self.dt)
        self.qp = PassivityQp(cfg.qp)
        self._ramp = CommandRamp(cfg.command_rates)
        self.heading_setpoint = HeadingSetpoint()
        self.reach = StepReach(cfg.max_step_length_m, cfg.min_step_width_m, cfg.max_step_width_m)
        self.mpc = AlipMpc(self.alip, cfg.mpc, self.reach, cfg.timing) if cfg.foot_placement == "mpc" else None
        self._kp, self._kd = np.asarray(cfg.kp, float).tolist(), np.asarray(cfg.kd, float).tolist()
        self._gravity_z = float(self.robot.model.gravity.linear[2])  # -9.81 m/s^2
        self._zero_joint_acceleration = np.zeros(digit.NUM_JOINTS)  # qdd_des: the IK gives positions and velocities
        self.gait_end_momenta = GaitEndMomenta(self.alip, cfg.timing.step_duration_s, cfg.step_width_m)
        self._last_q_des = digit.Q_STAND.copy()
        self._shift_start_xy, self._shift_offset_xy = np.zeros(2), np.zeros(2)  # the weight shift's pelvis path
        self.fallback_count = 0
        self.last_diagnostics: ControllerDiagnostics | None = None
        self._started = False

    @classmethod
    def for_digit(cls, **overrides) -> AlipController:
        """The controller with Digit defaults; keyword overrides name `AlipControllerConfig` fields."""
        valid = [f.name for f in dataclasses.fields(AlipControllerConfig)]
        unknown = sorted(set(overrides) - set(valid))
        if unknown:
            raise ConfigError(f"unknown controller option(s) {unknown}; valid: {valid}")
        return cls(AlipControllerConfig(**overrides))

    @property
    def pd_gains(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(kp, kd) the PD action-space conversion assumes the simulator applies; None in torque mode."""
        return (np.asarray(self.config.kp), np.asarray(self.config.kd)) if self.config.output == "pd" else None

    @property
    def command_limits(self) -> CommandLimits:
        """The command range; beyond it commands are clipped (reported in the diagnostics)."""
        return self.config.limits

    # --- Controller protocol ------------------------------------------------------------------------

    def reset(self, state: RobotState, stance: int | None = None, phase: float | None = None) -> None:
        """Start from `state`, standing or mid-gait.

        The stance foot is the only foot in contact, or, with both (or neither) down, the left one.
        A robot at rest or on both feet stands (`timing.is_standing`), and the gait starts with the
        weight shift (`GaitClock.start_standing`); otherwise the phase is read off the swing foot's
        height and vertical velocity on the swing profile (`swing.estimate_phase`). Explicit `stance`
        and `phase` override both.
        """
        contact = np.asarray(state.contact, dtype=bool)
        if stance is None and phase is None and is_standing(contact, state.base_linvel):
            self.clock.start_standing(state.time, contact)
        else:
            stance = (RIGHT if (contact[RIGHT] and not contact[LEFT]) else LEFT) if stance is None else stance
            if phase is None:
                phase = 0.0
                if contact.sum() == 1 and self._plausible_state(state):
                    self.robot.update(state)
                    swing = 1 - stance
                    height = self.robot.sole_position(swing)[2] - self.robot.sole_position(stance)[2]
                    phase = estimate_phase(height, self.robot.sole_velocity(swing)[2], self.config.swing)
            self.clock.reset(state.time, stance, phase)
        if self.clock.shifting_weight:
            self._plan_weight_shift(state)
        q = np.asarray(state.q, dtype=float)
        self._last_q_des = np.where(np.isfinite(q), q, digit.Q_STAND)
        if self._plausible_state(state):
            self.heading_setpoint.reset(yaw_of_quaternion(state.base_quat), state.time)
        self._ramp.reset()
        self.qp.reset()
        if self.mpc is not None:
            self.mpc.reset()
        self.fallback_count = 0
        self._started = True

    def follow(self, state: RobotState) -> None:
        """Advance the gait clock on a tick the controller is not asked to act on (a labeller that
        labels every k-th state still sees every touchdown); the rest of its state is refreshed by
        the next `act`."""
        if not self._started:
            self.reset(state)
        self.clock.update(state.time, state.contact)

    def act(self, state: RobotState, command: Command) -> JointCommand:
        """The joint command for this tick (never raises for solver failures or a bad state)."""
        if not isinstance(command, Command):
            raise ConfigError(f"act expects a Command, got {type(command).__name__}")
        if not self._started:
            self.reset(state)
        start = time.perf_counter()
        command_used, clipped = self.config.limits.clip(command)
        command_used = self._ramp(command_used, state.time)
        if not self._plausible_state(state):
            return self._fallback(command_used, clipped, start, reason="non-finite or implausible state")
        try:
            return self._tick(state, command_used, clipped, start)
        except SOLVER_ERRORS as exc:  # what placo, proxsuite and linear algebra raise; other errors are bugs
            return self._fallback(command_used, clipped, start, reason=f"{type(exc).__name__}: {exc}")

    # --- the tick -------------------------------------------------------------------------------------

    def _tick(self, state: RobotState, command: tuple[float, float, float], clipped: bool, start: float) -> JointCommand:
        """The seven steps of the module docstring, one named method each."""
        robot, clock = self.robot, self.clock
        robot.update(state)
        touchdown = clock.update(state.time, state.contact)  # 1. gait clock
        stance = clock.stance
        stance_sole, stance_rotation = robot.sole_pose(stance)
        heading = yaw_of_quaternion(state.base_quat)
        heading_ref = (self.heading_setpoint.update(heading, state.time, command[2])
                       if self.config.heading_correction_per_step_rad > 0 else heading)
        alip = alip_state(robot, stance_sole, heading)  # 2. ALIP state about the stance sole
        ground_normal = self._ground_normal(stance_rotation)
        if clock.shifting_weight:  # before the first step: both feet down, the CoM rocked onto the gait's orbit
            landing = robot.sole_position(clock.swing)
            targets = self._weight_shift_targets(stance_sole, stance_rotation, ground_normal)
        else:
            landing = self._landing_point(alip, command, stance, stance_sole, ground_normal, heading)  # 3. placement
            targets = self._ik_targets(state, command, landing, stance_sole, stance_rotation, ground_normal,
                                       heading_ref)  # 4. swing
        t_alip = time.perf_counter()
        ik = self.ik.solve(robot.q, targets)  # 5. whole-body IK
        t_ik = time.perf_counter()
        if not all(map(math.isfinite, ik.q_des.tolist() + ik.qd_des.tolist())):
            return self._fallback(command, clipped, start, reason="IK returned non-finite targets")
        result = self._inverse_dynamics(state, ik)  # 6. passivity QP
        t_qp = time.perf_counter()
        if not result.solved:
            return self._fallback(command, clipped, start, reason="QP not solved", qp_iterations=result.iterations)
        joint_command = self._joint_command(state, result.tau, ik.qd_des)  # 7. action-space conversion
        self._last_q_des = ik.q_des
        report = self._assumption_report(alip, result)
        self.last_diagnostics = ControllerDiagnostics(
            assumptions=report, stance=stance, phase=clock.phase, touchdown=touchdown, alip=alip, foot_target_world=landing,
            stance_sole_world=stance_sole, swing_reference_world=targets.swing_position, com_world=robot.com,
            command_used=np.array(command), command_clipped=clipped, ik_converged=ik.converged, qp_iterations=result.iterations,
            fallback=False, fallback_count=self.fallback_count, tau=result.tau,
            tick_time_s={"alip": t_alip - start, "ik": t_ik - t_alip, "qp": t_qp - t_ik, "total": time.perf_counter() - start})
        return joint_command

    def _landing_point(self, alip: AlipState, command: tuple[float, float, float], stance: int, stance_sole: np.ndarray,
                       ground_normal: np.ndarray, heading: float) -> np.ndarray:
        """(3,) world landing point of the swing foot: the step (heading frame) from the stance sole,
        on the plane of the ground under the stance foot."""
        step_x, step_y = self._foot_step(alip, command, stance)
        offset_x, offset_y = rotate_z(step_x, step_y, heading)
        nx, ny, nz = ground_normal.tolist()
        sole_x, sole_y, sole_z = stance_sole.tolist()
        return np.array([sole_x + offset_x, sole_y + offset_y, sole_z - (nx * offset_x + ny * offset_y) / nz])

    def _ik_targets(self, state: RobotState, command: tuple[float, float, float], landing: np.ndarray,
                    stance_sole: np.ndarray, stance_rotation: np.ndarray, ground_normal: np.ndarray,
                    heading_ref: float) -> IkTargets:
        """The swing sole's reference one tick ahead and the IK's other targets. The swing foot lands turned from
        the stance foot by w T, plus at most `heading_correction_per_step_rad` toward psi_ref + w (1 - phase) T (the
        heading setpoint at touchdown), at most `max_turn_per_step_rad` in all."""
        cfg, clock = self.config, self.clock
        swing_sole, swing_rotation = self.robot.sole_pose(clock.swing)
        swing_position, swing_velocity = swing_reference(swing_sole, landing, clock.phase, self.dt / clock.step_duration_s,
                                                         clock.step_duration_s, cfg.swing)
        stance_yaw, swing_yaw_now = yaw_of_rotation(stance_rotation), yaw_of_rotation(swing_rotation)
        turn = command[2] * cfg.timing.step_duration_s
        if cfg.heading_correction_per_step_rad > 0:  # the setpoint at touchdown, relative to that turn
            error = wrap_angle(heading_ref + command[2] * (1.0 - clock.phase) * clock.step_duration_s - stance_yaw - turn)
            turn += min(max(error, -cfg.heading_correction_per_step_rad), cfg.heading_correction_per_step_rad)
        turn = min(max(turn, -cfg.max_turn_per_step_rad), cfg.max_turn_per_step_rad)
        return IkTargets(
            stance=clock.stance, swing_position=swing_position, swing_velocity=swing_velocity,
            swing_yaw=stance_yaw + turn,  # the landing yaw: the light foot turns early in the swing
            ground_normal=ground_normal, pelvis_yaw=stance_yaw + 0.5 * wrap_angle(swing_yaw_now - stance_yaw),
            com_z_world_m=stance_sole[2] + cfg.nominal_com_height_m,
            pelvis_xy=state.base_pos[:2], pelvis_xy_velocity=state.base_linvel[:2])

    def _weight_shift_targets(self, stance_sole: np.ndarray, stance_rotation: np.ndarray,
                              ground_normal: np.ndarray) -> IkTargets:
        """IK targets of the weight shift: both feet where they are, the pelvis carried by
        `_shift_offset_xy` along a minimum-jerk blend, arriving at rest when the first step lifts off."""
        clock, shift_s = self.clock, self.config.timing.weight_shift_s
        s = 1.0 + clock.phase * clock.step_duration_s / shift_s  # 0 at the start of the shift, 1 at lift-off
        blend, blend_rate = min_jerk(s)
        swing_sole, swing_rotation = self.robot.sole_pose(clock.swing)
        return IkTargets(
            stance=clock.stance, swing_position=swing_sole, swing_velocity=np.zeros(3),
            swing_yaw=yaw_of_rotation(swing_rotation), ground_normal=ground_normal, pelvis_yaw=yaw_of_rotation(stance_rotation),
            com_z_world_m=stance_sole[2] + self.config.nominal_com_height_m,
            pelvis_xy=self._shift_start_xy + blend * self._shift_offset_xy,
            pelvis_xy_velocity=blend_rate / shift_s * self._shift_offset_xy)

    def _plan_weight_shift(self, state: RobotState) -> None:
        r"""Where the weight shift carries the pelvis: the CoM over the stance sole sagittally, and
        laterally to y_0 from it, the distance from which the ALIP, released at rest, reaches the gait's
        step-end speed v = L_0 / (m z) in the first step's duration T_1:

            y(t) = y_0 cosh(w t),  y'(T_1) = y_0 w sinh(w T_1) = v  =>  y_0 = v / (w sinh(w T_1))

        (about 7.5 cm for Digit, against 13 cm when standing: without the shift the first step starts
        on a fall that a full step lets grow to 0.6 m/s)."""
        self._shift_start_xy = np.array(state.base_pos[:2], dtype=float)
        self._shift_offset_xy = np.zeros(2)
        if not self._plausible_state(state):
            return
        self.robot.update(state)
        stance = self.clock.stance
        heading = yaw_of_quaternion(state.base_quat)
        alip = alip_state(self.robot, self.robot.sole_position(stance), heading)
        omega, first_step_s = self.alip.omega, self.config.timing.first_step_duration_s
        y_0 = self.gait_end_momenta.lateral / self.alip.mz / (omega * math.sinh(omega * first_step_s))
        x, y = alip.x.tolist()  # CoM from the stance sole, heading frame
        toward_stance = -math.copysign(1.0, y) if y else 0.0
        lateral = toward_stance * max(abs(y) - y_0, 0.0)
        self._shift_offset_xy = np.array(rotate_z(-x, lateral, heading))

    def _inverse_dynamics(self, state: RobotState, ik: IkResult) -> QpResult:
        """The passivity QP's joint torques tracking the IK; the swing foot counts as a contact in the
        weight shift and in the double support just after touchdown."""
        clock = self.clock
        swing_loaded = clock.shifting_weight or (bool(state.contact[clock.swing]) and clock.phase < 0.1)
        contact = (True, swing_loaded) if clock.stance == LEFT else (swing_loaded, True)
        problem, sliding = self.qp.build(self.robot, contact, ik.q_des, ik.qd_des, self._zero_joint_acceleration)
        return self.qp.solve(self.robot, problem, sliding)

    def _joint_command(self, state: RobotState, tau: np.ndarray, qd_des: np.ndarray) -> JointCommand:
        """PD mode: the position targets whose PD torque is `tau` at this state, with the IK's velocity
        targets; torque mode: `tau` as feed-forward over a PD that holds the state."""
        if self.config.output == "torque":
            return JointCommand(q_des=state.q.copy(), qd_des=state.qd.copy(), tau_ff=tau)
        q_des = position_target_for_torque(tau.tolist(), qd_des.tolist(), state.q.tolist(), state.qd.tolist(),
                                           self._kp, self._kd)
        return JointCommand(q_des=np.array(q_des), qd_des=qd_des)

    def _assumption_report(self, alip: AlipState, result: QpResult) -> AssumptionReport:
        """How far the robot is from the ALIP's assumptions this tick, and the QP's health."""
        robot = self.robot
        # Newton for the whole body (the QP satisfies the floating-base rows): m c'' = sum f + m g
        com_vertical_acceleration = result.vertical_force() / robot.mass + self._gravity_z
        return AssumptionReport(
            com_height_error_m=float(alip.com_height_above_contact_m - self.config.nominal_com_height_m),
            com_vertical_velocity_mps=float(alip.com_velocity[2]),
            com_vertical_acceleration_mps2=float(com_vertical_acceleration),
            stance_slip_speed_mps=robot.sole_horizontal_speed(self.clock.stance),
            centroidal_angular_momentum=math.hypot(*robot.centroidal_angular_momentum.tolist()),
            qp_solved=True, torque_saturation=saturation(result.tau, digit.TORQUE_LIMIT_NM))

    def _ground_normal(self, stance_sole_rotation: np.ndarray) -> np.ndarray:
        """The ground's normal under the stance foot, which lies flat on it: the sole's z axis.

        Tilts below the deadband read as flat; larger ones are clipped to the largest slope."""
        normal = stance_sole_rotation[:, 2]
        tilt = math.acos(min(max(normal[2], -1.0), 1.0))
        if tilt < self.config.ground_tilt_deadband_rad:
            return np.array([0.0, 0.0, 1.0])
        if tilt > self.config.max_ground_tilt_rad:
            limit = self.config.max_ground_tilt_rad
            scale = math.sin(limit) / math.hypot(normal[0], normal[1])
            return np.array([scale * normal[0], scale * normal[1], math.cos(limit)])
        return normal

    def _foot_step(self, alip: AlipState, command: tuple[float, float, float], stance: int) -> tuple[float, float]:
        """Next foot position relative to the stance sole (heading frame: x, y) [m], by the MPC or the
        one-step law, within reach."""
        swing_side = 1.0 if stance == RIGHT else -1.0  # the swing foot lands to the left (+1) or right (-1)
        L_des = self.gait_end_momenta(command, swing_side)  # the swing foot becomes the stance foot (+1 left)
        if self.mpc is not None:
            return self._mpc_step(alip, command, swing_side, L_des[0])
        return self._one_step_law_step(alip, swing_side, L_des)

    def _mpc_step(self, alip: AlipState, command: tuple[float, float, float], swing_side: float,
                  Lx_des: float) -> tuple[float, float]:
        """The MPC's first step, within reach; the touchdown retimed as the MPC plans it."""
        signs = swing_side * (-1.0) ** np.arange(self.mpc.config.horizon_steps)  # stance sides of the planned steps
        sequence = np.c_[np.full(len(signs), Lx_des), self.gait_end_momenta(command, signs)[1]]
        solution = self.mpc.solve(alip.x, alip.L, self.clock.time_in_step_s, -int(swing_side), sequence)
        if solution.time_left_s > 0.0:
            self.clock.retime(solution.time_left_s)
        step_x, step_y = solution.steps_m[0].tolist()
        return self.reach.clip(step_x, step_y, swing_side)

    def _one_step_law_step(self, alip: AlipState, swing_side: float, L_des: tuple[float, float]) -> tuple[float, float]:
        """The one-step-ahead law's step, within reach; with step-timing adaptation, a step beyond reach
        (after a push) is taken sooner, when the law's step fits (`AlipModel.time_left_for_step`)."""
        cfg, clock = self.config, self.clock
        (x, y), (Lx, Ly), (Lx_des, Ly_des) = alip.x.tolist(), alip.L.tolist(), L_des
        time_left = clock.time_to_touchdown_s
        step_x, step_y = self._law_step(x, y, Lx, Ly, Lx_des, Ly_des, time_left)
        clipped_x, clipped_y = self.reach.clip(step_x, step_y, swing_side)
        beyond_reach_x, beyond_reach_y = clipped_x != step_x, swing_side * step_y > cfg.max_step_width_m
        earliest = (1.0 - clock.phase) * cfg.timing.min_step_duration_s
        if not (cfg.adapt_step_timing and (beyond_reach_x or beyond_reach_y) and 0.0 < earliest < time_left):
            return clipped_x, clipped_y  # (a late step is not retimed)
        sooner = time_left
        if beyond_reach_x:
            sooner = self._time_left_to_fit(x, Lx, Lx_des, clipped_x, step_x, time_left, earliest)
        if beyond_reach_y:
            sooner = min(sooner, self._time_left_to_fit(y, Ly, Ly_des, clipped_y, step_y, time_left, earliest))
        if sooner >= time_left:
            return clipped_x, clipped_y
        clock.retime(sooner)
        return self.reach.clip(*self._law_step(x, y, Lx, Ly, Lx_des, Ly_des, clock.time_to_touchdown_s), swing_side)

    def _law_step(self, x: float, y: float, Lx: float, Ly: float, Lx_des: float, Ly_des: float,
                  time_left: float) -> tuple[float, float]:
        """`AlipModel.one_step_placement` on both axes for a touchdown `time_left` from now."""
        model, T = self.alip, self.config.timing.step_duration_s
        return model.one_step_placement(x, Lx, time_left, Lx_des, T), model.one_step_placement(y, Ly, time_left, Ly_des, T)

    def _time_left_to_fit(self, x: float, L: float, L_des: float, bound: float, step: float, time_left: float,
                          earliest: float) -> float:
        """Time to touchdown at which the one-step law's `step` on one axis comes within the reach `bound`
        it was clipped to: the latest such time from `earliest` on, else `earliest` if that brings it closer."""
        model, T = self.alip, self.config.timing.step_duration_s
        fit = model.time_left_for_step(x, L, L_des, T, bound, earliest, time_left)
        if fit is not None:
            return fit
        closer = abs(model.one_step_placement(x, L, earliest, L_des, T) - bound) < abs(step - bound)
        return earliest if closer else time_left

    # --- failures -------------------------------------------------------------------------------------

    @staticmethod
    def _plausible_state(state: RobotState) -> bool:
        """Finite, a usable quaternion, and speeds a walking robot can have (10x the motors' limits)."""
        quat, linvel, angvel = state.base_quat.tolist(), state.base_linvel.tolist(), state.base_angvel.tolist()
        qd = state.qd.tolist()
        values = state.base_pos.tolist() + quat + linvel + angvel + state.q.tolist() + qd
        if not (math.isfinite(state.time) and all(map(math.isfinite, values))):
            return False
        return (math.hypot(*quat) > 1e-6 and math.hypot(*linvel) < 20.0 and math.hypot(*angvel) < 50.0
                and all(map(operator.lt, map(abs, qd), _JOINT_SPEED_BOUND)))

    def _fallback(self, command: tuple[float, float, float], clipped: bool, start: float, reason: str,
                  qp_iterations: int = 0) -> JointCommand:
        """Damped hold of the last good joint targets."""
        self.fallback_count += 1
        if self.fallback_count == 1:
            warnings.warn(f"AlipController fell back to a damped hold ({reason})", RuntimeWarning, stacklevel=3)
        self.last_diagnostics = ControllerDiagnostics.of_fallback(
            self.clock.stance, self.clock.phase, command, clipped, qp_iterations, self.fallback_count,
            time.perf_counter() - start)
        return JointCommand.hold(self._last_q_des)
