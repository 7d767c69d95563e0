"""Walk the simulated Digit with the model-based ALIP controller and print a summary.

    python examples/walk_mbc.py --vx 0.4 --duration 10
    python examples/walk_mbc.py --vx 0.3 --terrain slope --angle-deg 5
    python examples/walk_mbc.py --vy 0.2 --push-force 0 100 0 --push-time 4
    python examples/walk_mbc.py --viewer          # needs a display
    python examples/walk_mbc.py --policy policies/distilled.pt --vx 0.5   # a learned policy instead of the MBC
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import tyro
from tqdm import tqdm

from learn.policy import PolicyController
from mbc.controller import AlipController
from mbc.rollout import Push, run_episode
from mbc.sim import DigitSim
from mbc.types import Command


@dataclass
class Args:
    vx: float = 0.4
    """Forward velocity command [m/s]."""
    vy: float = 0.0
    """Lateral velocity command [m/s]."""
    yaw_rate: float = 0.0
    """Yaw rate command [rad/s]."""
    duration: float = 10.0
    """Simulated time [s]."""
    terrain: Literal["flat", "slope", "uneven", "stairs", "course"] = "flat"
    angle_deg: float = 5.0
    """Slope angle, for --terrain slope [deg]."""
    amplitude: float = 0.02
    """Height amplitude, for --terrain uneven [m]."""
    step_height: float = 0.05
    """Riser height, for --terrain stairs [m]."""
    seed: int = 0
    push_force: tuple[float, float, float] | None = None
    """Push on the pelvis, world frame [N]."""
    push_time: float = 4.0
    push_duration: float = 0.2
    foot_placement: Literal["one_step", "mpc"] = "one_step"
    adapt_step_timing: bool = True
    """Touch down sooner when the one-step law's step is beyond reach (after a push)."""
    policy: Path | None = None
    """Walk with this learned policy checkpoint (`learn.PolicyController`) instead of the MBC."""
    viewer: bool = False
    """Open the passive MuJoCo viewer (needs a display)."""
    out: Path | None = None
    """Write the summary (and the resolved arguments) as JSON here."""


def terrain_params(args: Args) -> dict:
    return {"slope": {"angle_deg": args.angle_deg}, "uneven": {"amplitude": args.amplitude},
            "stairs": {"step_height": args.step_height}}.get(args.terrain, {})


def main(args: Args) -> dict:
    sim = DigitSim(args.terrain, seed=args.seed, viewer=args.viewer, **terrain_params(args))
    controller = PolicyController(args.policy) if args.policy else AlipController.for_digit(
        foot_placement=args.foot_placement, adapt_step_timing=args.adapt_step_timing)
    pushes = [Push(args.push_time, args.push_force, args.push_duration)] if args.push_force else []
    progress = tqdm(total=int(round(args.duration / sim.dt)), desc="walking", unit="tick", leave=False, disable=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        episode = run_episode(sim, controller, Command(args.vx, args.vy, args.yaw_rate), args.duration, pushes,
                              on_tick=lambda *_: progress.update())
    progress.close()
    sim.close()
    summary = episode.summary(since_s=min(2.0, args.duration / 2))
    diagnostics = [d for d in episode.diagnostics if d is not None and not d.fallback]
    violations = np.array([d.assumptions.as_array() for d in diagnostics])
    names = diagnostics[0].assumptions.NAMES if diagnostics else ()
    splits = {k: 1e3 * float(np.median([d.tick_time_s[k] for d in diagnostics])) if diagnostics else float("nan")
              for k in ("alip", "ik", "qp")}
    print(f"command (vx, vy, yaw_rate) = ({args.vx}, {args.vy}, {args.yaw_rate}) on {args.terrain}")
    print(f"  fell: {summary['fell']}" + (f" at {summary['fall_time_s']:.2f} s" if summary["fell"] else ""))
    print(f"  distance {summary['distance_m']:.2f} m; mean velocity vx {summary['mean_vx_mps']:.3f}, "
          f"vy {summary['mean_vy_mps']:.3f} m/s, yaw rate {summary['mean_yaw_rate_radps']:.3f} rad/s")
    print(f"  mean velocity tracking error {summary['velocity_error_mps']:.3f} m/s")
    print(f"  tick: median {summary['tick_median_ms']:.2f} ms (alip {splits['alip']:.2f}, ik {splits['ik']:.2f}, "
          f"qp {splits['qp']:.2f}), p99 {summary['tick_p99_ms']:.2f} ms, max {summary['tick_max_ms']:.2f} ms")
    print(f"  fallbacks: {getattr(controller, 'fallback_count', 0)}; warnings: {len(caught)}")
    if len(violations):
        print("  model-assumption violations (mean |.|, max |.|):")
        for name, column in zip(names, np.abs(violations).T):
            print(f"    {name:32s} {column.mean():9.4f} {column.max():9.4f}")
    summary.update(fallbacks=getattr(controller, "fallback_count", 0), tick_split_median_ms=splits,
                   args=vars(args) | {"out": str(args.out)})
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(summary, indent=2, default=str))
    return summary


if __name__ == "__main__":
    main(tyro.cli(Args))
