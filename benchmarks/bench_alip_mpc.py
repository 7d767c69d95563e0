"""ALIP MPC solve time over a walking-like sequence of states (warm-started, as in the controller).

    python benchmarks/bench_alip_mpc.py [--solves 300] [--horizon-steps 3]

Prints median and worst solve time for fixed and free step timing, and the one-step law's time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import tyro

from mbc.alip import AlipModel
from mbc.alip_mpc import AlipMpc, AlipMpcConfig
from robots.digit.constants import TOTAL_MASS_KG


@dataclass
class Args:
    solves: int = 300
    horizon_steps: int = 3
    seed: int = 0


def main(args: Args) -> None:
    model = AlipModel(TOTAL_MASS_KG, 0.95)
    config = AlipMpcConfig(horizon_steps=args.horizon_steps)
    mpc = AlipMpc(model, config)
    rng = np.random.default_rng(args.seed)
    T = mpc.timing.step_duration_s
    states = [(rng.uniform(-0.1, 0.1, 2), model.mz * rng.uniform(-0.6, 0.6, 2), rng.uniform(0, T), rng.choice([-1, 1]))
              for _ in range(args.solves)]
    for fixed in (True, False):
        times, failures, fallbacks = [], 0, 0
        for x, L, elapsed, sign in states:
            L_des = np.array([[model.mz * 0.3, model.lateral_end_momentum(-sign * (-1) ** k, 0.3, T)]
                              for k in range(args.horizon_steps)])
            solution = mpc.solve(x, L, elapsed, int(sign), L_des, fixed_timing=fixed)
            times.append(solution.solve_time_s)
            failures += not solution.success
            fallbacks += solution.solver == "ipopt"
        times_ms = 1e3 * np.array(times)
        print(f"{'fixed' if fixed else 'free '} timing: median {np.median(times_ms):.2f} ms, "
              f"p95 {np.percentile(times_ms, 95):.2f} ms, worst {times_ms.max():.2f} ms, "
              f"failures {failures}/{len(states)}, IPOPT answers {fallbacks}")
    start = time.perf_counter()
    for x, L, elapsed, _ in states:
        _, L_end = model.propagate(x, L, T - elapsed)
        model.foot_placement(L_end, 0.3, T)
    one_step = (time.perf_counter() - start) / len(states)
    print(f"one-step law: {one_step * 1e6:.1f} us per placement (ratio MPC/one-step "
          f"{np.median(times_ms) / (one_step * 1e3):.0f}x)")


if __name__ == "__main__":
    main(tyro.cli(Args))
