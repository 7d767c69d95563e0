"""Checkpoint files of both runners (DAgger and fine-tuning): the deployable policy, written atomically.

A deployable checkpoint holds the networks and what `PolicyController` needs to run them: the history
length, the PD gains of the action space (checked against a simulator's) and the command limits of
what it was trained on: the command ranges and, for a distilled policy, its teacher's turning limit.
"""

from __future__ import annotations

import math
from pathlib import Path

import torch

from learn.action import ActionSpace
from learn.config import EnvConfig
from learn.policy import ActorCritic, load_checkpoint
from learn.storage import atomic_write

TRAINING_STATE = "training_state.pt"
POLICY = "policy.pt"
SCALARS = "scalars.jsonl"
"""Every logged figure, one JSON line per iteration (beside TensorBoard's event files)."""


def deployable_checkpoint(model: ActorCritic, env: EnvConfig, action_space: ActionSpace,
                          turn_accel_mps2: float = math.inf, **extra) -> dict:
    """The networks, history length, gait clock, whether the heading error is observed, PD gains, trained command
    range and turning limit |v_xy| |yaw rate| [m/s^2] (inf: none), plus `extra` (iteration, samples, wall time,
    method)."""
    sampling = env.commands
    command_range = [[sampling.vx_mps[0], sampling.vy_mps[0], sampling.yaw_rate_radps[0]],
                     [sampling.vx_mps[1], sampling.vy_mps[1], sampling.yaw_rate_radps[1]]]
    return model.checkpoint(history_length=env.history_length, gait_clock=env.gait_clock,
                            observe_heading_error=env.observe_heading_error, kp=action_space.kp.tolist(),
                            kd=action_space.kd.tolist(),
                            command_range=command_range, turn_accel_mps2=float(turn_accel_mps2), **extra)


def save_torch(path: Path, payload: dict) -> None:
    atomic_write(path, lambda file: torch.save(payload, file))


def policy_summary(path: str | Path) -> dict:
    """Iteration, samples and wall time recorded in a policy checkpoint."""
    checkpoint = load_checkpoint(path)
    return {key: checkpoint.get(key) for key in ("iteration", "samples", "wall_s")}
