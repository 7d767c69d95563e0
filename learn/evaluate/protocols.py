"""The evaluation protocols: one (controller, protocol, seed, shift) job is one function call that builds
its simulator, runs its episodes from a perturbed standing start and returns its raw figures.

Protocol names (parametric ones take a number after the last underscore); what runs, success, figures:

* `flat`: 0.5 m/s forward, 0.2 m/s sideways, 0.5 rad/s turning, 10 s each; every command tracked
  (within 10% or 0.05); the fraction tracked.
* `course_slope[_L]`, `course_uneven[_L]`, `course_mixed[_L]` (or `course[_L]`): 0.6 m/s with heading hold through L levels
  (default 8) of growing difficulty (slopes up and down to 20 deg, bumps to 6 cm), 130 s for 8 levels;
  every level passed; levels passed, time to the end.
* `uphill_A`, `downhill_A`: 0.5 m/s up (down) a 5 m incline of A deg, no turning commanded; its end reached
  without a fall; the speed error on the incline [% of 0.5 m/s], and the largest heading drift [deg] (a policy that
  turns across the slope climbs a gentler grade, and may fall sideways).
* `uphill_hold_A`, `downhill_hold_A`: the same with heading hold (the courses' yaw correction, as an operator
  steering up the fall line would): what of an incline's failures is the heading's.
* `uphill_long_A`, `uphill_long_hold_A`: the same up an 8 m incline, 40 s: a slow turn off the fall line that
  the 5 m incline (and training's) hides shows here (the MBC without its heading hold climbed 5 m of 14 deg and
  fell on 8).
* `uneven_C`: 0.4 m/s for 20 s over bumps of C cm; no fall; distance [m].
* `step_slip_F`: the paper's step-and-slip hardware test: 0.3 m/s with heading hold onto and across a 2 cm board
  of friction F / 100 (`step_slip_15`: 0.15, a whiteboard with poppy seeds or oil) 1.5 m ahead, 1.5 m long;
  its far end passed without a fall within 20 s; how far the feet slid on the board [m].
* `sand[_T]`: 0.4 m/s for 20 s on yielding ground of contact time constant T ms (default 50,
  `mbc.sim.terrain.Soft`'s: the feet sink about 3 cm; MuJoCo's default time constant is 20); no fall; distance
  [m], and the largest peak-to-peak within a gait cycle of the forward speed [m/s] and of the yaw [deg], the cycle
  before a fall left out (an oscillation that the contact's lag excites grows them before it throws the robot).
* `random_velocity[_N]`: N trajectories per seed (default 20: the paper's 100 over 5 seeds) of four random
  5 s commands from ranges wider than training's; no fall; the return of the tracking rewards (46 is perfect).
* `max_velocity`: the forward command ramped 0.5 -> 1.6 m/s over 25 s; the highest speed held 2 s within
  0.15 m/s of the command.
* `mar`: 10 s on flat ground and a 14 deg incline (the paper's steepest) at 0.5 m/s, the CoM vertical
  velocity recorded; no fall; the shares of ticks whose MAR weight shows the assumption violated
  (w < 0.2 w0), partly and holding (w > 0.8 w0), and |z'| against the speed error per gait cycle.
* `gait`: 12 s at 0.5 m/s on flat ground, soles and contacts recorded; no fall; gait features
  (`learn.evaluate.gait`) and their distance from the MBC's.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import torch

from learn.config import EnvConfig
from learn.evaluate.gait import gait_features
from learn.evaluate.metrics import (
    incline_speed_error_pct,
    largest_oscillation,
    levels_completed,
    sustained_velocity,
    tracking_return,
)
from learn.evaluate.shifts import Shift, get_shift
from mbc.assumptions import MAR_W0, mar_weight
from mbc.errors import ConfigError
from mbc.geometry import wrap_angle, yaw_of_quaternion
from mbc.rollout import TRACKING_WINDOW_S, CommandSchedule, Episode, perturbed_stand, run_episode, tracked
from mbc.sim import DigitSim
from mbc.sim.terrain import Soft
from mbc.types import Command, Controller, JointCommand, RobotState

FIXED = ("flat", "max_velocity", "mar", "gait")
PARAMETRIC = {"uphill": "A deg", "downhill": "A deg", "uphill_hold": "A deg", "downhill_hold": "A deg",
              "uphill_long": "A deg", "uphill_long_hold": "A deg", "uneven": "C cm",
              "step_slip": "F friction / 100", "sand": "T ms",
              "course_slope": "L levels", "course_uneven": "L levels", "course_mixed": "L levels", "course": "L levels",
              "random_velocity": "N trajectories"}
OPTIONAL_NUMBER = ("course_slope", "course_uneven", "course_mixed", "course", "random_velocity", "sand")
DEFAULT_PROTOCOLS = ("flat", "course_slope", "course_uneven", "uphill_10", "uphill_12", "uphill_14", "uphill_16",
                     "uphill_18", "uphill_20", "uphill_22", "downhill_8", "downhill_10", "downhill_12", "downhill_14",
                     "uneven_4", "step_slip_15", "sand", "random_velocity", "max_velocity", "mar", "gait")
RUN_UP_M, INCLINE_M, LONG_INCLINE_M = 1.5, 5.0, 8.0
INCLINE_S, LONG_INCLINE_S = 30.0, 40.0
BOARD_HEIGHT_M, BOARD_LENGTH_M, STEP_SLIP_SPEED_MPS = 0.02, 1.5, 0.3
COURSE_LEVELS, COURSE_S_PER_LEVEL, COURSE_SPEED_MPS = 8, 130.0 / 8, 0.6
COURSE_MAX = {"slope": {"max_slope_deg": 20.0}, "uneven": {"max_amplitude": 0.06},
              "mixed": {"max_slope_deg": 20.0, "max_amplitude": 0.06, "max_step_height": 0.1}}
RANDOM_COMMANDS = {"vx_mps": (-0.7, 1.2), "vy_mps": (-0.45, 0.45), "yaw_rate_radps": (-1.0, 1.0)}
"""Ranges of the random velocity test, wider than training's (vx -0.5..1.0, vy +-0.3, yaw rate +-0.8)."""
RANDOM_TRAJECTORIES, RANDOM_COMMAND_S = 20, 5.0
MAR_UPHILL_DEG = 14.0
MAR_REGIONS = (0.2, 0.8)
"""w / w0 below 0.2: the assumption violated (|z'| > 0.16 m/s); above 0.8: it holds (|z'| < 0.06 m/s)."""


@dataclass(frozen=True)
class Job:
    """One episode set: a controller ('mbc' or a policy path), a protocol, a seed and a shift."""

    controller: str
    protocol: str
    seed: int
    shift: str = "nominal"


def parse_protocol(name: str) -> tuple[str, float | None]:
    """'uphill_16' -> ('uphill', 16.0); 'course_slope' -> ('course_slope', None); unknown names raise."""
    if name in FIXED or name in OPTIONAL_NUMBER:
        return name, None
    kind, _, value = name.rpartition("_")
    if kind in PARAMETRIC and value.replace(".", "", 1).isdigit():
        try:
            _check_value(kind, float(value))
        except ConfigError as error:
            raise ConfigError(f"protocol {name!r}: {error}") from None
        return kind, float(value)
    valid = list(FIXED) + [f"{k}_<{v}>" for k, v in PARAMETRIC.items()]
    raise ConfigError(f"unknown protocol {name!r}; valid: {valid} (course_* and random_velocity also without a number)")


def _check_value(kind: str, value: float) -> None:
    """Refuse a protocol number its terrain cannot take, before any job runs."""
    if kind == "step_slip" and value <= 0:
        raise ConfigError(f"step_slip needs a positive friction (in hundredths), got {value:g}")
    if kind == "sand":
        Soft(timeconst_s=value / 1000)  # raises on a time constant MuJoCo's contacts cannot take


def make_controller(spec: str) -> Controller:
    """'mbc' or the path of a policy checkpoint."""
    if spec == "mbc":
        from mbc.controller import AlipController

        return AlipController.for_digit()
    from learn.policy import PolicyController

    return PolicyController(spec)


def run_job(job: Job) -> dict:
    """The raw figures of one job: always 'success', 'fell' and 'metric', plus the protocol's own; a job
    that raises is a failure with its 'error' (one episode's crash does not lose the others' results)."""
    kind, value = parse_protocol(job.protocol)
    shift = get_shift(job.shift)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a policy's one-state forward gains nothing from threads; jobs run in parallel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the controllers' caught solver warnings
        try:
            return _RUNNERS[kind](make_controller(job.controller), value, job.seed, shift)
        except Exception as error:  # reported with the results, not raised
            return {"success": False, "fell": False, "metric": math.nan, "error": f"{type(error).__name__}: {error}"}
        finally:
            torch.set_num_threads(threads)


def _start(terrain: str, seed: int, shift: Shift, controller: Controller, **terrain_params):
    sim = shift.simulator(terrain, seed, **terrain_params)
    controller = shift.apply(sim, controller, seed)
    return sim, controller, perturbed_stand(sim, seed)


def _flat(controller, _, seed, shift) -> dict:
    outcomes, means, fell = [], [], False
    for command in (Command(0.5), Command(0.0, 0.2), Command(0.0, 0.0, 0.5)):
        sim, shifted, state = _start("flat", seed, shift, controller)
        episode = run_episode(sim, shifted, command, 10.0, state=state)
        mean = episode.mean_velocity(since_s=3.0)
        fell |= episode.fell
        means.append(mean.tolist())
        outcomes.append(not episode.fell and all(tracked(m, c) for m, c in zip(mean, command.as_array())))
    return {"success": all(outcomes), "fell": fell, "metric": float(np.mean(outcomes)), "tracked": outcomes,
            "mean_velocities": means}


class HeadingHold:
    """Walks a forward command with a yaw rate that turns the heading back to +x: w = -k wrap(yaw),
    clipped (the courses' heading correction); stands still (a zero command) once the pelvis is beyond
    `stop_beyond_x_m` (a course's end)."""

    def __init__(self, controller: Controller, gain: float = 1.0, max_rate_radps: float = 0.5,
                 stop_beyond_x_m: float = math.inf) -> None:
        self.controller, self.gain, self.max_rate, self.stop_x = controller, gain, max_rate_radps, stop_beyond_x_m

    def __getattr__(self, name: str):
        return getattr(self.controller, name)

    def reset(self, state: RobotState) -> None:
        self.controller.reset(state)

    def act(self, state: RobotState, command: Command) -> JointCommand:
        if state.base_pos[0] > self.stop_x:
            return self.controller.act(state, Command())
        yaw = wrap_angle(float(yaw_of_quaternion(state.base_quat)))
        rate = float(np.clip(-self.gain * yaw, -self.max_rate, self.max_rate))
        return self.controller.act(state, Command(command.vx, command.vy, rate))


def _course(kind: str):
    def run(controller, levels, seed, shift) -> dict:
        levels = int(levels or COURSE_LEVELS)
        if levels < 1:
            raise ConfigError(f"a course needs at least one level, got {levels}")
        sim, shifted, state = _start("course", seed, shift, controller, kind=kind, num_levels=levels, **COURSE_MAX[kind])
        starts = sim.terrain.level_starts_m()
        walker = HeadingHold(shifted, stop_beyond_x_m=starts[-1] + 0.5)
        episode = run_episode(sim, walker, Command(COURSE_SPEED_MPS), COURSE_S_PER_LEVEL * levels, state=state)
        x = episode.arrays("base_pos")[:, 0]
        passed = levels_completed(float(x.max()), starts)
        finished = np.flatnonzero(x >= starts[-1])
        return {"success": bool(passed == levels and not episode.fell), "fell": episode.fell, "metric": float(passed),
                "levels": levels, "time_to_end_s": float(episode.time[finished[0]]) if len(finished) else float("nan"),
                "x_reached_m": float(x.max()), "level_length_m": float(starts[1] - starts[0])}
    return run


def _incline(sign: int, hold_heading: bool = False, length_m: float = INCLINE_M, duration_s: float = INCLINE_S):
    def run(controller, angle, seed, shift) -> dict:
        sim, shifted, state = _start("slope", seed, shift, controller, angle_deg=sign * angle, run_up_m=RUN_UP_M,
                                     length_m=length_m)
        walker = HeadingHold(shifted) if hold_heading else shifted
        episode = run_episode(sim, walker, Command(0.5), duration_s, state=state)
        x = episode.arrays("base_pos")[:, 0]
        error = incline_speed_error_pct(episode, RUN_UP_M + 0.5, RUN_UP_M + length_m - 0.5, 0.5)
        return {"success": bool(not episode.fell and x.max() > RUN_UP_M + length_m), "fell": episode.fell,
                "metric": error, "heading_drift_deg": float(np.degrees(np.abs(episode.yaw()).max()))}
    return run


def _walk_forward(terrain: str, controller, seed, shift, **terrain_params) -> Episode:
    """0.4 m/s for 20 s on `terrain`."""
    sim, shifted, state = _start(terrain, seed, shift, controller, **terrain_params)
    return run_episode(sim, shifted, Command(0.4), 20.0, state=state)


def _distance_walked(episode: Episode) -> dict:
    """No fall; the distance along +x [m]."""
    return {"success": not episode.fell, "fell": episode.fell, "metric": float(episode.base_pos[-1][0])}


def _uneven(controller, centimetres, seed, shift) -> dict:
    return _distance_walked(_walk_forward("uneven", controller, seed, shift, amplitude=centimetres / 100))


def _step_slip(controller, hundredths, seed, shift) -> dict:
    friction = hundredths / 100
    sim, shifted, state = _start("board", seed, shift, controller, friction=friction, height_m=BOARD_HEIGHT_M,
                                 run_up_m=RUN_UP_M, length_m=BOARD_LENGTH_M)
    end = RUN_UP_M + BOARD_LENGTH_M
    recorder = SlipRecorder(sim, RUN_UP_M, end)
    episode = run_episode(sim, HeadingHold(shifted, stop_beyond_x_m=end + 0.5), Command(STEP_SLIP_SPEED_MPS), 20.0,
                          state=state, on_tick=recorder)
    crossed = bool(episode.arrays("base_pos")[:, 0].max() > end)
    return {"success": crossed and not episode.fell, "fell": episode.fell, "metric": recorder.slip_m}


def _sand(controller, milliseconds, seed, shift) -> dict:
    timeconst_s = Soft.timeconst_s if milliseconds is None else milliseconds / 1000
    episode = _walk_forward("soft", controller, seed, shift, timeconst_s=timeconst_s)
    speed_mps, yaw_deg = largest_oscillation(episode)
    return {**_distance_walked(episode), "timeconst_s": timeconst_s, "speed_oscillation_mps": speed_mps,
            "yaw_oscillation_deg": yaw_deg}


def random_commands(rng: np.random.Generator, count: int = 4, duration_s: float = RANDOM_COMMAND_S) -> CommandSchedule:
    """`count` commands uniform in `RANDOM_COMMANDS`, each for `duration_s`, as a schedule."""
    ranges = RANDOM_COMMANDS.values()
    return [(k * duration_s, Command(*(float(rng.uniform(*r)) for r in ranges))) for k in range(count)]


def _random_velocity(controller, trajectories, seed, shift) -> dict:
    rng = np.random.default_rng(seed)
    sigmas = EnvConfig()
    returns, falls = [], 0
    for k in range(int(trajectories or RANDOM_TRAJECTORIES)):
        sim, shifted, state = _start("flat", 1000 * seed + k, shift, controller)
        episode = run_episode(sim, shifted, random_commands(rng), 4 * RANDOM_COMMAND_S, state=state)
        returns.append(tracking_return(episode, sigmas.lin_vel_tracking_sigma, sigmas.ang_vel_tracking_sigma))
        falls += episode.fell
    return {"success": falls == 0, "fell": falls > 0, "metric": float(np.mean(returns)), "returns": returns,
            "falls": falls, "fall_share": falls / len(returns)}


def _max_velocity(controller, _, seed, shift) -> dict:
    sim, shifted, state = _start("flat", seed, shift, controller)
    ramp = lambda t: Command(min(0.5 + 1.1 * t / 25.0, 1.6))  # noqa: E731
    episode = run_episode(sim, shifted, ramp, 27.0, state=state)
    return {"success": True, "fell": episode.fell, "metric": sustained_velocity(episode)}


class SlipRecorder:
    """`run_episode`'s on_tick: how far the soles slid on the board: the summed horizontal displacement of each
    sole over the ticks it was in contact at both ends, its centre on the board (x in [start, end]) [m]."""

    def __init__(self, sim: DigitSim, start_x_m: float, end_x_m: float) -> None:
        self.sim, self.start, self.end = sim, start_x_m, end_x_m
        self.slip_m = 0.0
        self._soles, self._contact = None, np.zeros(2, bool)

    def __call__(self, state: RobotState, _command: JointCommand) -> None:
        soles = np.stack([self.sim.sole_position(foot) for foot in (0, 1)])
        if self._soles is not None:
            for foot in (0, 1):
                on_board = self.start <= soles[foot, 0] <= self.end
                if on_board and state.contact[foot] and self._contact[foot]:
                    self.slip_m += float(np.linalg.norm(soles[foot, :2] - self._soles[foot, :2]))
        self._soles, self._contact = soles, state.contact.copy()


class TickRecorder:
    """`run_episode`'s on_tick: the CoM vertical velocity, soles and contacts after each tick."""

    def __init__(self, sim: DigitSim) -> None:
        self.sim, self.com_vz, self.soles, self.contact = sim, [], [], []

    def __call__(self, state: RobotState, _command: JointCommand) -> None:
        self.com_vz.append(float(self.sim.com_state()[1][2]))
        self.soles.append([self.sim.sole_position(0), self.sim.sole_position(1)])
        self.contact.append(state.contact.copy())


def _recorded(terrain: str, controller, seed, shift, duration_s: float, **terrain_params) -> tuple[Episode, TickRecorder]:
    sim, shifted, state = _start(terrain, seed, shift, controller, **terrain_params)
    recorder = TickRecorder(sim)
    return run_episode(sim, shifted, Command(0.5), duration_s, state=state, on_tick=recorder), recorder


def weight_regions(com_vz: np.ndarray) -> list[float]:
    """Shares of ticks whose MAR weight w / w0 lies below, between and above `MAR_REGIONS`."""
    ratio = mar_weight(np.asarray(com_vz)) / MAR_W0
    low, high = MAR_REGIONS
    return [float(np.mean(ratio < low)), float(np.mean((ratio >= low) & (ratio <= high))), float(np.mean(ratio > high))]


def _mar(controller, _, seed, shift) -> dict:
    figures: dict = {}
    fell = False
    incline = {"angle_deg": MAR_UPHILL_DEG, "run_up_m": RUN_UP_M, "length_m": INCLINE_M}
    for terrain, params, duration in (("flat", {}, 10.0), ("slope", incline, 20.0)):
        episode, recorder = _recorded(terrain, controller, seed, shift, duration, **params)
        fell |= episode.fell
        com_vz = np.asarray(recorder.com_vz)
        histogram = np.histogram(mar_weight(com_vz) / MAR_W0, bins=20, range=(0, 1))[0]
        figures[terrain] = {"regions": weight_regions(com_vz), "weight_histogram": histogram.tolist()}
        if terrain == "slope":  # per gait cycle: mean |z'| against the forward speed error
            ticks = int(round(TRACKING_WINDOW_S / (episode.time[1] - episode.time[0])))
            velocity, command = episode.window_velocity()
            windows = min(len(velocity), len(com_vz) // ticks)
            figures["scatter"] = {"abs_com_vz_mps": [float(np.abs(com_vz[k * ticks:(k + 1) * ticks]).mean())
                                                     for k in range(windows)],
                                  "speed_error_mps": np.abs(velocity[:windows, 0] - command[:windows, 0]).tolist()}
    shares = {f"{terrain}_{region}": figures[key]["regions"][i] for terrain, key in (("flat", "flat"), ("uphill", "slope"))
              for i, region in enumerate(("violated", "partial", "holds"))}
    return {"success": not fell, "fell": fell, "metric": shares["uphill_violated"], **shares, **figures}


def _gait(controller, _, seed, shift) -> dict:
    episode, recorder = _recorded("flat", controller, seed, shift, 12.0)
    features = gait_features(episode.arrays("time"), np.asarray(recorder.soles), np.asarray(recorder.contact),
                             episode.arrays("q"), episode.yaw())
    if features is None:
        return {"success": False, "fell": episode.fell, "metric": math.nan, "features": None}
    scalars = {k: v for k, v in features.as_dict().items() if k != "joint_cycle"}
    return {"success": not episode.fell, "fell": episode.fell, "metric": features.step_length_m, **scalars,
            "features": features.as_dict()}


_RUNNERS = {"flat": _flat, "course_slope": _course("slope"), "course_uneven": _course("uneven"),
            "course_mixed": _course("mixed"), "course": _course("mixed"), "uphill": _incline(1),
            "downhill": _incline(-1), "uphill_hold": _incline(1, hold_heading=True),
            "downhill_hold": _incline(-1, hold_heading=True),
            "uphill_long": _incline(1, length_m=LONG_INCLINE_M, duration_s=LONG_INCLINE_S),
            "uphill_long_hold": _incline(1, hold_heading=True, length_m=LONG_INCLINE_M, duration_s=LONG_INCLINE_S),
            "uneven": _uneven, "random_velocity": _random_velocity,
            "max_velocity": _max_velocity, "mar": _mar, "gait": _gait, "step_slip": _step_slip, "sand": _sand}
