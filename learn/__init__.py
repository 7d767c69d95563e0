"""Distillation of the model-based controller into a neural policy (DAgger) and its preservative
fine-tuning (PPO with model-assumption-based regularization).

Not implemented yet: this package is reserved for that work (it depends on `mbc`, never the
reverse). The controller-side hooks it will use exist already: `mbc.rollout.Controller`,
`AlipController` as a labeller on arbitrary states, `mbc.assumptions.mar_weight`.
"""
