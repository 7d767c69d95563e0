"""Simulator throughput: `DigitSim.step` against bare `mj_step` on the same model, same run.

    python benchmarks/bench_sim.py [--steps 4000] [--terrain flat]

Prints control steps per second for both and the wrapper's overhead ratio (goal <= 1.30).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np
import tyro

from mbc.sim import DigitSim
from mbc.types import JointCommand


@dataclass
class Args:
    steps: int = 4000
    """Control steps per timed block."""
    repeats: int = 5
    """Blocks per method, interleaved; the median block is reported."""
    terrain: str = "flat"


def main(args: Args) -> None:
    sim = DigitSim(args.terrain)
    command = JointCommand.hold(sim.reset().q)
    substeps = sim.config.substeps

    def wrapper() -> None:
        for _ in range(args.steps):
            sim.step(command)

    def bare() -> None:
        for _ in range(args.steps):
            mujoco.mj_step(sim.model, sim.data, nstep=substeps)

    times = {"DigitSim.step": [], "bare mj_step": []}
    for _ in range(args.repeats):
        for name, run in (("DigitSim.step", wrapper), ("bare mj_step", bare)):
            sim.reset()
            start = time.perf_counter()
            run()
            times[name].append((time.perf_counter() - start) / args.steps)
    median = {name: float(np.median(t)) for name, t in times.items()}
    for name, seconds in median.items():
        print(f"{name:>14}: {1 / seconds:8.0f} control steps/s ({seconds * 1e6:6.1f} us per 5 ms step, "
              f"{substeps} physics steps)")
    ratio = median["DigitSim.step"] / median["bare mj_step"]
    print(f"wrapper / bare: {ratio:.2f} (goal <= 1.30); real-time factor {sim.dt / median['DigitSim.step']:.0f}x")


if __name__ == "__main__":
    main(tyro.cli(Args))
