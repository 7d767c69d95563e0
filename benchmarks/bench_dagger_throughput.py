"""Labelled samples per second of DAgger's rollouts, policy forward included, and where the time goes.

    python benchmarks/bench_dagger_throughput.py                        # 1 and 2 workers x 1, 4, 8, 16 envs
    python benchmarks/bench_dagger_throughput.py --workers 2 --envs 8 --steps 800

The expert acts (beta = 1) while the policy (an untrained 512-256-64 MLP) runs batched on every tick as
in DAgger, so the robot walks and every tick costs what a training tick costs. Shares are of the
summed worker time: expert (the AlipController's labelling), physics (DigitSim.step, reward,
observation), policy (the batched forward), and the rest (buffers, resets, IPC and start-up of the
rollout), from the workers' own clocks. The wall rate is over the whole `collect` call, IPC included.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import tyro

from learn.action import ActionSpace
from learn.checkpoints import deployable_checkpoint
from learn.config import EnvConfig
from learn.observation import ObservationLayout
from learn.policy import ActorCritic
from learn.vec_env import RolloutRequest, make_vec_env


@dataclass
class Args:
    workers: tuple[int, ...] = (1, 2)
    """Worker process counts to measure."""
    envs: tuple[int, ...] = (1, 4, 8, 16)
    """Environments per worker to measure."""
    steps: int = 400
    """Ticks per environment per measured rollout."""


def main(args: Args) -> None:
    config = EnvConfig(terrains=("flat",))
    policy = deployable_checkpoint(ActorCritic(ObservationLayout(config.history_length).size), config, ActionSpace())
    print(f"{'workers':>7} {'envs/w':>6} {'samples/s':>10} {'per worker':>10}   share of worker time: "
          f"{'expert':>6} {'physics':>7} {'policy':>6} {'other':>6}")
    for workers in args.workers:
        for envs in args.envs:
            with make_vec_env(config, workers, envs) as vec_env:
                vec_env.collect(RolloutRequest(policy, 20, seed=1, beta=1.0))  # warm-up: imports, first solves
                start = time.perf_counter()
                rollout = vec_env.collect(RolloutRequest(policy, args.steps, seed=2, beta=1.0))
                wall = time.perf_counter() - start
            timing = rollout.timing_s
            share = {part: timing[part] / timing["total"] for part in ("expert", "physics", "policy")}
            other = 1.0 - sum(share.values())
            rate = rollout.samples / wall
            print(f"{workers:7d} {envs:6d} {rate:10.0f} {rate / workers:10.0f}   {'':>21}"
                  f"{share['expert']:6.0%} {share['physics']:7.0%} {share['policy']:6.0%} {other:6.0%}")


if __name__ == "__main__":
    main(tyro.cli(Args))
