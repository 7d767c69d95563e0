"""Quick evaluation protocols for any controller (the MBC or a policy file), run in parallel:
where the MBC stops (steep slopes, rough ground, high speed) and whether flat walking survives.

    python -m learn.evaluate --controllers mbc policies/distilled.pt --protocols uphill_16 max_velocity

Protocols (each over `seeds` seeds, perturbed standing starts):
* `flat`: 0.5 m/s forward, 0.2 m/s sideways, 0.5 rad/s turning, 10 s each: success = no fall and the
  gait-cycle-averaged velocity within 10% or 0.05 of the command;
* `uphill_A` / `downhill_A`: 0.5 m/s up (down) a 5 m incline of A degrees: success = reaching its top
  (bottom) without a fall; tracking error of the forward speed on the incline in % of the command;
* `uneven_C`: 0.4 m/s for 20 s over bumps of C cm: success = no fall;
* `max_velocity`: the forward command ramps from 0.5 to 1.6 m/s over 25 s on flat ground: the highest
  gait-cycle-averaged speed held for 2 s within 0.15 m/s of the command, before a fall.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mbc.errors import ConfigError
from mbc.rollout import Episode, perturbed_stand, run_episode, tracked
from mbc.sim import DigitSim
from mbc.types import Command, Controller

PROTOCOLS = ("flat", "uphill_12", "uphill_16", "uphill_20", "downhill_8", "downhill_12", "uneven_4", "max_velocity")
RUN_UP_M, INCLINE_M = 1.5, 5.0


def make_controller(spec: str) -> Controller:
    """'mbc' or the path of a policy checkpoint."""
    if spec == "mbc":
        from mbc.controller import AlipController

        return AlipController.for_digit()
    from learn.policy import PolicyController

    return PolicyController(spec)


def check_protocols(names: tuple[str, ...]) -> None:
    unknown = [n for n in names if n not in PROTOCOLS and not _parametric(n)]
    if unknown:
        raise ConfigError(f"unknown protocol(s) {unknown}; valid: {list(PROTOCOLS)} (and uphill_A, downhill_A, uneven_C "
                          "for other angles in degrees and bump heights in cm)")


def _parametric(name: str) -> bool:
    kind, _, value = name.partition("_")
    return kind in ("uphill", "downhill", "uneven") and value.replace(".", "", 1).isdigit()


def run_protocol(job: tuple[str, str, int]) -> dict:
    """One (controller, protocol, seed) episode and its figures."""
    spec, protocol, seed = job
    warnings.simplefilter("ignore", RuntimeWarning)
    controller = make_controller(spec)
    kind, _, value = protocol.partition("_")  # e.g. uphill_16
    if kind == "flat":
        outcomes = []
        for command in (Command(0.5), Command(0.0, 0.2), Command(0.0, 0.0, 0.5)):
            sim = DigitSim(seed=seed)
            episode = run_episode(sim, controller, command, 10.0, state=perturbed_stand(sim, seed))
            mean = episode.mean_velocity(since_s=3.0)
            outcomes.append(not episode.fell and all(tracked(m, c) for m, c in zip(mean, command.as_array())))
        return {"success": all(outcomes), "fell": False, "metric": float(np.mean(outcomes))}
    if kind in ("uphill", "downhill"):
        angle = float(value) * (1 if kind == "uphill" else -1)
        sim = DigitSim("slope", seed=seed, angle_deg=angle, run_up_m=RUN_UP_M, length_m=INCLINE_M)
        episode = run_episode(sim, controller, Command(0.5), 30.0, state=perturbed_stand(sim, seed))
        x = np.asarray(episode.base_pos)[:, 0]
        on_incline = (x > RUN_UP_M + 0.5) & (x < RUN_UP_M + INCLINE_M - 0.5)
        speed = np.asarray(episode.heading_velocity())[on_incline, 0].mean() if on_incline.sum() > 100 else np.nan
        return {"success": bool(not episode.fell and x.max() > RUN_UP_M + INCLINE_M), "fell": episode.fell,
                "metric": float(100 * abs(speed - 0.5) / 0.5)}
    if kind == "uneven":
        sim = DigitSim("uneven", seed=seed, amplitude=float(value) / 100)
        episode = run_episode(sim, controller, Command(0.4), 20.0, state=perturbed_stand(sim, seed))
        return {"success": not episode.fell, "fell": episode.fell, "metric": float(episode.base_pos[-1][0])}
    if protocol == "max_velocity":
        sim = DigitSim(seed=seed)
        ramp = lambda t: Command(min(0.5 + 1.1 * t / 25.0, 1.6))  # noqa: E731
        episode = run_episode(sim, controller, ramp, 27.0, state=perturbed_stand(sim, seed))
        return {"success": True, "fell": episode.fell, "metric": sustained_velocity(episode)}
    raise ConfigError(f"unknown protocol {protocol!r}")


def sustained_velocity(episode: Episode, hold_s: float = 2.0, tolerance_mps: float = 0.15) -> float:
    """The highest forward speed held for `hold_s` (consecutive gait-cycle windows) within `tolerance_mps`
    of the command followed."""
    velocity, command = episode.window_velocity()
    if not len(velocity):
        return 0.0
    window_s = float(episode.time[1] - episode.time[0]) * round(0.7 / (episode.time[1] - episode.time[0]))
    needed = max(int(round(hold_s / window_s)), 1)
    good = np.abs(velocity[:, 0] - command[:, 0]) <= tolerance_mps
    best = 0.0
    for k in range(len(good) - needed + 1):
        if good[k:k + needed].all():
            best = max(best, float(velocity[k:k + needed, 0].min()))
    return best


@dataclass
class Results:
    """Per controller and protocol: success rate, mean metric and a 95% interval over seeds."""

    rows: list[dict] = field(default_factory=list)

    def table(self) -> str:
        lines = ["| controller | protocol | success | metric (mean +- 95% CI) |", "|---|---|---|---|"]
        for row in self.rows:
            lines.append(f"| {row['controller']} | {row['protocol']} | {row['successes']}/{row['runs']} | "
                         f"{row['metric']:.3f} +- {row['ci']:.3f} |")
        return "\n".join(lines)


def evaluate(controllers: list[str], protocols: tuple[str, ...], seeds: int = 5, workers: int | None = None) -> Results:
    """Every (controller, protocol, seed), in parallel over `workers` processes."""
    check_protocols(protocols)
    for spec in controllers:
        if spec != "mbc":
            make_controller(spec)  # a clear error before any work for a path that is not a policy
    jobs = [(spec, protocol, seed) for spec in controllers for protocol in protocols for seed in range(seeds)]
    workers = workers or os.cpu_count() or 1
    if workers > 1:
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            outcomes = pool.map(run_protocol, jobs, chunksize=1)
    else:
        outcomes = [run_protocol(job) for job in jobs]
    results = Results()
    for spec in controllers:
        for protocol in protocols:
            rows = [o for (s, p, _), o in zip(jobs, outcomes) if s == spec and p == protocol]
            metrics = np.array([r["metric"] for r in rows], float)
            finite = metrics[np.isfinite(metrics)]
            ci = 1.96 * finite.std(ddof=1) / np.sqrt(len(finite)) if len(finite) > 1 else float("nan")
            results.rows.append({"controller": Path(spec).stem if spec != "mbc" else "MBC", "protocol": protocol,
                                 "runs": len(rows), "successes": sum(r["success"] for r in rows),
                                 "metric": float(finite.mean()) if len(finite) else float("nan"), "ci": float(ci)})
    return results


def main(argv: list[str] | None = None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controllers", nargs="+", default=["mbc"], help="'mbc' or policy checkpoint paths")
    parser.add_argument("--protocols", nargs="+", default=list(PROTOCOLS), help=f"among {list(PROTOCOLS)}")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    try:
        results = evaluate(args.controllers, tuple(args.protocols), args.seeds, args.workers)
    except ConfigError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
    print(results.table())


if __name__ == "__main__":
    main()
