"""Run any `Controller` on a `DigitSim` and record the episode: one loop for examples, benchmarks,
tests and the viewer."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mbc.errors import ConfigError
from mbc.geometry import yaw_of_quaternion, yaw_rotation
from mbc.sim import DigitSim
from mbc.types import Command, Controller, JointCommand, RobotState


@dataclass(frozen=True)
class Push:
    """A push on the pelvis: world-frame force [N] from `time_s` for `duration_s`."""

    time_s: float
    force_n: tuple[float, float, float]
    duration_s: float = 0.2


CommandSchedule = Command | Sequence[tuple[float, Command]] | Callable[[float], Command]
"""A fixed command, a list of (start time [s], command), or a function of time."""


def command_at(schedule: CommandSchedule, t: float) -> Command:
    if isinstance(schedule, Command):
        return schedule
    if callable(schedule):
        return schedule(t)
    current = schedule[0][1]
    for start, command in schedule:
        if t >= start:
            current = command
    return current


@dataclass
class Episode:
    """Recorded episode, one row per control tick."""

    time: list[float] = field(default_factory=list)
    base_pos: list[np.ndarray] = field(default_factory=list)
    base_quat: list[np.ndarray] = field(default_factory=list)
    base_linvel: list[np.ndarray] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    command: list[np.ndarray] = field(default_factory=list)
    tick_time_s: list[float] = field(default_factory=list)
    diagnostics: list = field(default_factory=list)
    """The controller's `last_diagnostics` per tick, where it has them."""
    fell: bool = False
    fall_time_s: float = float("nan")

    def arrays(self, name: str) -> np.ndarray:
        return np.asarray(getattr(self, name))

    def heading_velocity(self) -> np.ndarray:
        """(n, 2) base velocity in the heading frame (forward, lateral) [m/s]."""
        return np.array([(yaw_rotation(yaw).T @ velocity)[:2]
                         for yaw, velocity in zip(self.yaw(), self.base_linvel)])

    def yaw(self) -> np.ndarray:
        """(n,) unwrapped base yaw [rad]."""
        return np.unwrap(yaw_of_quaternion(self.arrays("base_quat")))

    def mean_velocity(self, since_s: float = 0.0) -> np.ndarray:
        """Mean heading-frame (vx, vy) and yaw rate after `since_s`, from displacements."""
        t = self.arrays("time")
        keep = t >= since_s
        if keep.sum() < 2:
            return np.full(3, np.nan)
        heading = self.heading_velocity()[keep].mean(axis=0)
        yaw = self.yaw()[keep]
        return np.r_[heading, (yaw[-1] - yaw[0]) / (t[keep][-1] - t[keep][0])]

    def summary(self, since_s: float = 2.0) -> dict[str, float]:
        """Distance, mean velocity, tracking error, fall, tick-time statistics."""
        t, pos = self.arrays("time"), self.arrays("base_pos")
        command = self.arrays("command")
        keep = t >= since_s
        tick_ms = 1e3 * self.arrays("tick_time_s")
        error = np.linalg.norm(self.heading_velocity()[keep] - command[keep, :2], axis=1) if keep.any() else [np.nan]
        mean = self.mean_velocity(since_s)
        return {
            "duration_s": float(t[-1]) if len(t) else 0.0,
            "distance_m": float(np.linalg.norm(pos[-1, :2] - pos[0, :2])) if len(pos) else 0.0,
            "mean_vx_mps": float(mean[0]), "mean_vy_mps": float(mean[1]), "mean_yaw_rate_radps": float(mean[2]),
            "velocity_error_mps": float(np.mean(error)),
            "fell": self.fell, "fall_time_s": self.fall_time_s,
            "tick_median_ms": float(np.median(tick_ms)), "tick_p99_ms": float(np.percentile(tick_ms, 99)),
            "tick_max_ms": float(np.max(tick_ms)),
        }


def run_episode(sim: DigitSim, controller: Controller, commands: CommandSchedule, duration_s: float,
                pushes: Sequence[Push] = (), state: RobotState | None = None,
                on_tick: Callable[[RobotState, JointCommand], None] | None = None,
                stop_on_fall: bool = True) -> Episode:
    """Reset (or start from `state`), then run `controller` for `duration_s` of simulated time."""
    if duration_s <= 0:
        raise ConfigError(f"duration_s must be positive, got {duration_s}")
    if state is None:
        state = sim.reset()
    else:
        sim.set_state(state)
    controller.reset(state)
    episode = Episode()
    start_time = state.time
    pending = sorted(pushes, key=lambda p: p.time_s)
    for _ in range(int(round(duration_s / sim.dt))):
        t = state.time - start_time
        while pending and t >= pending[0].time_s:
            push = pending.pop(0)
            sim.push(push.force_n, push.duration_s)
        command = command_at(commands, t)
        tick_start = time.perf_counter()
        action = controller.act(state, command)
        episode.tick_time_s.append(time.perf_counter() - tick_start)
        episode.diagnostics.append(getattr(controller, "last_diagnostics", None))
        episode.time.append(t)
        episode.base_pos.append(state.base_pos)
        episode.base_quat.append(state.base_quat)
        episode.base_linvel.append(state.base_linvel)
        episode.q.append(state.q)
        episode.command.append(command.as_array())
        state = sim.step(action)
        if on_tick is not None:
            on_tick(state, action)
        if sim.fallen:
            episode.fell, episode.fall_time_s = True, state.time - start_time
            if stop_on_fall:
                break
    return episode
