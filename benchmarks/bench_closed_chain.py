"""The AlipController (or a policy) on the closed-chain Digit against the open chain it was built on.

    python benchmarks/bench_closed_chain.py                       # about 4 min on 2 cores
    python benchmarks/bench_closed_chain.py --policy policies/ppf.pt --seeds 1 --plot docs/figures/closed_chain.png

Robots: the open chain; the closed chain (springs and the 3 ms motor delay); and the closed chain with
the springs welded, without the delay, and without both: switching each part off says which one a
controller fails on. Nothing is tuned on the closed chain. Runs: standing, flat ground at 0.3 and
0.5 m/s, a 10 deg incline at 0.3 m/s, 100 N x 0.2 s pushes (forward, backward, left, right) while
walking at 0.2 m/s. Printed: falls, the speed held, and for each robot the gap figures (stand pose and
CoM, loop residual, joint angles held under gravity against those commanded), the simulation time
per control period against the open chain's and the MBC's tick on each (timed in one process,
robots alternated).
"""

from __future__ import annotations

import multiprocessing
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import tyro

from learn.policy import PolicyController
from mbc.controller import AlipController
from mbc.rollout import Push, perturbed_stand, run_episode
from mbc.sim import DigitSim
from mbc.types import Command, JointCommand
from robots.digit import constants as digit

ROBOTS = {"open chain": {"robot": "digit"},
          "closed chain": {"robot": "digit_closed_chain"},
          "closed, springs welded": {"robot": "digit_closed_chain", "springs": False},
          "closed, no motor delay": {"robot": "digit_closed_chain", "delay": False},
          "closed, neither": {"robot": "digit_closed_chain", "springs": False, "delay": False}}
_PUSHES = {"push forward": (1, 0, 0), "push backward": (-1, 0, 0), "push left": (0, 1, 0), "push right": (0, -1, 0)}


@dataclass
class Args:
    seeds: int = 2
    duration: float = 10.0
    """Seconds per run."""
    workers: int = field(default_factory=lambda: os.cpu_count() or 1)
    policy: Path | None = None
    """Run this learned policy instead of the MBC."""
    plot: Path | None = None
    """Write the forward velocity of every run against time here (PNG)."""


def scenarios(duration: float) -> dict[str, tuple]:
    """name -> (terrain, terrain params, command, pushes)."""
    runs = {"stand": ("flat", {}, Command(), ()), "flat 0.3 m/s": ("flat", {}, Command(0.3), ()),
            "flat 0.5 m/s": ("flat", {}, Command(0.5), ()),
            "uphill 10 deg, 0.3 m/s": ("slope", {"angle_deg": 10.0, "run_up_m": 1.0}, Command(0.3), ())}
    for name, direction in _PUSHES.items():
        runs[name] = ("flat", {}, Command(0.2), (Push(min(3.0, duration / 2), tuple(100.0 * np.array(direction)), 0.2),))
    return runs


def _run(job: tuple) -> dict:
    robot, scenario, seed, duration, policy = job
    warnings.simplefilter("ignore", RuntimeWarning)
    terrain, params, command, pushes = scenarios(duration)[scenario]
    sim = DigitSim(terrain, seed=seed, **params, **ROBOTS[robot])
    controller = PolicyController(policy) if policy else AlipController.for_digit()
    com_errors = []
    if sim.robot_name != "digit":
        def com_error(state, _action) -> None:  # every 10th tick: the CoM the open chain places at the mapped joints
            if len(com_errors) < state.time / (10 * sim.dt):
                com_errors.append(open_chain_com_error(sim, state))

    episode = run_episode(sim, controller, command, duration, pushes, state=perturbed_stand(sim, seed),
                          on_tick=com_error if sim.robot_name != "digit" else None)
    velocity, _ = episode.window_velocity()
    t = episode.arrays("time")
    return {"robot": robot, "scenario": scenario, "seed": seed, "fell": episode.fell, "fall_time_s": episode.fall_time_s,
            "vx": float(episode.mean_velocity(since_s=3.0)[0]) if not episode.fell else np.nan,
            "window_t": t[0] + (np.arange(len(velocity)) + 1) * (t[-1] - t[0]) / max(len(velocity), 1),
            "window_vx": velocity[:, 0],
            "com_error": np.mean(com_errors, axis=0) if com_errors else np.zeros(3)}


def open_chain_com_error(sim: DigitSim, state) -> np.ndarray:
    """(3,) the closed chain's CoM minus the open chain's at the joints the state map reports, pelvis frame [m]:
    what a controller built on the open chain misjudges."""
    com_world, _ = sim.com_state()
    rotation = sim.data.xmat[sim.model.body("pelvis").id].reshape(3, 3)
    sim.open_legs.foot_poses(state.q)  # the open chain's kinematics at these joints, pelvis at the origin
    return rotation.T @ (com_world - state.base_pos) - sim.open_legs.data.subtree_com[1]


def gap_figures(robot: str) -> dict[str, float]:
    """Stand pose and CoM, loop residual, and joints held under gravity (PD hold of the stand for 0.3 s)."""
    sim = DigitSim(**ROBOTS[robot])
    state = sim.reset()
    com, _ = sim.com_state()
    figures = {"mass_kg": float(mujoco.mj_getTotalmass(sim.model)), "pelvis_z_m": float(state.base_pos[2]),
               "com_x_m": float(com[0] - state.base_pos[0]), "com_z_m": float(com[2])}
    equality = sim.data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    figures["loop_residual_m"] = float(np.abs(sim.data.efc_pos[equality]).max()) if equality.any() else 0.0
    errors = []
    for _ in range(int(0.3 / sim.dt)):
        state = sim.step(JointCommand.hold(digit.Q_STAND))
        errors.append(np.abs(state.q - digit.Q_STAND))
    held = np.mean(errors[len(errors) // 2:], axis=0)
    figures["knee_held_deg"], figures["ankle_pitch_held_deg"] = np.rad2deg(held[[3, 4]])
    figures["joints_held_rms_deg"] = float(np.rad2deg(np.sqrt(np.mean(held ** 2))))
    return figures


def step_and_tick_ms(rounds: int = 3, ticks: int = 200) -> dict[str, tuple[float, float]]:
    """Median wall time of one `sim.step` and of one MBC `act` per robot, walking at 0.3 m/s; robots
    alternated `rounds` times in this one process (so they share the machine's state)."""
    times = {robot: ([], []) for robot in ROBOTS}
    for _ in range(rounds):
        for robot, (steps, acts) in times.items():
            sim, controller = DigitSim(**ROBOTS[robot]), AlipController.for_digit()
            state = sim.reset()
            controller.reset(state)
            for _ in range(ticks):
                start = time.perf_counter()
                action = controller.act(state, Command(0.3))
                middle = time.perf_counter()
                state = sim.step(action)
                steps.append(time.perf_counter() - middle)
                acts.append(middle - start)
    return {robot: (1e3 * float(np.median(steps)), 1e3 * float(np.median(acts))) for robot, (steps, acts) in times.items()}


def main(args: Args) -> None:
    jobs = [(robot, scenario, seed, args.duration, str(args.policy) if args.policy else None)
            for scenario in scenarios(args.duration) for robot in ROBOTS for seed in range(args.seeds)]
    start = time.perf_counter()
    with multiprocessing.get_context("fork").Pool(args.workers) as pool:
        results = pool.map(_run, jobs, chunksize=1)
        gaps = dict(zip(ROBOTS, pool.map(gap_figures, list(ROBOTS))))
    who = f"policy {args.policy}" if args.policy else "AlipController"
    print(f"{who} on each robot, {args.seeds} seed(s) x {args.duration:.0f} s; cells: runs without a fall / runs, "
          f"mean forward speed after 3 s [m/s] (falls: mean time of the fall [s])\n")
    print("| run | " + " | ".join(ROBOTS) + " |\n|---|" + "---|" * len(ROBOTS))
    for scenario in scenarios(args.duration):
        cells = []
        for robot in ROBOTS:
            rows = [r for r in results if r["robot"] == robot and r["scenario"] == scenario]
            up = [r for r in rows if not r["fell"]]
            cell = f"{len(up)}/{len(rows)}" + (f", {np.mean([r['vx'] for r in up]):.2f}" if up else "")
            if len(up) < len(rows):
                cell += f" (falls at {np.mean([r['fall_time_s'] for r in rows if r['fell']]):.1f} s)"
            cells.append(cell)
        print(f"| {scenario} | " + " | ".join(cells) + " |")
    print("\n| gap | " + " | ".join(ROBOTS) + " |\n|---|" + "---|" * len(ROBOTS))
    for key in next(iter(gaps.values())):
        print(f"| {key} | " + " | ".join(f"{gaps[robot][key]:.4g}" for robot in ROBOTS) + " |")
    timing = step_and_tick_ms()
    print("| sim step (5 ms of simulated time), median [ms] | " + " | ".join(f"{timing[r][0]:.3f}" for r in ROBOTS) + " |")
    print("| sim step / open chain's | " + " | ".join(f"{timing[r][0] / timing['open chain'][0]:.1f}x" for r in ROBOTS) + " |")
    print("| MBC tick, median [ms] | " + " | ".join(f"{timing[r][1]:.3f}" for r in ROBOTS) + " |")
    walking = [r for r in results if r["robot"] != "open chain" and r["scenario"].startswith("flat") and not r["fell"]]
    if walking:
        error = np.mean([r["com_error"] for r in walking], axis=0) * 100
        print(f"\nCoM of the closed chain minus the open chain's at the mapped joints, pelvis frame, flat walking: "
              f"({error[0]:+.2f}, {error[1]:+.2f}, {error[2]:+.2f}) cm")
    print(f"\nwall time {time.perf_counter() - start:.0f} s")
    if args.plot:
        plot(results, args.plot, who)


def plot(results: list[dict], path: Path, who: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["scenario"] for r in results))
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(3.6 * ((len(names) + 1) // 2), 6.4), sharex=True)
    colors = dict(zip(ROBOTS, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, name in zip(axes.flat, names):
        for r in (r for r in results if r["scenario"] == name):
            ax.plot(r["window_t"], r["window_vx"], color=colors[r["robot"]], lw=1.2,
                    label=r["robot"] if r["seed"] == 0 else None)
            if r["fell"]:
                ax.plot(r["fall_time_s"], r["window_vx"][-1] if len(r["window_vx"]) else 0.0, "x", color=colors[r["robot"]])
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    for ax in axes[:, 0]:
        ax.set_ylabel("forward speed, gait-cycle mean [m/s]")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"{who} on the open and the closed-chain Digit (x: fall)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(tyro.cli(Args))
