"""The walking task as a gymnasium environment: `gymnasium.make("ppf_digit/DigitWalk-v0", ...)`, registered
when `learn` is imported, so a third-party learner can train on it.

    import gymnasium as gym
    import learn  # registers ppf_digit/DigitWalk-v0
    env = gym.make("ppf_digit/DigitWalk-v0", terrain="slope:angle_deg=5", randomization="paper", with_expert=True)
    observation, info = env.reset(seed=0)
    observation, reward, terminated, truncated, info = env.step(env.action_space.sample())

* Observation: the paper's 136 values (`learn.observation`), float32, unbounded.
* Action: the project's normalized action (`learn.action`): 24 values, the torque each PD term asks for in units
  of the joint's torque limit, a = [Kp (q_des - q), Kd (qd_des - qd)] / tau_max, in [-1, 1] (clipped there: the
  MBC's own actions leave it in 0.05% of their entries, measured on the distillation's labels).
* `info`: `reward_terms` (each unweighted term of this step), `monitors` (the ALIP assumption monitors:
  CoM z', CoM height error, stance slip), `command` (vx, vy, yaw rate); with `with_expert=True`, the MBC's
  action for the returned observation's state (`expert_action`) and whether it is usable (`expert_valid`).
* Episodes end (terminated) on a fall or beyond 20 deg of tilt, and are truncated at `episode_length_s`.
* `make_vector_env(n, ...)`: gymnasium's `VectorEnv` over n worker processes, one environment each, the i-th
  on terrain i mod len(terrains), as the project's own training spreads them. The project's learners use
  `learn.vec_env` instead, whose workers run whole rollouts with the policy inside (two messages per rollout,
  not two per tick).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import gymnasium
import numpy as np

from learn.action import ACTION_DIM
from learn.config import EnvConfig, PushSampling, Randomization, paper_randomization
from learn.env import MONITOR_NAMES, WalkEnv
from mbc.errors import ConfigError

ENV_ID = "ppf_digit/DigitWalk-v0"
RANDOMIZATIONS = {"none": Randomization, "paper": paper_randomization}


def walk_config(terrain: str | tuple[str, ...] = "flat", randomization: str = "none", pushes: bool = True,
                episode_length_s: float = 20.0, purerl_rewards: bool = False) -> EnvConfig:
    """The `EnvConfig` of the keyword arguments: terrains as 'name' or 'name:key=value,...' (one, or one per index)."""
    if randomization not in RANDOMIZATIONS:
        raise ConfigError(f"unknown randomization {randomization!r}; valid: {sorted(RANDOMIZATIONS)}")
    terrains = (terrain,) if isinstance(terrain, str) else tuple(terrain)
    config = EnvConfig(terrains=terrains, randomization=RANDOMIZATIONS[randomization](), episode_length_s=episode_length_s,
                       purerl_rewards=purerl_rewards)
    return config if pushes else dataclasses.replace(config, pushes=PushSampling(probability=0.0))


class DigitWalkEnv(gymnasium.Env):
    """`WalkEnv` behind gymnasium's API (see the module docstring for the spaces and `info`)."""

    metadata: ClassVar[dict] = {"render_modes": []}

    def __init__(self, terrain: str | tuple[str, ...] = "flat", randomization: str = "none", pushes: bool = True,
                 episode_length_s: float = 20.0, purerl_rewards: bool = False, with_expert: bool = False,
                 index: int = 0) -> None:
        self.config = walk_config(terrain, randomization, pushes, episode_length_s, purerl_rewards)
        self.walk = WalkEnv(self.config, index, with_expert)
        self.with_expert = with_expert
        self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (self.walk.observation_size,), np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (ACTION_DIM,), np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        observation = self.walk.reset(int(self.np_random.integers(2**31)))
        return observation.astype(np.float32), self._info({})

    def step(self, action):
        action = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        if action.shape != (ACTION_DIM,):
            raise ConfigError(f"an action is ({ACTION_DIM},), got shape {action.shape}")
        step = self.walk.step(action)
        return (step.observation.astype(np.float32), float(step.reward), bool(step.terminated), bool(step.truncated),
                self._info(step.reward_terms))

    def _info(self, reward_terms: dict[str, float]) -> dict:
        info = {"reward_terms": dict(reward_terms), "monitors": dict(zip(MONITOR_NAMES, self.walk.monitors.tolist())),
                "command": self.walk.command.copy()}
        if self.with_expert:  # the expert sees every state in order: label the one just observed
            label, valid = self.walk.label()
            info |= {"expert_action": label.astype(np.float32), "expert_valid": bool(valid)}
        return info


def make_vector_env(num_envs: int, **kwargs) -> gymnasium.vector.VectorEnv:
    """gymnasium's `AsyncVectorEnv` of `num_envs` `DigitWalkEnv`s in worker processes (environment i: index i)."""
    if num_envs < 1:
        raise ConfigError(f"num_envs must be >= 1, got {num_envs}")
    return gymnasium.vector.AsyncVectorEnv([_factory(i, kwargs) for i in range(num_envs)], context="spawn")


def _factory(index: int, kwargs: dict):
    return lambda: DigitWalkEnv(index=index, **kwargs)
