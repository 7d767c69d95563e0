r"""DAgger: the paper's loss, which labels are trained on, and the supervised fit.

    L_DAgger = sum_{(s, a_E) in D} || a_E - mu_theta(s) ||^2

over the aggregated dataset D of states visited by the beta-mixture of expert and learner, each
labelled by the expert (Ross et al. 2011). We minimize its per-sample mean by minibatch Adam.
Labels are dropped where the expert fell back (no label) and in the last moments before a
termination (a falling robot: the expert's labels there are unusable, issue 13).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from learn.policy import ActorCritic
from learn.vec_env import Rollout


def dagger_loss(predicted: torch.Tensor, expert: torch.Tensor) -> torch.Tensor:
    """Mean over samples of the squared Euclidean action error ||a_E - mu(s)||^2."""
    return (predicted - expert).square().sum(dim=-1).mean()


def usable_labels(rollout: Rollout, discard_ticks: int) -> np.ndarray:
    """(steps, n_envs) bool: the expert gave a label and the episode does not terminate within the
    next `discard_ticks` ticks (the tick that terminates included)."""
    usable = rollout.label_valid.copy()
    for t, env in zip(*np.nonzero(rollout.terminated)):
        usable[max(t - discard_ticks + 1, 0):t + 1, env] = False
    return usable


def cosine_learning_rate(initial: float, final: float, progress: float) -> float:
    """initial at progress 0, final at 1, cosine in between."""
    return final + 0.5 * (initial - final) * (1.0 + math.cos(math.pi * min(max(progress, 0.0), 1.0)))


class DaggerFit:
    """Fits the actor's mean to the expert's labels (the critic and the log-std are untouched)."""

    def __init__(self, model: ActorCritic, learning_rate: float, device: torch.device | str = "cpu") -> None:
        self.device = torch.device(device)
        self.model = model.to(self.device)
        self.optimizer = torch.optim.Adam(model.actor.parameters(), lr=learning_rate)

    def fit(self, observations: np.ndarray, actions: np.ndarray, steps: int, batch_size: int, learning_rate: float,
            seed: int, progress=None) -> list[float]:
        """`steps` minibatch updates on (observations, actions), normalizer set from `observations`;
        returns the minibatch losses. Minibatches are drawn with a generator seeded by `seed`."""
        self.model.normalizer.set_statistics(observations)
        for group in self.optimizer.param_groups:
            group["lr"] = learning_rate
        obs = torch.as_tensor(observations).to(self.device)
        act = torch.as_tensor(actions).to(self.device)
        generator = torch.Generator().manual_seed(seed)
        losses = []
        self.model.train()
        for _ in range(steps):
            index = torch.randint(len(obs), (min(batch_size, len(obs)),), generator=generator)
            loss = dagger_loss(self.model.action_mean(obs[index]), act[index])
            self.optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.optimizer.step()
            losses.append(loss.item())
            if progress is not None:
                progress.update()
        self.model.eval()
        return losses

    def evaluate(self, observations: np.ndarray, actions: np.ndarray) -> float:
        """The loss on a whole dataset, without updating."""
        with torch.inference_mode():
            return float(dagger_loss(self.model.action_mean(torch.as_tensor(observations).to(self.device)),
                                     torch.as_tensor(actions).to(self.device)))
