"""`FinetuneRunner`: PPO fine-tuning of a distilled policy (PPF, FullReg, IFM) or of a fresh one
(PureRL): rollouts that continue their episodes, the update, curricula, logging and checkpoints.

Each iteration: every environment runs `steps_per_env` ticks with the Gaussian policy (the expert
labelling every k-th tick for PPF and FullReg), PPO updates on them (the critic alone for the first
iterations), the velocity curriculum widens the forward commands while they are tracked, and the
training state is written atomically. A run killed at any moment resumes from its last checkpoint
(`resume=True`) with the same schedule; the episodes in flight at the kill are started again.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from learn.action import ActionSpace
from learn.checkpoints import POLICY, SCALARS, TRAINING_STATE, deployable_checkpoint, save_torch
from learn.config import EnvConfig, PolicyConfig, WorkerConfig, paper_randomization
from learn.console import append_scalars, iteration_line, number
from learn.curriculum import TerrainCurriculum, VelocityCurriculum
from learn.observation import observation_layout
from learn.policy import ActorCritic, check_gains, check_observation, learner_device, load_checkpoint
from learn.ppo import METHODS, PAPER_MONITORS, Method, Ppo, PpoConfig, RegularizerConfig, method_regularizer
from learn.storage import output_directory
from learn.vec_env import RolloutRequest, rollout_seed, vec_env_for
from mbc.errors import ConfigError

DISTILLED = Path(__file__).resolve().parents[1] / "policies" / "distilled.pt"
SCRATCH_GAMMA, SCRATCH_LAM, SCRATCH_START_LEVEL = 0.9975, 0.987, 0
"""PureRL's settings in the main job: legged_gym's horizons in time (its 0.99 and 0.95 at 50 Hz, per 200 Hz tick:
2 s, where PPO's default 0.99 is 0.5 s) and the terrain curriculum from level 0 (docs/design.md, PureRL)."""


@dataclass(frozen=True)
class FinetuneConfig:
    """A fine-tuning run."""

    method: Method = "ppf"
    """ppf (MAR-weighted regularizer), fullreg (constant weight), ifm (none), purerl (none, no pre-training; the
    main job gives it `SCRATCH_GAMMA`, `SCRATCH_LAM` and `SCRATCH_START_LEVEL`)."""
    run_dir: Path = Path("runs/finetune")
    seed: int = 0
    resume: bool = False
    """Continue the run in `run_dir` from its last checkpoint."""
    init_policy: Path | None = DISTILLED
    """The pre-trained policy to start from (ignored by purerl, which starts from scratch)."""
    iterations: int = 150
    """PPO iterations (about 4 s each for PPF with 2 workers x 8 environments: 10 minutes, 960,000 steps;
    the shipped policies' budget)."""
    steps_per_env: int = 400
    """Ticks per environment per iteration (2 s; 6,400 steps per iteration with 16 environments: minibatches
    of 1,600, where 100 ticks (400 per minibatch) made the actor's updates a random walk)."""
    label_every: int = 4
    """PPF and FullReg: the expert labels every k-th tick (its clock still sees every tick); 4 keeps PPO
    above 3,500 steps/s on 2 cores (`benchmarks/bench_ppo_throughput.py`)."""
    mar_monitors: tuple[str, ...] = PAPER_MONITORS
    """PPF: the assumption monitors its MAR weight reads (`learn.ppo.MONITOR_DELTAS`; the paper's CoM z' alone)."""
    regularize_true_observations: bool = False
    """PPF and FullReg: fit the pull toward the expert at the noise-free observations
    (`RegularizerConfig.true_observations`); False: at the noisy ones the policy acts on (the paper's)."""
    init_log_std: float = -2.0
    """Log standard deviation of the exploration noise at the start (normalized action units)."""
    terrain_curriculum: bool = True
    velocity_curriculum: bool = True
    env: EnvConfig = field(default_factory=lambda: EnvConfig(terrains=("flat",), randomization=paper_randomization()))
    ppo: PpoConfig = field(default_factory=PpoConfig)
    curriculum: TerrainCurriculum = field(default_factory=TerrainCurriculum)
    velocity: VelocityCurriculum = field(default_factory=VelocityCurriculum)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    workers: WorkerConfig = field(default_factory=WorkerConfig)
    device: str = "cpu"
    """Where the PPO update runs: 'cpu', or 'cuda' when torch sees a GPU (the rollouts stay on the CPU workers)."""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"unknown method {self.method!r}; valid: {list(METHODS)}")
        if self.iterations < 1 or self.steps_per_env < 1:
            raise ConfigError(f"iterations and steps_per_env must be >= 1, got {self.iterations} and {self.steps_per_env}")
        if self.label_every < 1 and self.method in ("ppf", "fullreg"):
            raise ConfigError(f"{self.method} regularizes toward the expert's labels: label_every must be >= 1 "
                              f"(1: every tick, 4: the default), got {self.label_every}")
        self.regularizer()  # checks the MAR monitors, and that regularize_true_observations has a regularizer to fit

    def regularizer(self) -> RegularizerConfig:
        regularizer = method_regularizer(self.method, self.label_every, self.mar_monitors)
        return dataclasses.replace(regularizer, true_observations=self.regularize_true_observations)


class FinetuneRunner:
    """Runs (or resumes) a fine-tuning in `config.run_dir`."""

    def __init__(self, config: FinetuneConfig) -> None:
        self.config = cfg = config
        self.run_dir = output_directory(cfg.run_dir, "run_dir")
        state_path = self.run_dir / TRAINING_STATE
        if state_path.exists() and not cfg.resume:
            raise ConfigError(f"{self.run_dir} already holds a run; pass --resume to continue it or choose another run_dir")
        if cfg.resume and not state_path.exists():
            raise ConfigError(f"nothing to resume in {self.run_dir} (no {TRAINING_STATE})")
        env = dataclasses.replace(cfg.env, purerl_rewards=cfg.method == "purerl")
        self.env_config = env
        self.action_space = ActionSpace()
        if cfg.method == "purerl" or cfg.init_policy is None:
            self.model = ActorCritic(observation_layout(env).size, cfg.policy, seed=cfg.seed)
            self._fresh_normalizer = True
        else:
            checkpoint = load_checkpoint(cfg.init_policy)
            check_gains(checkpoint, self.action_space.kp, self.action_space.kd, "this fine-tuning's action space")
            check_observation(checkpoint, env, cfg.init_policy)
            self.model = ActorCritic.from_checkpoint(checkpoint)
            self._fresh_normalizer = False
        with torch.no_grad():
            self.model.log_std.fill_(cfg.init_log_std)
        self.ppo = Ppo(self.model, cfg.ppo, cfg.regularizer(), seed=cfg.seed, device=learner_device(cfg.device))
        self.start_iteration, self.samples, self.wall_s = 0, 0, 0.0
        self.forward_max = cfg.velocity.start_mps
        if state_path.exists():
            self._restore(state_path)
        (self.run_dir / "config.json").write_text(json.dumps(dataclasses.asdict(cfg), indent=2, default=str))

    def _restore(self, path: Path) -> None:
        state = torch.load(path, map_location="cpu", weights_only=True)
        check_observation(state["policy"], self.env_config, path)
        self.model.load_state_dict(state["policy"]["state_dict"])
        self.ppo.optimizer.load_state_dict(state["optimizer"])
        self.ppo.learning_rate = float(state["learning_rate"])
        self.start_iteration = int(state["iteration"]) + 1
        self.samples, self.wall_s, self.forward_max = int(state["samples"]), float(state["wall_s"]), float(state["forward_max"])
        self._fresh_normalizer = False

    def learn(self) -> Path:
        """Run the remaining iterations; returns the path of the deployable policy."""
        from torch.utils.tensorboard import SummaryWriter

        cfg = self.config
        regularizer = cfg.regularizer()
        curriculum = cfg.curriculum if cfg.terrain_curriculum else None
        writer = SummaryWriter(str(self.run_dir / "tensorboard"))
        with vec_env_for(self.env_config, cfg.workers, regularizer.uses_expert, curriculum) as vec_env:
            bar = tqdm(range(self.start_iteration, cfg.iterations), desc=f"fine-tuning ({cfg.method})", unit="it",
                       initial=self.start_iteration, total=cfg.iterations, disable=None)
            for iteration in bar:
                start = time.perf_counter()
                rollout = vec_env.collect(RolloutRequest(
                    deployable_checkpoint(self.model, self.env_config, self.action_space), cfg.steps_per_env,
                    rollout_seed(cfg.seed, iteration), label_every=regularizer.label_every if regularizer.uses_expert else 0,
                    stochastic=True, continue_episodes=iteration > self.start_iteration,
                    true_observations=regularizer.true_observations,
                    forward_command_max_mps=self.forward_max if cfg.velocity_curriculum else None))
                collected = time.perf_counter()
                if self._fresh_normalizer:  # PureRL: normalize by the first rollout's statistics, then keep them
                    self.model.normalizer.set_statistics(rollout.observations.reshape(-1, rollout.observations.shape[-1]))
                    self._fresh_normalizer = False
                stats = self.ppo.update(rollout, critic_only=iteration < cfg.ppo.critic_warmup_iterations)
                self.samples += rollout.samples
                self.wall_s += time.perf_counter() - start
                scalars = self._scalars(rollout, stats, collected - start, time.perf_counter() - collected)
                if cfg.velocity_curriculum:
                    self.forward_max = cfg.velocity.next_max(self.forward_max, scalars["rollout/lin_vel_tracking"],
                                                             iteration + 1)
                self._checkpoint(iteration)
                for name, value in scalars.items():
                    writer.add_scalar(name, value, iteration)
                append_scalars(self.run_dir / SCALARS, iteration, scalars)
                bar.write(iteration_line(iteration, cfg.iterations, self._figures(scalars)))
        writer.close()
        print(f"fine-tuning ({cfg.method}) done: {self.samples:,} steps in {self.wall_s / 60:.1f} min "
              f"({self.samples / max(self.wall_s, 1e-9):,.0f} steps/s); policy {self.run_dir / POLICY}; "
              f"every figure per iteration: {self.run_dir / SCALARS} and TensorBoard ({self.run_dir / 'tensorboard'})")
        return self.run_dir / POLICY

    @staticmethod
    def _figures(scalars: dict[str, float]) -> dict[str, str]:
        """The few figures of an iteration a user watches (all of them go to TensorBoard and `scalars.jsonl`)."""
        iteration_s = scalars["time/collect_s"] + scalars["time/update_s"]
        return {"samples": number(scalars["samples_total"]), "steps/s": number(scalars["time/steps_per_s"]),
                "update": f"{scalars['time/update_s'] / iteration_s:.0%}",
                "reward/tick": number(scalars["rollout/reward_per_tick"]),
                "tracking": number(scalars["rollout/lin_vel_tracking"]),
                "falls": f"{scalars['rollout/falls']:.0f}/{scalars['rollout/episodes']:.0f}",
                "level": number(scalars["rollout/mean_terrain_level"], 2),
                "vx max": number(scalars["curriculum/forward_max_mps"], 2),
                "reg w": number(scalars.get("loss/regularization_weight", float("nan")), 2)}

    def _scalars(self, rollout, stats: dict[str, float], collect_s: float, update_s: float) -> dict[str, float]:
        episodes = rollout.episodes
        scalars = {f"loss/{k}": v for k, v in stats.items()}
        scalars |= {f"reward/{k}": v for k, v in rollout.reward_terms.items()}
        scalars |= {"rollout/reward_per_tick": float(rollout.rewards.mean()),
                    "rollout/lin_vel_tracking": rollout.reward_terms["lin_vel_tracking"],
                    "rollout/falls": float(sum(e["fell"] for e in episodes)), "rollout/episodes": float(len(episodes)),
                    "rollout/mean_terrain_level": float(np.mean([e["level"] for e in episodes])) if episodes else np.nan,
                    "rollout/samples_per_s": rollout.samples / collect_s, "time/collect_s": collect_s, "time/update_s": update_s,
                    "time/steps_per_s": rollout.samples / (collect_s + update_s),
                    "curriculum/forward_max_mps": self.forward_max, "samples_total": float(self.samples)}
        for kind in sorted({e["kind"] for e in episodes if "kind" in e}):  # the episodes that ended, per terrain kind
            ended = [e for e in episodes if e.get("kind") == kind]
            scalars[f"curriculum/level_{kind}"] = float(np.mean([e["level"] for e in ended]))
            scalars[f"rollout/falls_{kind}"] = float(sum(e["fell"] for e in ended))
            scalars[f"rollout/episodes_{kind}"] = float(len(ended))
            upright = [e["heading_error_deg"] for e in ended if not e["fell"]]  # a fall's own spin is not a turn
            if upright:
                scalars[f"rollout/heading_error_deg_{kind}"] = float(np.mean(upright))
        return scalars

    def _checkpoint(self, iteration: int) -> None:
        sampling = self.env_config.commands
        trained = dataclasses.replace(self.env_config, commands=dataclasses.replace(  # the commands it has seen
            sampling, vx_mps=(sampling.vx_mps[0], max(sampling.vx_mps[1], self.forward_max))))
        policy = deployable_checkpoint(self.model, trained, self.action_space, iteration=iteration,
                                       samples=self.samples, wall_s=self.wall_s, method=self.config.method)
        save_torch(self.run_dir / POLICY, policy)
        save_torch(self.run_dir / TRAINING_STATE, {"policy": policy, "optimizer": self.ppo.optimizer.state_dict(),
                                                   "learning_rate": self.ppo.learning_rate, "iteration": iteration,
                                                   "samples": self.samples, "wall_s": self.wall_s,
                                                   "forward_max": self.forward_max})
