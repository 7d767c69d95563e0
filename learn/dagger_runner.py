"""`DaggerRunner`: the distillation loop (rollout, label, aggregate, fit), logging and checkpoints.

Each iteration k runs every environment for `steps_per_env` ticks from fresh episodes with the
beta_k-mixture of expert and policy, adds the usable labelled states to the dataset as one shard,
fits the actor on the whole aggregated dataset and writes a checkpoint atomically. A run killed at
any moment resumes from its last checkpoint (`resume=True`): shards written after it are reused, the
rollouts are seeded by (seed, iteration), so the schedule and the dataset are those of an unbroken run.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from learn.action import ActionSpace
from learn.checkpoints import POLICY, SCALARS, TRAINING_STATE, deployable_checkpoint, save_torch
from learn.config import DistillConfig
from learn.console import append_scalars, iteration_line, number
from learn.dagger import DaggerFit, cosine_learning_rate, usable_labels
from learn.expert import teacher_command_limits
from learn.observation import observation_layout
from learn.policy import ActorCritic, learner_device
from learn.storage import LabelledDataset, output_directory
from learn.vec_env import RolloutRequest, VecEnv, rollout_seed, vec_env_for
from mbc.errors import ConfigError
from mbc.types import CONTROL_PERIOD_S


class DaggerRunner:
    """Runs (or resumes) a distillation in `config.run_dir`."""

    def __init__(self, config: DistillConfig) -> None:
        self.config = config
        self.run_dir = output_directory(config.run_dir, "run_dir")
        state_path = self.run_dir / TRAINING_STATE
        if state_path.exists() and not config.resume:
            raise ConfigError(f"{self.run_dir} already holds a run; pass --resume to continue it or choose another run_dir")
        if config.resume and not state_path.exists() and not LabelledDataset(self.run_dir / "data").shards_on_disk():
            raise ConfigError(f"nothing to resume in {self.run_dir} (no {TRAINING_STATE})")
        layout = observation_layout(config.env)
        self.model = ActorCritic(layout.size, config.policy, seed=config.seed)
        self.action_space = ActionSpace()
        self.turn_accel_mps2 = teacher_command_limits().turn_accel_mps2
        """The teacher's turning limit: a distilled policy learned only commands its teacher followed."""
        self.fitter = DaggerFit(self.model, config.dagger.learning_rate, learner_device(config.device))
        self.dataset = LabelledDataset(self.run_dir / "data", config.dagger.max_dataset_samples)
        self.start_iteration, self.samples, self.wall_s = 0, 0, 0.0
        if state_path.exists():
            self._restore(state_path)
        (self.run_dir / "config.json").write_text(json.dumps(dataclasses.asdict(config), indent=2, default=str))

    def _restore(self, path: Path) -> None:
        state = torch.load(path, map_location="cpu", weights_only=True)
        self.model.load_state_dict(state["policy"]["state_dict"])
        self.fitter.optimizer.load_state_dict(state["optimizer"])
        self.start_iteration = int(state["iteration"]) + 1
        self.samples, self.wall_s = int(state["samples"]), float(state["wall_s"])
        self.dataset.load([k for k in self.dataset.shards_on_disk() if k < self.start_iteration])

    def learn(self, vec_env: VecEnv | None = None) -> Path:
        """Run the remaining iterations; returns the path of the deployable policy."""
        cfg, dagger = self.config, self.config.dagger
        from torch.utils.tensorboard import SummaryWriter

        own_env = vec_env is None
        vec_env = vec_env or vec_env_for(cfg.env, cfg.workers)
        writer = SummaryWriter(str(self.run_dir / "tensorboard"))
        discard = int(round(dagger.discard_before_fall_s / CONTROL_PERIOD_S))
        try:
            bar = tqdm(range(self.start_iteration, dagger.iterations), desc="DAgger", unit="it", initial=self.start_iteration,
                       total=dagger.iterations, disable=None)
            for iteration in bar:
                start = time.perf_counter()
                beta = dagger.beta(iteration)
                scalars = {"beta": beta}
                if iteration in self.dataset.shards_on_disk():  # written before the last kill: reuse it
                    self.dataset.load([iteration])
                    self.samples += self.dataset.visited[iteration]
                else:
                    policy = None if beta >= 1.0 else deployable_checkpoint(self.model, cfg.env, self.action_space,
                                                                                       self.turn_accel_mps2)
                    rollout = vec_env.collect(RolloutRequest(policy, dagger.steps_per_env, rollout_seed(cfg.seed, iteration),
                                                             beta=beta))
                    usable = usable_labels(rollout, discard)
                    observations, actions = rollout.observations[usable], rollout.expert_actions[usable]
                    if len(observations):
                        scalars["loss/on_policy"] = self.fitter.evaluate(observations, actions) if iteration else float("nan")
                    self.dataset.add(iteration, observations, actions, rollout.monitors[usable], rollout.samples)
                    self.samples += rollout.samples
                    episodes = rollout.terminated.sum() + rollout.truncated.sum() + rollout.terminated.shape[1]
                    scalars |= {"rollout/terminations_per_episode": float(rollout.terminated.sum() / episodes),
                                "rollout/reward_per_tick": float(rollout.rewards.mean()),
                                "rollout/usable_label_fraction": float(usable.mean()),
                                "rollout/samples_per_s": rollout.samples / (time.perf_counter() - start)}
                collected = time.perf_counter()
                observations, actions, _ = self.dataset.arrays()
                progress = iteration / max(dagger.iterations - 1, 1)
                learning_rate = cosine_learning_rate(dagger.learning_rate, dagger.learning_rate_final, progress)
                losses = self.fitter.fit(observations, actions, dagger.gradient_steps, dagger.batch_size, learning_rate,
                                         seed=rollout_seed(cfg.seed + 1, iteration))
                self.wall_s += time.perf_counter() - start
                scalars |= {"loss/fit_last_tenth": float(np.mean(losses[-max(len(losses) // 10, 1):])) if losses else np.nan,
                            "dataset/samples": len(observations), "time/collect_s": collected - start,
                            "time/fit_s": time.perf_counter() - collected, "learning_rate": learning_rate,
                            "samples_total": self.samples}
                self._checkpoint(iteration)
                for name, value in scalars.items():
                    writer.add_scalar(name, value, iteration)
                append_scalars(self.run_dir / SCALARS, iteration, scalars)
                bar.write(iteration_line(iteration, dagger.iterations, {
                    "beta": number(beta, 2), "samples": number(self.samples),
                    "labelled/s": number(scalars.get("rollout/samples_per_s", float("nan"))),
                    "fit": f"{scalars['time/fit_s'] / (time.perf_counter() - start):.0%}",
                    "on-policy loss": number(scalars.get("loss/on_policy", float("nan"))),
                    "fit loss": number(scalars["loss/fit_last_tenth"]), "dataset": number(scalars["dataset/samples"])}))
        finally:
            writer.close()
            if own_env:
                vec_env.close()
        print(f"DAgger done: {self.samples:,} labelled states in {self.wall_s / 60:.1f} min; policy {self.run_dir / POLICY}; "
              f"every figure per iteration: {self.run_dir / SCALARS} and TensorBoard ({self.run_dir / 'tensorboard'})")
        return self.run_dir / POLICY

    def _checkpoint(self, iteration: int) -> None:
        policy = deployable_checkpoint(self.model, self.config.env, self.action_space, self.turn_accel_mps2, iteration=iteration,
                                       samples=self.samples, wall_s=self.wall_s)
        save_torch(self.run_dir / POLICY, policy)
        save_torch(self.run_dir / TRAINING_STATE, {"policy": policy, "optimizer": self.fitter.optimizer.state_dict(),
                                                   "iteration": iteration, "samples": self.samples, "wall_s": self.wall_s})
