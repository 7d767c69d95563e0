"""Parallel environments: groups of `WalkEnv`s, each group in a worker process with the policy
running batched over its environments.

A rollout is requested as a `RolloutRequest` (a policy snapshot, a number of ticks, a seed, how the
expert labels and mixes in) and comes back as one `Rollout` per group. The policy does not change
within a rollout, so each worker runs it on its own copy (one batched forward per tick over its
environments) and the workers exchange nothing per tick: a rollout costs two messages per worker,
not two per tick. `VecEnv` is the interface the algorithms see; `InProcessVecEnv`, `ProcessVecEnv`
and `learn.ray_vec_env.RayVecEnv` (Ray actors each holding an `EnvGroup`) implement it.

DAgger's rollouts start fresh episodes, seeded from (request seed, environment index), so a rollout
depends only on its request. PPO's continue the episodes of the previous rollout (`continue_episodes`),
sample the Gaussian policy, and return log-probabilities and values; the expert labels every
`label_every`-th tick of each environment and only follows the others (its clock still sees every state).
"""

from __future__ import annotations

import math
import multiprocessing
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np
import torch

from learn.action import ACTION_DIM
from learn.config import EnvConfig, WorkerConfig
from learn.curriculum import TerrainCurriculum
from learn.env import MONITOR_NAMES, WalkEnv
from learn.policy import ActorCritic
from mbc.errors import ConfigError

TIMING_PARTS = ("expert", "physics", "policy", "total")
CURRICULUM_STREAM = 7_919
"""Tells the terrain levels' random stream (rollout seed, environment index, this) from the episodes' streams."""


def rollout_seed(seed: int, iteration: int) -> int:
    """The seed of a run's rollout `iteration`: a rollout depends only on (run seed, iteration)."""
    return int(np.random.SeedSequence([seed, iteration]).generate_state(1)[0])


@dataclass(frozen=True)
class RolloutRequest:
    """What to run: `steps` ticks per environment."""

    policy: dict | None
    """An `ActorCritic.checkpoint()` dict, or None to let the expert act alone (then beta must be 1)."""
    steps: int
    seed: int
    beta: float = 0.0
    """Probability, per labelled tick and environment, that the expert's action is executed instead of the policy's."""
    label_every: int = 1
    """Ask the expert for a label every this many ticks of each environment (0: never)."""
    stochastic: bool = False
    """Sample the Gaussian policy (PPO) instead of acting with its mean (DAgger)."""
    continue_episodes: bool = False
    """Continue the environments' episodes from the previous rollout instead of starting fresh ones."""
    forward_command_max_mps: float | None = None
    """Upper end of the forward commands drawn (velocity curriculum); None: the config's."""
    true_observations: bool = False
    """Also record each tick's noise-free observation (`Rollout.true_observations`)."""

    def __post_init__(self) -> None:
        if self.policy is None and not (self.label_every == 1 and self.beta == 1.0):
            raise ConfigError("without a policy the expert must act: label_every=1 and beta=1")
        if self.label_every < 0 or self.steps <= 0:
            raise ConfigError("label_every must be >= 0 and steps positive")


@dataclass
class Rollout:
    """One group's rollout, arrays (steps, n_envs, ...)."""

    observations: np.ndarray
    expert_actions: np.ndarray
    label_valid: np.ndarray
    """The expert was asked and gave a label (no fallback)."""
    label_followed: np.ndarray
    """The label is the expert's action for the commanded velocity itself (`Expert.followed`)."""
    expert_acted: np.ndarray
    """The expert's action was executed."""
    actions: np.ndarray
    """The executed actions."""
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    monitors: np.ndarray
    """Model-assumption monitors of each observed state (`learn.env.MONITOR_NAMES`)."""
    log_probs: np.ndarray
    """log pi(action | observation) of the executed action (stochastic rollouts; else 0)."""
    values: np.ndarray
    """V(observation) (stochastic rollouts; else 0)."""
    last_values: np.ndarray
    """(n_envs,) V of the observation after the last tick."""
    episodes: list[dict] = field(default_factory=list)
    """One record per episode that ended: return, length_s, distance_m, fell, heading_error_deg (the largest turn off
    the commanded heading, `WalkEnv.largest_heading_error_rad`), terrain."""
    reward_terms: dict[str, float] = field(default_factory=dict)
    """Mean of each unweighted reward term per tick."""
    timing_s: dict[str, float] = field(default_factory=dict)
    """Wall time spent in the expert, the physics and reward, the policy, and in total [s]."""
    true_observations: np.ndarray | None = None
    """The observations without their noise (`RolloutRequest.true_observations`; None: not recorded)."""

    @property
    def samples(self) -> int:
        return self.observations.shape[0] * self.observations.shape[1]

    @staticmethod
    def concatenate(rollouts: list[Rollout]) -> Rollout:
        """Join groups along the environment axis (timings summed, episodes listed)."""
        arrays = {name: None if getattr(rollouts[0], name) is None else
                  np.concatenate([getattr(r, name) for r in rollouts], axis=-1 if name == "last_values" else 1)
                  for name in Rollout.__dataclass_fields__ if name not in ("timing_s", "episodes", "reward_terms")}
        timing = {part: sum(r.timing_s.get(part, 0.0) for r in rollouts) for part in TIMING_PARTS}
        terms = {name: float(np.mean([r.reward_terms[name] for r in rollouts])) for name in rollouts[0].reward_terms}
        return Rollout(**arrays, episodes=[e for r in rollouts for e in r.episodes], reward_terms=terms, timing_s=timing)


class EnvGroup:
    """Environments of one process, stepped together with one batched policy forward per tick."""

    def __init__(self, config: EnvConfig, indices: list[int], with_expert: bool = True,
                 curriculum: TerrainCurriculum | None = None) -> None:
        self.indices = indices
        self.envs = [WalkEnv(config, index, with_expert) for index in indices]
        self.curriculum = curriculum
        self.levels = [0] * len(indices)
        self._rngs: list[np.random.Generator] | None = None
        self._level_rngs: list[np.random.Generator] = []
        self._ticks = [0] * len(indices)
        if curriculum is not None:  # an environment's kind, so its commands, is fixed by its index
            for k, env in enumerate(self.envs):
                env.command_sampling = curriculum.commands(self._kind(k), config.commands)
        torch.set_num_threads(1)  # parallelism comes from the workers

    def _kind(self, k: int) -> str:
        return self.curriculum.kinds[self.indices[k] % len(self.curriculum.kinds)]

    def _start_curriculum(self, seed: int) -> None:
        """Each environment's first level and terrain, drawn from the rollout's seed and the environment's index."""
        self._level_rngs = [np.random.default_rng([seed, index, CURRICULUM_STREAM]) for index in self.indices]
        for k, (env, rng) in enumerate(zip(self.envs, self._level_rngs)):
            self.levels[k] = self.curriculum.initial_level(rng)
            env.set_terrain(self.curriculum.spec(self._kind(k), self.levels[k]))

    def _start(self, k: int) -> None:
        self.envs[k].reset(int(self._rngs[k].integers(2**31)))

    def _end_episode(self, k: int, episode_return: float, fell: bool) -> dict:
        env = self.envs[k]
        distance = float(np.linalg.norm(env.state.base_pos[:2] - env.episode_start_xy))
        record = {"return": episode_return, "length_s": env.episode_time_s, "distance_m": distance, "fell": fell,
                  "heading_error_deg": math.degrees(env.largest_heading_error_rad),
                  "terrain": env.terrain, "level": self.levels[k]}
        if self.curriculum is not None:
            record["kind"] = self._kind(k)
            self.levels[k] = self.curriculum.next_level(self.levels[k], distance, fell, self._level_rngs[k])
            env.set_terrain(self.curriculum.spec(self._kind(k), self.levels[k]))
        self._start(k)
        return record

    def run(self, request: RolloutRequest) -> Rollout:
        n, T, envs = len(self.envs), request.steps, self.envs
        obs_size = envs[0].observation_size
        buffers = {"observations": np.zeros((T, n, obs_size), np.float32),
                   "expert_actions": np.zeros((T, n, ACTION_DIM), np.float32), "label_valid": np.zeros((T, n), bool),
                   "label_followed": np.zeros((T, n), bool),
                   "expert_acted": np.zeros((T, n), bool), "actions": np.zeros((T, n, ACTION_DIM), np.float32),
                   "rewards": np.zeros((T, n), np.float32), "terminated": np.zeros((T, n), bool),
                   "truncated": np.zeros((T, n), bool), "monitors": np.zeros((T, n, len(MONITOR_NAMES)), np.float32),
                   "log_probs": np.zeros((T, n), np.float32), "values": np.zeros((T, n), np.float32),
                   "true_observations": np.zeros((T, n, obs_size), np.float32) if request.true_observations else None}
        for env in envs:
            if request.forward_command_max_mps is not None:
                env.forward_command_max_mps = request.forward_command_max_mps
        if not (request.continue_episodes and self._rngs is not None):
            self._rngs = [np.random.default_rng([request.seed, index]) for index in self.indices]
            self._returns = [0.0] * n
            if self.curriculum is not None:
                self._start_curriculum(request.seed)
            for k in range(n):
                self._start(k)
        generator = torch.Generator().manual_seed(int(self._rngs[0].integers(2**31)))
        model = ActorCritic.from_checkpoint(request.policy).eval() if request.policy is not None else None
        timing = dict.fromkeys(TIMING_PARTS, 0.0)
        episodes, term_sums = [], {}
        start = time.perf_counter()
        for t in range(T):
            observations = np.stack([env.observation for env in envs])
            buffers["observations"][t] = observations
            if request.true_observations:
                buffers["true_observations"][t] = np.stack([env.true_observation for env in envs])
            buffers["monitors"][t] = np.stack([env.monitors for env in envs])
            tick = time.perf_counter()
            if model is not None:
                policy_actions = self._policy_actions(model, observations, request.stochastic, generator, buffers, t)
            timing["policy"] += time.perf_counter() - tick
            for k, (env, rng) in enumerate(zip(envs, self._rngs)):
                tick = time.perf_counter()
                labelling = request.label_every > 0 and self._ticks[k] % request.label_every == 0
                self._ticks[k] += 1
                if labelling:
                    expert_action, valid = env.label()
                    buffers["expert_actions"][t, k], buffers["label_valid"][t, k] = expert_action, valid
                    buffers["label_followed"][t, k] = env.expert.followed(env.command)
                elif env.expert is not None:
                    env.expert.follow(env.state)
                middle = time.perf_counter()
                use_expert = labelling and rng.random() < request.beta
                action = expert_action if use_expert else policy_actions[k].astype(float)
                step = env.step(action)
                buffers["expert_acted"][t, k], buffers["actions"][t, k] = use_expert, action
                buffers["rewards"][t, k] = step.reward
                buffers["terminated"][t, k], buffers["truncated"][t, k] = step.terminated, step.truncated
                self._returns[k] += step.reward
                for name, value in step.reward_terms.items():
                    term_sums[name] = term_sums.get(name, 0.0) + value
                if step.terminated or step.truncated:
                    episodes.append(self._end_episode(k, self._returns[k], step.terminated))
                    self._returns[k] = 0.0
                if labelling or env.expert is not None:  # a method without the expert books no expert time
                    timing["expert"] += middle - tick
                timing["physics"] += time.perf_counter() - middle
        last_values = np.zeros(n, np.float32)
        if model is not None and request.stochastic:
            with torch.inference_mode():
                last = torch.as_tensor(np.stack([env.observation for env in envs]), dtype=torch.float32)
                last_values = model.value(last).numpy()
        timing["total"] = time.perf_counter() - start
        terms = {name: total / (T * n) for name, total in term_sums.items()}
        return Rollout(**buffers, last_values=last_values, episodes=episodes, reward_terms=terms, timing_s=timing)

    @staticmethod
    def _policy_actions(model: ActorCritic, observations: np.ndarray, stochastic: bool, generator: torch.Generator,
                        buffers: dict, t: int) -> np.ndarray:
        """The policy's actions for a batch of observations (mean, or sampled with log-probs and values)."""
        with torch.inference_mode():
            obs = torch.as_tensor(observations, dtype=torch.float32)
            if not stochastic:
                return model.action_mean(obs).numpy()
            distribution = model.distribution(obs)
            actions = distribution.mean + distribution.stddev * torch.randn(distribution.mean.shape, generator=generator)
            buffers["log_probs"][t] = distribution.log_prob(actions).sum(-1).numpy()
            buffers["values"][t] = model.value(obs).numpy()
            return actions.numpy()


class VecEnv(ABC):
    """Environments the algorithms collect rollouts from."""

    num_envs: int
    observation_size: int

    @abstractmethod
    def collect(self, request: RolloutRequest) -> Rollout:
        """Run `request` on every environment; the groups' rollouts joined along the environment axis."""

    @abstractmethod
    def close(self) -> None:
        """Release workers and environments."""

    def __enter__(self) -> VecEnv:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class InProcessVecEnv(VecEnv):
    """All environments in this process (tests, debugging, one core)."""

    def __init__(self, config: EnvConfig, num_envs: int, with_expert: bool = True,
                 curriculum: TerrainCurriculum | None = None) -> None:
        self.group = EnvGroup(config, list(range(num_envs)), with_expert, curriculum)
        self.num_envs, self.observation_size = num_envs, self.group.envs[0].observation_size

    def collect(self, request: RolloutRequest) -> Rollout:
        return self.group.run(request)

    def close(self) -> None:
        """Nothing to release: the environments live in this process."""


def _worker(connection, config: EnvConfig, indices: list[int], with_expert: bool,
            curriculum: TerrainCurriculum | None) -> None:
    group = EnvGroup(config, indices, with_expert, curriculum)
    connection.send(group.envs[0].observation_size)
    while True:
        message = connection.recv()
        if message is None:
            break
        connection.send(group.run(message))
    connection.close()


class ProcessVecEnv(VecEnv):
    """`workers` processes with `envs_per_worker` environments each."""

    def __init__(self, config: EnvConfig, workers: int, envs_per_worker: int, with_expert: bool = True,
                 curriculum: TerrainCurriculum | None = None) -> None:
        context = multiprocessing.get_context("spawn")
        self._connections, self._processes = [], []
        for w in range(workers):
            parent, child = context.Pipe()
            indices = list(range(w * envs_per_worker, (w + 1) * envs_per_worker))
            process = context.Process(target=_worker, args=(child, config, indices, with_expert, curriculum),
                                      daemon=True)
            process.start()
            self._connections.append(parent)
            self._processes.append(process)
        self.observation_size = [c.recv() for c in self._connections][0]
        self.num_envs = workers * envs_per_worker

    def collect(self, request: RolloutRequest) -> Rollout:
        for connection in self._connections:
            connection.send(request)
        return Rollout.concatenate([connection.recv() for connection in self._connections])

    def close(self) -> None:
        for connection, process in zip(self._connections, self._processes):
            try:
                connection.send(None)
            except (BrokenPipeError, OSError):
                pass
            process.join(timeout=5)
            if process.is_alive():
                process.terminate()
        self._connections, self._processes = [], []


def make_vec_env(config: EnvConfig, workers: int, envs_per_worker: int, with_expert: bool = True,
                 curriculum: TerrainCurriculum | None = None, backend: str = "process",
                 ray_address: str | None = None) -> VecEnv:
    """`workers` groups of `envs_per_worker` environments: worker processes (`backend="process"`), Ray actors
    (`"ray"`, `learn.ray_vec_env`), or with `workers` = 0 all in this process."""
    if backend == "ray":
        from learn.ray_vec_env import RayVecEnv  # Ray is imported only when asked for

        return RayVecEnv(config, workers, envs_per_worker, with_expert, curriculum, ray_address)
    if backend != "process":
        raise ConfigError(f"unknown backend {backend!r}; valid: ['process', 'ray']")
    if workers <= 0:
        return InProcessVecEnv(config, envs_per_worker, with_expert, curriculum)
    return ProcessVecEnv(config, workers, envs_per_worker, with_expert, curriculum)


def vec_env_for(config: EnvConfig, workers: WorkerConfig, with_expert: bool = True,
                curriculum: TerrainCurriculum | None = None) -> VecEnv:
    """`make_vec_env` as a run's `WorkerConfig` says (count, environments each, backend, Ray address)."""
    return make_vec_env(config, workers.workers, workers.envs_per_worker, with_expert, curriculum, workers.backend,
                        workers.ray_address)
