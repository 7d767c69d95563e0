"""Parallel environments: groups of `WalkEnv`s, each group in a worker process with the policy
running batched over its environments.

A rollout is requested as a `RolloutRequest` (a policy snapshot, a number of ticks, a seed, the DAgger
mixing probability) and comes back as one `Rollout` per group. The policy does not change within a
rollout, so each worker runs it on its own copy (one batched forward per tick over its environments)
and the workers exchange nothing per tick: a rollout costs two messages per worker, not two per tick.
`VecEnv` is the interface the algorithms see; `InProcessVecEnv` and `ProcessVecEnv` implement it, and
a distributed engine (Ray actors each holding an `EnvGroup`) would implement the same two methods.

Every environment resets at the start of each rollout, seeded from (request seed, environment index),
so a rollout depends only on the request: a resumed run reproduces it exactly.
"""

from __future__ import annotations

import multiprocessing
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np
import torch

from learn.action import ACTION_DIM
from learn.config import EnvConfig
from learn.env import MONITOR_NAMES, WalkEnv
from learn.policy import ActorCritic

TIMING_PARTS = ("expert", "physics", "policy", "total")


@dataclass(frozen=True)
class RolloutRequest:
    """What to run: `steps` ticks per environment from fresh episodes."""

    policy: dict | None
    """An `ActorCritic.checkpoint()` dict, or None to let the expert act alone (then beta must be 1)."""
    steps: int
    seed: int
    beta: float = 0.0
    """Probability, per tick and environment, that the expert's action is executed instead of the policy's."""
    label: bool = True
    """Ask the expert for a label at every tick (it then also sees every state, in order)."""

    def __post_init__(self) -> None:
        if self.policy is None and not (self.label and self.beta == 1.0):
            raise ValueError("without a policy the expert must act: label=True and beta=1")


@dataclass
class Rollout:
    """One group's rollout, arrays (steps, n_envs, ...)."""

    observations: np.ndarray
    expert_actions: np.ndarray
    label_valid: np.ndarray
    """The expert gave a label (no fallback)."""
    expert_acted: np.ndarray
    """The expert's action was executed."""
    actions: np.ndarray
    """The executed actions."""
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    monitors: np.ndarray
    """Model-assumption monitors of each observed state (`learn.env.MONITOR_NAMES`)."""
    timing_s: dict[str, float] = field(default_factory=dict)
    """Wall time spent in the expert, the physics and reward, the policy, and in total [s]."""

    @property
    def samples(self) -> int:
        return self.observations.shape[0] * self.observations.shape[1]

    @staticmethod
    def concatenate(rollouts: list[Rollout]) -> Rollout:
        """Join groups along the environment axis (timings summed)."""
        arrays = {name: np.concatenate([getattr(r, name) for r in rollouts], axis=1)
                  for name in Rollout.__dataclass_fields__ if name != "timing_s"}
        timing = {part: sum(r.timing_s.get(part, 0.0) for r in rollouts) for part in TIMING_PARTS}
        return Rollout(**arrays, timing_s=timing)


class EnvGroup:
    """Environments of one process, stepped together with one batched policy forward per tick."""

    def __init__(self, config: EnvConfig, indices: list[int], with_expert: bool = True) -> None:
        self.indices = indices
        self.envs = [WalkEnv(config, index, with_expert) for index in indices]
        torch.set_num_threads(1)  # parallelism comes from the workers

    def run(self, request: RolloutRequest) -> Rollout:
        n, T, envs = len(self.envs), request.steps, self.envs
        obs_size = envs[0].observation_size
        buffers = {"observations": np.zeros((T, n, obs_size), np.float32),
                   "expert_actions": np.zeros((T, n, ACTION_DIM), np.float32), "label_valid": np.zeros((T, n), bool),
                   "expert_acted": np.zeros((T, n), bool), "actions": np.zeros((T, n, ACTION_DIM), np.float32),
                   "rewards": np.zeros((T, n), np.float32), "terminated": np.zeros((T, n), bool),
                   "truncated": np.zeros((T, n), bool), "monitors": np.zeros((T, n, len(MONITOR_NAMES)), np.float32)}
        rngs = [np.random.default_rng([request.seed, index]) for index in self.indices]
        for env, rng in zip(envs, rngs):
            env.reset(int(rng.integers(2**31)))
        model = ActorCritic.from_checkpoint(request.policy).eval() if request.policy is not None else None
        timing = dict.fromkeys(TIMING_PARTS, 0.0)
        start = time.perf_counter()
        for t in range(T):
            observations = np.stack([env.observation for env in envs])
            buffers["observations"][t] = observations
            buffers["monitors"][t] = np.stack([env.monitors for env in envs])
            tick = time.perf_counter()
            if model is not None:
                with torch.inference_mode():
                    policy_actions = model.action_mean(torch.as_tensor(observations, dtype=torch.float32)).numpy()
            timing["policy"] += time.perf_counter() - tick
            for i, (env, rng) in enumerate(zip(envs, rngs)):
                tick = time.perf_counter()
                if request.label:
                    expert_action, valid = env.label()
                    buffers["expert_actions"][t, i], buffers["label_valid"][t, i] = expert_action, valid
                middle = time.perf_counter()
                use_expert = request.label and rng.random() < request.beta
                action = expert_action if use_expert else policy_actions[i].astype(float)
                step = env.step(action)
                buffers["expert_acted"][t, i], buffers["actions"][t, i] = use_expert, action
                buffers["rewards"][t, i] = step.reward
                buffers["terminated"][t, i], buffers["truncated"][t, i] = step.terminated, step.truncated
                if step.terminated or step.truncated:
                    env.reset(int(rng.integers(2**31)))
                timing["expert"] += middle - tick
                timing["physics"] += time.perf_counter() - middle
        timing["total"] = time.perf_counter() - start
        return Rollout(**buffers, timing_s=timing)


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

    def __init__(self, config: EnvConfig, num_envs: int, with_expert: bool = True) -> None:
        self.group = EnvGroup(config, list(range(num_envs)), with_expert)
        self.num_envs, self.observation_size = num_envs, self.group.envs[0].observation_size

    def collect(self, request: RolloutRequest) -> Rollout:
        return self.group.run(request)

    def close(self) -> None:
        """Nothing to release: the environments live in this process."""


def _worker(connection, config: EnvConfig, indices: list[int], with_expert: bool) -> None:
    group = EnvGroup(config, indices, with_expert)
    connection.send(group.envs[0].observation_size)
    while True:
        message = connection.recv()
        if message is None:
            break
        connection.send(group.run(message))
    connection.close()


class ProcessVecEnv(VecEnv):
    """`workers` processes with `envs_per_worker` environments each."""

    def __init__(self, config: EnvConfig, workers: int, envs_per_worker: int, with_expert: bool = True) -> None:
        context = multiprocessing.get_context("spawn")
        self._connections, self._processes = [], []
        for w in range(workers):
            parent, child = context.Pipe()
            indices = list(range(w * envs_per_worker, (w + 1) * envs_per_worker))
            process = context.Process(target=_worker, args=(child, config, indices, with_expert), daemon=True)
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


def make_vec_env(config: EnvConfig, workers: int, envs_per_worker: int, with_expert: bool = True) -> VecEnv:
    """`ProcessVecEnv` with `workers` > 0, else all environments in this process."""
    if workers <= 0:
        return InProcessVecEnv(config, envs_per_worker, with_expert)
    return ProcessVecEnv(config, workers, envs_per_worker, with_expert)
