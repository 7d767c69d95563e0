"""`WalkEnv`: one Digit walking task on a `DigitSim`: observation, action, reward, termination,
command sampling and pushes, with the privileged quantities the learner needs beside the observation.

One tick, as the rollout drives it:

    obs = env.observation                      # of the current state
    expert_action, valid = env.label()         # the expert sees every state, in order (optional)
    step = env.step(action)                    # the executed action (policy's or expert's)

Privileged quantities (`env.monitors`: the model-assumption monitors of the current state, read from
MuJoCo; the expert's label) never enter the observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from learn.action import ACTION_DIM, ActionSpace
from learn.config import CommandSampling, EnvConfig, Randomization
from learn.expert import Expert
from learn.mean_velocity import MeanVelocityError
from learn.observation import ObservationBuilder, gait_timing
from learn.rewards import (
    PAPER_WEIGHTS,
    PURERL_REWARD_FLOOR,
    PURERL_WEIGHTS,
    RewardInputs,
    action_smoothness,
    base_orientation,
    contact_schedule,
    cos_tilt,
    feet_air_time,
    reward_terms,
    total_reward,
    vertical_velocity,
)
from learn.swing_reward import SwingFootReference
from mbc.controller import AlipControllerConfig
from mbc.errors import ConfigError, MbcError
from mbc.geometry import rotate_inverse, wrap_angle, yaw_of_quaternion
from mbc.heading import HeadingSetpoint
from mbc.sim import DigitSim, DomainParams
from mbc.timing import LEFT, RIGHT
from mbc.types import RobotState
from robots.digit import constants as digit

MONITOR_NAMES = ("com_vertical_velocity_mps", "com_height_error_m", "stance_slip_speed_mps")
"""The model-assumption monitors each tick reports (ALIP: z' = 0, z = z_bar; a stance foot that does not slip)."""


def parse_terrain(spec: str) -> tuple[str, dict[str, float]]:
    """'slope:angle_deg=5,length_m=4' -> ('slope', {'angle_deg': 5.0, 'length_m': 4.0})."""
    name, _, rest = spec.partition(":")
    params = {}
    for item in filter(None, rest.split(",")):
        key, sep, value = item.partition("=")
        try:
            params[key.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise ConfigError(f"terrain {spec!r}: parameters must be key=number, separated by commas")
    return name.strip(), params


def sample_command(rng: np.random.Generator, sampling: CommandSampling) -> np.ndarray:
    """(3,) a command (vx, vy, yaw rate) drawn from `sampling`."""
    if rng.random() < sampling.standing_probability:
        return np.zeros(3)
    vx = rng.uniform(*sampling.vx_mps)
    vy = rng.uniform(*sampling.vy_mps) if rng.random() < sampling.lateral_probability else 0.0
    yaw = rng.uniform(*sampling.yaw_rate_radps) if rng.random() < sampling.yaw_probability else 0.0
    return np.array([vx, vy, yaw])


def tilt_of(quat_wxyz: np.ndarray) -> float:
    """Angle between the base z axis and the world vertical [rad]."""
    return math.acos(min(max(cos_tilt(quat_wxyz), -1.0), 1.0))


@dataclass
class Step:
    """What one `WalkEnv.step` returns."""

    observation: np.ndarray
    """Observation of the new state (of the next episode's first state after a reset)."""
    reward: float
    terminated: bool
    """Fell or tilted beyond the limit."""
    truncated: bool
    """Reached the episode length."""
    reward_terms: dict[str, float]


class WalkEnv:
    """The walking task for one robot; environment `index` takes terrain `config.terrains[index % n]`."""

    def __init__(self, config: EnvConfig, index: int = 0, with_expert: bool = True) -> None:
        self.config = config
        self.index = index
        self.terrain = ""
        self.set_terrain(config.terrains[index % len(config.terrains)])
        self.action_space = ActionSpace(self.sim.kp, self.sim.kd)
        self.expert = (Expert(self.action_space, heading_correction_per_step_rad=config.expert_heading_correction_per_step_rad)
                       if with_expert else None)
        self.builder = ObservationBuilder(config.history_length, gait_timing(config.gait_clock),
                                          config.observe_heading_error)
        self.rng = np.random.default_rng(index)
        self.forward_command_max_mps = config.commands.vx_mps[1]
        """Upper end of the forward commands of `config.commands` (the velocity curriculum widens it)."""
        self.command_sampling = config.commands
        """How this environment draws its commands (a terrain curriculum gives inclines their own)."""
        self._noise_scale = self._observation_noise_scale()
        self._weights = ((PURERL_WEIGHTS if config.purerl_rewards else PAPER_WEIGHTS)
                         | ({"mean_vel_tracking": config.mean_vel_tracking_weight} if config.mean_vel_tracking_weight else {}))
        """The reward's weights: the paper's table (PureRL's with `purerl_rewards`) and the gait-averaged term if weighted."""
        self._mean_velocity_error = MeanVelocityError(config.mean_vel_time_constant_s)
        self._velocity = np.zeros(6)
        self.state: RobotState | None = None
        self.command = np.zeros(3)
        self.observation = np.zeros(self.builder.layout.size)
        self.true_observation = self.observation
        """The observation without its noise (privileged: for the training's losses, never the policy's input)."""
        self.monitors = np.zeros(len(MONITOR_NAMES))
        self.episode_start_s = 0.0
        self.commanded_heading = HeadingSetpoint(max_error_rad=math.pi)
        """The episode's first heading advanced by the commanded yaw rates, psi_ref = psi_0 + sum(w_cmd dt) (unbounded)."""
        self.largest_heading_error_rad = 0.0
        """max |wrap(psi - psi_ref)| over the episode so far: how far the walker turned off its commanded heading
        (the fine-tunings' turn up inclines, docs/design.md) [rad]."""

    @property
    def observation_size(self) -> int:
        return self.builder.layout.size

    def set_terrain(self, spec: str) -> None:
        """Rebuild the simulator on terrain `spec` ('name' or 'name:key=value,...'); about 30 ms."""
        if spec == self.terrain:
            return
        name, params = parse_terrain(spec)
        self.sim = DigitSim(name, seed=self.index, **params)
        self.terrain = spec
        self._feet = [self.sim.model.body(f).id for f in digit.FOOT_LINKS]
        self._swing_reference = SwingFootReference(self.sim) if self.config.purerl_rewards else None

    # --- episode --------------------------------------------------------------------------------

    def reset(self, seed: int) -> np.ndarray:
        """Start an episode from a perturbed stand; returns the first observation."""
        cfg = self.config
        self.rng = rng = np.random.default_rng(seed)
        if self.config.randomization != Randomization():
            self._randomize_dynamics(rng)  # before the reset: MuJoCo's mj_setConst overwrites the state
        state = self.sim.reset()
        state.q = state.q + rng.uniform(-cfg.init_joint_noise_rad, cfg.init_joint_noise_rad, digit.NUM_JOINTS)
        state.base_linvel = np.r_[rng.uniform(-cfg.init_velocity_noise_mps, cfg.init_velocity_noise_mps, 2), 0.0]
        self.sim.set_state(state)
        self.state = self.sim.state()
        self.episode_start_s = self.state.time
        self.episode_start_xy = self.state.base_pos[:2].copy()
        self.command = self._sample_command()
        self.commanded_heading.reset(yaw_of_quaternion(self.state.base_quat), self.state.time)
        self.commanded_heading.update(yaw_of_quaternion(self.state.base_quat), self.state.time, self.command[2])
        self.largest_heading_error_rad = 0.0
        self._next_command_s = rng.uniform(*self.command_sampling.resample_interval_s)
        self._air_time_s, self._in_contact = np.zeros(2), self.state.contact.copy()
        self._mean_velocity_error.reset()
        self._earlier_actions = [np.zeros(ACTION_DIM), np.zeros(ACTION_DIM)]
        if self._swing_reference is not None:
            self._swing_reference.reset()
        pushes = cfg.pushes
        self._push_at_s = rng.uniform(1.0, 6.0) if rng.random() < pushes.probability else math.inf
        self.builder.reset(self.state)
        if self.expert is not None:  # the expert's clock starts as the observation's
            self.expert.reset(self.state, self.builder.clock.stance, self.builder.clock.phase)
        self.observation = self._observe()
        self._update_monitors()
        return self.observation

    def _sample_command(self) -> np.ndarray:
        command = sample_command(self.rng, self.command_sampling)
        high = self.config.commands.vx_mps[1]
        if self.command_sampling.widened and command[0] > 0 and high > 0:  # as the task's range by the velocity curriculum
            command[0] *= self.forward_command_max_mps / high
        return command

    def _randomize_dynamics(self, rng: np.random.Generator) -> None:
        r = self.config.randomization
        nbody = self.sim.model.nbody
        self.sim.set_domain(DomainParams(
            friction=rng.uniform(*r.friction), mass_scale=rng.uniform(*r.mass_scale, nbody),
            motor_strength=rng.uniform(*r.motor_strength, digit.NUM_JOINTS), delay_s=rng.uniform(*r.delay_s)))

    def _observation_noise_scale(self) -> np.ndarray:
        """Per-entry scale of the uniform observation noise (`Randomization.observation_noise`)."""
        layout, scale = self.builder.layout, np.zeros(self.builder.layout.size)
        for part, size in (("base_linvel", 0.1), ("base_angvel", 0.05), ("projected_gravity", 0.03), ("q", 0.01),
                           ("qd", 0.5), ("q_history", 0.01), ("qd_history", 0.5)):
            scale[layout.slice(part)] = size
        return self.config.randomization.observation_noise * scale

    def _observe(self) -> np.ndarray:
        """The noisy observation; its noise-free value is kept in `true_observation`."""
        self.true_observation = observation = self.builder.observe(self.state, self.command)
        if self.config.randomization.observation_noise:
            observation = observation + self._noise_scale * self.rng.uniform(-1.0, 1.0, observation.shape)
        return observation

    @property
    def episode_time_s(self) -> float:
        return self.state.time - self.episode_start_s

    def label(self) -> tuple[np.ndarray, bool]:
        """The expert's action for the current state and whether it is a usable label."""
        if self.expert is None:
            raise ConfigError("this environment was built without an expert (with_expert=False)")
        return self.expert.label(self.state, self.command)

    def step(self, action: np.ndarray) -> Step:
        """Apply `action` (normalized, see `learn.action`) for one control period."""
        cfg = self.config
        t = self.episode_time_s
        if t >= self._push_at_s:
            angle = self.rng.uniform(0, 2 * math.pi)
            force = self.rng.uniform(*cfg.pushes.force_n)
            self.sim.push((force * math.cos(angle), force * math.sin(angle), 0.0), cfg.pushes.duration_s)
            self._push_at_s = math.inf
        command = self.command
        self.state = state = self.sim.step(self.action_space.to_command(action, self.state))
        yaw = yaw_of_quaternion(state.base_quat)
        cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
        vx, vy = state.base_linvel[0], state.base_linvel[1]
        v_xy_heading = np.array([cos_yaw * vx + sin_yaw * vy, -sin_yaw * vx + cos_yaw * vy])
        terms = reward_terms(RewardInputs(
            v_xy_heading=v_xy_heading,
            angvel_base=np.array(rotate_inverse(state.base_quat, state.base_angvel)), yaw_rate=float(state.base_angvel[2]),
            command=command, tau=state.tau), cfg.lin_vel_tracking_sigma, cfg.ang_vel_tracking_sigma)
        if cfg.mean_vel_tracking_weight:  # 5 us a tick: only where it is paid
            x, y = self._mean_velocity_error.update(float(v_xy_heading[0]), float(v_xy_heading[1]), tuple(command.tolist()),
                                                    state.time, self.sim.dt)
            terms["mean_vel_tracking"] = math.exp(-(x * x + y * y) / cfg.mean_vel_tracking_sigma)
        try:
            fell, off_terrain = self.sim.fallen, False
        except MbcError:  # walked off the edge of a bounded terrain: the episode ends, not as a failure
            fell, off_terrain = False, True
        terminated = fell or tilt_of(state.base_quat) > cfg.tilt_limit_rad
        truncated = not terminated and (off_terrain or self.episode_time_s >= cfg.episode_length_s - 1e-9)
        if self.episode_time_s >= self._next_command_s:
            self.command = self._sample_command()
            self._next_command_s += self.rng.uniform(*self.command_sampling.resample_interval_s)
        reference = self.commanded_heading.update(yaw, state.time, self.command[2])  # advanced by this tick's command
        self.largest_heading_error_rad = max(self.largest_heading_error_rad, abs(wrap_angle(yaw - reference)))
        self.builder.record_action(action)
        self.observation = self._observe()  # (the gait clock advances to the new state)
        if cfg.purerl_rewards:  # of this tick's command, at the new state
            terms |= self._purerl_terms(state, action, command)
        self._update_monitors()
        reward = (total_reward(terms, self._weights, PURERL_REWARD_FLOOR) if cfg.purerl_rewards
                  else total_reward(terms, self._weights))
        return Step(self.observation, reward, terminated, truncated, terms)

    def _purerl_terms(self, state: RobotState, action: np.ndarray, command: np.ndarray) -> dict[str, float]:
        """PureRL's terms (`learn.rewards`); updates the memory of air times and actions."""
        contact = state.contact
        touchdown = contact & ~self._in_contact
        air_time = feet_air_time(self._air_time_s + self.sim.dt, touchdown)
        self._air_time_s = np.where(contact, 0.0, self._air_time_s + self.sim.dt)
        self._in_contact = contact.copy()
        smoothness = action_smoothness(action, *self._earlier_actions)
        self._earlier_actions = [np.asarray(action, float).copy(), self._earlier_actions[0]]
        clock = self.builder.clock
        scheduled = (True, True) if clock.shifting_weight else (clock.stance == LEFT, clock.stance == RIGHT)
        return {"feet_air_time": air_time, "action_smoothness": smoothness,
                "contact_schedule": contact_schedule(contact, scheduled),
                "swing_foot_tracking": self._swing_reference.reward(clock, command, state.base_quat),
                "vertical_velocity": vertical_velocity(float(state.base_linvel[2])),
                "base_orientation": base_orientation(state.base_quat)}

    # --- privileged -------------------------------------------------------------------------------

    def _update_monitors(self) -> None:
        """CoM vertical velocity, CoM height above the stance sole minus the ALIP height, stance sole speed."""
        stance = self.builder.clock.stance
        com, com_velocity = self.sim.com_state()
        sole_z = self.sim.sole_position(stance)[2]
        mujoco.mj_objectVelocity(self.sim.model, self.sim.data, mujoco.mjtObj.mjOBJ_BODY, self._feet[stance],
                                 self._velocity, 0)
        self.monitors = np.array([com_velocity[2], com[2] - sole_z - AlipControllerConfig.nominal_com_height_m,
                                  math.hypot(self._velocity[3], self._velocity[4])])
