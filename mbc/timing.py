"""Gait phase and step timing: a nominal period, with touchdown detected from contact.

A step starts when the swing foot touches down. Within a step the phase s runs from 0 to 1 at the
pace 1 / T. `retime` changes the time left in the step (step-timing adaptation) by changing the
pace from then on, so the phase, and with it the swing profile, stays continuous. Touchdown is
accepted once s >= `early_touchdown_phase` (early touchdown ends the step where it happens); if the
swing foot has not touched down by s = 1 the step goes on (late touchdown: the swing trajectory
keeps lowering the foot) until contact or `late_touchdown_phase`, when the step is ended
regardless. The clock follows the observed robot: it only needs the time and the contact flags, so
it can be started mid-gait.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mbc.errors import ConfigError

LEFT, RIGHT = 0, 1
STANDING_SPEED_MPS = 0.1
"""A robot whose pelvis moves slower than this, or with both feet (or none) in contact, is standing [m/s]."""


def is_standing(contact: np.ndarray, base_linvel: np.ndarray) -> bool:
    """Whether a gait starting here starts from a stand (with the weight shift) rather than mid-step."""
    return int(np.count_nonzero(contact)) != 1 or math.hypot(*np.asarray(base_linvel, float).tolist()) < STANDING_SPEED_MPS


@dataclass(frozen=True)
class TimingConfig:
    """Step timing parameters."""

    step_duration_s: float = 0.35
    """Nominal step duration T [s] (Digit controllers use 0.30-0.40 s)."""
    early_touchdown_phase: float = 0.6
    """Earliest phase at which swing-foot contact ends the step."""
    late_touchdown_phase: float = 1.4
    """Phase at which the step ends even without swing-foot contact."""
    min_step_duration_s: float = 0.25
    """Fastest pace `retime` may set: the rest of a step takes at least (1 - s) times this [s]."""
    weight_shift_s: float = 0.35
    """Double support before the first step from a stand [s]: the clock starts at phase
    -weight_shift_s / step_duration_s, and the controller shifts the CoM toward the stance foot."""
    first_step_duration_s: float = 0.2
    """Duration of the first step after the weight shift [s]: from rest, a short step reaches the
    gait's lateral speed without overshooting it (see `AlipController`)."""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.step_duration_s) and self.step_duration_s > 0):
            raise ConfigError(f"step_duration_s must be positive, got {self.step_duration_s}")
        if not 0 < self.min_step_duration_s <= self.step_duration_s:
            raise ConfigError(f"need 0 < min_step_duration_s <= step_duration_s, got {self.min_step_duration_s}")
        if not (math.isfinite(self.weight_shift_s) and self.weight_shift_s >= 0):
            raise ConfigError(f"weight_shift_s must be >= 0, got {self.weight_shift_s}")
        if not (math.isfinite(self.first_step_duration_s) and self.first_step_duration_s > 0):
            raise ConfigError(f"first_step_duration_s must be positive, got {self.first_step_duration_s}")
        if not 0 < self.early_touchdown_phase <= 1 <= self.late_touchdown_phase:
            raise ConfigError("need 0 < early_touchdown_phase <= 1 <= late_touchdown_phase, got "
                              f"{self.early_touchdown_phase}, {self.late_touchdown_phase}")


class GaitClock:
    """Stance side and phase of the current step, advanced by time and contact."""

    def __init__(self, config: TimingConfig | None = None) -> None:
        self.config = config or TimingConfig()
        self.stance = LEFT
        self.step_start_s = 0.0
        """When the current step began (its touchdown) [s]."""
        self.step_duration_s = self.config.step_duration_s
        """The current pace: the phase advances by 1 per this many seconds [s]."""
        self.time_s = 0.0
        self._anchor_phase, self._anchor_time_s = 0.0, 0.0  # the phase at the last pace change
        self.touchdowns = 0
        """Number of stance switches since `reset`."""

    def reset(self, time_s: float, stance: int, phase: float = 0.0) -> None:
        """Start (or resume) the gait with `stance` foot down at `phase` of its step."""
        if stance not in (LEFT, RIGHT):
            raise ConfigError(f"stance must be LEFT (0) or RIGHT (1), got {stance}")
        self.stance = stance
        self.time_s = time_s
        self.step_duration_s = self.config.step_duration_s
        self.step_start_s = time_s - phase * self.step_duration_s
        self._anchor_phase, self._anchor_time_s = phase, time_s
        self.touchdowns = 0

    def start_standing(self, time_s: float, contact: np.ndarray) -> None:
        """Start from a stand: the stance foot is the only one in contact, else the left; the phase
        starts at -weight_shift_s / step_duration_s (the weight shift, before the first step)."""
        stance = RIGHT if (contact[RIGHT] and not contact[LEFT]) else LEFT
        self.reset(time_s, stance, -self.config.weight_shift_s / self.config.step_duration_s)

    @property
    def shifting_weight(self) -> bool:
        """In the double-support weight shift before the first step (phase < 0)."""
        return self.phase < 0.0

    @property
    def swing(self) -> int:
        return 1 - self.stance

    @property
    def phase(self) -> float:
        """Phase of the current step, 0 at its start, 1 at its planned end (may exceed 1 when late)."""
        return self._anchor_phase + (self.time_s - self._anchor_time_s) / self.step_duration_s

    @property
    def time_in_step_s(self) -> float:
        """Time since the current step began [s]."""
        return self.time_s - self.step_start_s

    @property
    def time_to_touchdown_s(self) -> float:
        """Planned time left in the current step (0 once late) [s]."""
        return max((1.0 - self.phase) * self.step_duration_s, 0.0)

    def update(self, time_s: float, contact: np.ndarray) -> bool:
        """Advance to `time_s` with contact flags (left, right); True when a new step starts."""
        self.time_s = time_s
        if self._anchor_phase < 0.0 <= self.phase:  # the weight shift ended: the first step, at its own pace
            self._anchor_time_s -= self._anchor_phase * self.step_duration_s
            self._anchor_phase = 0.0
            self.step_duration_s = self.config.first_step_duration_s
        s = self.phase
        touched = bool(contact[self.swing]) and s >= self.config.early_touchdown_phase
        if touched or s >= self.config.late_touchdown_phase:
            self.stance = self.swing
            self.step_start_s = time_s
            self.step_duration_s = self.config.step_duration_s
            self._anchor_phase, self._anchor_time_s = 0.0, time_s
            self.touchdowns += 1
            return True
        return False

    def retime(self, time_left_s: float) -> None:
        """Plan the touchdown `time_left_s` from now, keeping the phase continuous: from here the phase
        runs at (1 - s) / time_left per second, at most as fast as in a step of `min_step_duration_s`.
        A late step (s >= 1) is left as it is."""
        if not (math.isfinite(time_left_s) and time_left_s > 0):
            raise ConfigError(f"time left must be positive, got {time_left_s}")
        s = self.phase
        if s >= 1.0:
            return
        self._anchor_phase, self._anchor_time_s = s, self.time_s
        self.step_duration_s = max(time_left_s / (1.0 - s), self.config.min_step_duration_s)

    def observation(self) -> np.ndarray:
        """(4,) policy features: sin/cos of the two-step gait phase, stance one-hot (left, right)."""
        cycle = 2 * np.pi * (min(self.phase, 1.0) + self.stance) / 2
        return np.array([np.sin(cycle), np.cos(cycle), float(self.stance == LEFT), float(self.stance == RIGHT)])
