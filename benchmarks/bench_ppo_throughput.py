"""PPO environment steps per second per method and expert-label rate, policy sampling included, and
the share of worker time in the expert.

    python benchmarks/bench_ppo_throughput.py                    # 2 workers x 8 envs; ifm, and ppf at 1, 2, 4, 10
    python benchmarks/bench_ppo_throughput.py --workers 1 --label-every 1 4

IFM and PureRL never call the expert; PPF and FullReg call its IK and QP on every k-th tick of each
environment and only advance its gait clock on the others. Rates are over a whole `collect` (IPC
included) after a warm-up rollout, with the shipped distilled policy acting (so the robot walks).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import tyro

from learn.action import ActionSpace
from learn.checkpoints import deployable_checkpoint
from learn.config import EnvConfig
from learn.finetune import DISTILLED
from learn.policy import ActorCritic, load_checkpoint
from learn.vec_env import RolloutRequest, make_vec_env


@dataclass
class Args:
    workers: int = 2
    envs_per_worker: int = 8
    steps: int = 300
    """Ticks per environment of the measured rollout."""
    label_every: tuple[int, ...] = (1, 2, 4, 10)
    """Label rates to measure for the regularized methods."""


def measure(args: Args, label_every: int) -> tuple[float, float]:
    config = EnvConfig(terrains=("flat",))
    model = ActorCritic.from_checkpoint(load_checkpoint(DISTILLED))
    policy = deployable_checkpoint(model, config, ActionSpace())
    with make_vec_env(config, args.workers, args.envs_per_worker, with_expert=label_every > 0) as vec_env:
        vec_env.collect(RolloutRequest(policy, 20, seed=1, label_every=label_every, stochastic=True))
        start = time.perf_counter()
        rollout = vec_env.collect(RolloutRequest(policy, args.steps, seed=2, label_every=label_every, stochastic=True,
                                                 continue_episodes=True))
        wall = time.perf_counter() - start
    return rollout.samples / wall, rollout.timing_s["expert"] / rollout.timing_s["total"]


def main(args: Args) -> None:
    print(f"{args.workers} workers x {args.envs_per_worker} envs, {args.steps} ticks each")
    print(f"{'method':>22} {'steps/s':>9} {'expert share':>13}")
    baseline, _ = measure(args, 0)
    print(f"{'ifm / purerl (no expert)':>22} {baseline:9.0f} {0.0:13.0%}")
    for k in args.label_every:
        rate, share = measure(args, k)
        print(f"{f'ppf / fullreg, 1/{k}':>22} {rate:9.0f} {share:13.0%}   ({rate / baseline:.2f}x the no-expert rate)")


if __name__ == "__main__":
    main(tyro.cli(Args))
