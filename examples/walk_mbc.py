"""Walk the simulated Digit with the model-based ALIP controller (or a learned policy) and print a summary.

    python examples/walk_mbc.py --vx 0.4 --duration 10
    python examples/walk_mbc.py --vx 0.3 --terrain slope --angle-deg 5
    python examples/walk_mbc.py --vy 0.2 --push-force 0 100 0 --push-time 4
    python examples/walk_mbc.py --policy policies/distilled.pt --vx 0.5   # a learned policy instead of the MBC
    python examples/walk_mbc.py --viewer          # needs a display
    python examples/walk_mbc.py --robot digit_closed_chain --vx 0.3   # Digit's closed-chain legs (transfer)

The controller follows vx in [-0.5, 1.0] m/s, vy in [-0.3, 0.3] m/s and yaw rate in [-0.8, 0.8] rad/s;
commands beyond are clipped, and the summary says so. Tracking errors are per axis, on velocities
averaged over each gait cycle, against the command followed. Exit status: 0 walked, 1 fell, 2 bad input.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import tyro
from tqdm import tqdm

from learn.policy import PolicyController
from mbc.controller import AlipController
from mbc.errors import ConfigError, MbcError
from mbc.rollout import Push, check_duration, run_episode
from mbc.sim import DigitSim
from mbc.types import Command

TERRAIN_OPTIONS = {"angle_deg": "slope", "amplitude": "uneven", "step_height": "stairs"}
"""Each terrain option and the terrain it belongs to."""


@dataclass
class Args:
    vx: float = 0.4
    """Forward velocity command [m/s], followed within [-0.5, 1.0]."""
    vy: float = 0.0
    """Lateral velocity command [m/s], followed within [-0.3, 0.3]."""
    yaw_rate: float = 0.0
    """Yaw rate command [rad/s], followed within [-0.8, 0.8]."""
    duration: float = 10.0
    """Simulated time [s]."""
    terrain: Literal["flat", "slope", "uneven", "stairs", "course"] = "flat"
    angle_deg: float | None = None
    """Slope angle, only with --terrain slope [deg] (default: the library's, 10)."""
    amplitude: float | None = None
    """Height amplitude, only with --terrain uneven [m] (default: the library's, 0.02)."""
    step_height: float | None = None
    """Riser height, only with --terrain stairs [m] (default: the library's, 0.1)."""
    seed: int = 0
    robot: Literal["digit", "digit_closed_chain"] = "digit"
    """The simulated robot: the open chain every controller is built on, or Digit's closed-chain legs."""
    push_force: tuple[float, float, float] | None = None
    """Push on the pelvis, world frame [N]."""
    push_time: float = 4.0
    """When the push starts [s]."""
    push_duration: float = 0.2
    """How long the push lasts [s]."""
    foot_placement: Literal["one_step", "mpc"] = "one_step"
    adapt_step_timing: bool = True
    """Touch down sooner when the one-step law's step is beyond reach (after a push)."""
    policy: Path | None = None
    """Walk with this learned policy checkpoint (`learn.PolicyController`) instead of the MBC."""
    viewer: bool = False
    """Open the passive MuJoCo viewer (needs a display)."""
    out: Path | None = None
    """Write the summary (and the resolved arguments) as JSON here (NaN written as null)."""


def terrain_params(args: Args) -> dict:
    """The terrain options given, checked against the chosen terrain (the library supplies defaults)."""
    params = {}
    for option, terrain in TERRAIN_OPTIONS.items():
        value = getattr(args, option)
        if value is None:
            continue
        if args.terrain != terrain:
            raise ConfigError(f"--{option.replace('_', '-')} applies to --terrain {terrain}, not {args.terrain}")
        params[option] = value
    return params


def json_safe(value):
    """`value` with NaN and infinities as None, numpy scalars as Python numbers."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    return value


def main(args: Args) -> dict:
    params = terrain_params(args)
    check_duration(args.duration, AlipController.dt)
    command = Command(args.vx, args.vy, args.yaw_rate)
    pushes = [Push(args.push_time, args.push_force, args.push_duration)] if args.push_force else []
    sim = DigitSim(args.terrain, seed=args.seed, viewer=args.viewer, robot=args.robot, **params)
    controller = PolicyController(args.policy) if args.policy else AlipController.for_digit(
        foot_placement=args.foot_placement, adapt_step_timing=args.adapt_step_timing)
    used, clipped = controller.command_limits.clip(command)
    if clipped:
        print(f"note: command ({args.vx:g}, {args.vy:g}, {args.yaw_rate:g}) is beyond the controller's range "
              f"({controller.command_limits.describe()}); following ({used[0]:g}, {used[1]:g}, {used[2]:g})")
    progress = tqdm(total=int(round(args.duration / sim.dt)), desc="walking", unit="tick", leave=False, disable=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        episode = run_episode(sim, controller, command, args.duration, pushes, on_tick=lambda *_: progress.update())
    progress.close()
    sim.close()
    summary = episode.summary()
    diagnostics = [d for d in episode.diagnostics if d is not None and not d.fallback]
    print(f"command followed (vx, vy, yaw_rate) = ({used[0]:g}, {used[1]:g}, {used[2]:g}) on {args.terrain} "
          f"{params or ''}".rstrip())
    print(f"  fell: {summary['fell']}" + (f" at {summary['fall_time_s']:.2f} s" if summary["fell"] else ""))
    print(f"  distance {summary['distance_m']:.2f} m; mean velocity vx {summary['mean_vx_mps']:.3f}, "
          f"vy {summary['mean_vy_mps']:.3f} m/s, yaw rate {summary['mean_yaw_rate_radps']:.3f} rad/s")
    print(f"  tracking error (gait-cycle averages after {min(2.0, summary['duration_s'] / 2):g} s): "
          f"vx {summary['tracking_error_vx_mps']:.3f} m/s, vy {summary['tracking_error_vy_mps']:.3f} m/s, "
          f"yaw rate {summary['tracking_error_yaw_rate_radps']:.3f} rad/s")
    print(f"  tick: median {summary['tick_median_ms']:.2f} ms, p99 {summary['tick_p99_ms']:.2f} ms, "
          f"max {summary['tick_max_ms']:.2f} ms")
    if diagnostics:
        splits = {k: 1e3 * float(np.median([d.tick_time_s[k] for d in diagnostics])) for k in ("alip", "ik", "qp")}
        print(f"  tick split (median): alip {splits['alip']:.2f}, ik {splits['ik']:.2f}, qp {splits['qp']:.2f} ms")
        summary["tick_split_median_ms"] = splits
        violations = np.abs(np.array([d.assumptions.as_array() for d in diagnostics]))
        print("  model-assumption violations (mean |.|, max |.|):")
        for name, column in zip(diagnostics[0].assumptions.NAMES, violations.T):
            print(f"    {name:32s} {column.mean():9.4f} {column.max():9.4f}")
    fallbacks = getattr(controller, "fallback_count", 0)
    print(f"  fallbacks: {fallbacks}; warnings: {len(caught)}")
    for message, count in Counter(f"{w.category.__name__}: {w.message}" for w in caught).items():
        print(f"    {message}" + (f" (x{count})" if count > 1 else ""))
    summary.update(fallbacks=fallbacks, command_followed=list(used), args=vars(args) | {"out": str(args.out)})
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(json_safe(summary), indent=2, default=str, allow_nan=False))
    return summary


if __name__ == "__main__":
    try:
        result = main(tyro.cli(Args))
    except MbcError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
    sys.exit(1 if result["fell"] else 0)
