"""Distillation of the model-based controller into a neural policy (DAgger) and its preservative
fine-tuning (PPO with model-assumption-based regularization), after the PPF paper.

    from learn import PolicyController        # a trained policy as a `mbc.types.Controller`
    controller = PolicyController("policies/distilled.pt")
    gymnasium.make("ppf_digit/DigitWalk-v0")  # the walking task as a gymnasium environment (`learn.gym_env`)

`learn` depends only on `mbc`'s public API; `mbc` never imports it. Entry points:
`examples/distill.py` (DAgger), `examples/distill_and_finetune.py` (the main job),
`python -m learn.evaluate` (protocols for any controller).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__all__ = ["PolicyController"]

if "ppf_digit/DigitWalk-v0" not in registry:  # the walking task for third-party learners (`learn.gym_env`)
    register(id="ppf_digit/DigitWalk-v0", entry_point="learn.gym_env:DigitWalkEnv")


def __getattr__(name: str):
    """`learn.PolicyController` without importing torch for every `import learn.config` (PEP 562)."""
    if name == "PolicyController":
        from learn.policy import PolicyController

        return PolicyController
    raise AttributeError(f"module 'learn' has no attribute {name!r}")
