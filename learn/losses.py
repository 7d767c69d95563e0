r"""The terms of the fine-tuning loss, each a small pure function (tested one by one).

    L = L_surrogate + c_v L_value - c_e H[pi] + L_reg + alpha E[ ||grad_s mu(s)||^2 ]

* PPO's clipped surrogate and clipped value loss, with GAE advantages (Schulman et al. 2017);
* the regularizer toward the expert, E[ w(s) ||a_E(s) - mu(s)||^2 ] over the labelled states, with
  w(s) the MAR weight w0 prod_m exp(-m(s)^2 / delta_m) (PPF; the paper uses the CoM vertical
  velocity alone, w0 = 5, delta = 0.0159), a constant w0 (FullReg), or none (IFM, PureRL);
* the Lipschitz continuity penalty of the paper (after Chen et al. 2024), on the network's input.
"""

from __future__ import annotations

import torch


def generalized_advantages(rewards: torch.Tensor, values: torch.Tensor, terminated: torch.Tensor,
                           truncated: torch.Tensor, last_values: torch.Tensor, gamma: float,
                           lam: float) -> tuple[torch.Tensor, torch.Tensor]:
    r"""GAE over (T, n) tensors; returns (advantages, returns = advantages + values).

        delta_t = r_t + gamma V(s_{t+1}) (1 - d_t) - V(s_t),   A_t = delta_t + gamma lam (1 - d_t) A_{t+1},

    where d_t ends the episode at t (terminated or truncated; the next stored state belongs to a new
    episode). A truncated episode did not fail: its last reward is bootstrapped with gamma V(s_t),
    the value of the last state seen (as rsl_rl does). `last_values` is V of the states after the
    last step."""
    rewards = rewards + gamma * values * truncated.float()
    done = (terminated | truncated).float()
    advantages = torch.zeros_like(rewards)
    next_advantage = torch.zeros_like(last_values)
    next_value = last_values
    for t in reversed(range(rewards.shape[0])):
        not_done = 1.0 - done[t]
        delta = rewards[t] + gamma * next_value * not_done - values[t]
        next_advantage = delta + gamma * lam * not_done * next_advantage
        advantages[t] = next_advantage
        next_value = values[t]
    return advantages, advantages + values


def clipped_surrogate(log_prob: torch.Tensor, old_log_prob: torch.Tensor, advantages: torch.Tensor,
                      clip: float) -> torch.Tensor:
    """-E[min(r A, clip(r, 1 - eps, 1 + eps) A)], r = pi / pi_old."""
    ratio = torch.exp(log_prob - old_log_prob)
    return -torch.min(ratio * advantages, torch.clamp(ratio, 1.0 - clip, 1.0 + clip) * advantages).mean()


def clipped_value_loss(values: torch.Tensor, old_values: torch.Tensor, returns: torch.Tensor, clip: float) -> torch.Tensor:
    """E[max((V - R)^2, (V_old + clip(V - V_old, -eps, eps) - R)^2)]."""
    clipped = old_values + torch.clamp(values - old_values, -clip, clip)
    return torch.max((values - returns).square(), (clipped - returns).square()).mean()


def mar_weight(monitors: torch.Tensor, deltas: torch.Tensor, w0: float) -> torch.Tensor:
    """w0 prod_m exp(-m^2 / delta_m) for monitors (..., M) and their deltas (M,): the paper's
    w0 exp(-zdot^2 / delta) with one monitor."""
    return w0 * torch.exp(-(monitors.square() / deltas).sum(dim=-1))


def expert_regularizer(mean_action: torch.Tensor, expert_action: torch.Tensor, weight: torch.Tensor,
                       labelled: torch.Tensor) -> torch.Tensor:
    """E[w ||a_E - mu||^2] over the labelled samples (0 when none is labelled)."""
    squared = (expert_action - mean_action).square().sum(dim=-1)
    count = labelled.float().sum()
    return (weight * squared * labelled.float()).sum() / count.clamp(min=1.0)


def lipschitz_penalty(network, inputs: torch.Tensor, generator: torch.Generator | None = None,
                      samples: int | None = None) -> torch.Tensor:
    r"""E_s[ ||d mu / d s||_F^2 ] at `inputs`, by an unbiased random projection: for v ~ N(0, I),
    E_v[ ||J^T v||^2 ] = trace(J J^T) = ||J||_F^2, so one backward pass (with a graph, so that the
    penalty itself can be differentiated) per batch instead of one per output. With `samples`, on that
    many rows of `inputs` drawn without replacement: the mean over a uniform subset is an unbiased
    estimate of the mean over all rows, and the double backward's cost shrinks with the subset."""
    if samples is not None and samples < len(inputs):
        inputs = inputs[torch.randperm(len(inputs), generator=generator)[:samples]]
    inputs = inputs.detach().requires_grad_(True)
    outputs = network(inputs)
    v = torch.randn(outputs.shape, generator=generator, dtype=outputs.dtype).to(outputs.device)  # CPU generator: any device
    (gradient,) = torch.autograd.grad(outputs, inputs, grad_outputs=v, create_graph=True)
    return gradient.square().sum(dim=-1).mean()


def gaussian_kl(old_mean: torch.Tensor, old_std: torch.Tensor, new_mean: torch.Tensor, new_std: torch.Tensor) -> torch.Tensor:
    """Mean over samples of KL(old || new) of diagonal Gaussians:
    sum_i log(s_i / s0_i) + (s0_i^2 + (m0_i - m_i)^2) / (2 s_i^2) - 1/2."""
    return (torch.log(new_std / old_std) + (old_std.square() + (old_mean - new_mean).square()) / (2 * new_std.square())
            - 0.5).sum(-1).mean()
