"""The policy's observation (the paper's), built the same way in training and at deployment.

Layout (`ObservationLayout`, in order): base linear and angular velocity in the base frame, projected
gravity, command (vx, vy, yaw rate), leg joint positions and velocities, gait clock features (sin and
cos of the two-step phase, stance one-hot) from a `GaitClock` fed time and contacts, the previous
action, and the leg joint positions and velocities of the last `history_length` ticks (most recent
first); optionally last, the heading error wrap(psi - psi_ref) [rad] to the commanded yaw rate integrated
(`mbc.heading.HeadingSetpoint`, within +-0.5 rad), which a heading-holding expert steers by. Privileged
quantities (the expert's action, the assumption monitors) are never in it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from learn.action import ACTION_DIM
from learn.config import GAIT_CLOCKS, EnvConfig
from mbc.errors import ConfigError
from mbc.geometry import rotate_inverse, wrap_angle, yaw_of_quaternion
from mbc.heading import HeadingSetpoint
from mbc.timing import LEFT, RIGHT, GaitClock, TimingConfig, is_standing
from mbc.types import RobotState
from robots.digit.constants import NUM_JOINTS

GAIT_FEATURES = 4


def gait_timing(gait_clock: str) -> TimingConfig:
    """The clock's timing for a `learn.config.GAIT_CLOCKS` name: the MBC's, or one whose steps end at phase 1
    exactly (earliest and latest touchdown phase both 1: contacts never end a step early or late)."""
    if gait_clock not in GAIT_CLOCKS:
        raise ConfigError(f"unknown gait clock {gait_clock!r}; choose from {GAIT_CLOCKS}")
    return TimingConfig() if gait_clock == "contact" else TimingConfig(early_touchdown_phase=1.0,
                                                                       late_touchdown_phase=1.0)


@dataclass(frozen=True)
class ObservationLayout:
    """Names and sizes of the observation's parts, in order."""

    history_length: int
    heading_error: bool = False
    """Whether the heading error to the integrated yaw-rate command is the last part."""

    @property
    def parts(self) -> tuple[tuple[str, int], ...]:
        return (("base_linvel", 3), ("base_angvel", 3), ("projected_gravity", 3), ("command", 3),
                ("q", NUM_JOINTS), ("qd", NUM_JOINTS), ("gait", GAIT_FEATURES), ("previous_action", ACTION_DIM),
                ("q_history", NUM_JOINTS * self.history_length), ("qd_history", NUM_JOINTS * self.history_length),
                *((("heading_error", 1),) if self.heading_error else ()))

    @property
    def size(self) -> int:
        return sum(n for _, n in self.parts)

    def slice(self, name: str) -> slice:
        start = 0
        for part, n in self.parts:
            if part == name:
                return slice(start, start + n)
            start += n
        raise KeyError(f"no observation part {name!r}; parts: {[p for p, _ in self.parts]}")


def observation_layout(env: EnvConfig) -> ObservationLayout:
    """The layout a policy of environment `env` observes."""
    return ObservationLayout(env.history_length, env.observe_heading_error)


class ObservationBuilder:
    """Keeps what the observation needs across ticks (gait clock, joint history, previous action)."""

    def __init__(self, history_length: int, timing: TimingConfig | None = None, heading_error: bool = False) -> None:
        self.layout = ObservationLayout(history_length, heading_error)
        self.clock = GaitClock(timing)
        self.heading_setpoint = HeadingSetpoint()
        """psi_ref, as a heading-holding `AlipController` integrates it (used with `layout.heading_error`)."""
        self._q_history: deque[np.ndarray] = deque(maxlen=history_length)
        self._qd_history: deque[np.ndarray] = deque(maxlen=history_length)
        self.previous_action = np.zeros(ACTION_DIM)
        self._last_q, self._last_qd = np.zeros(NUM_JOINTS), np.zeros(NUM_JOINTS)

    def reset(self, state: RobotState) -> None:
        """Start from `state`: history filled with its joints, no previous action; the clock as the
        expert starts it from a stand (`timing.is_standing`: with the weight shift), or, moving on one
        foot, at the start of that foot's stance."""
        contact = np.asarray(state.contact, bool)
        if is_standing(contact, state.base_linvel):
            self.clock.start_standing(state.time, contact)
        else:
            self.clock.reset(state.time, LEFT if contact[LEFT] else RIGHT, 0.0)
        for _ in range(self.layout.history_length):
            self._q_history.append(state.q.copy())
            self._qd_history.append(state.qd.copy())
        self._last_q, self._last_qd = state.q.copy(), state.qd.copy()
        self.previous_action = np.zeros(ACTION_DIM)
        self.heading_setpoint.reset(yaw_of_quaternion(state.base_quat), state.time)

    def observe(self, state: RobotState, command: np.ndarray) -> np.ndarray:
        """(layout.size,) the observation of `state`; advances the clock and the history by one tick."""
        if self.layout.history_length:
            self._q_history.appendleft(self._last_q)
            self._qd_history.appendleft(self._last_qd)
        self._last_q, self._last_qd = state.q.copy(), state.qd.copy()
        self.clock.update(state.time, state.contact)
        quat = state.base_quat
        parts = [rotate_inverse(quat, state.base_linvel), rotate_inverse(quat, state.base_angvel),
                 rotate_inverse(quat, np.array([0.0, 0.0, -1.0])), np.asarray(command, float), state.q, state.qd,
                 self.clock.observation(), self.previous_action, *self._q_history, *self._qd_history]
        if self.layout.heading_error:
            heading = yaw_of_quaternion(quat)
            reference = self.heading_setpoint.update(heading, state.time, float(command[2]))
            parts.append(np.array([wrap_angle(heading - reference)]))
        return np.concatenate(parts)

    def record_action(self, action: np.ndarray) -> None:
        """The action executed after the last observation (it appears in the next one)."""
        self.previous_action = np.asarray(action, float).copy()
