"""PPO steps per second per method as training runs them: the rollout alone, and end to end (the rollout and
the update on it, one iteration), with the update's share and the expert's share of worker time.

    python benchmarks/bench_ppo_throughput.py                       # 2 workers x 8 envs, 400 ticks: the training's
    python benchmarks/bench_ppo_throughput.py --workers 1 2 --backends process ray   # scaling (ray: see below)

Methods: IFM and PureRL never call the expert (their update has no regularizer; PureRL's rollout also computes its
swing-foot and other reward terms); PPF and FullReg call its
IK and QP on every k-th tick of each environment and only advance its gait clock on the others. A rollout
is a whole `collect` (IPC included) after a warm-up one, with the shipped distilled policy acting; the
update is `Ppo.update` on that rollout with the method's loss, in this process as in training (torch's
default threads; the workers idle meanwhile). `--backends ray` starts a local Ray cluster, which the
project allows only where loopback is the only interface: run it as `sudo unshare -n ...` after `ip link
set lo up` (docs/cluster.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import tyro

from learn.action import ActionSpace
from learn.checkpoints import deployable_checkpoint
from learn.config import EnvConfig, paper_randomization
from learn.finetune import DISTILLED
from learn.policy import ActorCritic, load_checkpoint
from learn.ppo import Ppo, PpoConfig, method_regularizer
from learn.vec_env import RolloutRequest, make_vec_env


@dataclass
class Args:
    workers: tuple[int, ...] = (2,)
    envs_per_worker: int = 8
    steps: int = 400
    """Ticks per environment of the measured rollout (the training's iteration)."""
    label_every: tuple[int, ...] = (4,)
    """Label rates to measure for the regularized methods (the training's default: 4)."""
    backends: tuple[str, ...] = ("process",)
    repeats: int = 3
    """Rollouts timed per case (the median is printed; the update is timed on the last)."""


def measure(workers: int, args: Args, backend: str, method: str, label_every: int) -> dict[str, float]:
    config = EnvConfig(terrains=("flat",), randomization=paper_randomization(), purerl_rewards=method == "purerl")
    model = ActorCritic.from_checkpoint(load_checkpoint(DISTILLED))
    model.log_std.data.fill_(-2.0)  # the fine-tuning's exploration
    policy = deployable_checkpoint(model, config, ActionSpace())
    ppo = Ppo(model, PpoConfig(), method_regularizer(method, label_every))
    with make_vec_env(config, workers, args.envs_per_worker, with_expert=label_every > 0, backend=backend) as vec_env:
        vec_env.collect(RolloutRequest(policy, 20, seed=1, label_every=label_every, stochastic=True))
        times = []
        for repeat in range(args.repeats):
            start = time.perf_counter()
            rollout = vec_env.collect(RolloutRequest(policy, args.steps, seed=2 + repeat, label_every=label_every,
                                                     stochastic=True, continue_episodes=True))
            times.append(time.perf_counter() - start)
        collect_s = float(np.median(times))
    start = time.perf_counter()
    ppo.update(rollout)
    update_s = time.perf_counter() - start
    return {"rollout": rollout.samples / collect_s, "end_to_end": rollout.samples / (collect_s + update_s),
            "update_share": update_s / (collect_s + update_s),
            "expert_share": rollout.timing_s["expert"] / rollout.timing_s["total"]}


def main(args: Args) -> None:
    print(f"{args.envs_per_worker} envs per worker, {args.steps} ticks each; steps/s (rollout: median of {args.repeats})")
    print(f"{'method':>24} {'backend':>8} {'workers':>7} {'rollout':>8} {'end-to-end':>10} {'update':>7} {'expert':>7}")
    methods = [("ifm (no expert)", "ifm", 0), ("purerl (no expert)", "purerl", 0)]
    methods += [(f"ppf / fullreg, 1/{k}", "ppf", k) for k in args.label_every]
    for name, method, label_every in methods:
        for backend in args.backends:
            for workers in args.workers:
                m = measure(workers, args, backend, method, label_every)
                print(f"{name:>24} {backend:>8} {workers:7d} {m['rollout']:8.0f} {m['end_to_end']:10.0f} "
                      f"{m['update_share']:7.0%} {m['expert_share']:7.0%}")


if __name__ == "__main__":
    main(tyro.cli(Args))
