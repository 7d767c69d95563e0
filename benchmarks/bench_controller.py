"""AlipController benchmarks: flat-ground velocity sweep, pushes, terrain, tick time, robustness.

    python benchmarks/bench_controller.py                    # everything (about 15 min on 2 cores)
    python benchmarks/bench_controller.py --suites speed corrupt --seeds 3
    python benchmarks/bench_controller.py --suites flat push terrain --policy policies/distilled.pt

Every suite prints its figures. A run succeeds when the robot does not fall; velocity tracking is
judged on the mean heading-frame velocity after the first 3 s, within 10% or 0.05 m/s
(yaw: 10% or 0.05 rad/s) of the command. Seeds perturb the initial state (joint angles, base
velocity), so runs differ. With `--policy`, the flat, push and terrain suites run the learned policy
(`learn.PolicyController`) on the same runs as the MBC, rows side by side.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import tyro

from learn.policy import PolicyController
from mbc.controller import AlipController
from mbc.fuzz import random_robot_state
from mbc.rollout import Push, perturbed_stand, run_episode, tracked
from mbc.sim import DigitSim
from mbc.types import Command

Suite = Literal["flat", "push", "terrain", "speed", "corrupt", "takeover"]


@dataclass
class Args:
    suites: tuple[Suite, ...] = ("flat", "push", "terrain", "speed", "corrupt", "takeover")
    seeds: int = 10
    duration: float = 20.0
    """Seconds per flat-ground run."""
    workers: int = field(default_factory=lambda: os.cpu_count() or 1)
    corrupt_states: int = 10_000
    speed_runs: int = 3
    """Back-to-back timing runs of the speed suite."""
    plots: Path | None = None
    """Directory for figures (the push suite's recovery map)."""
    policy: Path | None = None
    """A learned policy checkpoint to run beside the MBC in the flat, push and terrain suites."""


def _walk(job: tuple) -> dict:
    """One run: (label, commands, duration, seed, terrain, terrain params, pushes[, controller options])."""
    label, commands, duration, seed, terrain, params, pushes, *options = job
    warnings.simplefilter("ignore", RuntimeWarning)
    sim = DigitSim(terrain, seed=seed, **params)
    options = dict(options[0]) if options else {}
    policy = options.pop("policy", None)
    controller = PolicyController(policy) if policy else AlipController.for_digit(**options)
    episode = run_episode(sim, controller, commands, duration, pushes, state=perturbed_stand(sim, seed))
    final = commands if isinstance(commands, Command) else commands[-1][1]
    since = 3.0 if isinstance(commands, Command) else commands[-1][0] + 2.0
    mean = episode.mean_velocity(since_s=since)
    followed = not episode.fell and all(tracked(m, cmd) for m, cmd in zip(mean, final.as_array()))
    return {"label": label, "seed": seed, "push_n": max((float(np.linalg.norm(p.force_n)) for p in pushes), default=0.0),
            "fell": episode.fell, "tracked": followed, "mean": mean, "final": final.as_array(),
            "x_end": episode.base_pos[-1][0], "fallbacks": getattr(controller, "fallback_count", 0)}


def _report(title: str, results: list[dict]) -> None:
    print(f"\n== {title}")
    print(f"{'case':>48} {'runs':>4} {'no fall':>8} {'tracked':>8}   mean (vx, vy, yaw) over runs")
    for label in dict.fromkeys(r["label"] for r in results):
        rows = [r for r in results if r["label"] == label]
        mean = np.nanmean([r["mean"] for r in rows], axis=0)
        print(f"{label:>48} {len(rows):4d} {sum(not r['fell'] for r in rows):8d} {sum(r['tracked'] for r in rows):8d}"
              f"   ({mean[0]:+.3f}, {mean[1]:+.3f}, {mean[2]:+.3f})")
    print(f"{'total':>48} {len(results):4d} {sum(not r['fell'] for r in results):8d} {sum(r['tracked'] for r in results):8d}")


def _with_policy(jobs: list[tuple], policy: Path | None) -> list[tuple]:
    """Each job for the MBC and, with a policy, the same job for the policy right after it."""
    if policy is None:
        return jobs
    paired = []
    for label, *rest in jobs:
        options = rest[6] if len(rest) > 6 else {}
        paired += [("MBC: " + label, *rest[:6], options), ("policy: " + label, *rest[:6], options | {"policy": str(policy)})]
    return paired


def _run_jobs(jobs: list[tuple], workers: int) -> list[dict]:
    if workers <= 1:
        return [_walk(job) for job in jobs]
    with multiprocessing.get_context("fork").Pool(workers) as pool:
        return pool.map(_walk, jobs, chunksize=1)


def suite_flat(args: Args) -> None:
    commands = [Command(v, 0.0, 0.0) for v in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)]
    commands += [Command(-0.3, 0.0, 0.0), Command(0.0, 0.2, 0.0), Command(0.0, -0.2, 0.0),
                 Command(0.0, 0.0, 0.5), Command(0.0, 0.0, -0.5)]
    jobs = [(f"{tuple(float(x) for x in cmd.as_array())}", cmd, args.duration, seed, "flat", {}, ())
            for cmd in commands for seed in range(args.seeds)]
    if args.duration < 10.0:
        raise SystemExit(f"--duration must be at least 10 s (tracking is judged 2 s after the last command change), "
                         f"got {args.duration}")
    quarter = args.duration / 4  # a new command each quarter of the run (5 s apart in 20 s runs)
    changes = [(0.0, Command(0.3, 0.0, 0.0)), (quarter, Command(0.0, 0.2, 0.0)), (2 * quarter, Command(0.2, 0.0, 0.4)),
               (3 * quarter, Command(0.5, 0.0, 0.0))]
    jobs += [("changes 0.3 -> vy 0.2 -> turn -> 0.5", changes, args.duration, seed, "flat", {}, ())
             for seed in range(args.seeds)]
    _report(f"flat ground, {args.duration:.0f} s per run", _run_jobs(_with_policy(jobs, args.policy), args.workers))


def suite_push(args: Args) -> None:
    """100 N for 0.2 s on the pelvis, four directions, at phases spread over a two-step cycle; then
    stronger sideways pushes, with and without step-timing adaptation (same runs otherwise)."""
    T = AlipController.for_digit().config.timing.step_duration_s
    directions = {"forward": (1, 0, 0), "backward": (-1, 0, 0), "left": (0, 1, 0), "right": (0, -1, 0)}

    def jobs_for(force: float, names: tuple[str, ...], options: dict, tag: str = "") -> list[tuple]:
        return [(f"push {name} {force:.0f} N x 0.2 s{tag}", Command(0.2, 0.0, 0.0), 8.0, k, "flat", {},
                 (Push(3.0 + 2 * T * k / args.seeds, tuple(force * u for u in directions[name]), 0.2),), options)
                for name in names for k in range(args.seeds)]

    _report("pushes while walking at 0.2 m/s (phases spread over a gait cycle)",
             _run_jobs(_with_policy(jobs_for(100.0, tuple(directions), {}), args.policy), args.workers))
    jobs = []
    for force in (150.0, 200.0):
        for adapt in (True, False):
            jobs += jobs_for(force, ("left", "right"), {"adapt_step_timing": adapt}, "" if adapt else ", fixed timing")
    strong = _run_jobs(jobs, args.workers)
    _report("stronger sideways pushes: step-timing adaptation against fixed step timing", strong)
    if args.plots is not None:
        print(f"   recovery map: {_plot_push_recovery(strong, args.seeds, args.plots / 'push_recovery.png')}")


def _plot_push_recovery(results: list[dict], seeds: int, path: Path) -> Path:
    """Survived (filled) or fell (open) against push phase and force, fixed against adaptive timing."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    for ax, fixed in zip(axes, (True, False)):
        rows = [r for r in results if r["label"].endswith("fixed timing") == fixed]
        for side, offset, color in (("left", 0.04, "tab:blue"), ("right", -0.04, "tab:orange")):
            for r in (r for r in rows if f" {side} " in r["label"]):
                ax.scatter(r["seed"] / seeds, r["push_n"] * (1 + offset), s=60, color=color,
                           facecolors="none" if r["fell"] else color)
        ax.set_title(f"{'fixed' if fixed else 'adaptive'} step timing: "
                     f"{sum(not r['fell'] for r in rows)}/{len(rows)} without a fall")
        ax.set_xlabel("push start after t = 3 s [two-step cycles]")
    axes[0].set_ylabel("sideways push for 0.2 s [N]")
    axes[0].set_yticks(sorted({r["push_n"] for r in results}))
    markers = [plt.Line2D([], [], marker="o", linestyle="", color=color) for color in ("tab:blue", "tab:orange")]
    fig.legend(markers, ["push to the left", "push to the right (open marker: fell)"], loc="lower center", ncol=2)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def suite_terrain(args: Args) -> None:
    jobs = []
    for angle in (5.0, -5.0):
        jobs += [(f"slope {angle:+.0f} deg (5 m incline)", Command(0.3, 0.0, 0.0), 30.0, seed, "slope",
                  {"angle_deg": angle, "run_up_m": 1.5, "length_m": 5.0}, ()) for seed in range(args.seeds)]
    jobs += [("uneven 2 cm", Command(0.3, 0.0, 0.0), args.duration, seed, "uneven", {"amplitude": 0.02}, ())
             for seed in range(args.seeds)]
    results = _run_jobs(_with_policy(jobs, args.policy), args.workers)
    _report("terrain", results)
    for r in results:
        if "slope" in r["label"] and not r["fell"] and r["x_end"] < 6.5:
            print(f"   note: {r['label']} run ended at x = {r['x_end']:.2f} m, before the top (6.5 m)")


def _timed_run(ticks: int) -> tuple[np.ndarray, list[dict], np.ndarray]:
    """One walk (0.3 m/s, then standing): wall time of each `act` call, the controller's own
    tick-time split, and DigitSim.step times [s]."""
    sim = DigitSim()
    controller = AlipController.for_digit()
    state = sim.reset()
    controller.reset(state)
    act_time, split, physics = [], [], []
    for k in range(ticks):
        command = Command(0.3 if k < ticks // 2 else 0.0, 0.0, 0.0)
        start = time.perf_counter()
        action = controller.act(state, command)
        middle = time.perf_counter()
        state = sim.step(action)
        physics.append(time.perf_counter() - middle)
        act_time.append(middle - start)
        split.append(controller.last_diagnostics.tick_time_s)
    return np.array(act_time), split, np.array(physics)


def suite_speed(args: Args) -> None:
    """Tick time and its split, against the physics time of one control period, in the same run.

    Several runs back to back: on a shared machine the speed of both drifts by tens of percent
    between runs, while their ratio stays put."""
    print(f"\n== control tick time (one core; {args.speed_runs} runs of 2000 ticks, walking at 0.3 m/s then standing)")
    medians, ratios = [], []
    for run in range(args.speed_runs):
        act_time, split, physics = _timed_run(2000)
        act_ms = act_time * 1e3
        parts = {part: np.array([t[part] for t in split]) * 1e3 for part in ("alip", "ik", "qp")}
        total, physics_ms = np.median(act_ms), np.median(physics) * 1e3
        medians.append(total)
        ratios.append(total / physics_ms)
        print(f"   run {run}: tick (act() call) median {total:.3f} ms (p99 {np.percentile(act_ms, 99):.3f}); split median "
              + ", ".join(f"{part} {np.median(parts[part]):.3f}" for part in ("alip", "ik", "qp"))
              + f" ms; physics of one control period (DigitSim.step) {physics_ms:.3f} ms; tick / physics {ratios[-1]:.1f}")
    print(f"   over runs: tick median {np.median(medians):.3f} ms (range {min(medians):.3f}-{max(medians):.3f}), "
          f"tick / physics {np.median(ratios):.1f}; 0.5 ms budget met: {np.median(medians) <= 0.5}")


def suite_corrupt(args: Args) -> None:
    controller = AlipController.for_digit()
    rng = np.random.default_rng(0)
    exceptions, non_finite, fallbacks = 0, 0, 0
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for _ in range(args.corrupt_states):
            state = random_robot_state(rng)
            if rng.random() < 0.2:
                controller.reset(state)
            try:
                action = controller.act(state, Command(*rng.uniform(-2, 2, 3)))
            except Exception:  # counted: the contract is that none happen
                exceptions += 1
                continue
            non_finite += not all(np.isfinite(a).all() for a in (action.q_des, action.qd_des, action.tau_ff))
            fallbacks += controller.last_diagnostics.fallback
    print(f"\n== {args.corrupt_states} randomized and corrupted states through act(): exceptions {exceptions}, "
          f"non-finite outputs {non_finite}, ticks that fell back to a damped hold {fallbacks} "
          f"({time.perf_counter() - start:.0f} s)")


def suite_takeover(args: Args) -> None:
    """A fresh controller takes over from states of another run: mid-swing and just after a push."""
    outcomes = []
    for seed in range(args.seeds):
        sim = DigitSim(seed=seed)
        source = AlipController.for_digit()
        t_switch = 2.0 + 0.037 * seed
        pushes = (Push(1.8, (0.0, 80.0, 0.0), 0.15),) if seed % 2 else ()
        run_episode(sim, source, Command(0.3, 0.0, 0.0), t_switch, pushes, state=perturbed_stand(sim, seed))
        state = sim.state()
        fresh = AlipController.for_digit()
        episode = run_episode(sim, fresh, Command(0.3, 0.0, 0.0), 6.0, state=state)
        outcomes.append((int(state.contact.sum()), bool(pushes), episode.fell))
    single = [o for o in outcomes if o[0] == 1]
    print(f"\n== mid-gait takeover: {len(outcomes)} runs ({len(single)} from single support, "
          f"{sum(o[1] for o in outcomes)} right after a push): falls {sum(o[2] for o in outcomes)}")


def main(args: Args) -> None:
    suites = {"flat": suite_flat, "push": suite_push, "terrain": suite_terrain, "speed": suite_speed,
              "corrupt": suite_corrupt, "takeover": suite_takeover}
    for name in args.suites:
        start = time.perf_counter()
        suites[name](args)
        print(f"   ({name}: {time.perf_counter() - start:.0f} s wall)")


if __name__ == "__main__":
    main(tyro.cli(Args))
