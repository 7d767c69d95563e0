"""How strongly each policy's action responds to each part of its observation, on a walk on flat ground.

    python examples/observation_sensitivity.py policies/distilled_hold_s1.pt policies/ppf_5m_hold_s1.pt
    python examples/observation_sensitivity.py policies/ppf.pt --vx 0.0 --yaw-rate 0.5

Each policy walks its own closed loop (no observation noise, no pushes) under one command; at every
`--every`-th tick after `--settle-s` the Jacobian J = d mu / d o of the action mean with respect to the raw
observation is taken, and the table gives the mean over those ticks of ||J_part||_F for each part (base
velocity, base angular velocity, joint angles, joint rates). The base velocity's column is the policy's
velocity feedback, the core of the ALIP foot placement it was distilled from (docs/design.md, "drift on flat
ground").
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
from mbc.errors import ConfigError, MbcError

PARTS = ("base_linvel", "base_angvel", "q", "qd")


@dataclass
class Args:
    policies: tyro.conf.Positional[list[Path]]
    """Policy checkpoints."""
    vx: float = 0.5
    vy: float = 0.0
    yaw_rate: float = 0.0
    duration_s: float = 5.0
    settle_s: float = 2.0
    """Ticks before this are walked, not measured [s]."""
    every: int = 10
    """Measure every this many ticks."""


def sensitivity(path: Path, command: tuple[float, float, float], duration_s: float, settle_s: float,
                every: int) -> tuple[np.ndarray, bool]:
    """(mean ||d mu / d o_part||_F per part of `PARTS`, whether the walk fell)."""
    checkpoint = load_checkpoint(path)
    network = ActorCritic.from_checkpoint(checkpoint).eval()
    env = WalkEnv(EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0), commands=CommandSampling.held(*command),
                            observe_heading_error=observes_heading_error(checkpoint)), with_expert=False)
    slices = [env.builder.layout.slice(part) for part in PARTS]
    observation, norms = env.reset(0), []
    for tick in range(int(round(duration_s / env.sim.dt))):
        o = torch.as_tensor(observation, dtype=torch.float32)[None]
        if tick * env.sim.dt >= settle_s and tick % every == 0:
            jacobian = torch.autograd.functional.jacobian(lambda x: network.action_mean(x)[0], o)[:, 0, :]
            norms.append([float(jacobian[:, s].norm()) for s in slices])
        with torch.no_grad():
            action = network.action_mean(o)[0].numpy()
        step = env.step(action)
        if step.terminated:
            return np.mean(norms, axis=0) if norms else np.full(len(PARTS), np.nan), True
        observation = step.observation
    return np.mean(norms, axis=0), False


def main(args: Args) -> None:
    if args.every < 1 or args.duration_s <= args.settle_s or args.settle_s < 0:
        raise ConfigError("need --every >= 1 and 0 <= --settle-s < --duration-s")
    torch.set_num_threads(1)
    print("| policy | " + " | ".join(f"d mu / d {part}" for part in PARTS) + " |")
    print("|---|" + "---|" * len(PARTS))
    for path in args.policies:
        norms, fell = sensitivity(path, (args.vx, args.vy, args.yaw_rate), args.duration_s, args.settle_s, args.every)
        print(f"| {path.name}{' (fell)' if fell else ''} | " + " | ".join(f"{n:.2f}" for n in norms) + " |", flush=True)


if __name__ == "__main__":
    try:
        main(tyro.cli(Args))
    except (ConfigError, MbcError) as error:
        raise SystemExit(f"error: {error}") from None
