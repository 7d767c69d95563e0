"""The PPO learner alone: wall time of one update (the default 16 environments x 400 ticks, 5 epochs x 4
minibatches) per method, and where it goes, on a synthetic rollout of the training's shapes.

    python benchmarks/bench_ppo_update.py                   # ppf and ifm, torch's default threads
    python benchmarks/bench_ppo_update.py --threads 1 2 --repeats 5
    python benchmarks/bench_ppo_update.py --devices cpu cuda --envs 128   # a GPU learner, a cluster's batch
    python benchmarks/bench_ppo_update.py --methods ppf --true-observations False True   # the regularizer's inputs

The update's time does not depend on the data's values, only on its shapes and on which loss terms a
method has; the full profile of one PPF update is printed by --profile.
"""

from __future__ import annotations

import cProfile
import dataclasses
import pstats
import time
from dataclasses import dataclass

import numpy as np
import torch
import tyro

from learn.action import ACTION_DIM
from learn.env import MONITOR_NAMES
from learn.observation import ObservationLayout
from learn.policy import ActorCritic, learner_device
from learn.ppo import Ppo, PpoConfig, method_regularizer
from learn.vec_env import Rollout


@dataclass
class Args:
    methods: tuple[str, ...] = ("ppf", "ifm")
    threads: tuple[int, ...] = (0,)
    """torch intra-op threads to measure (0: torch's default for this machine)."""
    devices: tuple[str, ...] = ("cpu",)
    """Learner devices to measure ('cpu', 'cuda', 'cuda:N'); the first is the baseline of the ratios."""
    steps: int = 400
    envs: int = 16
    lipschitz_samples: tuple[int, ...] = (0, 256)
    """States per minibatch of the Lipschitz penalty's estimate to compare (0: the whole minibatch, as before)."""
    true_observations: tuple[bool, ...] = (False,)
    """Where the regularizer evaluates mu (`RegularizerConfig.true_observations`): False, the policy's noisy
    observations; True, the noise-free ones (one more forward, on the labelled states; only methods with a
    regularizer)."""
    repeats: int = 3
    """Updates timed per case (after one warm-up); the median is printed."""
    profile: bool = False


def synthetic_rollout(steps: int, envs: int, seed: int = 0) -> Rollout:
    """A rollout of the training's shapes: random observations and actions, a quarter of the states labelled."""
    rng = np.random.default_rng(seed)
    obs_size = ObservationLayout(3).size
    f32 = np.float32
    return Rollout(
        observations=rng.normal(size=(steps, envs, obs_size)).astype(f32),
        expert_actions=rng.normal(0, 0.3, (steps, envs, ACTION_DIM)).astype(f32),
        label_valid=rng.random((steps, envs)) < 0.25, label_followed=np.ones((steps, envs), bool),
        expert_acted=np.zeros((steps, envs), bool), actions=rng.normal(0, 0.3, (steps, envs, ACTION_DIM)).astype(f32),
        rewards=rng.normal(1.5, 0.2, (steps, envs)).astype(f32), terminated=rng.random((steps, envs)) < 0.002,
        truncated=np.zeros((steps, envs), bool), monitors=rng.normal(0, 0.1, (steps, envs, len(MONITOR_NAMES))).astype(f32),
        log_probs=rng.normal(20, 1, (steps, envs)).astype(f32), values=rng.normal(1, 0.1, (steps, envs)).astype(f32),
        last_values=rng.normal(1, 0.1, envs).astype(f32), true_observations=rng.normal(size=(steps, envs, obs_size)).astype(f32))


def time_update(method: str, rollout: Rollout, repeats: int, lipschitz_samples: int, device: torch.device,
                true_observations: bool = False) -> float:
    """Median wall time of one update [s], the rollout's copy to `device` included (the update returns floats, so
    each timed call has finished on the device when it returns)."""
    model = ActorCritic(rollout.observations.shape[-1])
    regularizer = dataclasses.replace(method_regularizer(method, label_every=4), lipschitz_samples=lipschitz_samples or None,
                                      true_observations=true_observations)
    ppo = Ppo(model, PpoConfig(), regularizer, device=device)
    ppo.update(rollout)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        ppo.update(rollout)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main(args: Args) -> None:
    rollout = synthetic_rollout(args.steps, args.envs)
    default_threads = torch.get_num_threads()
    devices = [learner_device(name) for name in args.devices]
    print(f"one update of {rollout.samples:,} samples (5 epochs x 4 minibatches), median of {args.repeats} [s]")
    print(f"{'method':>8} {'device':>7} {'threads':>8} {'Lipschitz on':>13} {'mu fitted at':>13} {'update [s]':>11} "
          f"{'samples/s':>10} {'vs first':>9}")
    for threads in args.threads:
        torch.set_num_threads(threads or default_threads)
        for method in args.methods:
            first = None
            for device in devices:
                for samples in args.lipschitz_samples:
                    for true in args.true_observations:
                        if true and not method_regularizer(method).uses_expert:
                            continue
                        seconds = time_update(method, rollout, args.repeats, samples, device, true)
                        first = first or seconds
                        print(f"{method:>8} {device.type:>7} {torch.get_num_threads():>8} {samples or 'all':>13} "
                              f"{'true obs' if true else 'noisy obs':>13} {seconds:11.3f} {rollout.samples / seconds:10.0f} "
                              f"{first / seconds:8.2f}x")
    if args.profile:
        torch.set_num_threads(default_threads)
        model = ActorCritic(rollout.observations.shape[-1])
        ppo = Ppo(model, PpoConfig(), method_regularizer("ppf", label_every=4))
        profiler = cProfile.Profile()
        profiler.runcall(ppo.update, rollout)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(15)


if __name__ == "__main__":
    main(tyro.cli(Args))
