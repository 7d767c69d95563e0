"""Run any `Controller` on a `DigitSim` and record the episode: one loop for examples, benchmarks,
tests and the viewer."""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mbc.errors import ConfigError, MbcError
from mbc.geometry import yaw_of_quaternion, yaw_rotation
from mbc.sim import DigitSim
from mbc.types import Command, Controller, JointCommand, RobotState

TRACKING_WINDOW_S = 0.7
"""Velocity tracking is judged on averages over this window: one gait cycle (two 0.35 s steps) [s]."""


@dataclass(frozen=True)
class Push:
    """A push on the pelvis: world-frame force [N] from `time_s` for `duration_s`."""

    time_s: float
    force_n: tuple[float, float, float]
    duration_s: float = 0.2

    def __post_init__(self) -> None:
        if not (math.isfinite(self.time_s) and self.time_s >= 0):
            raise ConfigError(f"push time_s must be >= 0 (seconds from the episode start), got {self.time_s}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ConfigError(f"push duration_s must be positive, got {self.duration_s}")
        force = np.asarray(self.force_n, dtype=float)
        if force.shape != (3,) or not np.all(np.isfinite(force)):
            raise ConfigError(f"push force_n must be a finite (fx, fy, fz) [N], got {self.force_n}")


CommandSchedule = Command | Sequence[tuple[float, Command]] | Callable[[float], Command]
"""A fixed command, a list of (start time [s], command), or a function of time."""

_SCHEDULE_FORMS = "a Command, a non-empty list of (start time [s], Command) pairs, or a function of time returning a Command"


def check_schedule(schedule: CommandSchedule) -> None:
    """Raise `ConfigError` naming the valid forms unless `schedule` is one of them."""
    if isinstance(schedule, Command) or callable(schedule):
        return
    if isinstance(schedule, Sequence) and not isinstance(schedule, str) and len(schedule) > 0 and all(
            isinstance(item, Sequence) and len(item) == 2 and isinstance(item[1], Command) for item in schedule):
        return
    hint = " (a plain tuple of numbers is not a command: use Command(vx, vy, yaw_rate))" if (
        isinstance(schedule, Sequence) and schedule and all(isinstance(v, (int, float)) for v in schedule)) else ""
    raise ConfigError(f"commands must be {_SCHEDULE_FORMS}; got {schedule!r}{hint}")


def command_at(schedule: CommandSchedule, t: float) -> Command:
    if isinstance(schedule, Command):
        return schedule
    if callable(schedule):
        command = schedule(t)
        if not isinstance(command, Command):
            raise ConfigError(f"the command function returned {command!r} at t = {t:.3f} s, not a Command")
        return command
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
    """(3,) the command given at each tick."""
    command_used: list[np.ndarray] = field(default_factory=list)
    """(3,) the command the controller followed: the given one clipped to its `command_limits`."""
    tick_time_s: list[float] = field(default_factory=list)
    diagnostics: list = field(default_factory=list)
    """The controller's `last_diagnostics` per tick, where it has them."""
    fell: bool = False
    fall_time_s: float = float("nan")
    left_terrain: bool = False
    """The robot walked off the edge of a bounded terrain (a fall: there is no ground beyond it)."""

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

    def window_ticks(self, window_s: float = TRACKING_WINDOW_S) -> int:
        """The ticks of one window of `window_s` [s] at the episode's control period (at least one)."""
        t = self.arrays("time")
        return max(int(round(window_s / (t[1] - t[0]))), 1) if len(t) > 1 else 1

    def window_velocity(self, window_s: float = TRACKING_WINDOW_S, since_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Velocities averaged over consecutive windows of `window_s` after `since_s`, with the command
        followed over each: ((k, 3) heading-frame vx, vy and yaw rate, (k, 3) mean command used).

        A window of one gait cycle (two steps) averages out the sway of walking; when less than one
        window remains after `since_s`, that remainder is the one window."""
        t = self.arrays("time")
        start = int(np.searchsorted(t, since_s))
        ticks = min(self.window_ticks(window_s), len(t) - start)
        heading, yaw, used = self.heading_velocity(), self.yaw(), self.arrays("command_used")
        velocity, command = [], []
        for k in range(start, len(t) - ticks + 1, ticks):
            window = slice(k, k + ticks)
            yaw_rate = (yaw[k + ticks - 1] - yaw[k]) / (t[k + ticks - 1] - t[k]) if ticks > 1 else np.nan
            velocity.append(np.r_[heading[window].mean(axis=0), yaw_rate])
            command.append(used[window].mean(axis=0))
        return np.reshape(velocity, (-1, 3)), np.reshape(command, (-1, 3))

    def summary(self, since_s: float | None = None) -> dict[str, float]:
        """Distance, mean velocity, per-axis tracking error, fall, tick-time statistics.

        Tracking is judged after `since_s` (default: 2 s, or half the episode if it is shorter) on
        gait-cycle averages of the velocity (`window_velocity`), against the command the controller
        followed (clipped to its range)."""
        t, pos = self.arrays("time"), self.arrays("base_pos")
        if not len(t):
            raise ConfigError("the episode has no ticks to summarize")
        duration = float(t[-1] + (t[1] - t[0] if len(t) > 1 else 0.0))
        since_s = min(2.0, duration / 2) if since_s is None else since_s
        if since_s >= t[-1]:
            raise ConfigError(f"summary(since_s={since_s}) leaves nothing to judge: the episode lasted {duration:.3f} s"
                              + (f" (it fell at {self.fall_time_s:.2f} s)" if self.fell else ""))
        tick_ms = 1e3 * self.arrays("tick_time_s")
        velocity, command = self.window_velocity(since_s=since_s)
        error = np.abs(velocity - command).mean(axis=0) if len(velocity) else np.full(3, np.nan)
        mean = self.mean_velocity(since_s)
        return {
            "duration_s": duration, "distance_m": float(np.linalg.norm(pos[-1, :2] - pos[0, :2])),
            "mean_vx_mps": float(mean[0]), "mean_vy_mps": float(mean[1]), "mean_yaw_rate_radps": float(mean[2]),
            "tracking_error_vx_mps": float(error[0]), "tracking_error_vy_mps": float(error[1]),
            "tracking_error_yaw_rate_radps": float(error[2]),
            "clipped_command_ticks": int(np.any(self.arrays("command") != self.arrays("command_used"), axis=1).sum()),
            "fell": self.fell, "fall_time_s": self.fall_time_s,
            "tick_median_ms": float(np.median(tick_ms)), "tick_p99_ms": float(np.percentile(tick_ms, 99)),
            "tick_max_ms": float(np.max(tick_ms)),
        }


def tracked(measured: float, commanded: float) -> bool:
    """Whether a mean velocity follows its command: within 10% of it or 0.05 (m/s or rad/s), the
    tolerance of the benchmarks and evaluations."""
    return abs(measured - commanded) <= max(0.1 * abs(commanded), 0.05)


def perturbed_stand(sim: DigitSim, seed: int, joint_noise_rad: float = 0.02, velocity_noise_mps: float = 0.05) -> RobotState:
    """`sim` reset to the stand with uniform noise on the joint angles and the horizontal base velocity,
    seeded: the start of the benchmarks' and evaluations' runs (the simulator is left in that state)."""
    rng = np.random.default_rng(seed)
    state = sim.reset(seed=seed)
    state.q = state.q + rng.uniform(-joint_noise_rad, joint_noise_rad, len(state.q))
    state.base_linvel = np.r_[rng.uniform(-velocity_noise_mps, velocity_noise_mps, 2), 0.0]
    sim.set_state(state)
    return sim.state()


def check_duration(duration_s: float, dt: float) -> None:
    """Raise `ConfigError` unless `duration_s` is a finite number of seconds of at least one period `dt`."""
    if not (isinstance(duration_s, numbers.Real) and math.isfinite(duration_s) and duration_s >= dt):
        raise ConfigError(f"duration_s must be a finite number of seconds, at least one control period ({dt} s); "
                          f"got {duration_s!r}")


def run_episode(sim: DigitSim, controller: Controller, commands: CommandSchedule, duration_s: float,
                pushes: Sequence[Push] = (), state: RobotState | None = None,
                on_tick: Callable[[RobotState, JointCommand], None] | None = None,
                stop_on_fall: bool = True) -> Episode:
    """Reset (or start from `state`), then run `controller` for `duration_s` of simulated time."""
    check_duration(duration_s, sim.dt)
    if abs(controller.dt - sim.dt) > 1e-12:
        raise ConfigError(f"the controller runs every {controller.dt} s but the simulator steps {sim.dt} s per call")
    check_schedule(commands)
    gains = getattr(controller, "pd_gains", None)
    if gains is not None and not (np.allclose(gains[0], sim.kp) and np.allclose(gains[1], sim.kd)):
        raise ConfigError("the controller's joint targets assume PD gains other than the simulator's: "
                          f"kp {np.round(gains[0], 1).tolist()} kd {np.round(gains[1], 1).tolist()} against "
                          f"kp {np.round(sim.kp, 1).tolist()} kd {np.round(sim.kd, 1).tolist()}")
    limits = getattr(controller, "command_limits", None)
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
        episode.command_used.append(np.array(limits.clip(command)[0]) if limits is not None else command.as_array())
        state = sim.step(action)
        if on_tick is not None:
            on_tick(state, action)
        try:
            fallen = sim.fallen
        except MbcError:  # no terrain below the pelvis: beyond the edge of a bounded terrain
            episode.left_terrain = fallen = True
        if fallen:
            episode.fell, episode.fall_time_s = True, state.time - start_time
            if stop_on_fall or episode.left_terrain:  # off the terrain there is nothing left to simulate
                break
    return episode
