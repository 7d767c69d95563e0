"""Distillation of the model-based controller into a neural policy (DAgger) and its preservative
fine-tuning (PPO with model-assumption-based regularization), after the PPF paper.

    from learn.policy import PolicyController        # a trained policy as a `mbc.types.Controller`

`learn` depends only on `mbc`'s public API; `mbc` never imports it. Entry points:
`examples/distill.py` (DAgger), `examples/distill_and_finetune.py` (the main job),
`python -m learn.evaluate` (protocols for any controller).
"""
