"""Watch the model-based controller walk Digit in the browser (meshcat), and save plots.

    python examples/visualize_meshcat.py                       # prints the viewer URL, walks 10 s
    python examples/visualize_meshcat.py --record walk.html    # also writes a self-contained replay
    python examples/visualize_meshcat.py --terrain uneven --plots plots/
    python examples/visualize_meshcat.py --policy policies/distilled.pt   # a learned policy instead of the MBC
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import tyro

from learn.policy import PolicyController
from mbc.controller import AlipController
from mbc.rollout import run_episode
from mbc.sim import DigitSim
from mbc.types import Command
from mbc.viz import MeshcatViewer, save_all


@dataclass
class Args:
    vx: float = 0.4
    vy: float = 0.0
    yaw_rate: float = 0.2
    duration: float = 10.0
    terrain: Literal["flat", "slope", "uneven", "stairs", "course"] = "flat"
    seed: int = 0
    record: Path | None = None
    """Write the episode as a self-contained HTML replay here."""
    plots: Path | None = None
    """Write PNG plots (phase portrait, velocity, footsteps, violations, tick time) into this folder."""
    realtime: bool = True
    """Pace the simulation to wall-clock time so the live view plays at real speed."""
    keep_open_s: float = 0.0
    """Keep the server up this long after the run (to look around)."""
    policy: Path | None = None
    """Walk with this learned policy checkpoint instead of the MBC (no controller diagnostics are drawn)."""


def main(args: Args) -> None:
    sim = DigitSim(args.terrain, seed=args.seed)
    viewer = MeshcatViewer(sim)
    controller = PolicyController(args.policy) if args.policy else AlipController.for_digit()
    draw = viewer.on_tick(controller)
    start = time.perf_counter()

    def on_tick(state, action) -> None:
        draw(state, action)
        if args.realtime:
            time.sleep(max(0.0, state.time - (time.perf_counter() - start)))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        episode = run_episode(sim, controller, Command(args.vx, args.vy, args.yaw_rate), args.duration, on_tick=on_tick)
    print({k: round(v, 3) if isinstance(v, float) else v for k, v in episode.summary().items()})
    if args.record:
        print(f"replay written to {viewer.export_html(args.record)}")
    if args.plots:
        for path in save_all(episode, args.plots):
            print(f"plot written to {path}")
    time.sleep(args.keep_open_s)
    viewer.close()


if __name__ == "__main__":
    main(tyro.cli(Args))
