"""Actor-critic networks with observation normalization, their checkpoint format, and
`PolicyController`: a trained policy behind the `Controller` protocol.

The actor is an MLP (512-256-64, ELU) whose output is the mean action mu(s), the deterministic policy;
a learnable log standard deviation makes it the Gaussian policy of PPO. Observations are normalized
by a mean and standard deviation saved with the networks, so a checkpoint is self-contained.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import torch
from torch import nn

from learn.action import ACTION_DIM, ActionSpace
from learn.config import EnvConfig, PolicyConfig
from learn.observation import ObservationBuilder, gait_timing
from mbc.errors import ConfigError
from mbc.types import CONTROL_PERIOD_S, Command, CommandLimits, JointCommand, RobotState

CHECKPOINT_FORMAT = "ppf-digit-policy-1"


def mlp(sizes: tuple[int, ...]) -> nn.Sequential:
    """Linear layers of `sizes` with ELU between them (none after the last)."""
    layers: list[nn.Module] = []
    for k, (n_in, n_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(n_in, n_out))
        if k < len(sizes) - 2:
            layers.append(nn.ELU())
    return nn.Sequential(*layers)


class Normalizer(nn.Module):
    """(x - mean) / std with statistics set from data; `inverse` undoes it."""

    def __init__(self, size: int, epsilon: float = 1e-2) -> None:
        super().__init__()
        self.epsilon = epsilon
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("std", torch.ones(size))

    def set_statistics(self, data: np.ndarray) -> None:
        """Mean and std of `data` (n, size); std floored at epsilon (constant features stay finite)."""
        data = np.asarray(data, np.float64)
        self.mean.copy_(torch.as_tensor(data.mean(axis=0), dtype=torch.float32))
        self.std.copy_(torch.as_tensor(np.maximum(data.std(axis=0), self.epsilon), dtype=torch.float32))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std

    def inverse(self, y: torch.Tensor) -> torch.Tensor:
        return y * self.std + self.mean


class ActorCritic(nn.Module):
    """Gaussian actor with a state-independent learnable log-std, and a value critic."""

    def __init__(self, observation_size: int, config: PolicyConfig | None = None, action_size: int = ACTION_DIM,
                 seed: int | None = None) -> None:
        """`seed`: the initial weights are drawn from torch's generator seeded by it, and torch's global stream is
        left as it was (None: drawn from that stream, so a run's seed does not fix them)."""
        super().__init__()
        self.config = config or PolicyConfig()
        self.observation_size, self.action_size = observation_size, action_size
        self.normalizer = Normalizer(observation_size)
        with torch.random.fork_rng(devices=[], enabled=seed is not None):
            if seed is not None:
                torch.manual_seed(seed)
            self.actor = mlp((observation_size, *self.config.actor_hidden, action_size))
            self.critic = mlp((observation_size, *self.config.critic_hidden, 1))
        self.log_std = nn.Parameter(torch.full((action_size,), self.config.init_log_std))

    def action_mean(self, observation: torch.Tensor) -> torch.Tensor:
        """mu(s): the deterministic policy, (n, action_size)."""
        return self.actor(self.normalizer(observation))

    def value(self, observation: torch.Tensor) -> torch.Tensor:
        """V(s), (n,)."""
        return self.critic(self.normalizer(observation)).squeeze(-1)

    def distribution(self, observation: torch.Tensor) -> torch.distributions.Normal:
        return torch.distributions.Normal(self.action_mean(observation), self.log_std.exp().expand(self.action_size))

    def checkpoint(self, **extra) -> dict:
        """A `torch.save`-able dict loadable with `weights_only=True`."""
        return {"format": CHECKPOINT_FORMAT, "observation_size": self.observation_size, "action_size": self.action_size,
                "policy_config": dataclasses.asdict(self.config),
                "state_dict": {k: v.detach().cpu() for k, v in self.state_dict().items()}, **extra}

    @classmethod
    def from_checkpoint(cls, checkpoint: dict) -> ActorCritic:
        if checkpoint.get("format") != CHECKPOINT_FORMAT:
            raise ConfigError(f"not a policy checkpoint (format {checkpoint.get('format')!r}, "
                              f"expected {CHECKPOINT_FORMAT!r})")
        config = PolicyConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in checkpoint["policy_config"].items()})
        model = cls(checkpoint["observation_size"], config, checkpoint["action_size"])
        model.load_state_dict(checkpoint["state_dict"])
        return model


WHAT_A_CHECKPOINT_IS = ("a policy checkpoint is the policy.pt a training run writes (examples/distill.py, "
                        "examples/distill_and_finetune.py) or one of policies/*.pt")


def load_checkpoint(path: str | Path) -> dict:
    """A checkpoint file's dict (tensors and plain data only: `weights_only=True`), with clear errors."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"no policy checkpoint at {path}")
    try:
        checkpoint = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # pickle, zip or torch format errors: not a checkpoint of ours (torch's text says nothing useful)
        raise ConfigError(f"{path} is not a policy checkpoint: {WHAT_A_CHECKPOINT_IS}") from exc
    if not isinstance(checkpoint, dict) or checkpoint.get("format") != CHECKPOINT_FORMAT:
        raise ConfigError(f"{path} is not a policy checkpoint of this project (expected format {CHECKPOINT_FORMAT!r}): "
                          f"{WHAT_A_CHECKPOINT_IS}")
    return checkpoint


def learner_device(name: str) -> torch.device:
    """The torch device the learner runs on ('cpu', 'cuda', 'cuda:1', ...), refused clearly where it does not exist.
    Rollouts always run on the CPU workers; only the update (PPO) or the fit (DAgger) moves."""
    try:
        device = torch.device(name)
    except RuntimeError as error:
        raise ConfigError(f"unknown device {name!r}; valid: 'cpu', 'cuda', 'cuda:N'") from error
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"device {name!r}: torch sees no CUDA device on this machine; use 'cpu'")
    if device.type not in ("cpu", "cuda"):
        raise ConfigError(f"unsupported device {name!r}; valid: 'cpu', 'cuda', 'cuda:N'")
    return device


def check_gains(checkpoint: dict, kp: np.ndarray, kd: np.ndarray, where: str) -> None:
    """Raise `ConfigError` unless the checkpoint's action space was trained with the joint gains (kp, kd) of `where`:
    an action means a torque only through the gains it was learned with."""
    trained = np.asarray(checkpoint["kp"], float), np.asarray(checkpoint["kd"], float)
    if not (np.allclose(trained[0], kp) and np.allclose(trained[1], kd)):
        raise ConfigError(f"the policy was trained with joint gains kp {np.round(trained[0], 1).tolist()} kd "
                          f"{np.round(trained[1], 1).tolist()}, but {where} applies kp {np.round(kp, 1).tolist()} kd "
                          f"{np.round(kd, 1).tolist()}; retrain it on these gains (robots/digit/constants.py KP, KD)")


def gait_clock_of(checkpoint: dict) -> str:
    """The gait clock a checkpoint's policy observes (`learn.config.GAIT_CLOCKS`); 'contact' for checkpoints
    written before the key existed."""
    return str(checkpoint.get("gait_clock", "contact"))


def observes_heading_error(checkpoint: dict) -> bool:
    """Whether a checkpoint's policy observes its heading error (`learn.observation`); False for checkpoints
    written before the key existed."""
    return bool(checkpoint.get("observe_heading_error", False))


def check_observation(checkpoint: dict, env: EnvConfig, source: str | Path) -> None:
    """Raise `ConfigError` unless `env` builds the observation the checkpoint's policy was trained on (its gait
    clock and whether the heading error is in it); `source` names the checkpoint in the message."""
    if gait_clock_of(checkpoint) != env.gait_clock:
        raise ConfigError(f"{source} observes the {gait_clock_of(checkpoint)!r} gait clock; this environment has "
                          f"{env.gait_clock!r}")
    if observes_heading_error(checkpoint) != env.observe_heading_error:
        raise ConfigError(f"{source} was trained {'with' if observes_heading_error(checkpoint) else 'without'} the "
                          f"heading error in its observation; this environment has observe_heading_error="
                          f"{env.observe_heading_error}")


class PolicyController:
    """A trained policy as a `Controller`: its own gait clock, joint history and previous action.

    >>> controller = PolicyController("policies/distilled.pt")
    >>> episode = run_episode(DigitSim(), controller, Command(vx=0.3), duration_s=10.0)
    """

    dt = CONTROL_PERIOD_S

    def __init__(self, path: str | Path) -> None:
        checkpoint = load_checkpoint(path)
        self.model = ActorCritic.from_checkpoint(checkpoint).eval()
        self.gait_clock = gait_clock_of(checkpoint)
        self.builder = ObservationBuilder(int(checkpoint["history_length"]), gait_timing(self.gait_clock),
                                          observes_heading_error(checkpoint))
        if self.builder.layout.size != self.model.observation_size:
            raise ConfigError(f"{path}: observation size {self.model.observation_size} does not match its layout "
                              f"({self.builder.layout.size})")
        self.action_space = ActionSpace(np.asarray(checkpoint["kp"]), np.asarray(checkpoint["kd"]))
        low, high = np.asarray(checkpoint["command_range"], float).tolist()  # (2, 3): the trained command range
        self.command_limits = CommandLimits(*zip(low, high), turn_accel_mps2=float(checkpoint.get("turn_accel_mps2", math.inf)))
        """The commands it was trained on (a distilled policy: its teacher's, turning limit included); beyond them
        commands are clipped and the episode summary counts the ticks (`clipped_command_ticks`)."""
        self.path = Path(path)
        self._started = False

    @property
    def pd_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """(kp, kd) of the action space the policy was trained in."""
        return self.action_space.kp, self.action_space.kd

    def reset(self, state: RobotState) -> None:
        self.builder.reset(state)
        self._started = True

    def act(self, state: RobotState, command: Command) -> JointCommand:
        if not isinstance(command, Command):
            raise ConfigError(f"act expects a Command, got {type(command).__name__}")
        if not self._started:
            self.reset(state)
        observation = self.builder.observe(state, np.array(self.command_limits.clip(command)[0]))
        with torch.inference_mode():
            action = self.model.action_mean(torch.as_tensor(observation, dtype=torch.float32)[None])[0].numpy()
        self.builder.record_action(action)
        return self.action_space.to_command(action.astype(float), state)
