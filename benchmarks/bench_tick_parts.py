"""The parts of a control tick timed alone and inside the tick: what the tick loses to cache misses.

    python benchmarks/bench_tick_parts.py
    MBC_QP_SOLVER_BUILD=simd python benchmarks/bench_tick_parts.py   # proxsuite's AVX build (mbc.qp_solver_build)

Each part (the IK, the QP build, the QP solve) is run on the inputs it had at one tick of a walk,
many times in a row, so its code and data stay in the CPU caches; the whole `act()` is run the same
way on that tick's state. Inside `act()` each part runs after code that evicted it, so it takes
longer there (the controller's own split, `tick_time_s`). The gap is the cost of switching between
the libraries (numpy, pinocchio, placo, proxsuite, the interpreter) rather than of their work.
"""

from __future__ import annotations

import timeit
from dataclasses import dataclass

import numpy as np
import tyro

from mbc.controller import AlipController
from mbc.qp_solver_build import loaded_build
from mbc.sim import DigitSim
from mbc.types import Command


@dataclass
class Args:
    ticks: int = 450
    """Ticks of walking at 0.3 m/s before the timed tick (450: mid single support)."""
    repeats: int = 2000
    """Calls per timing."""


def _median_call_s(function, repeats: int) -> float:
    """Median over 5 rounds of the mean time of `repeats` back-to-back calls [s]."""
    return float(np.median(timeit.repeat(function, number=repeats, repeat=5))) / repeats


def main(args: Args) -> None:
    if args.ticks < 1 or args.repeats < 1:
        raise SystemExit("ticks and repeats must be positive")
    sim, controller, command = DigitSim(), AlipController.for_digit(), Command(0.3, 0.0, 0.0)
    state = sim.reset()
    controller.reset(state)
    for _ in range(args.ticks):
        state = sim.step(controller.act(state, command))

    captured = {}  # the inputs of each part at the timed tick
    ik_solve, qp_build, qp_solve = controller.ik.solve, controller.qp.build, controller.qp.solve

    def recording(name, function):
        def call(*inputs):
            captured[name] = inputs
            return function(*inputs)
        return call

    controller.ik.solve, controller.qp.build = recording("ik", ik_solve), recording("build", qp_build)
    controller.qp.solve = recording("solve", qp_solve)
    controller.act(state, command)
    controller.ik.solve, controller.qp.build, controller.qp.solve = ik_solve, qp_build, qp_solve

    alone = {"ik": _median_call_s(lambda: ik_solve(*captured["ik"]), args.repeats),
             "build": _median_call_s(lambda: qp_build(*captured["build"]), args.repeats),
             "solve": _median_call_s(lambda: qp_solve(*captured["solve"]), args.repeats)}
    split = []
    whole = _median_call_s(lambda: (controller.act(state, command), split.append(controller.last_diagnostics.tick_time_s)),
                           args.repeats)
    in_tick = {part: float(np.median([t[part] for t in split])) for part in ("ik", "qp")}

    print(f"== tick parts alone (each repeated {args.repeats}x on tick {args.ticks}'s inputs) and inside act(); "
          f"proxsuite build {loaded_build()}")
    print(f"   IK (placo, two solves)       alone {alone['ik'] * 1e6:6.1f} us   in the tick {in_tick['ik'] * 1e6:6.1f} us")
    print(f"   QP build + solve (proxsuite) alone {(alone['build'] + alone['solve']) * 1e6:6.1f} us   "
          f"in the tick {in_tick['qp'] * 1e6:6.1f} us   (build {alone['build'] * 1e6:.1f}, solve {alone['solve'] * 1e6:.1f})")
    print(f"   whole act() {whole * 1e6:.1f} us; IK and QP alone add up to {sum(alone.values()) * 1e6:.1f} us, "
          f"inside the tick to {sum(in_tick.values()) * 1e6:.1f} us (x{sum(in_tick.values()) / sum(alone.values()):.2f})")


if __name__ == "__main__":
    main(tyro.cli(Args))
