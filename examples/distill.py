"""Distill the AlipController into a neural policy with DAgger, from nothing.

    python examples/distill.py --run-dir runs/distill                    # defaults: 2 workers x 8 envs
    python examples/distill.py --run-dir runs/distill --resume           # continue a killed run
    python examples/distill.py --dagger.iterations 5 --workers.envs-per-worker 4   # a short run

The run directory receives the resolved config (config.json), TensorBoard logs (tensorboard/), the
dataset shards (data/), the deployable policy (policy.pt) and the training state to resume from.
Walk the result with `python examples/walk_mbc.py --policy RUN_DIR/policy.pt`.
"""

from __future__ import annotations

import sys

import tyro

from learn.checkpoints import policy_summary
from learn.config import DistillConfig
from learn.dagger_runner import DaggerRunner
from mbc.errors import MbcError


def main(config: DistillConfig) -> None:
    path = DaggerRunner(config).learn()
    summary = policy_summary(path)
    print(f"policy: {path} (iteration {summary['iteration']}, {summary['samples']:,} samples, "
          f"{summary['wall_s'] / 60:.1f} min of training)")


if __name__ == "__main__":
    try:
        main(tyro.cli(DistillConfig))
    except MbcError as error:
        sys.exit(f"error: {error}")
