"""The data that crosses the controller/simulator boundary.

`RobotState`, `Command` and `JointCommand` are the contracts of DESIGN.md: every controller maps a
`RobotState` and a `Command` to a `JointCommand`, every simulator produces `RobotState`s.
Joint arrays follow `robots.digit.constants.JOINT_NAMES`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from mbc.errors import ConfigError
from robots.digit.constants import NUM_JOINTS


def _vector(name: str, value, size: int) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (size,):
        raise ConfigError(f"{name} must have shape ({size},), got {array.shape}")
    if not all(map(math.isfinite, array.tolist())):  # exact, and 3x faster than np.isfinite(...).all() on 12
        raise ConfigError(f"{name} must be finite, got {array}")
    return array


@dataclass
class RobotState:
    """Measured state of the robot at one control tick.

    Velocities are in the world frame; joint arrays in `JOINT_NAMES` order.
    """

    time: float
    """Simulation time [s]."""
    base_pos: np.ndarray
    """(3,) pelvis origin in the world [m]."""
    base_quat: np.ndarray
    """(4,) pelvis orientation, w x y z."""
    base_linvel: np.ndarray
    """(3,) pelvis origin linear velocity, world frame [m/s]."""
    base_angvel: np.ndarray
    """(3,) pelvis angular velocity, world frame [rad/s]."""
    q: np.ndarray
    """(12,) leg joint positions [rad]."""
    qd: np.ndarray
    """(12,) leg joint velocities [rad/s]."""
    contact: np.ndarray
    """(2,) bool, left/right foot in contact."""
    foot_force: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """(2,) left/right foot normal contact force [N]."""
    tau: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))
    """(12,) joint torque applied at the last physics step [N m]."""

    def copy(self) -> RobotState:
        """A deep copy (arrays are not shared)."""
        return RobotState(**{k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()})


@dataclass(frozen=True)
class Command:
    """Desired walking velocity: forward and lateral [m/s] in the heading frame, yaw rate [rad/s]."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def __post_init__(self) -> None:
        for name in ("vx", "vy", "yaw_rate"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ConfigError(f"Command.{name} must be a real number, got {value!r} ({type(value).__name__})")
            if not math.isfinite(value):
                raise ConfigError(f"Command.{name} must be finite, got {value}")

    def as_array(self) -> np.ndarray:
        """(3,) [vx, vy, yaw_rate]."""
        return np.array([self.vx, self.vy, self.yaw_rate])


@dataclass(frozen=True)
class CommandLimits:
    """The command range a controller accepts; beyond it commands are clipped and reported."""

    vx_mps: tuple[float, float] = (-0.5, 1.0)
    vy_mps: tuple[float, float] = (-0.3, 0.3)
    yaw_rate_radps: tuple[float, float] = (-0.8, 0.8)
    turn_accel_mps2: float = math.inf
    """Largest |v_xy| |yaw rate|, the centripetal acceleration of walking a curve [m/s^2]: beyond it the
    yaw rate is reduced (the speed is kept)."""

    def __post_init__(self) -> None:
        for name in ("vx_mps", "vy_mps", "yaw_rate_radps"):
            low, high = getattr(self, name)
            if not low <= 0.0 <= high:
                raise ConfigError(f"CommandLimits.{name} must be (low, high) with low <= 0 <= high, got {(low, high)}")
        if not self.turn_accel_mps2 > 0:
            raise ConfigError(f"CommandLimits.turn_accel_mps2 must be positive, got {self.turn_accel_mps2}")

    def clip(self, command: Command) -> tuple[tuple[float, float, float], bool]:
        """The command clipped to the limits as (vx, vy, yaw_rate), and whether it was clipped."""
        raw = (command.vx, command.vy, command.yaw_rate)
        vx, vy = min(max(raw[0], self.vx_mps[0]), self.vx_mps[1]), min(max(raw[1], self.vy_mps[0]), self.vy_mps[1])
        yaw_rate = min(max(raw[2], self.yaw_rate_radps[0]), self.yaw_rate_radps[1])
        speed = math.hypot(vx, vy)
        if speed * abs(yaw_rate) > self.turn_accel_mps2:
            yaw_rate = math.copysign(self.turn_accel_mps2 / speed, yaw_rate)
        clipped = (vx, vy, yaw_rate)
        return clipped, clipped != raw

    def describe(self) -> str:
        turn = f", |v| |yaw rate| <= {self.turn_accel_mps2:g} m/s^2" if math.isfinite(self.turn_accel_mps2) else ""
        return (f"vx {self.vx_mps[0]:g}..{self.vx_mps[1]:g} m/s, vy {self.vy_mps[0]:g}..{self.vy_mps[1]:g} m/s, "
                f"yaw rate {self.yaw_rate_radps[0]:g}..{self.yaw_rate_radps[1]:g} rad/s" + turn)


@dataclass
class JointCommand:
    """Per-joint PD targets and feed-forward torque.

    The simulator applies tau = Kp (q_des - q) + Kd (qd_des - qd) + tau_ff, clipped to the torque
    limits, at the simulation rate. Arrays are validated: shape (12,) and finite.
    """

    q_des: np.ndarray
    qd_des: np.ndarray
    tau_ff: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))

    def __post_init__(self) -> None:
        self.q_des = _vector("JointCommand.q_des", self.q_des, NUM_JOINTS)
        self.qd_des = _vector("JointCommand.qd_des", self.qd_des, NUM_JOINTS)
        self.tau_ff = _vector("JointCommand.tau_ff", self.tau_ff, NUM_JOINTS)

    @classmethod
    def hold(cls, q: np.ndarray) -> JointCommand:
        """Hold joint positions `q` with zero velocity and no feed-forward."""
        return cls(q_des=np.array(q, dtype=float), qd_des=np.zeros(NUM_JOINTS))


CONTROL_PERIOD_S = 0.005
"""The control period of every controller and of `DigitSim.step`: 200 Hz [s]."""


@runtime_checkable
class Controller(Protocol):
    """What drives the robot: the model-based controller and every learned policy.

    `dt` is the control period [s]; `reset` starts from a state (standing or mid-gait); `act` maps the
    measured state and the velocity command to the joint command of this tick. A controller with a
    limited command range says so in a `command_limits: CommandLimits` attribute (`run_episode`
    then records the command it actually followed); one whose targets assume the simulator's PD
    gains says which in `pd_gains: (kp, kd)` (`run_episode` refuses a simulator with other gains)."""

    dt: float

    def reset(self, state: RobotState) -> None: ...

    def act(self, state: RobotState, command: Command) -> JointCommand: ...
