"""What the paper's reward pays a policy per tick for walking a held command on flat ground, term by term.

    python examples/reward_budget.py policies/distilled_hold_s1.pt policies/ppf_5m_hold_true_soft_s1.pt
    python examples/reward_budget.py policies/ppf.pt --commands 0.5 0.6 --score-vx 0.5

Each policy walks its own closed loop (its action mean; no observation noise, no pushes, nominal dynamics) under
each forward command of `--commands` for `--duration-s`; after `--settle-s` the weighted terms of
`learn.rewards.PAPER_WEIGHTS` are averaged over the ticks. The last column scores the same walk's velocity
against `--score-vx` instead of its command, 1.2 exp(-|v_xy - (score_vx, 0)|^2 / delta_xy): walked at a higher
command, it says what the reward would pay the policy for reaching `--score-vx`, with the penalties that walk costs
(docs/design.md, "drift on flat ground").
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import tyro

from learn.config import CommandSampling, EnvConfig, PushSampling
from learn.env import WalkEnv
from learn.policy import ActorCritic, load_checkpoint, observes_heading_error
from learn.rewards import PAPER_WEIGHTS, lin_vel_tracking
from mbc.errors import ConfigError
from mbc.geometry import yaw_of_quaternion


@dataclass
class Args:
    policies: tyro.conf.Positional[list[Path]]
    """Policy checkpoints."""
    commands: tuple[float, ...] = (0.5, 0.6)
    """Forward commands to walk [m/s]."""
    score_vx: float = 0.5
    """The speed the last column scores each walk against [m/s]."""
    duration_s: float = 10.0
    settle_s: float = 3.0
    """Ticks before this are walked, not scored [s]."""


@dataclass(frozen=True)
class Budget:
    velocity_heading_mps: np.ndarray
    """(2,) mean heading-frame velocity (forward, lateral) over the scored ticks."""
    weighted_terms: dict[str, float]
    """Mean weighted reward term per tick."""
    tracking_at_score: float
    """Mean 1.2 exp(-|v_xy - (score_vx, 0)|^2 / delta_xy) per tick."""
    fell: bool


def budget(path: Path, vx_mps: float, score_vx_mps: float, duration_s: float, settle_s: float) -> Budget:
    checkpoint = load_checkpoint(path)
    network = ActorCritic.from_checkpoint(checkpoint).eval()
    env = WalkEnv(EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0), commands=CommandSampling.held(vx_mps),
                            observe_heading_error=observes_heading_error(checkpoint)), with_expert=False)
    observation, sums, velocities, tracking = env.reset(0), dict.fromkeys(PAPER_WEIGHTS, 0.0), [], 0.0
    for tick in range(int(round(duration_s / env.sim.dt))):
        with torch.no_grad():
            action = network.action_mean(torch.as_tensor(observation, dtype=torch.float32)[None])[0].numpy()
        step = env.step(action)
        if step.terminated:
            return Budget(np.full(2, np.nan), dict.fromkeys(PAPER_WEIGHTS, np.nan), np.nan, True)
        observation = step.observation
        if tick * env.sim.dt < settle_s:
            continue
        for name, weight in PAPER_WEIGHTS.items():
            sums[name] += weight * step.reward_terms[name]
        yaw = yaw_of_quaternion(env.state.base_quat)
        c, s = np.cos(yaw), np.sin(yaw)
        vx, vy = env.state.base_linvel[:2]
        velocity = np.array([c * vx + s * vy, -s * vx + c * vy])
        velocities.append(velocity)
        tracking += PAPER_WEIGHTS["lin_vel_tracking"] * lin_vel_tracking(velocity, np.array([score_vx_mps, 0.0]),
                                                                         env.config.lin_vel_tracking_sigma)
    n = len(velocities)
    return Budget(np.mean(velocities, axis=0), {k: v / n for k, v in sums.items()}, tracking / n, False)


def main(args: Args) -> None:
    if args.duration_s <= args.settle_s or args.settle_s < 0 or not args.commands:
        raise ConfigError("need 0 <= --settle-s < --duration-s and at least one --commands")
    torch.set_num_threads(1)
    names = list(PAPER_WEIGHTS)
    print("| policy | command | vx, vy [m/s] | " + " | ".join(names) + f" | sum | tracking at {args.score_vx:g} |")
    print("|---|---|---|" + "---|" * (len(names) + 2))
    for path in args.policies:
        for vx in args.commands:
            b = budget(path, vx, args.score_vx, args.duration_s, args.settle_s)
            label = f"{path.name}{' (fell)' if b.fell else ''}"
            print(f"| {label} | {vx:g} | {b.velocity_heading_mps[0]:.3f}, {b.velocity_heading_mps[1]:.3f} | "
                  + " | ".join(f"{b.weighted_terms[k]:.3f}" for k in names)
                  + f" | {sum(b.weighted_terms.values()):.3f} | {b.tracking_at_score:.3f} |", flush=True)


if __name__ == "__main__":
    main(tyro.cli(Args))
