"""PPO with the paper's regularizers: the update of one iteration, on a batch of rollouts.

A compact PPO of our own rather than rsl-rl-lib's: its `PPO.update` computes the surrogate, value and
entropy terms inside one loop with no hook for another loss term, so the expert regularizer (which
needs the expert's labels and the assumption monitors of each sample) and the Lipschitz penalty
could only be added by copying that loop. Here the loss is the sum of the small terms of
`learn.losses`, and the paper's variants are configurations of `RegularizerConfig` (`method_regularizer`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch

from learn.env import MONITOR_NAMES
from learn.losses import (
    clipped_surrogate,
    clipped_value_loss,
    expert_regularizer,
    gaussian_kl,
    generalized_advantages,
    lipschitz_penalty,
    mar_weight,
)
from learn.policy import ActorCritic
from learn.vec_env import Rollout
from mbc.assumptions import MAR_DELTA, MAR_W0
from mbc.errors import ConfigError
from mbc.types import CONTROL_PERIOD_S

Method = Literal["ppf", "fullreg", "ifm", "purerl"]
METHODS: tuple[str, ...] = ("ppf", "fullreg", "ifm", "purerl")


@dataclass(frozen=True)
class RegularizerConfig:
    """The pull toward the expert, E[w(s) ||a_E(s) - mu(s)||^2], and the Lipschitz penalty."""

    weighting: Literal["mar", "constant", "none"] = "mar"
    """'mar': w0 prod_m exp(-m^2 / delta_m) (PPF); 'constant': w0 (FullReg); 'none' (IFM, PureRL)."""
    w0: float = MAR_W0
    """Largest regularization weight (the paper's 5)."""
    monitors: tuple[str, ...] = ("com_vertical_velocity_mps",)
    """Assumption monitors the MAR weight reads (`learn.env.MONITOR_NAMES`); the paper's: CoM z' alone."""
    deltas: tuple[float, ...] = (MAR_DELTA,)
    """delta_m of each monitor (the paper's 0.0159 (m/s)^2 for z')."""
    label_every: int = 1
    """The expert labels every k-th tick of each environment (an unbiased subsample of the states)."""
    only_followed_commands: bool = True
    """Regularize only toward labels that are the expert's action for the commanded velocity: where it clips
    the command (beyond its range or turning limit) or is mid-ramp toward it, its action is for another
    command, and pulling toward it fights the tracking reward (`Expert.followed`)."""
    true_observations: bool = False
    """Fit mu to the labels at each labelled state's noise-free observation (privileged, training only), not at the
    noisy one the policy acts on: a regression of the expert's labels, computed from the true state, on noisy inputs
    shrinks the gains it fits (errors in variables; docs/design.md, "drift on flat ground")."""
    lipschitz_alpha: float = 1e-4
    """alpha of the Lipschitz penalty alpha E[||grad_s mu(s)||^2] (the paper's 1e-4; 0: off)."""
    lipschitz_samples: int | None = 256
    """States of each minibatch the penalty is estimated on (drawn anew each time; None: all): an unbiased
    estimate of the minibatch's mean, at a fraction of the double backward's cost (docs/design.md)."""

    def __post_init__(self) -> None:
        if self.weighting not in ("mar", "constant", "none"):
            raise ConfigError(f"weighting must be 'mar', 'constant' or 'none', got {self.weighting!r}")
        unknown = sorted(set(self.monitors) - set(MONITOR_NAMES))
        if unknown or len(self.monitors) != len(self.deltas) or any(d <= 0 for d in self.deltas):
            raise ConfigError(f"monitors must be among {MONITOR_NAMES} with one positive delta each; "
                              f"got {self.monitors}, {self.deltas}")
        if self.lipschitz_samples is not None and self.lipschitz_samples < 1:
            raise ConfigError(f"lipschitz_samples must be >= 1 or None, got {self.lipschitz_samples}")
        if self.label_every < 1 and self.weighting != "none":
            raise ConfigError("a regularizer toward the expert needs labels: label_every >= 1")
        if self.true_observations and self.weighting == "none":
            raise ConfigError("true_observations is where the pull toward the expert is fitted: it needs a regularizer "
                              "(weighting 'mar' or 'constant')")

    @property
    def uses_expert(self) -> bool:
        return self.weighting != "none"


PAPER_MONITORS = ("com_vertical_velocity_mps",)
MONITOR_DELTAS = {"com_vertical_velocity_mps": MAR_DELTA, "com_height_error_m": 9e-5, "stance_slip_speed_mps": 0.18}
"""delta_m of each monitor for MAR over several: z' has the paper's; each other one puts the 99th percentile of its
|value| while the MBC walks flat ground at the weight z''s has there (w / w0 = 0.85; p99 over 10,794 ticks of 6
episodes on training's commands: |z'| 0.052 m/s, |height error| 3.9 mm, stance sole speed 0.175 m/s). The weight
halves at |z'| 0.105 m/s, 7.9 mm of height error, 0.35 m/s of slip."""


def method_regularizer(method: Method, label_every: int = 1, monitors: tuple[str, ...] = PAPER_MONITORS) -> RegularizerConfig:
    """The paper's variants: PPF (MAR on `monitors`, the paper's z' alone by default), FullReg (constant weight),
    IFM and PureRL (none)."""
    if monitors != PAPER_MONITORS and method != "ppf":
        raise ConfigError(f"only ppf weights by assumption monitors; {method} takes none (got {list(monitors)})")
    if method == "ppf":
        unknown = sorted(set(monitors) - set(MONITOR_DELTAS))
        if unknown or not monitors or len(set(monitors)) != len(monitors):
            raise ConfigError(f"MAR monitors must be distinct names among {list(MONITOR_DELTAS)}, got {list(monitors)}")
        return RegularizerConfig("mar", monitors=tuple(monitors), deltas=tuple(MONITOR_DELTAS[m] for m in monitors),
                                 label_every=label_every)
    if method == "fullreg":
        return RegularizerConfig("constant", label_every=label_every)
    if method in ("ifm", "purerl"):
        return RegularizerConfig("none", label_every=0)
    raise ConfigError(f"unknown method {method!r}; valid: {list(METHODS)}")


@dataclass(frozen=True)
class PpoConfig:
    """PPO's settings."""

    epochs: int = 5
    minibatches: int = 4
    clip: float = 0.2
    """Ratio clip of the surrogate, and of the value change."""
    gamma: float = 0.99
    lam: float = 0.95
    reward_scale: float = CONTROL_PERIOD_S
    """Rewards are multiplied by this before the returns (legged_gym's reward x dt): the paper's per-tick
    rewards (about 1.5) have returns of about 150, which the value clip of 0.2 per update let the
    critic approach only over hundreds of iterations; scaled, values are about 1."""
    learning_rate: float = 1e-5
    """Adam step size at the start (small: Adam's first steps move every weight of a pre-trained actor
    by about this much at once); the KL rule adapts it."""
    critic_learning_rate: float = 1e-3
    """Adam step size of the critic (fixed: the distilled policy comes with an untrained critic)."""
    desired_kl: float = 0.05
    """Adaptive learning rate: divided by 1.5 when an update's KL exceeds twice this, multiplied below half.
    rsl_rl's 0.01 is for exploration std near 1; with our 0.135 it held the actor at the 1e-6 floor in most
    updates, and the fine-tuned policies learned speeds beyond the MBC but walked 20-40% fast at 0.5 m/s;
    at 0.05 PPF tracks the flat-ground commands (policies/README.md)."""
    learning_rate_bounds: tuple[float, float] = (1e-6, 1e-3)
    """The adaptive learning rate stays within these (rsl_rl's floor of 1e-5 held the KL of our pre-trained
    actor at 3-90x its target in every update: the floor, not the rule, set the step)."""
    entropy_coef: float = 0.001
    value_coef: float = 1.0
    max_grad_norm: float = 1.0
    critic_warmup_iterations: int = 10
    """Iterations in which only the critic learns (a pre-trained actor facing a random critic otherwise
    forgets in the first updates)."""

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.minibatches < 1 or not 0 < self.clip < 1 or not 0 < self.gamma <= 1 or not 0 <= self.lam <= 1:
            raise ConfigError(f"need epochs, minibatches >= 1, clip in (0, 1), gamma in (0, 1] and lam in [0, 1]; got "
                              f"{self.epochs}, {self.minibatches}, {self.clip}, {self.gamma}, {self.lam}")
        if not self.reward_scale > 0:
            raise ConfigError(f"reward_scale must be positive, got {self.reward_scale}")
        low, high = self.learning_rate_bounds
        if not 0 < low <= self.learning_rate <= high:
            raise ConfigError(f"need 0 < learning_rate_bounds[0] <= learning_rate <= learning_rate_bounds[1], got "
                              f"{self.learning_rate} within {self.learning_rate_bounds}")


def flat(array: np.ndarray) -> torch.Tensor:
    """(steps, n_envs, ...) rollout array as a (steps * n_envs, ...) tensor."""
    return torch.as_tensor(array).reshape(-1, *np.shape(array)[2:])


class Ppo:
    """The update of the actor-critic from one batch of rollouts."""

    def __init__(self, model: ActorCritic, config: PpoConfig, regularizer: RegularizerConfig, seed: int = 0,
                 device: torch.device | str = "cpu") -> None:
        self.device = torch.device(device)
        self.model, self.config, self.regularizer = model.to(self.device), config, regularizer
        self.learning_rate = config.learning_rate
        actor = [*model.actor.parameters(), model.log_std]
        self.optimizer = torch.optim.Adam([{"params": actor, "lr": self.learning_rate},
                                           {"params": model.critic.parameters(), "lr": config.critic_learning_rate}])
        self._monitor_columns = [MONITOR_NAMES.index(m) for m in regularizer.monitors]
        self._deltas = torch.tensor(regularizer.deltas, device=self.device)
        self.generator = torch.Generator().manual_seed(seed)

    def regularization_weight(self, monitors: torch.Tensor) -> torch.Tensor:
        """w(s) of each sample from its monitors (N, len(MONITOR_NAMES))."""
        if self.regularizer.weighting == "mar":
            return mar_weight(monitors[:, self._monitor_columns], self._deltas, self.regularizer.w0)
        return torch.full(monitors.shape[:1], self.regularizer.w0 if self.regularizer.weighting == "constant" else 0.0,
                          device=monitors.device)

    def update(self, rollout: Rollout, critic_only: bool = False) -> dict[str, float]:
        """Epochs of minibatch updates on `rollout`; returns the mean of each loss term and statistics."""
        cfg = self.config
        rewards = cfg.reward_scale * torch.as_tensor(rollout.rewards)
        advantages, returns = generalized_advantages(
            rewards, torch.as_tensor(rollout.values), torch.as_tensor(rollout.terminated),
            torch.as_tensor(rollout.truncated), torch.as_tensor(rollout.last_values), cfg.gamma, cfg.lam)
        to = self.device
        obs, actions, old_log_probs = (flat(getattr(rollout, name)).to(to) for name in ("observations", "actions", "log_probs"))
        old_values, returns, advantages = flat(rollout.values).to(to), returns.reshape(-1).to(to), advantages.reshape(-1).to(to)
        advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
        labelled = flat(rollout.label_valid)
        if self.regularizer.only_followed_commands:
            labelled = labelled & flat(rollout.label_followed)  # not in place: flat() shares the rollout's memory
        labelled = labelled.to(to)
        expert_actions, weights = flat(rollout.expert_actions).to(to), self.regularization_weight(flat(rollout.monitors).to(to))
        true_obs = self._true_observations(rollout)
        old_mean = self.model.action_mean(obs).detach()
        old_std = self.model.log_std.exp().detach()
        sums: dict[str, float] = {}
        count = 0
        n = len(obs)
        for _ in range(cfg.epochs):
            order = torch.randperm(n, generator=self.generator)
            for batch in order.chunk(cfg.minibatches):
                terms, mean = self._terms(obs[batch], actions[batch], old_log_probs[batch], old_values[batch], returns[batch],
                                          advantages[batch], expert_actions[batch], weights[batch], labelled[batch],
                                          None if true_obs is None else true_obs[batch], critic_only)
                loss = sum(terms.values())
                if not critic_only:  # how far the actor has moved, on this minibatch before its step (rsl_rl's order)
                    terms["kl"] = gaussian_kl(old_mean[batch], old_std, mean.detach(), self.model.log_std.detach().exp())
                    self._adapt_learning_rate(float(terms["kl"]))
                self.optimizer.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.model.parameters(), cfg.max_grad_norm)
                self.optimizer.step()
                for name, value in terms.items():
                    sums[name] = sums.get(name, 0.0) + float(value.detach())
                count += 1
        stats = {name: value / count for name, value in sums.items()}
        stats |= {"learning_rate": self.learning_rate, "action_std": float(self.model.log_std.detach().exp().mean()),
                  "regularization_weight": float(weights[labelled].mean()) if labelled.any() else 0.0,
                  "labelled_fraction": float(labelled.float().mean())}
        return stats

    def _true_observations(self, rollout: Rollout) -> torch.Tensor | None:
        """The noise-free observations the pull toward the expert is fitted at (`RegularizerConfig.true_observations`);
        None: it is fitted at the policy's own."""
        if not self.regularizer.true_observations:
            return None
        if rollout.true_observations is None:
            raise ConfigError("the regularizer is fitted at the noise-free observations, but the rollout has none: "
                              "collect it with RolloutRequest(true_observations=True)")
        return flat(rollout.true_observations).to(self.device)

    def _terms(self, obs, actions, old_log_probs, old_values, returns, advantages, expert_actions, weights, labelled,
               true_obs, critic_only: bool) -> tuple[dict[str, torch.Tensor], torch.Tensor | None]:
        """The loss terms of one minibatch, and the actor's mean on it (None for the critic alone)."""
        cfg = self.config
        terms = {"value": cfg.value_coef * clipped_value_loss(self.model.value(obs), old_values, returns, cfg.clip)}
        if critic_only:
            return terms, None
        distribution = self.model.distribution(obs)
        terms["surrogate"] = clipped_surrogate(distribution.log_prob(actions).sum(-1), old_log_probs, advantages, cfg.clip)
        terms["entropy"] = -cfg.entropy_coef * distribution.entropy().sum(-1).mean()
        if self.regularizer.uses_expert:
            if true_obs is None:
                terms["regularizer"] = expert_regularizer(distribution.mean, expert_actions, weights, labelled)
            else:  # mu at the labelled rows' noise-free observations only (the others weigh nothing)
                rows = labelled.nonzero().squeeze(-1)
                terms["regularizer"] = expert_regularizer(self.model.action_mean(true_obs[rows]), expert_actions[rows],
                                                          weights[rows], labelled[rows])
        if self.regularizer.lipschitz_alpha > 0:
            terms["lipschitz"] = self.regularizer.lipschitz_alpha * lipschitz_penalty(
                self.model.actor, self.model.normalizer(obs), self.generator, self.regularizer.lipschitz_samples)
        return terms, distribution.mean

    def _adapt_learning_rate(self, kl: float) -> None:
        low, high = self.config.learning_rate_bounds
        if kl > 2.0 * self.config.desired_kl:
            self.learning_rate = max(self.learning_rate / 1.5, low)
        elif kl < 0.5 * self.config.desired_kl:
            self.learning_rate = min(self.learning_rate * 1.5, high)
        self.optimizer.param_groups[0]["lr"] = self.learning_rate  # the actor's
